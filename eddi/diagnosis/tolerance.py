"""The measurement chain's calibration tolerance as a component of the noise floor.

Captures of one set are often taken in several acquisition sessions: between them the
accelerometer is remounted or recalibrated and the DAQ's sample clock is not the same crystal
at the same temperature. A held-out comparison assumes every capture was measured by the same
chain; it is not, within the chain's calibration tolerance, and on a nonlinear system that
alone moves a held-out prediction far beyond the noise (session 9, issue 10):

* **gain.** A record measured with the accelerometer's sensitivity off by ``g`` (relative) is
  ``a = 1 + g`` times the true motion. Fitted with the given mass, its free response is the
  true model's with every term ``x^p v^q`` scaled by ``a^(1 - p - q)``: linear terms are
  unchanged (a linear system's frequency does not see a gain error) but ``x^3`` is ``1/a^2``
  times the true one, so at a given amplitude the frequency differs by about ``g`` times the
  nonlinear share of the stiffness, and over ``N`` cycles the phase by ``2 pi N`` times that.
  On a 55 Hz spring whose stiffness doubles at the peak, 0.3 % gain over 90 cycles: 0.4 rad,
  a held-out nrmse of 0.1-0.4 with a noise floor of 0.02.
* **clock.** A sample clock off by ``e`` (relative) stamps every sample ``1 + e`` times late:
  the model's terms scale by ``b^(2 - q)`` (``b = 1 + e``), every frequency by ``b``; 100 ppm
  over 90 cycles is 0.06 rad, linear systems included.

Both are exact changes of variables: the held-out record as it would be measured through a
chain differing by ``(a, b)`` is simulated with the *same* fold model by transforming the
record into the fold's units (``t b``, ``x / a``, ``v / (a b)``, acceleration and force
``/ (a b^2)``), simulating, and scaling the result back by ``a`` (:func:`chained_record`). The
floor component of a part is ``sqrt(d_gain^2 + d_clock^2)`` (independent components combined
in quadrature, as the GUM combines standard uncertainties), each ``d`` the change of the
part's held-out simulation relative to the measured part's norm, and it joins the noise's
``sqrt(d_cond^2 + d_pred^2)`` in quadrature (:func:`eddi.diagnosis.measure.noise_floor`).

Tolerances (:class:`ChainTolerance`): the accelerometer's sensitivity between sessions,
default 1 % (ISO 16063-21 back-to-back comparison calibration: an expanded uncertainty of
about 1 % at the reference frequency is typical of a calibration certificate, and a remounted
sensor is within its calibration); the sample clock, default 50 ppm (a DAQ's timebase
accuracy, e.g. +-50 ppm for NI C-series sound-and-vibration modules: captures of one device
differ by less; two devices may differ by twice that, give ``clock_ppm=100``). Where the
records have a force channel the gain need not be assumed: the hammer impulse over the
momentum change from the measured acceleration (:func:`eddi.diagnosis.chain.capture_ratios`)
is the ratio of the two sensitivities per capture, and its deviation from the other captures'
median measures the held-out capture's gain difference (0.3 % between two sessions was read
to 0.03 % on a 55 dB record); the part then uses the smaller of the two. (A gain common to both
channels, e.g. the DAQ's reference, is not seen that way; DAQ gain drifts are typically well
below 0.1 %.)
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from eddi.chain_tolerance import CLOCK_PPM, GAIN_TOLERANCE  # the defaults (re-exported here)
from eddi.diagnosis.mapping import Mapper, serial_map
from eddi.diagnosis.records import Part, Record
from eddi.diagnosis.show import simulate_part
from eddi.errors import EddiError
from eddi.model import EquationOfMotion


#: A held-out simulation this far off (nrmse) is lost: its chain sensitivity is not counted.
LOST = 1.0


@dataclass(frozen=True)
class ChainTolerance:
    """How far the measurement chains of the captures may differ.

    Attributes
    ----------
    gain : float
        Relative difference of the response sensor's sensitivity between captures (0.01 = 1 %).
    clock_ppm : float
        Difference of the sample clock between captures [ppm].
    from_data : bool
        Where the records have a force channel, use the gain differences the impulse/momentum
        ratios measure when smaller than ``gain``.
    """

    gain: float = GAIN_TOLERANCE
    clock_ppm: float = CLOCK_PPM
    from_data: bool = True

    def __post_init__(self) -> None:
        if not (math.isfinite(self.gain) and 0.0 <= self.gain < 0.5):
            raise ValueError(f"gain tolerance must be in [0, 0.5), got {self.gain}")
        if not (math.isfinite(self.clock_ppm) and 0.0 <= self.clock_ppm < 1e4):
            raise ValueError(f"clock tolerance must be in [0, 1e4) ppm, got {self.clock_ppm}")

    @property
    def off(self) -> bool:
        return self.gain == 0.0 and self.clock_ppm == 0.0


def chained_record(rec: Record, gain: float, clock: float) -> Record:
    """``rec`` in the units of a chain whose response gain is ``1 + gain`` and whose clock is
    ``1 + clock`` (relative) times the record's: ``t b``, ``x / a``, ``v / (a b)``, ``a / (a b^2)``,
    force ``/ (a b^2)`` (module notes). A model simulated on it and scaled by ``a`` is the
    model as seen through that chain."""
    a, b = 1.0 + gain, 1.0 + clock
    return rec.replace(t=rec.t * b, x=rec.x / a, v=rec.v / (a * b), a=rec.a / (a * b * b),
                       force=None if rec.force is None else rec.force / (a * b * b))


def chain_part_nrmse(eom: EquationOfMotion, rec: Record, part: Part, xb: np.ndarray, gain: float,
                     clock: float) -> tuple[float, float]:
    """(d_gain, d_clock): how far ``eom``'s held-out simulation of ``part`` (``xb``) moves when
    the record is measured through a chain off by ``gain`` / ``clock`` (relative), each
    relative to the measured part's norm; NaN where the simulation fails."""
    xm = rec.x[part.start:part.stop]
    den = float(np.linalg.norm(xm)) or 1.0
    out = []
    for g, c in ((gain, 0.0), (0.0, clock)):
        if g == 0.0 and c == 0.0:
            out.append(0.0)
            continue
        try:
            xs = (1.0 + g) * simulate_part(eom, chained_record(rec, g, c), part)
        except (EddiError, ValueError, ArithmeticError):
            out.append(float("nan"))
            continue
        out.append(float(np.linalg.norm(xs - xb)) / den if np.all(np.isfinite(xs)) else float("nan"))
    return out[0], out[1]


def part_gains(records: Sequence[Record], parts: Sequence[Part], mass: float, tol: ChainTolerance
               ) -> list[float]:
    """The gain difference assumed for each held-out part: ``tol.gain``, or (``tol.from_data``,
    force channels) the held-out capture's impulse/momentum ratio against the median of the
    other captures' when that is smaller."""
    if tol.gain == 0.0:
        return [0.0] * len(parts)
    ratios: list[float | None] = [None] * len(records)
    if tol.from_data and len(records) >= 2:
        from eddi.diagnosis.chain import capture_ratios

        ratios = capture_ratios(records, mass)
    out = []
    for p in parts:
        r = ratios[p.record]
        others = [q for j, q in enumerate(ratios) if j != p.record and q is not None]
        if r is None or not others:
            out.append(tol.gain)
            continue
        out.append(min(tol.gain, abs(r / float(np.median(others)) - 1.0)))
    return out


def chain_floor(records: Sequence[Record], parts: Sequence[Part], models: Sequence[EquationOfMotion | None],
                base_sims: Sequence[np.ndarray], mass: float, tol: ChainTolerance,
                mapper: Mapper | None = None) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """Per held-out part, the chain's floor component ``sqrt(d_gain^2 + d_clock^2)`` for the
    fold model that judged it (``models``), and the gain assumed for it. 0 where the baseline
    is lost on the part (nrmse >= :data:`LOST`), has no model, or ``tol`` is off."""
    gains = part_gains(records, parts, mass, tol)
    if tol.off:
        return tuple(0.0 for _ in parts), tuple(gains)
    clock = 1e-6 * tol.clock_ppm

    def one(k: int) -> float:
        part, eom, xb = parts[k], models[k], base_sims[k]
        rec = records[part.record]
        xm = rec.x[part.start:part.stop]
        if eom is None or not np.all(np.isfinite(xb)):
            return 0.0
        if float(np.linalg.norm(xb - xm)) / (float(np.linalg.norm(xm)) or 1.0) >= LOST:
            return 0.0
        dg, dc = chain_part_nrmse(eom, rec, part, xb, gains[k], clock)
        # a perturbed simulation that fails says nothing of the chain: that component counts 0
        return float(math.hypot(dg if math.isfinite(dg) else 0.0, dc if math.isfinite(dc) else 0.0))

    return tuple((mapper or serial_map)(one, list(range(len(parts))))), tuple(gains)


def chain_text(floor) -> str:
    """One clause on the chain's share of a :class:`~eddi.diagnosis.results.NoiseFloor` ('' without one)."""
    comp = [c for c in floor.chain_nrmse if math.isfinite(c)]
    if not comp:
        return ""
    info = floor.chain
    gains = [g for g in info.get("gain_per_part", []) if math.isfinite(g)]
    gain = (f"sensor gain {100 * max(gains):.2g} % at most per part (tolerance {100 * info.get('gain_tolerance', 0):.3g} %"
            + (", lowered to what the impulse/momentum ratios measure" if gains and max(gains) < info.get("gain_tolerance", 0)
               else "") + ")") if gains else "sensor gain 0"
    return (f"the measurement chain's tolerance ({gain}, sample clock {info.get('clock_ppm', 0):.3g} ppm) moves the "
            f"held-out simulations by {max(comp):.3g} at most (per part " + ", ".join(f"{c:.3g}" for c in comp)
            + "), joined in quadrature")
