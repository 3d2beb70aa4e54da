"""Mains interference on multi-channel captures (``station diagnose`` on several accelerometers).

Each response channel measured as acceleration is searched for persistent line tones
(:func:`eddi.diagnosis.mains.line_tones`: 50/60 Hz and harmonics within 1 %, standing in the
pre-trigger before the blow and in the late tail at one amplitude) on the captures as read, at
their own rate. A tone is reported as a ``line_tone`` symptom naming the channel, the frequency,
the amplitude [m/s^2] and its share of the channel's power at rest.

A tone rings on in the tail where the modes have died: the backbone of a mode read there
(:mod:`eddi.mdof.amplitude`) rings at the tone's frequency with the damping of a constant
amplitude (session 19, helper s19hum: a blind logger export with 0.005 g of 50 Hz on both
channels read "at 6.7e-07 m the records ring at 49.9 Hz, damping ratio 0.0037, the model at
73.7 Hz" and turned the verdict ``unexplained``). An amplitude symptom whose records ring within
2 % of a tone on its channel, at an amplitude no more than :data:`TONE_AMPLITUDE_FACTOR` times
the tone's displacement, is the tone's: it is kept among the symptoms, marked, and does not
decide the verdict (:func:`split_amplitude`).
"""

from __future__ import annotations

import math
from typing import Any, Sequence

import numpy as np

#: An amplitude symptom is the tone's when its amplitude is at most this many times the tone's
#: displacement amplitude ``A / (2 pi f)^2`` (the window's envelope holds the tone, the noise and
#: what is left of the mode).
TONE_AMPLITUDE_FACTOR = 4.0
#: ... and its records' frequency within this relative distance of the tone's.
TONE_FREQUENCY_REL = 0.02


def _blow_start(force: np.ndarray | None, rest: int) -> int:
    """The sample before the blow (force above 5 % of its peak, its offset the pre-trigger's median,
    or the whole channel's when no pre-trigger is known: a blow is a few samples), at most ``rest``
    when that is known (> 0). A capture whose time starts at 0 with no pre-trigger count (a lab's
    CSV) has its rest up to the blow, as the one-coordinate search has (``chain.record_tones``;
    before session 20 no tone was looked for on such captures here)."""
    from eddi.peaks import first_abs_above, peak_abs

    if force is None:
        return rest
    force = np.asarray(force, float)
    f = force - float(np.median(force[:rest] if rest > 8 else force))
    peak = peak_abs(f) if f.size else 0.0
    if not peak > 0:
        return rest
    hit = first_abs_above(f, 0.05 * peak)
    if hit < 0:
        return rest
    return min(rest, hit - 1) if rest > 0 else max(0, hit - 1)


def line_tone_symptoms(meas: Sequence[Any], names: Sequence[str]) -> list[dict]:
    """One ``line_tone`` symptom per channel and grid frequency seen on the captures (module
    notes): the median capture's tone, and in how many captures it stands."""
    from eddi.diagnosis.mains import line_tones, tail_of, tone_text
    from station.readers import response_channels

    seen: dict[tuple[str, float], list] = {}
    for m in meas:
        t = np.asarray(m.t, float)
        rest = int(m.pretrigger_samples or 0) or int(np.sum(t < 0))
        rest = _blow_start(m.channels.get("force"), rest)
        resp = response_channels(m.channels)
        for name in names:
            if name not in resp or resp[name][0] != "acc" or rest < 16:
                continue
            for tn in line_tones(t, np.asarray(resp[name][1], float), rest, tail_of(rest, t.size)):
                seen.setdefault((name, tn.nominal_hz), []).append(tn)
    out = []
    for (name, nominal), tones in sorted(seen.items()):
        mid = tones[int(np.argsort([tn.amplitude for tn in tones])[len(tones) // 2])]
        out.append({"kind": "line_tone", "channel": name, "frequency_hz": mid.frequency_hz, "nominal_hz": nominal,
                    "amplitude_m_s2": mid.amplitude, "share_pct": 100 * mid.power_share,
                    "captures": len(tones), "text": tone_text(name, [mid], len(tones), len(meas))})
    return out


def split_amplitude(amp: Sequence[dict], tones: Sequence[dict]) -> tuple[list[dict], list[dict]]:
    """(amplitude symptoms that stand, those a line tone on their channel explains: marked
    ``explained_by`` and with the reason in their text; module notes)."""
    keep, by_tone = [], []
    for s in amp:
        hit = None
        for tn in tones:
            f = float(tn["frequency_hz"])
            disp = float(tn["amplitude_m_s2"]) / (2 * math.pi * f) ** 2
            if (tn["channel"] == s.get("channel") and abs(float(s["measured_hz"]) - f) <= TONE_FREQUENCY_REL * f
                    and float(s["amplitude_m"]) <= TONE_AMPLITUDE_FACTOR * disp):
                hit = tn
                break
        if hit is None:
            keep.append(s)
            continue
        d = dict(s)
        d["explained_by"] = "line_tone"
        d["text"] = (f"{s['text']} - explained by the line tone at {hit['frequency_hz']:.4g} Hz on {hit['channel']} "
                     f"({hit['amplitude_m_s2']:.3g} m/s^2, {hit['amplitude_m_s2'] / (2 * math.pi * hit['frequency_hz']) ** 2:.2g} m "
                     "of displacement): the tail rings at the tone, not the mode")
        by_tone.append(d)
    return keep, by_tone


def tone_note(tones: Sequence[dict], explained: Sequence[dict]) -> str:
    """A note for the verdict on the line tones ('' without any)."""
    if not tones:
        return ""
    chans = sorted({t["channel"] for t in tones})
    freqs = sorted({round(float(t["frequency_hz"]), 2) for t in tones})
    text = (f"mains interference: a persistent line tone at {', '.join(f'{f:g}' for f in freqs)} Hz on "
            f"{', '.join(chans)} (before the blow and in the tail alike; "
            + "; ".join(f"{t['channel']} {t['amplitude_m_s2']:.3g} m/s^2, {t['share_pct']:.0f} % of its power at rest"
                        for t in tones) + ")")
    if explained:
        text += (f"; {len(explained)} amplitude symptom(s) ring at the tone's frequency at the tone's amplitude: the "
                 "tone's, not the model's (they do not decide the verdict)")
    return text
