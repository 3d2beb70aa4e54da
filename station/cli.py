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
import os
import re
import sys
from typing import Any, Sequence

# One BLAS thread per station process, unless the user says otherwise: the engine's matrices
# are small and tall, and a second OpenBLAS thread burnt ~43 % more CPU for the same wall time
# (issue 13's profile), which on a busy two-core laptop slows every other process. Set before
# numpy is imported by any command module.
_threads = importlib.import_module("eddi.threads")  # imports no numpy
for _var in _threads.THREAD_VARIABLES:
    os.environ.setdefault(_var, "1")
# ... and when all three are 1 before numpy is imported, the engine need not limit the pools again
# per call (eddi.threads: threadpoolctl's look-up, ~7 ms of CPU a `station identify`)
_threads.declare_one_thread_environment()


#: Sub-command name -> (module that provides it with ``register(subparsers)``, one-line help).
#: Only the module of the command being run is imported, so ``station identify`` does not
#: pay for the drivers and ``station --help`` imports no command at all.
COMMANDS: dict[str, tuple[str, str]] = {
    "demo": ("station.commands.demo", "acquire, identify, validate and report on the simulated rig"),
    "acquire": ("station.commands.acquire", "record triggered impacts into an HDF5 session file"),
    "identify": ("station.commands.identify", "identify the equation of motion of one record"),
    "validate": ("station.commands.validate", "simulate a model for measured records and score it"),
    "diagnose": ("station.commands.diagnose", "what a model gets wrong, why, and the extended model"),
    "report": ("station.commands.report", "HTML report with the paper's figures (identify + validate)"),
    "replay": ("station.commands.replay", "rerun the pipeline on saved captures (optionally through the device)"),
    "export": ("station.commands.export", "write force and acceleration of captures to a UFF58 file"),
    "import": ("station.commands.export", "store CSV measurements as captures of an HDF5 session file"),
    "devices": ("station.commands.devices", "list serial ports, USB DAQs and simulated systems"),
    "rig": ("station.commands.rig", "the simulated rig: serve it on a pty, strike it; the firmware in QEMU"),
    "campaign": ("station.commands.campaign", "identify / validate / diagnose many captures in parallel (Dask)"),
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

#: Optional libraries -> the extra that installs them (``pip install "eddi-station[EXTRA]"``).
OPTIONAL_MODULES: dict[str, str] = {"matplotlib": "report", "dask": "campaign", "distributed": "campaign",
                                    "pyarrow": "campaign", "libusb_package": "usb"}


def missing_extra(exc: BaseException) -> str | None:
    """The one-line error for a missing optional library, or None when ``exc`` is not that."""
    if not isinstance(exc, ModuleNotFoundError) or exc.name is None:
        return None
    extra = OPTIONAL_MODULES.get(exc.name.split(".")[0])
    if extra is None:
        return None
    return f"this needs {exc.name.split('.')[0]}, which is not installed: pip install \"eddi-station[{extra}]\""


EXIT_USER_ERROR = 2
EXIT_INTERRUPTED = 130
#: The command ran and printed its result, but the result is flagged: an identified model
#: that is unstable (negative stiffness or damping at the record's amplitudes) or whose
#: simulation blows up, grows or does not decay (``station identify/validate/demo/replay``),
#: or a replay through the device that is not bit exact. Scripts must not take such a model.
EXIT_FLAGGED = 1
#: The station failed in its own code (a bug, not the input): one line naming the error, and the
#: traceback only with ``STATION_DEBUG=1``. Blind unseen10 (session 13): a diagnose ended in a
#: numpy traceback ("SVD did not converge") with exit 1, the code of a flagged result.
EXIT_INTERNAL = 3


def flagged(command: str, why: str) -> int:
    """One line on stderr for a flagged result (:data:`EXIT_FLAGGED`); returns the exit code."""
    print(f"station {command}: {why} (exit code {EXIT_FLAGGED}; see the WARNING lines)", file=sys.stderr)
    return EXIT_FLAGGED

#: Commands that only read their inputs and print one result (no file written, no worker, no
#: device): a whole ``station`` process of one of them loads these modules (every run uses them)
#: with the garbage collector paused and ends as soon as its output is flushed
#: (:mod:`station.process`: ~0.1 s of CPU a `station identify` with the kernels built ahead of
#: time, ~0.4 s with numba's JIT).
QUICK_EXIT: dict[str, tuple[str, ...]] = {
    "identify": ("station.readers", "station.session", "station.coupling", "eddi.diagnosis.chain"),
    "validate": ("station.session", "eddi.multimode"),
    # its forked workers (station.forkmap) have all ended when it prints; with a file to write
    # (QUICK_EXIT_UNLESS) it ends the ordinary way
    "diagnose": ("station.readers", "station.session", "eddi.diagnosis.loop"),
}
#: Options that write files: a command given one ends the ordinary way (its engine still loads
#: with the collector paused).
QUICK_EXIT_UNLESS = ("save_model", "report")

#: Commands that draw their own live status (the others get :class:`station.progress.Working`).
OWN_PROGRESS = frozenset({"acquire", "demo", "rig", "campaign"})


_ROLE = re.compile(r":[a-z]+:`~?([^`]+)`")


def plain(text: str) -> str:
    """Docstring text without reStructuredText / Sphinx markup (for ``--help``)."""
    return _ROLE.sub(r"\1", text).replace("``", "")


def version() -> str:
    """The installed version of the package (or "unknown" when run from a bare checkout)."""
    from importlib.metadata import PackageNotFoundError
    from importlib.metadata import version as dist_version

    try:
        return dist_version("eddi-station")
    except PackageNotFoundError:
        return "unknown"


class _Version(argparse.Action):
    """``--version``: looked up only when asked (importlib.metadata is not free)."""

    def __init__(self, option_strings: Sequence[str], dest: str = argparse.SUPPRESS, **kw: Any) -> None:
        super().__init__(option_strings, dest, nargs=0, help="print the version and exit", **kw)

    def __call__(self, parser: argparse.ArgumentParser, *args: Any) -> None:
        sys.stdout.write(f"station {version()}\n")
        parser.exit(0)


class _Parser(argparse.ArgumentParser):
    """An argument parser whose errors are one line and whose help is plain text."""

    def error(self, message: str) -> None:  # type: ignore[override]
        self.exit(EXIT_USER_ERROR, f"{self.prog}: error: {message}\n")

    def format_help(self) -> str:
        return plain(super().format_help())


def command_of(argv: Sequence[str]) -> str | None:
    """The command an argument list names (its first word that is not an option), or None."""
    return next((a for a in argv if not a.startswith("-")), None)


def build_parser(argv: Sequence[str] | None = None) -> argparse.ArgumentParser:
    """The parser; with ``argv`` naming a known command, only that command's module is loaded.

    Without one (``station --help``, a typo) no command module is imported: the list of
    commands comes from :data:`COMMANDS`.
    """
    parser = _Parser(
        prog="station",
        description="EDDI Station: impact testing and identification of nonlinear equations of motion.",
        epilog="Run `station COMMAND --help` for a command's options. Every command prints text for "
               "people, or one JSON object with --json; a bad input ends in one line and exit code 2.",
    )
    parser.add_argument("--version", action=_Version)
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True
    first = command_of(argv or ())
    if first in COMMANDS:
        importlib.import_module(COMMANDS[first][0]).register(sub)
    else:
        for name, (_, what) in COMMANDS.items():
            sub.add_parser(name, help=what, add_help=False)
    return parser


def _missing_package(exc: ModuleNotFoundError) -> int:
    """One line for an installation that lacks a package the command needs; exit code 2."""
    extra = missing_extra(exc)
    if extra is not None:  # an optional library: name the extra that installs it
        print(f"station: error: {extra}", file=sys.stderr)
        return EXIT_USER_ERROR
    name = exc.name or str(exc)
    print(f"station: error: this command needs the Python package '{name}', which is not installed "
          f"(reinstall with `pip install -e .` or add the extra that names it)", file=sys.stderr)
    return EXIT_USER_ERROR


def main(argv: Sequence[str] | None = None, whole_process: bool = False) -> int:
    """Run the CLI and return the exit code.

    ``whole_process=True`` (:func:`run`, the ``station`` executable): the interpreter exists
    for this one command, so a command of :data:`QUICK_EXIT` loads its engine with the garbage
    collector paused and ends the process once its output is flushed (:mod:`station.process`;
    this function then does not return).
    """
    if argv is None:
        argv = sys.argv[1:]
    try:
        parser = build_parser(argv)
        args = parser.parse_args(argv)
    except SystemExit as exc:  # --help, --version, or a one-line usage error already printed
        return exc.code if isinstance(exc.code, int) else EXIT_USER_ERROR
    except KeyboardInterrupt:  # Ctrl-C while the command's modules load
        print("station: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except ModuleNotFoundError as exc:
        return _missing_package(exc)
    try:
        from station.progress import Working

        quick = whole_process and args.command in QUICK_EXIT
        if quick:
            from station.process import load_quietly

            load_quietly(QUICK_EXIT[args.command])
        quiet = bool(getattr(args, "json", False)) or args.command in OWN_PROGRESS
        with Working(f"station {args.command}", enabled=not quiet), _quiet_numeric_warnings():
            code = int(args.func(args) or 0)
        if quick and not any(getattr(args, name, None) for name in QUICK_EXIT_UNLESS):
            from station.process import end_now

            end_now(code)
        return code
    except KeyboardInterrupt:
        print("station: interrupted (what was saved is kept)", file=sys.stderr)
        return EXIT_INTERRUPTED
    except ModuleNotFoundError as exc:
        return _missing_package(exc)
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
        return _internal_error(args.command, exc)


class _quiet_numeric_warnings:
    """numpy's ``RuntimeWarning`` (an overflow in a trial simulation of a diverging model, a mean
    of an empty slice...) kept off stderr while a command runs: it printed two lines of its own
    under the command's one (``station diagnose --model`` with a diverging model, session 19);
    the results carry their own warnings. ``STATION_DEBUG=1`` lets them through."""

    def __enter__(self) -> None:
        import warnings

        self._saved = warnings.catch_warnings()
        self._saved.__enter__()
        if os.environ.get("STATION_DEBUG", "") in ("", "0"):
            warnings.simplefilter("ignore", RuntimeWarning)

    def __exit__(self, *exc: object) -> None:
        self._saved.__exit__(*exc)


def _internal_error(command: str, exc: Exception) -> int:
    """One line for a failure of the station's own code (:data:`EXIT_INTERNAL`); with
    ``STATION_DEBUG=1`` in the environment the exception propagates (traceback) instead."""
    import os

    if os.environ.get("STATION_DEBUG", "") not in ("", "0"):
        raise exc
    what = f"{type(exc).__name__}: {exc}".splitlines()[0][:300]
    print(f"station {command}: internal error ({what}); this is a bug in the station, not your input: "
          "please report it with the command (STATION_DEBUG=1 prints the traceback)", file=sys.stderr)
    return EXIT_INTERNAL


def run() -> None:  # pragma: no cover - console-script entry
    code = main(whole_process=True)
    # the command has ended and said so (its one line when interrupted). A Ctrl-C from here on, in
    # the interpreter's teardown (exit handlers, modules cleared), ended the process killed by
    # SIGINT (-2) with no line and the command's code lost: ignored, the code stands (session 20:
    # `station import` at its first teardown line). And an interrupted command that had printed its
    # line still ended -2 when the Ctrl-C came while a module was importing (the interpreter
    # remembers an interrupt that escaped a module's own code run, and re-raises SIGINT at exit):
    # its with-blocks have closed what it wrote, so it ends at once with 130 (the sweep's
    # `validate` once in 44, session 19; `import` at `eddi.conditioning`, session 20).
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if code == EXIT_INTERRUPTED:
        from station.process import end_now

        end_now(code)
    sys.exit(code)


if __name__ == "__main__":  # pragma: no cover
    run()
