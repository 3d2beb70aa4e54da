"""The ``station`` command line.

Each sub-command lives in its own module under :mod:`station.commands` and exposes
``register(subparsers)``, which adds its parser and sets ``func`` to a handler
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

from drivers.errors import DriverError
from eddi.errors import EddiError
from simulated_rig.errors import RigError
from station.errors import StationError

#: Modules that provide sub-commands, in the order ``station --help`` lists them.
COMMAND_MODULES: tuple[str, ...] = (
    "station.commands.acquire", "station.commands.export",
    "station.commands.diagnose",
    "station.commands.identify",
    "station.commands.devices", "station.commands.rig",
)

#: Errors that are the user's or the world's, not the program's: one line, exit code 2.
USER_ERRORS = (StationError, EddiError, DriverError, RigError)

EXIT_USER_ERROR = 2
EXIT_INTERRUPTED = 130


class _Parser(argparse.ArgumentParser):
    """An argument parser whose errors are one line."""

    def error(self, message: str) -> None:  # type: ignore[override]
        self.exit(EXIT_USER_ERROR, f"{self.prog}: error: {message}\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="station",
        description="EDDI Station: impact testing and identification of nonlinear equations of motion.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True
    for name in COMMAND_MODULES:
        importlib.import_module(name).register(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the CLI and return the exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except USER_ERRORS as exc:
        print(f"station: error: {exc}", file=sys.stderr)
        return EXIT_USER_ERROR
    except KeyboardInterrupt:
        print("station: interrupted (what was saved is kept)", file=sys.stderr)
        return EXIT_INTERRUPTED
    except OSError as exc:
        what = exc.strerror or str(exc)
        if exc.errno == errno.ENOSPC:
            what = "disk full"
        where = f": {exc.filename}" if getattr(exc, "filename", None) else ""
        print(f"station: error: {what}{where}", file=sys.stderr)
        return EXIT_USER_ERROR


def run() -> None:  # pragma: no cover - console-script entry
    sys.exit(main())


if __name__ == "__main__":  # pragma: no cover
    run()
