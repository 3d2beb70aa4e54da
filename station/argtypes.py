"""Argument types for the command line: invalid values are refused where they enter.

Each is an ``argparse`` ``type=`` callable: it returns the parsed value or raises
``argparse.ArgumentTypeError`` with what was expected, which the CLI prints as one line with
exit code 2 (``station X: error: argument --mass: expected a finite number > 0 [kg], got 'inf'``).
``float("nan")``, ``inf`` and ``1e400`` are all refused where a physical value is meant.
"""

from __future__ import annotations

import argparse
import math
import re

#: Longest record or wait a command accepts [s] (a day): beyond it a typo, not a test.
MAX_SECONDS = 86_400.0


def _number(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not math.isfinite(v):
        raise argparse.ArgumentTypeError(f"expected a finite number, got {text!r}")
    return v


def finite_float(text: str) -> float:
    """Any finite number."""
    return _number(text)


def finite_positive(text: str) -> float:
    """A finite number > 0 (a mass [kg], a rate [Hz], a level)."""
    v = _number(text)
    if not v > 0:
        raise argparse.ArgumentTypeError(f"expected a finite number > 0, got {text!r}")
    return v


def nonnegative_seconds(text: str) -> float:
    """A duration [s] in 0..:data:`MAX_SECONDS`."""
    v = _number(text)
    if not 0 <= v <= MAX_SECONDS:
        raise argparse.ArgumentTypeError(f"expected a duration in 0..{MAX_SECONDS:g} s, got {text!r}")
    return v


def positive_seconds(text: str) -> float:
    """A duration [s] in (0, :data:`MAX_SECONDS`]."""
    v = nonnegative_seconds(text)
    if v == 0:
        raise argparse.ArgumentTypeError(f"expected a duration > 0 s, got {text!r}")
    return v


def percent_tolerance(text: str) -> float:
    """A tolerance in percent, 0 <= v < 50."""
    v = _number(text)
    if not 0 <= v < 50:
        raise argparse.ArgumentTypeError(f"expected a tolerance in 0..50 %, got {text!r}")
    return v


def ppm_tolerance(text: str) -> float:
    """A tolerance in ppm, 0 <= v < 10000."""
    v = _number(text)
    if not 0 <= v < 1e4:
        raise argparse.ArgumentTypeError(f"expected a tolerance in 0..10000 ppm, got {text!r}")
    return v


def fraction(text: str) -> float:
    """A number in [0, 1]."""
    v = _number(text)
    if not 0 <= v <= 1:
        raise argparse.ArgumentTypeError(f"expected a fraction in 0..1, got {text!r}")
    return v


def positive_int(text: str) -> int:
    """An integer >= 1."""
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
    if v < 1:
        raise argparse.ArgumentTypeError(f"expected a whole number >= 1, got {text!r}")
    return v


def nonnegative_int(text: str) -> int:
    """An integer >= 0."""
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
    if v < 0:
        raise argparse.ArgumentTypeError(f"expected a whole number >= 0, got {text!r}")
    return v


def damping_terms(text: str) -> str:
    """Comma-separated damping candidates; each must involve the rate ``v`` (else it is not damping)."""
    return _terms(text, damping=True)


def stiffness_terms(text: str) -> str:
    """Comma-separated stiffness candidates; each must depend on ``x`` only."""
    return _terms(text, damping=False)


def _terms(text: str, damping: bool) -> str:
    from eddi.errors import EddiError
    from eddi.terms import parse_terms

    try:
        terms = parse_terms(text)
    except (EddiError, ValueError) as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    for t in terms:
        if damping and not t.depends_on_v:
            raise argparse.ArgumentTypeError(f"damping term {t.text!r} does not involve the rate v; expected "
                                             "terms such as v, x^2*v, v^3 (x-only terms are stiffness)")
        if not damping and t.depends_on_v:
            raise argparse.ArgumentTypeError(f"stiffness term {t.text!r} involves the rate v; expected terms of "
                                             "x only, such as x, x^3 (v terms are damping)")
    return text


def adc_filter(text: str) -> tuple[int, int | None]:
    """A DAQ's decimation filter: ``sincK`` or ``sincK:R`` (order K in 1..8, R >= 2 modulator
    samples per output sample; the ADS131M04's is ``sinc3:R``) or ``none`` (point samples or a
    flat, compensated passband). Returns ``(K, R or None)``; ``(0, None)`` for ``none``."""
    t = text.strip().lower()
    if t == "none":
        return 0, None
    m = re.fullmatch(r"sinc([1-8])(?::(\d+))?", t)
    if m is None or (m.group(2) is not None and int(m.group(2)) < 2):
        raise argparse.ArgumentTypeError(f"expected sincK or sincK:R (K 1..8, R >= 2) or none, got {text!r}")
    return int(m.group(1)), (int(m.group(2)) if m.group(2) else None)


def add_adc_filter_option(p: argparse.ArgumentParser) -> None:
    """``--adc-filter``: the DAQ's decimation filter, so the fit compares the model through it."""
    p.add_argument("--adc-filter", type=adc_filter, default=None, metavar="sincK[:R]|none",
                   help="the DAQ's decimation filter (e.g. sinc3:128 for an ADS131M04 at OSR 128): "
                        "the fit compares the model through its kernel; none: point samples (or a flat "
                        "passband); default: what the capture file records, else not stated (the fit "
                        "assumes point samples and the 95 %% intervals make room for means over each "
                        "sample interval)")


def sensor_highpass(text: str) -> float:
    """A declared first-order AC coupling of the accelerometer (IEPE): its corner [Hz], a finite
    number in (0, 100], or ``none`` (DC-coupled, overriding what the file records; returned as 0)."""
    t = text.strip().lower()
    if t == "none":
        return 0.0
    try:
        hz = float(t)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a corner frequency in Hz (e.g. 0.4) or none, got {text!r}") from None
    if not (math.isfinite(hz) and 0.0 < hz <= 100.0):
        raise argparse.ArgumentTypeError(f"expected a corner frequency in (0, 100] Hz or none, got {text!r}")
    return hz


def add_sensor_highpass_option(p: argparse.ArgumentParser) -> None:
    """``--sensor-highpass HZ``: the accelerometer's (a velocity-only record: the velocity sensor's)
    first-order AC coupling, inverted in conditioning."""
    p.add_argument("--sensor-highpass", type=sensor_highpass, default=None, metavar="HZ|none",
                   help="the accelerometer's first-order AC coupling corner [Hz] (IEPE: typically 0.1-1 Hz; "
                        "on a record with velocity and no acceleration: the velocity sensor's; "
                        "see its data sheet), inverted before identification; none: DC-coupled; default: what "
                        "the capture file records, else DC-coupled (identify warns when the record looks "
                        "AC-coupled)")


def add_refine_option(p: argparse.ArgumentParser) -> None:
    """``--refine/--no-refine``, the same on every command that identifies."""
    p.add_argument("--refine", action=argparse.BooleanOptionalAction, default=True,
                   help="try the output-error refinement EDDI seeds and keep it unless it validates "
                        "measurably worse (default: on; the EDDI estimate is reported too)")
