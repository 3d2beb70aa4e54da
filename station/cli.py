"""The ``station`` command line.

Each sub-command lives in its own module under :mod:`station.commands` and exposes
``register(subparsers)``, which adds its parser (listed in :data:`COMMANDS`) and sets ``func`` to a handler
``handler(args) -> int``. Handlers print people-friendly text by default and exactly one JSON
object on stdout with ``--json`` (use :func:`station.output.emit`).

Every error a user can cause (bad file, bad option, unplugged device, full disk, Ctrl-C) ends
in one line on stderr and a non-zero exit code, never a traceback.
"""

from __future__ import annotations

import argparse
import errno
import importlib
import sys
from typing import Sequence


#: Sub-command name -> module that provides it (``register(subparsers)``). Only the module of
#: the command being run is imported, so ``station identify`` does not pay for the drivers.
COMMANDS: dict[str, str] = {
    "acquire": "station.commands.acquire",
    "export": "station.commands.export",
    "import": "station.commands.export",
    "identify": "station.commands.identify",
    "diagnose": "station.commands.diagnose",
    "devices": "station.commands.devices",
    "rig": "station.commands.rig",
    "demo": "station.commands.demo",
    "validate": "station.commands.validate",
    "replay": "station.commands.replay",
    "report": "station.commands.report",
    "campaign": "station.commands.campaign",
}


#: Roots of the errors that are the user's or the world's, not the program's: one line, exit
#: code 2. Given as (module, class) so the CLI starts without importing numba and scipy: an
#: error of a layer can only have been raised once that layer is imported.
USER_ERROR_ROOTS: tuple[tuple[str, str], ...] = (
    ("station.errors", "StationError"),
    ("eddi.errors", "EddiError"),
    ("drivers.errors", "DriverError"),
    ("simulated_rig.errors", "RigError"),
)


def is_user_error(exc: BaseException) -> bool:
    """True when ``exc`` derives from one of the layers' error roots."""
    for module, name in USER_ERROR_ROOTS:
        mod = sys.modules.get(module)
        if mod is not None and isinstance(exc, getattr(mod, name)):
            return True
    return False

EXIT_USER_ERROR = 2
EXIT_INTERRUPTED = 130


class _Parser(argparse.ArgumentParser):
    """An argument parser whose errors are one line."""

    def error(self, message: str) -> None:  # type: ignore[override]
        self.exit(EXIT_USER_ERROR, f"{self.prog}: error: {message}\n")


def build_parser(argv: Sequence[str] | None = None) -> argparse.ArgumentParser:
    """The parser; with ``argv`` naming a known command, only that command's module is loaded."""
    parser = _Parser(
        prog="station",
        description="EDDI Station: impact testing and identification of nonlinear equations of motion.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True
    first = next((a for a in (argv or ()) if not a.startswith("-")), None)
    modules = [COMMANDS[first]] if first in COMMANDS else list(dict.fromkeys(COMMANDS.values()))
    for name in modules:
        importlib.import_module(name).register(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the CLI and return the exit code."""
    if argv is None:
        argv = sys.argv[1:]
    parser = build_parser(argv)
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # --help, --version, or a one-line usage error already printed
        return exc.code if isinstance(exc.code, int) else EXIT_USER_ERROR
    try:
        return int(args.func(args) or 0)
    except KeyboardInterrupt:
        print("station: interrupted (what was saved is kept)", file=sys.stderr)
        return EXIT_INTERRUPTED
    except Exception as exc:
        if is_user_error(exc):
            print(f"station: error: {exc}", file=sys.stderr)
            return EXIT_USER_ERROR
        if isinstance(exc, OSError):
            what = exc.strerror or str(exc)
            if exc.errno == errno.ENOSPC:
                what = "disk full"
            where = f": {exc.filename}" if getattr(exc, "filename", None) else ""
            print(f"station: error: {what}{where}", file=sys.stderr)
            return EXIT_USER_ERROR
        raise


def run() -> None:  # pragma: no cover - console-script entry
    sys.exit(main())


if __name__ == "__main__":  # pragma: no cover
    run()
