"""Inputs of the loop and how they are split into held-out parts.

:class:`Record` is one measured response (conditioned ``x, v, a`` and maybe the force);
:func:`split` makes the held-out parts: leave one record out with several records, leave one
amplitude band out with one record. A model is never judged on data it was fitted on.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Sequence

import numpy as np

from eddi.diagnosis.settings import MIN_BAND_CROSSINGS
from eddi.energy import zero_crossings
from eddi.errors import SignalError

if TYPE_CHECKING:  # the catalogue (every mechanism) is not needed to read a record: station identify's impulse check
    from eddi.diagnosis.catalogue import Signal

#: A record needs this many zero crossings in its free response to be judged (one
#: oscillation); fewer is refused in one line. Training uses every segment with 3 or more.
MIN_PART_CROSSINGS = 2


@dataclass(frozen=True)
class Record:
    """One measured response, ready for diagnosis.

    Attributes
    ----------
    t : ndarray, shape (n,), [s]
        Uniform sample times.
    x, v, a : ndarray, shape (n,)
        Coordinate [m], rate [m/s], acceleration [m/s^2].
    force : ndarray, shape (n,), [N] or None
        Measured external force, when there is a force channel.
    free_start, free_stop : int
        ``[start, stop)`` samples of the free response (after the impact).
    label : str
        A name for people (file name).
    response : str
        The measured channel the coordinate came from (``"acc"``, ``"vel"``, ``"disp"``),
        empty when unknown; with it the loop can re-run the conditioning (noise floor,
        sensor high-pass correction).
    noise_rms : float
        Noise RMS of that channel measured at rest (SI units; 0 when unknown).
    pretrigger_samples : int or None
        Samples of rest before the trigger, as given to the conditioning.
    impact_start, impact_end : int
        ``[impact_start, impact_end)``: the impact as the conditioning found it (both 0 when
        unknown). With them a held-out record is simulated as the pipeline validates it
        (:func:`eddi.fit_record.validate_conditioned`): from rest at ``impact_start``,
        driven by the force during the impact only (the sensor's noise after it drives
        nothing), fused with ``m a + R(x, v)`` when the acceleration was measured.
    force_noise_rms : float
        Noise RMS of the force channel [N] (0 when unknown).
    acc_measured : bool
        True when ``a`` is the measured acceleration.
    ac_coupling_s : float
        Time constant [s] of the AC coupling the conditioning inverted (0: none).
    """

    t: np.ndarray
    x: np.ndarray
    v: np.ndarray
    a: np.ndarray
    force: np.ndarray | None
    free_start: int
    free_stop: int
    label: str = ""
    response: str = ""
    noise_rms: float = 0.0
    pretrigger_samples: int | None = None
    impact_start: int = 0
    impact_end: int = 0
    force_noise_rms: float = 0.0
    acc_measured: bool = False
    ac_coupling_s: float = 0.0

    @property
    def rate_hz(self) -> float:
        return 1.0 / float(self.t[1] - self.t[0])

    @classmethod
    def create(cls, t: np.ndarray, x: np.ndarray, v: np.ndarray, a: np.ndarray | None = None, *,
               force: np.ndarray | None = None, free_start: int | None = None,
               free_stop: int | None = None, label: str = "", response: str = "",
               noise_rms: float = 0.0, pretrigger_samples: int | None = None) -> "Record":
        """Check and build a record.

        ``a`` defaults to the gradient of ``v``; ``free_start`` defaults to the first sample
        after the force last exceeds 2 % of its peak (0 without force); ``free_stop`` to ``n``.

        Raises
        ------
        SignalError
            On mismatched lengths, NaN, non-uniform time or a bad window.
        """
        t = np.asarray(t, float)
        if t.ndim != 1 or t.size < 16:
            raise SignalError(f"a record needs at least 16 samples, got {t.size}")
        dt = float(t[1] - t[0])
        if not dt > 0 or not np.allclose(np.diff(t), dt, rtol=1e-6, atol=1e-12):
            raise SignalError(f"record {label or ''} time is not uniform and increasing".replace("  ", " "))
        arrays = {"x": x, "v": v, "a": a, "force": force}
        out: dict[str, np.ndarray | None] = {}
        for name, arr in arrays.items():
            if arr is None:
                out[name] = None
                continue
            arr = np.asarray(arr, float)
            if arr.shape != t.shape:
                raise SignalError(f"{name} has {arr.size} samples, expected {t.size} like the time")
            if not np.all(np.isfinite(arr)):
                raise SignalError(f"{name} of record {label!r} contains NaN or infinite values")
            out[name] = arr
        if out["a"] is None:
            out["a"] = np.gradient(out["v"], t)
        n = t.size
        f = out["force"]
        if free_start is None:
            free_start = 0
            if f is not None and np.max(np.abs(f)) > 0:
                hit = np.flatnonzero(np.abs(f) > 0.02 * np.max(np.abs(f)))
                free_start = int(min(n - 1, hit[-1] + 1))
        free_stop = n if free_stop is None else int(free_stop)
        if not 0 <= free_start < free_stop <= n:
            raise SignalError(f"free response [{free_start}, {free_stop}) is not inside 0..{n}")
        return cls(t=t, x=out["x"], v=out["v"], a=out["a"], force=f,  # type: ignore[arg-type]
                   free_start=int(free_start), free_stop=int(free_stop), label=label,
                   response=response if response in ("acc", "vel", "disp") else "",
                   noise_rms=float(noise_rms) if math.isfinite(noise_rms) else 0.0,
                   pretrigger_samples=pretrigger_samples)

    @classmethod
    def from_conditioned(cls, sig: Any, label: str = "",
                         pretrigger_samples: int | None = None) -> "Record":
        """Build from any object with ``t, x, v, a, force`` (and optionally ``free_start``,
        ``free_stop``, ``response``, ``noise_rms``, ``impact_start``, ``impact_end``,
        ``force_noise_rms``, ``acc_measured``), such as
        :class:`eddi.conditioning.ConditionedSignal`; ``pretrigger_samples`` as given to the
        conditioning (so the loop can re-run it)."""
        rec = cls.create(sig.t, sig.x, sig.v, getattr(sig, "a", None),
                         force=getattr(sig, "force", None),
                         free_start=getattr(sig, "free_start", None),
                         free_stop=getattr(sig, "free_stop", None), label=label,
                         response=str(getattr(sig, "response", "") or ""),
                         noise_rms=float(getattr(sig, "noise_rms", 0.0) or 0.0),
                         pretrigger_samples=pretrigger_samples)
        tau = float(getattr(sig, "ac_coupling_s", 0.0) or 0.0)
        if tau > 0 and math.isfinite(tau):
            rec = rec.replace(ac_coupling_s=tau)
        i0, i1 = int(getattr(sig, "impact_start", 0) or 0), int(getattr(sig, "impact_end", 0) or 0)
        if rec.force is None or not 0 <= i0 < i1 <= rec.free_start:
            return rec
        fn = float(getattr(sig, "force_noise_rms", 0.0) or 0.0)
        return rec.replace(impact_start=i0, impact_end=i1, force_noise_rms=fn if math.isfinite(fn) else 0.0,
                           acc_measured=bool(getattr(sig, "acc_measured", False)))

    def replace(self, **changes: Any) -> "Record":
        """A copy with some fields changed (arrays are not copied)."""
        return dataclasses.replace(self, **changes)

    def signal(self) -> Signal:
        from eddi.diagnosis.catalogue import Signal  # local: see the imports

        f = self.force if self.force is not None else np.zeros_like(self.x)
        return Signal(t=self.t, x=self.x, v=self.v, a=self.a, force=f)



@dataclass(frozen=True)
class Part:
    """A held-out part: a record, the samples simulated, and the training samples of its fold.

    Attributes
    ----------
    record : int
        Index of the record.
    start, stop : int
        Samples simulated and compared, ``[start, stop)``.
    from_rest : bool
        True when the simulation starts from rest driven by the measured force; False when it
        starts from the measured state at ``start``.
    label : str
    """

    record: int
    start: int
    stop: int
    from_rest: bool
    label: str


def _bands(rec: Record, n_bands: int) -> list[tuple[int, int]]:
    """Split the free response of one record into amplitude bands (contiguous in time)."""
    s0, s1 = rec.free_start, rec.free_stop
    ax = np.abs(rec.x[s0:s1])
    env = np.maximum.accumulate(ax[::-1])[::-1]  # largest |x| from here to the end
    peak = float(env[0])
    if peak <= 0:
        raise SignalError(f"record {rec.label!r} has no motion to diagnose")
    tail = ax[int(0.9 * ax.size):]
    noise = float(np.sqrt(np.mean(tail**2))) if tail.size else 0.0
    floor = min(max(0.03 * peak, 3.0 * noise), 0.5 * peak)
    levels = [peak * (floor / peak) ** (k / n_bands) for k in range(1, n_bands + 1)]
    bounds = [0]
    for lv in levels[:-1]:
        below = np.flatnonzero(env < lv)
        bounds.append(int(below[0]) if below.size else ax.size)
    below = np.flatnonzero(env < levels[-1])
    bounds.append(int(below[0]) if below.size else ax.size)
    out = []
    for k in range(n_bands):
        a, b = s0 + bounds[k], s0 + bounds[k + 1]
        nz = zero_crossings(rec.t[a:b], rec.x[a:b], rec.v[a:b]).size if b - a > 2 else 0
        if nz < MIN_BAND_CROSSINGS:
            raise SignalError(
                f"record {rec.label!r} is too short to split into {n_bands} amplitude bands: band "
                f"{k + 1} holds {nz} zero crossings, need {MIN_BAND_CROSSINGS}")
        out.append((a, b))
    return out


def split(records: Sequence[Record], n_bands: int) -> tuple[str, list[Part], list[list[np.ndarray]]]:
    """Held-out parts and, for each, the training masks of every record."""
    parts: list[Part] = []
    masks: list[list[np.ndarray]] = []
    free = []
    for r in records:
        m = np.zeros(r.t.size, bool)
        m[r.free_start:r.free_stop] = True
        free.append(m)
    if len(records) >= 2:
        peaks = [float(np.max(np.abs(r.x[r.free_start:r.free_stop]))) for r in records]
        for i, r in enumerate(records):
            nz = zero_crossings(r.t[r.free_start:r.free_stop], r.x[r.free_start:r.free_stop],
                                r.v[r.free_start:r.free_stop]).size
            if nz < MIN_PART_CROSSINGS:
                # a short ring-down (sticking friction, heavy damping, a low blow) is still
                # judged over what it holds; only a record without one oscillation is refused
                raise SignalError(f"record {r.label!r} has {nz} zero crossings in its free response: "
                                  f"nothing to fit or judge (need at least {MIN_PART_CROSSINGS})")
            from_rest = r.force is not None and r.free_start > 0
            # compared over the free response, as the pipeline validates (simulated from rest
            # before it when driven by the force: show.simulate_part_xv)
            start = r.free_start
            # no extrapolation: a capture larger than every training one is judged only from
            # where its ring-down has decayed into the training amplitude range, starting
            # from its measured state there (a polynomial stiffness fitted below that range
            # can diverge above it)
            train_peak = max(p for j, p in enumerate(peaks) if j != i)
            if peaks[i] > train_peak:
                ax = np.abs(r.x[r.free_start:r.free_stop])
                env = np.maximum.accumulate(ax[::-1])[::-1]
                inside = r.free_start + int(np.argmax(env <= train_peak))
                left = zero_crossings(r.t[inside:r.free_stop], r.x[inside:r.free_stop],
                                      r.v[inside:r.free_stop]).size
                if left >= MIN_BAND_CROSSINGS:
                    start, from_rest = inside, False
            parts.append(Part(i, start, r.free_stop, from_rest, r.label or f"record {i + 1}"))
            masks.append([f if j != i else np.zeros_like(f) for j, f in enumerate(free)])
        return "leave-one-record-out", parts, masks
    r = records[0]
    for k, (a, b) in enumerate(_bands(r, n_bands)):
        parts.append(Part(0, a, b, False, f"{r.label or 'record'} band {k + 1}/{n_bands}"))
        m = free[0].copy()
        m[a:b] = False
        masks.append([m])
    return "amplitude-bands", parts, masks
