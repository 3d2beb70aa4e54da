"""Earned silence: ``none`` and a name only when the measurement chain can be trusted.

:func:`eddi.diagnosis.name.decide` judges models held out against the noise floor. Its
comparison assumes that the records are what the model simulates: the force the structure
received and the acceleration of the given mass. When the measurement chain says otherwise,
a model that reproduces the held-out parts proves nothing:

* **impulse_mass** (:func:`eddi.diagnosis.chain.inspect`): the hammer impulse divided by the
  momentum change the measured acceleration gives is a mass that differs from the given one
  beyond the systematic allowance and beyond three times its spread over the captures. The
  model was identified with the wrong inertia (mass loading, a sensitivity error): its
  stiffness and damping per unit force are off by the same ratio, and a fit within the floor
  is the coefficients absorbing the error, not the model being right.
* **clipping**: the acceleration or force was flat at the converter's extreme; the records
  hold a nonlinearity of the chain, not of the structure.
* **base_motion**: a slow rigid-body motion under the response; the measured acceleration
  is not the deflection's.

With any of these the verdict is ``unexplained`` (never a bare ``none``, never a physical
name): the finding is the reason, in words and numbers, and a mechanism that would have been
named (or the best partial one) is kept as the partial explanation.

A **double_hit** (the hammer bounced: a second pulse in the force record) is reported, in
words and numbers, but does not overturn the verdict (since session 10; it did in sessions
7-9). The free response that EDDI fits and the folds judge starts after the last pulse the
force channel recorded (``free_start``), and every simulation starts there from the measured
state: the bounce is outside what is compared, so a model within the floor there is earned
as on a clean blow (the rig's bouncing hammer on the 0.3 kg, 9 Hz test system: baseline 0.8x
the floor, and it was called ``unexplained``; a blind set's bouncing nulls likewise, at
1.0x). :data:`REPORTED_KINDS` names such findings; the verdict says them
(:func:`reported_text`). A
blow that lands inside the free response (``inside_free_response``) still overturns it.

A baseline between the noise floor and ``none_factor`` times it keeps ``none`` only when no
symptom of :data:`BAND_KINDS` is notable (:func:`eddi.diagnosis.symptoms.notable`). The floor
is a typical scale of the held-out error the noise causes (median of three draws, raised to a
minimum), not an upper bound, so the held-out nrmse alone cannot tell a null from a small
departure in that band; the symptoms measure one physical quantity each, and on the 180
calibration nulls of session 7 (every ratio; benchmarks/bench_diagnose_calibration.py) the
largest were 0.15 % frequency bias, 0.044 % drift power and growth 1.01, against thresholds of
0.5 %, 5 % and 1.5 (on the fair test's nulls, 0.065 %, 0.15 % and 0.95): a notable one there
is a systematic error of the model, and ``none`` would say the model is complete where it
measurably is not. ``residual_peak`` counts only as a motion below the main frequency, at the
same frequency in every held-out part (``lower_motion``, session 18): where the error has its power is
notable on almost every null (171 of 180: the noise's own peak), it says where, not how much;
nor is the energy per cycle (:func:`_band_notable`: noise-bound on lightly damped records), except
as a loss law wrong in amplitude in every held-out part, each beyond its own standard errors
(:func:`eddi.diagnosis.smallamp.amplitude_signature`, session 19). At or below the floor, ``none``
stands (the model reproduces the records as well as the noise lets one tell).
"""

from __future__ import annotations

from typing import Sequence

from eddi.diagnosis.name import Decision
from eddi.diagnosis.results import Symptom
from eddi.diagnosis.smallamp import amplitude_signature, signature_text
from eddi.diagnosis.symptoms import notable

#: Measurement-chain findings that forbid ``none`` and a name (module notes).
CHAIN_KINDS = ("impulse_mass", "clipping", "base_motion", "response_lag")
#: Measurement-chain findings reported with the verdict but not overturning it (module notes).
REPORTED_KINDS = ("double_hit",)
#: How the reason of a verdict the chain overturned begins.
CHAIN_REASON = "the measurement chain cannot be trusted"
#: Baseline symptoms that forbid ``none`` above the floor (within the none factor) when notable
#: (not the energy per cycle: :func:`_band_notable`).
BAND_KINDS: tuple[str, ...] = ("frequency_bias", "low_frequency_drift", "growth", "residual_peak")


def earn(dec: Decision, ratio: float, symptoms: Sequence[Symptom], data_ratio: float | None = None) -> Decision:
    """The verdict once the measurement chain and the symptoms have been heard.

    Parameters
    ----------
    dec : Decision
        :func:`eddi.diagnosis.name.decide`'s verdict.
    ratio : float
        The baseline's held-out nrmse over the noise floor (both means over the parts).
    data_ratio : float, optional
        The same over the floor of the data (what ``none`` is judged and printed against); the
        small-amplitude signature (:mod:`eddi.diagnosis.smallamp`) applies above it (``ratio`` when
        not given).
    symptoms : sequence of Symptom
        The baseline's symptoms and the chain's findings.

    Returns
    -------
    Decision
        ``dec``, or ``unexplained`` with the reason and the partial explanation kept.
    """
    chain = [s for s in symptoms if overturns(s)]
    if chain:
        kinds = sorted({s.kind for s in chain})
        would = (f"{dec.winner.name} would have been named" if dec.winner is not None
                 else "the baseline would have been called complete" if dec.cause == "none"
                 else f"besides: {dec.reason}" if dec.reason else "")
        return Decision("unexplained", None, dec.winner or dec.partial, dec.within_floor,
                        f"{CHAIN_REASON} ({', '.join(kinds)}: "
                        + "; ".join(s.text for s in chain)
                        + ")" + (f"; {would}" if would else "")
                        + "; a model fitted to such records does not earn a verdict")
    if dec.cause == "unexplained":
        return dec
    if dec.cause == "none" and ratio > 1.0:
        band = [s for s in symptoms if s.kind in BAND_KINDS and _band_notable(s)]
        if band:
            return Decision("unexplained", None, dec.partial or dec.helpful, dec.within_floor,
                            f"the baseline is {ratio:.1f}x the noise floor (within the factor) and "
                            + "; ".join(s.text for s in band))
    above = ratio if data_ratio is None else data_ratio
    sig = amplitude_signature(symptoms) if dec.cause == "none" and above > 1.0 else None
    if sig is not None:  # the loss law wrong in amplitude in every part (session 19, eddi.diagnosis.smallamp)
        return Decision("unexplained", None, dec.partial or dec.helpful, dec.within_floor,
                        f"the baseline is {above:.1f}x the noise floor (within the factor, where nulls land too, "
                        f"so the ratio alone cannot tell) and {signature_text(sig)}")
    # the refit's swing (eddi.diagnosis.swing, session 20) is reported with the symptoms, never turns `none`:
    # a null of tests/eddi/test_diagnose_earned.py (0.3 kg, 9 Hz, 2 kHz, 38 dB, library call) swings 1.8-7.4x
    return dec


def _inside(s: Symptom) -> bool:
    """A reported finding that lands inside the free response compared (then it overturns)."""
    return bool(s.values.get("inside_free_response", 0.0))


def overturns(s: Symptom) -> bool:
    """Whether a measurement-chain finding forbids ``none`` and a name (module notes)."""
    return s.kind in CHAIN_KINDS or (s.kind in REPORTED_KINDS and _inside(s))


def reported_text(symptoms: Sequence[Symptom]) -> str:
    """A sentence for the verdict on the findings reported without overturning it
    (:data:`REPORTED_KINDS`), '' when there are none."""
    drift = "".join(f" Warning: {s.text}." for s in symptoms if s.kind == "capture_drift")
    found = [s for s in symptoms if s.kind in REPORTED_KINDS and not _inside(s)]
    if not found:
        return drift
    return drift + (" The hammer bounced (" + "; ".join(s.text for s in found) + "): the free response "
            "compared starts after the last blow the force channel recorded, so the bounce does not "
            "bear on the verdict (a clean single blow is still the better capture).")


def _band_notable(s: Symptom) -> bool:
    """Notable for the band rule (:func:`notable`). The energy per cycle is not in
    :data:`BAND_KINDS`: its mismatch is relative to the energy a cycle loses, ``4 pi zeta`` of
    its energy (2.5 % at zeta 0.2 %), so an error of a fraction of a percent in the measured
    energy is a mismatch of tens of percent. On nulls of my fair test (nothing hidden) it was
    -22 % to -37 % at small amplitude (0.8 kg, 60 Hz, zeta 0.5 %, 3 kHz, 33 dB) and -21 % at
    large amplitude (0.15 kg, 80 Hz, zeta 0.2 %, 2 kHz, 30 dB); each was called
    ``unexplained`` by an earlier form of this rule."""
    if s.kind == "residual_peak":
        # where the error has its power is the noise's own peak on almost every null (module notes);
        # only a peak below the main frequency, at the same frequency in every held-out part, is a
        # motion the model lacks (eddi.diagnosis.symptoms._lower_motion; session 18)
        return bool(s.values.get("lower_motion", 0.0))
    return notable(s)
