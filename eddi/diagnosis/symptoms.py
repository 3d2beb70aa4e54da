"""Symptoms: what the baseline's held-out simulations get wrong, in numbers and plain words.

Measured over the held-out parts (measured coordinate against the baseline's simulation fitted
without that part), median over parts:

* ``frequency_bias``: the model's cycle frequency against the measured one, in %, at large and
  small amplitude (upper and lower third of the measured amplitudes);
* ``energy_mismatch``: the model's energy lost per cycle against the measured one, in %, at
  large and small amplitude;
* ``residual_peak``: where the residual ``x - x_sim`` has its power (Hz, and as a multiple of
  the main frequency);
* ``low_frequency_drift``: residual power below 0.3 times the main frequency, in % of the
  measured power;
* ``growth``: the simulation's amplitude over the last quarter of the part against the
  measured one (ratio; a diverged simulation counts as growth).

Each symptom is ``notable`` when it is beyond its threshold (``THRESHOLDS``); the text lists the
notable ones.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from eddi.diagnosis.drift import capture_drift
from eddi.diagnosis.records import Part, Record
from eddi.diagnosis.results import Symptom
from eddi.diagnosis.show import backbone, cycle_energies, spectrum

#: A symptom is worth a sentence beyond these values.
THRESHOLDS = {"frequency_bias_pct": 0.5, "energy_mismatch_pct": 15.0, "low_frequency_drift_pct": 5.0,
              "growth_ratio": 1.5}
#: A frequency bias is notable only beyond this many of its standard errors too
#: (:func:`bias_threshold_pct`; 3: a null's bias beyond it once in ~370 bands if normal).
BIAS_SE_FACTOR = 3.0
#: A cycle gives a frequency only when its amplitude is at least this many times the RMS noise
#: of the coordinate (a crossing moves by the noise over the speed, ``sigma / A`` of a radian:
#: 0.2 here; nearer the noise the noise makes crossings of its own and the cycles read short).
NOISE_AMPLITUDE = 5.0


def _thirds(amp: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    lo, hi = np.nanpercentile(amp, [33.0, 67.0]) if amp.size else (0.0, 0.0)
    return amp >= hi, amp <= lo


def _interp_loglog(xq: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    ok = (x > 0) & (y > 0) & np.isfinite(x) & np.isfinite(y)
    if ok.sum() < 2:
        return np.full(xq.shape, np.nan)
    o = np.argsort(x[ok])
    lx, ly = np.log(x[ok][o]), np.log(y[ok][o])
    out = np.exp(np.interp(np.log(np.maximum(xq, 1e-300)), lx, ly, left=np.nan, right=np.nan))
    return out


#: Dead band of the measured cycles' zero crossings, in noise sd of a measured displacement: a
#: passage from -3 sd to +3 sd is not the noise's (a 30 t, 1.4 Hz disp set at 500 Hz, 40 dB:
#: without it the tail's noise added 150 crossings 2-7 ms apart to 20 true ones, and its
#: "frequency bias" read -50 % at large amplitude, the model 1.1x its floor; blind unseen8, s13).
CROSSING_DEADBAND_SD = 3.0


def median_uncertainty_pct(r: np.ndarray) -> float:
    """Standard error [%] of the median of cycle-by-cycle ratios ``r`` (model over measured, in
    the order of the record) from their own scatter (:func:`bias_uncertainty_pct` says why);
    the frequency bias's and the energy mismatch's."""
    return bias_uncertainty_pct(r)


def bias_uncertainty_pct(r: np.ndarray) -> float:
    """Standard error [%] of the median of the cycle-by-cycle frequency ratios ``r`` (model over
    measured, in the order of the record) from their own scatter.

    A cycle's measured frequency moves with the noise at its zero crossings (a crossing shifts by
    the noise over the speed there, so the relative error grows as the amplitude falls to the
    noise); the model's frequency is smooth in amplitude. The scatter is read from successive
    differences (``r_i`` and ``r_i+1`` share no crossing, so their difference has twice a cycle's
    variance; a slow trend of the bias with amplitude cancels), robustly (median absolute
    deviation), and the median of ``n`` values has a standard error of ``1.2533 sigma / sqrt(n)``.
    Fewer than 4 cycles: infinite (no claim can rest on them)."""
    r = np.asarray(r, float)
    if r.size < 4:
        return float("inf")
    d = np.diff(r)
    sigma = 1.4826 * float(np.median(np.abs(d - np.median(d)))) / np.sqrt(2.0)
    return float(100.0 * 1.2533 * sigma / np.sqrt(r.size))


def _part_numbers(t: np.ndarray, xm: np.ndarray, vm: np.ndarray, xs: np.ndarray, vs: np.ndarray | None,
                  mass: float, rate: float, noise: float = 0.0) -> dict[str, float]:
    """The symptoms' numbers on one part; ``noise`` the measured coordinate's noise sd [m]
    (:func:`part_noise`): zero crossings need a passage through +-:data:`CROSSING_DEADBAND_SD`
    of it, and cycles under :data:`NOISE_AMPLITUDE` times it give no frequency."""
    out: dict[str, float] = {}
    finite = np.all(np.isfinite(xs))
    q = max(4, xm.size // 4)
    am = float(np.max(np.abs(xm[-q:]))) or 1e-300
    out["growth_ratio"] = float(np.max(np.abs(xs[-q:])) / am) if finite else float("inf")
    if not finite or vs is None:
        return out
    h = CROSSING_DEADBAND_SD * noise
    a_m, f_m, _ = backbone(t, xm, vm, mass, h)
    a_s, f_s, _ = backbone(t, xs, vs, mass)
    if a_m.size >= 6 and a_s.size >= 3:
        hi, lo = _thirds(a_m)
        fs_at = np.interp(a_m, a_s[np.argsort(a_s)], f_s[np.argsort(a_s)], left=np.nan, right=np.nan)
        above = a_m >= NOISE_AMPLITUDE * noise  # cycles whose crossings the noise cannot make
        for key, sel in (("high", hi), ("low", lo)):
            r = fs_at[sel & above] / f_m[sel & above]
            r = r[np.isfinite(r)]
            out[f"frequency_bias_{key}_pct"] = float(100 * (np.median(r) - 1)) if r.size else float("nan")
            out[f"frequency_bias_{key}_se_pct"] = bias_uncertainty_pct(r)
        out.update(_energy_numbers(t, xm, vm, xs, vs, mass, noise))
    res = xm - xs
    f, amp = spectrum(res - np.mean(res), rate)
    _f, am_spec = spectrum(xm - np.mean(xm), rate)
    f1 = float(f[np.argmax(am_spec[1:]) + 1]) if f.size > 2 else float("nan")
    k = int(np.argmax(amp[1:]) + 1) if f.size > 2 else 0
    out["main_frequency_hz"] = f1
    out["residual_peak_hz"] = float(f[k])
    out["residual_peak_ratio"] = float(f[k] / f1) if f1 > 0 else float("nan")
    slow = (f > 0) & (f < 0.3 * f1)
    p_meas = float(np.sum(am_spec ** 2)) or 1e-300
    out["low_frequency_drift_pct"] = float(100 * np.sum(amp[slow] ** 2) / p_meas)
    return out


#: The measured energy loss of a band is compared only when it is this many times its own
#: noise (:func:`loss_ratio_pct`).
LOSS_DETERMINED = 3.0


def _energy_numbers(t: np.ndarray, xm: np.ndarray, vm: np.ndarray, xs: np.ndarray, vs: np.ndarray,
                    mass: float, noise: float) -> dict[str, float]:
    """The energy lost per cycle, model against measured, at large and small amplitude [%], each
    with its standard error (:func:`median_uncertainty_pct`: the measured loss of a cycle is the
    difference of two kinetic energies at crossings, so it scatters with the noise far more than
    a frequency does: on lightly damped nulls it read -22..-37 % at small amplitude, s13noisy).
    The crossings' dead band and the amplitude guard as the frequency's (``noise``: :func:`part_noise`)."""
    out: dict[str, float] = {}
    e_m_amp, e_m_level, de_m = cycle_energies(t, xm, vm, mass, CROSSING_DEADBAND_SD * noise, noise)
    _amp, e_s_level, de_s = cycle_energies(t, xs, vs, mass)
    if e_m_amp.size < 6 or e_s_level.size < 3:
        return out
    hi, lo = _thirds(e_m_amp)
    # the model's loss at the measured cycle's RMS level, not at its largest |x| (biased up by the
    # noise near the peak: show.cycle_energies; session 20, s20strong)
    ds_at = _interp_loglog(e_m_level, e_s_level, de_s)
    above = e_m_amp >= NOISE_AMPLITUDE * noise
    for key, sel in (("high", hi), ("low", lo)):
        used = sel & above & np.isfinite(ds_at)
        out[f"energy_mismatch_{key}_pct"], out[f"energy_mismatch_{key}_se_pct"] = loss_ratio_pct(ds_at, de_m, used)
    return out


def loss_ratio_pct(model: np.ndarray, measured: np.ndarray, used: np.ndarray) -> tuple[float, float]:
    """The model's energy lost over the cycles ``used`` (a mask over the part's cycles, in order)
    against the measured one, ``sum model / sum measured - 1`` [%], and its standard error [%]
    (``nan, inf`` with fewer than 4 cycles, or a measured loss within :data:`LOSS_DETERMINED`
    of its own noise: the ratio of a loss the noise can zero is heavy-tailed, +185 % on average
    with a spread of 1000 % over 60 draws at zeta 1 % and noise 3 % of the peak).

    Not the median of per-cycle ratios: a cycle's measured loss ``E_i - E_i+2`` is the difference
    of two kinetic energies at crossings, on a lightly damped record a few times the noise of
    either, so per cycle it can be negative; keeping only the positive ones (as before session
    14) read the truth model of a noisy ring-down (zeta 1 %, noise 1 % of the peak) -29 % at small
    amplitude on average. The sum carries the noise without that selection, and over
    consecutive cycles it telescopes: only the crossings at the band's ends (and at its gaps)
    remain, ``sum_j c_j^2`` of them with ``c_j`` the count of used cycles starting at crossing
    ``j`` less those ending there. A crossing energy's noise ``s`` from successive differences
    of the band's measured-less-model losses (``4 s^2`` each; the model is smooth in amplitude),
    by MAD."""
    m, d, used = np.asarray(model, float), np.asarray(measured, float), np.asarray(used, bool)
    total = float(np.sum(d[used]))
    if used.sum() < 4 or not total > 0:
        return float("nan"), float("inf")
    u = np.diff((d - m)[used])  # within the band: a crossing's noise grows with the speed there
    s = 1.4826 * float(np.median(np.abs(u - np.median(u)))) / 2.0
    c = np.zeros(used.size + 2)
    c[:-2] += used
    c[2:] -= used
    noise = s * float(np.sqrt(np.sum(c ** 2)))
    if not total > LOSS_DETERMINED * noise:
        return float("nan"), float("inf")  # the measured loss is not told from its noise: no ratio
    ratio = float(np.sum(m[used])) / total
    return float(100 * (ratio - 1)), float(100 * abs(ratio) * noise / total)


def part_noise(r: Record, xm: np.ndarray, cond_nrmse: float = float("nan")) -> float:
    """The noise sd [m] of the measured coordinate on one held-out part: the one figure that
    both the crossings' dead band (:data:`CROSSING_DEADBAND_SD`) and the amplitude guard
    (:data:`NOISE_AMPLITUDE`) are measured in. The largest of

    * the noise floor's draw, ``cond_nrmse`` times the part's RMS (:attr:`NoiseFloor.part_conditioning_nrmse`:
      how far one more draw of the record's noise moves the conditioned coordinate; any channel,
      so an acceleration's integrated noise counts as it reaches the coordinate);
    * on a displacement channel, its noise at rest and its quantisation ``q / sqrt(12)`` (``q``
      the typical step between the values it takes): an 8-bit 1 kHz displacement channel is flat
      at rest, so its drawn noise is 0, yet it chatters between counts about zero once the ring-
      down is a few counts (its frequency doubled there: a -24 % "small-amplitude bias", blind
      unseen9 seed 9191, session 13).

    Session 13 kept two figures: the dead band from the displacement channel alone (none on an
    integrated coordinate, whose tail then crossed zero on the noise) and the guard from the
    floor's draw alone (none without a floor, so a coarse displacement's cycles of a few counts
    still gave a frequency)."""
    d = float(cond_nrmse)
    drawn = d * float(np.sqrt(np.mean(xm ** 2))) if np.isfinite(d) and xm.size else 0.0
    if r.response != "disp":
        return drawn
    steps = np.diff(np.unique(xm))
    q = float(np.median(steps)) if steps.size else 0.0
    return max(drawn, float(r.noise_rms), q / np.sqrt(12.0))


def baseline_symptoms(records: Sequence[Record], parts: Sequence[Part], sims: Sequence[np.ndarray],
                      vsims: Sequence[np.ndarray | None], mass: float,
                      cond_nrmse: Sequence[float] | None = None) -> list[Symptom]:
    """The symptoms listed in the module notes, median over the held-out parts.

    ``cond_nrmse``: per part, how far one more draw of the noise moves the conditioned
    coordinate, over the part's norm (the noise floor's ``d_cond``,
    :attr:`eddi.diagnosis.results.NoiseFloor.part_conditioning_nrmse`); with it the RMS noise
    of the coordinate is ``d_cond`` times the part's RMS, and cycles whose amplitude is within
    :data:`NOISE_AMPLITUDE` times it give no frequency (their zero crossings are the noise's
    as much as the motion's)."""
    rows = []
    for i, (p, xs, vs) in enumerate(zip(parts, sims, vsims)):
        r = records[p.record]
        sl = slice(p.start, p.stop)
        xm = r.x[sl]
        d = cond_nrmse[i] if cond_nrmse is not None and i < len(cond_nrmse) else float("nan")
        rows.append(_part_numbers(r.t[sl], xm, r.v[sl], xs, vs, mass, r.rate_hz, part_noise(r, xm, d)))

    def med(key: str) -> float:
        vals = [row[key] for row in rows if key in row and np.isfinite(row[key])]
        if not vals and any(key in row and row[key] == float("inf") for row in rows):
            return float("inf")
        return float(np.median(vals)) if vals else float("nan")

    out: list[Symptom] = []
    fh, fl = med("frequency_bias_high_pct"), med("frequency_bias_low_pct")
    sh, sl = med("frequency_bias_high_se_pct"), med("frequency_bias_low_se_pct")
    if np.isfinite(fh) or np.isfinite(fl):
        def said(b: float, se: float) -> str:
            return (f"{b:+.2f} % (+-{se:.2g} %)" if np.isfinite(b) and np.isfinite(se) else f"{b:+.2f} %"
                    if np.isfinite(b) else "not measured (the cycles there are at the noise)")
        words = (f"the model's frequency is off by {said(fh, sh)} at large amplitude and "
                 f"{said(fl, sl)} at small amplitude")
        if np.isfinite(fh) and np.isfinite(fl) and abs(fh - fl) > max(
                bias_threshold_pct(sh), bias_threshold_pct(sl)):
            words += ": the stiffness changes with amplitude differently from the model"
        elif not (_bias_beyond(fh, sh) or _bias_beyond(fl, sl)):
            words += " (within what the noise lets the cycles' frequencies tell)"
        out.append(Symptom("frequency_bias", words, {"high_amplitude_pct": fh, "low_amplitude_pct": fl,
                                                     "high_amplitude_se_pct": sh, "low_amplitude_se_pct": sl}))
    eh, el = med("energy_mismatch_high_pct"), med("energy_mismatch_low_pct")
    seh, sel_ = med("energy_mismatch_high_se_pct"), med("energy_mismatch_low_se_pct")
    if np.isfinite(eh) or np.isfinite(el):
        out.append(Symptom("energy_mismatch", _energy_words(eh, seh, el, sel_),
                           {"high_amplitude_pct": eh, "low_amplitude_pct": el,
                            "high_amplitude_se_pct": seh, "low_amplitude_se_pct": sel_,
                            **part_energy_z(rows)}))
    fr, ratio, f1 = med("residual_peak_hz"), med("residual_peak_ratio"), med("main_frequency_hz")
    if np.isfinite(fr):
        where = ("at the main frequency (a frequency or decay-rate error)" if abs(ratio - 1) < 0.05
                 else f"at {ratio:.2f} times the main frequency ({f1:.4g} Hz)")
        lower = _lower_motion([row.get("residual_peak_hz", float("nan")) for row in rows], ratio)
        if lower:
            where += (": below it, at the same frequency in every held-out part, a motion the single-mode "
                      "model has no response of its own at (a second, lower mode: a mount, rocking or "
                      "suspension mode, or the base moving)")
        out.append(Symptom("residual_peak", f"the error has most of its power near {fr:.4g} Hz, {where}",
                           {"frequency_hz": fr, "ratio_to_main": ratio, "main_frequency_hz": f1,
                            "lower_motion": float(lower)}))
    d = med("low_frequency_drift_pct")
    if np.isfinite(d):
        out.append(Symptom("low_frequency_drift",
                           f"{d:.1f} % of the measured power is a slow error below 0.3 times the main "
                           "frequency (drift, a slow sensor or base motion)", {"power_pct": d}))
    g = med("growth_ratio")
    if np.isfinite(g) or g == float("inf"):
        words = ("the simulation diverges" if g == float("inf") else
                 f"at the end of the record the simulation's amplitude is {g:.2f} times the measured one")
        if np.isfinite(g) and g > THRESHOLDS["growth_ratio"]:
            words += " (it decays too slowly or grows)"
        out.append(Symptom("growth", words, {"ratio": g}))
    drift = capture_drift(rows, [p.record for p in parts], [records[p.record].label or f"capture {p.record + 1}"
                                                             for p in parts],
                          [float(np.max(np.abs(records[p.record].x[p.start:p.stop]))) for p in parts])
    return out + ([drift] if drift is not None else [])


def part_energy_z(rows: Sequence[dict[str, float]]) -> dict[str, float]:
    """Per held-out part, the small-amplitude energy mismatch in its own standard errors (``z``) and
    the small-less-large difference in its standard errors (``shape z``): the least, the largest and
    the sum over the parts and how many parts gave one (the median over parts hides whether every part
    says the same; :mod:`eddi.diagnosis.smallamp`)."""
    z, dz = [], []
    for row in rows:
        el, sl = row.get("energy_mismatch_low_pct", np.nan), row.get("energy_mismatch_low_se_pct", np.nan)
        eh, sh = row.get("energy_mismatch_high_pct", np.nan), row.get("energy_mismatch_high_se_pct", np.nan)
        if np.isfinite(el) and np.isfinite(sl) and sl > 0:
            z.append(el / sl)
            if np.isfinite(eh) and np.isfinite(sh):
                dz.append((el - eh) / float(np.hypot(sl, sh)))
    nan = float("nan")
    return {"low_parts": float(len(z)), "low_z_min": min(z, default=nan), "low_z_max": max(z, default=nan),
            "low_z_sum": float(sum(z)), "shape_parts": float(len(dz)), "shape_z_min": min(dz, default=nan),
            "shape_z_max": max(dz, default=nan), "shape_z_sum": float(sum(dz)), "parts": float(len(rows))}


#: The band of residual-peak ratios (to the main frequency) read as a motion below the main mode
#: (:func:`_lower_motion`): above the drift band (0.3, ``low_frequency_drift``; the held-out nulls'
#: peaks sit at 0.24-0.38 of the main frequency, the slow error of the conditioning) and clear of
#: the main peak's skirt. The peaks of every held-out part must agree within LOWER_AGREE (relative).
LOWER_BAND = (0.4, 0.9)
LOWER_AGREE = 0.05


def _lower_motion(peaks_hz: Sequence[float], ratio: float) -> bool:
    """True when the residual's power peaks below the main frequency (ratio in :data:`LOWER_BAND`)
    at the same frequency in every held-out part (two or more, within :data:`LOWER_AGREE`): a
    motion the model lacks, not the noise, whose peak would wander from part to part (session 18:
    a lightly damped mode at 0.66 f1 put every part's peak within 1 % of 0.64 f1)."""
    p = np.asarray([f for f in peaks_hz if np.isfinite(f)], dtype=float)
    if p.size < 2 or not LOWER_BAND[0] <= ratio <= LOWER_BAND[1]:
        return False
    mid = float(np.median(p))
    return bool(mid > 0 and np.all(np.abs(p - mid) <= LOWER_AGREE * mid))


def _energy_words(eh: float, seh: float, el: float, sel_: float) -> str:
    def said(v: float, se: float) -> str:
        if not np.isfinite(v):
            return "not measured (the cycles there are at the noise)"
        side = "too much" if v > 0 else "too little"
        return f"{abs(v):.0f} % {side}" + (f" (+-{se:.2g} %)" if np.isfinite(se) else "")
    words = f"the model loses {said(eh, seh)} energy per cycle at large amplitude and {said(el, sel_)} at small amplitude"
    if not (_energy_beyond(eh, seh) or _energy_beyond(el, sel_)):
        words += " (within what the noise lets the cycles' losses tell)"
    return words


def energy_threshold_pct(se_pct: float) -> float:
    """The energy mismatch [%] beyond which it is notable: the larger of
    ``THRESHOLDS["energy_mismatch_pct"]`` (15 %) and ``BIAS_SE_FACTOR`` standard errors (as
    :func:`bias_threshold_pct`); an unknown standard error leaves the constant."""
    return _se_threshold("energy_mismatch_pct", se_pct)


def _energy_beyond(pct: float, se_pct: float) -> bool:
    return bool(np.isfinite(pct) and abs(pct) > energy_threshold_pct(se_pct))


def damping_signature(s: Symptom) -> bool:
    """An energy-per-cycle mismatch beyond its uncertainty in either band (a loss the model gets
    wrong: what a damping mechanism is, and a stiffness mechanism, conservative, does not mend)."""
    v = s.values
    return s.kind == "energy_mismatch" and any(
        _energy_beyond(v.get(f"{key}_amplitude_pct", float("nan")), v.get(f"{key}_amplitude_se_pct", float("nan")))
        for key in ("high", "low"))


def bias_threshold_pct(se_pct: float) -> float:
    """The frequency bias [%] beyond which it is notable, given its standard error: the larger
    of ``THRESHOLDS["frequency_bias_pct"]`` (0.5 %, set on nulls at 30-60 dB, where the noise
    moves the median cycle frequency by hundredths of a percent) and ``BIAS_SE_FACTOR`` standard
    errors (noisy records, and the cycles at small amplitude where the signal nears the noise).
    An unknown standard error (a symptom built elsewhere) leaves the constant."""
    return _se_threshold("frequency_bias_pct", se_pct)


def _se_threshold(key: str, se_pct: float) -> float:
    """The larger of ``THRESHOLDS[key]`` and ``BIAS_SE_FACTOR`` standard errors (the constant
    alone when the standard error is unknown)."""
    if np.isnan(se_pct):
        return THRESHOLDS[key]
    return max(THRESHOLDS[key], BIAS_SE_FACTOR * se_pct)


def _bias_beyond(bias_pct: float, se_pct: float) -> bool:
    return bool(np.isfinite(bias_pct) and abs(bias_pct) > bias_threshold_pct(se_pct))


def notable(s: Symptom) -> bool:
    """True when the symptom is beyond its threshold (worth saying)."""
    v = s.values
    if s.kind == "frequency_bias":
        return any(_bias_beyond(v.get(f"{key}_amplitude_pct", float("nan")),
                                v.get(f"{key}_amplitude_se_pct", float("nan"))) for key in ("high", "low"))
    if s.kind == "energy_mismatch":
        return damping_signature(s)
    if s.kind == "low_frequency_drift":
        return v.get("power_pct", 0.0) > THRESHOLDS["low_frequency_drift_pct"]
    if s.kind == "growth":
        return not np.isfinite(v.get("ratio", 1.0)) or v["ratio"] > THRESHOLDS["growth_ratio"]
    if s.kind == "residual_peak":
        return abs(v.get("ratio_to_main", 1.0) - 1.0) >= 0.05
    return True  # measurement-chain findings are always worth saying
