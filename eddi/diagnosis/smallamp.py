"""A loss law the model gets wrong with amplitude, the same way in every held-out part (session 19).

Between the noise floor and the ``none`` limit (:data:`eddi.diagnosis.settings.NONE_LIMIT`) the
ratio of the held-out error to the floor cannot tell a null from a small departure: nulls reach
1.8x (station path) and 2.4x (library call) the floor of the data (session 18), and one-DOF records
whose decay at small amplitude loses 12-21 % more energy per cycle than the model (a Stribeck-like
friction below the viscous loss, ``bench_diagnose_smallamp.py`` family ``smooth2``) land at 1.16-1.75x. The floor is a
scale of what the noise does to the *comparison*; the energy per cycle measures one physical
quantity, and its standard error from the cycles' own scatter (:func:`eddi.diagnosis.symptoms.loss_ratio_pct`)
says how far the noise moves it.

The median over parts of that mismatch is not enough (it is noise-bound on lightly damped records:
:func:`eddi.diagnosis.earn._band_notable`), and a single part's ``z`` is not either: on nulls one
part reached ``z = -10`` while another part of the same set read ``+0.6`` (an error of that fold's
model, or a part whose cycles scatter less than their ends move). A missing mechanism is in every
record: **every** held-out part must show the small-amplitude mismatch beyond :data:`PART_Z` of its
own standard error, all of one sign, and the parts together beyond :data:`POOLED_Z` (the sum of their
``z`` over the root of their number); the small-less-large difference likewise, of the same sign (the
loss law's *shape* in amplitude is wrong, not a damping coefficient a fold set a little high or low,
which moves both bands together); and the median mismatch at least :data:`MIN_PCT`. Then, above
the floor of the data, the verdict is ``unexplained`` with that symptom (:func:`eddi.diagnosis.earn.earn`),
never ``none (uncertain)``, unless a mechanism earns its name by the ordinary rule (:func:`named`).
Thresholds from nulls: on 58 (own, the calibration's held-out 2000-2029, s18none's 20-32 dB family) none
held every part beyond 2 SE of one sign at 5 %; the nearest (noisy 13, 20-32 dB: +13 %, parts at z
1.8-2.5, pooled 4.4, the shape's pooled 3.9) sets :data:`PART_Z` and :data:`POOLED_Z` above it.

The measured distributions (nulls and hidden small-amplitude losses, ``benchmarks/bench_diagnose_smallamp.py``
and the calibration's held-out nulls) are in docs/diagnosis.md, "Session 19 (helper s19small)".
"""

from __future__ import annotations

import math
from typing import Callable, Sequence

from eddi.diagnosis.decide import Decision
from eddi.diagnosis.results import Symptom

#: Each held-out part's small-amplitude energy mismatch, and its small-less-large difference, must be
#: beyond this many of their standard errors, all of one sign (module notes).
PART_Z = 2.0
#: And over the parts together (the sum of the parts' ``z`` over the root of their number) beyond this.
POOLED_Z = 5.0
#: The median small-amplitude mismatch must be at least this [%] (module notes).
MIN_PCT = 5.0
#: Held-out parts that must give a figure (all of them, and at least this many).
MIN_PARTS = 2


def _one_sign(v: dict[str, float], key: str, sign: float, parts: float) -> bool:
    """Every part's ``z`` of ``key`` beyond PART_Z with ``sign``, and their pooled ``z`` beyond POOLED_Z."""
    least = min(sign * v.get(f"{key}_z_min", math.nan), sign * v.get(f"{key}_z_max", math.nan))
    pooled = sign * v.get(f"{key}_z_sum", math.nan) / math.sqrt(parts)
    return bool(least >= PART_Z and pooled >= POOLED_Z)


def amplitude_signature(symptoms: Sequence[Symptom]) -> Symptom | None:
    """The energy-mismatch symptom when it shows a loss law wrong in amplitude in every held-out part
    (module notes), else None."""
    s = next((x for x in symptoms if x.kind == "energy_mismatch"), None)
    if s is None:
        return None
    v = s.values
    parts = v.get("parts", 0.0)
    el = v.get("low_amplitude_pct", math.nan)
    if not (parts >= MIN_PARTS and v.get("low_parts") == parts and v.get("shape_parts") == parts):
        return None
    if not (math.isfinite(el) and abs(el) >= MIN_PCT):
        return None
    sign = -1.0 if el < 0 else 1.0
    return s if (_one_sign(v, "low", sign, parts) and _one_sign(v, "shape", sign, parts)) else None


def signature_text(s: Symptom) -> str:
    """The reason of an ``unexplained`` the signature made (one clause)."""
    v = s.values
    el, eh = v["low_amplitude_pct"], v.get("high_amplitude_pct", math.nan)
    pooled = abs(v["low_z_sum"]) / math.sqrt(v["parts"])
    large = (f", against {eh:+.0f} % (+-{v.get('high_amplitude_se_pct', math.nan):.2g} %) at large amplitude"
             if math.isfinite(eh) else "")
    return (f"at small amplitude the measured decay loses energy {'faster' if el < 0 else 'slower'} than the model "
            f"in every held-out part (the model loses {abs(el):.0f} % {'less' if el < 0 else 'more'} per cycle, "
            f"+-{v.get('low_amplitude_se_pct', math.nan):.2g} %{large}; every part beyond {PART_Z:g} of its standard "
            f"errors and of one sign, {pooled:.0f} pooled over the parts, and the small-less-large difference too): the "
            f"model's loss law in amplitude is not the records' ({'more' if el < 0 else 'less'} loss where the "
            "motion is small: dry friction, a joint or contact, radiation, or the measurement chain), a departure "
            "the noise does not make")


def named(dec: Decision, symptoms: Sequence[Symptom], ratio: float, redecide: Callable[[], Decision]) -> Decision:
    """``dec``, or a name judged as above the ``none`` limit when the signature holds above the floor.

    Within the limit a name needs the strong cut (``settings.STRONG_MARGIN``, 60 %): there the
    baseline's error may be the noise's. With the signature the records refuse that excuse, so a
    mechanism is judged by the ordinary rule (``redecide``: :func:`eddi.diagnosis.decide.decide` with
    no ``none`` allowance: the margin, every part, consistent strength, look-alikes told apart, within
    the named factor). Without a winner there ``dec`` stands, and :func:`eddi.diagnosis.earn.earn`
    turns its ``none`` into ``unexplained`` with the symptom."""
    if dec.cause != "none" or not ratio > 1.0 or amplitude_signature(symptoms) is None:
        return dec
    alt = redecide()
    return alt if alt.winner is not None else dec


def below_floor_note(cause: str, symptoms: Sequence[Symptom], data_ratio: float) -> str:
    """A sentence for a ``none`` at or below the floor of the data whose energy shows the signature
    (session 20, s20onedof; '' otherwise). The policy: the verdict stays ``none``. Below the floor the
    model predicts every held-out part as well as the noise lets one tell, so a missing mechanism there
    changes no prediction the records can check, and ``none`` is what the held-out comparison says
    (turning it would move the calibration ladders' ``none`` rungs, not a null: the signature held on
    none of 58 nulls and on 12 hidden-loss sets below the floor, s19small). But the energy per cycle
    measures one physical quantity beyond its own standard errors in every part, which the noise does
    not make: the verdict says so, in numbers, as a remark, so the user can test it (longer records,
    more blows at small amplitude)."""
    sig = amplitude_signature(symptoms) if cause == "none" and data_ratio <= 1.0 else None
    if sig is None:
        return ""
    return (f" A remark, not a verdict (the energy per cycle says more than the held-out comparison): "
            f"{signature_text(sig)}; the held-out prediction is within the noise (the baseline is {data_ratio:.2f}x "
            "the floor), so the verdict stays none: no mechanism is missing that the prediction can show, and "
            "longer records or more cycles at small amplitude would test this one.")
