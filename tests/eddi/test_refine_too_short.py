"""A record too short to refine keeps EDDI's estimate with refinement "off" and the reason
(session 14), instead of refusing the whole command.

``bench_diagnose_floor.py --snr 18,25`` coulomb_friction seed 300 (72.9 kg, 18.9 Hz at 256 Hz,
19 dB, three 308-sample captures): the pipeline's fit record has a free-response window of 28
samples, EDDI fits its 11 parameters there, and ``station diagnose`` was refused outright with
"output-error refinement of 11 parameters needs >= 44 compared values, got 28".
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from eddi.errors import IdentificationError, TooShortToRefine
from eddi.refine import refine_output_error

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))


def _case():
    from bench_diagnose_floor import recipe

    return recipe("coulomb_friction", 300, (18.0, 25.0))


def test_too_short_is_its_own_identification_error() -> None:
    """The refusal is a :class:`TooShortToRefine` (still an IdentificationError for callers)."""
    from eddi.model import EquationOfMotion

    import numpy as np

    t = np.arange(28) / 256.0
    x = 0.01 * np.cos(2 * np.pi * 18.9 * t)
    v = np.gradient(x, t)
    wide = EquationOfMotion.create(mass=1.0, damping={"v": 1.0, "x^2*v": 1.0, "v^3": 1.0},
                                   stiffness={"x": 1e4, "x^2": 1.0, "x^3": 1.0, "x^4": 1.0, "x^5": 1.0})
    with pytest.raises(TooShortToRefine, match="11 parameters needs >= 44 compared values, got 28"):
        refine_output_error(wide, t, x, v)
    assert issubclass(TooShortToRefine, IdentificationError)


def test_short_fit_record_keeps_eddi_with_refinement_off() -> None:
    """The pipeline delivers EDDI's estimate, refinement 'off' with the reason, and says so in a
    warning; diagnose gives a verdict (old code: IdentificationError from the pipeline)."""
    from eddi.diagnosis import diagnose
    from eddi.diagnosis.pipeline_base import pipeline_baseline
    from eddi.terms import DEFAULT_STIFFNESS

    recs, info = _case()
    pipe = pipeline_baseline(recs, info["mass_kg"], stiffness=DEFAULT_STIFFNESS)
    ch = pipe.choices
    assert ch["refinement"] == "off"
    assert ch["refinement_reason"].startswith("the record is too short to refine (output-error refinement of "
                                              "11 parameters needs >= 44 compared values, got 28)")
    assert ch["nrmse_refined"] is None
    assert any(w.startswith("the record is too short to refine") and "EDDI's estimate, not refined" in w
               for w in ch["warnings"])
    d = diagnose(recs, info["mass_kg"], stiffness=DEFAULT_STIFFNESS, pipeline=pipe)
    assert d.cause == "unexplained", d.verdict  # hidden friction: not `none`, and no wrong name
