"""The shared-QR least squares of the candidates' shapes (``eddi.equation_error.Projector``):
one extra column in closed form, not LAPACK's SVD solver (session 11b, issue 13: ~1 ms a shape
on 2e4 rows, ~15 % of the candidates' fold fits); the same coefficients to rounding."""

from __future__ import annotations

import numpy as np
import pytest

from eddi.equation_error import Projector


def _problem(n: int, seed: int):
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 1.0, n)
    a0 = np.column_stack([np.sin(40 * t), 3e4 * np.cos(40 * t), 1e9 * np.sin(40 * t) ** 3])
    e = 1e-3 * np.sign(np.sin(40 * t))[:, None] + 1e-5 * rng.standard_normal((n, 1))
    y = a0 @ [2.0, -1e-4, 3e-9] + 5e2 * e[:, 0] + 1e-3 * rng.standard_normal(n)
    return a0, e, y


@pytest.mark.parametrize("n, seed", [(20000, 0), (3001, 1)])
def test_one_column_is_solved_in_closed_form_to_rounding(monkeypatch, n, seed) -> None:
    a0, e, y = _problem(n, seed)
    proj = Projector(a0, y)
    # the reference: LAPACK's solver on the same projected column
    se = np.sqrt(np.mean(e * e, axis=0))
    ep = e / se - proj.q @ (proj.q.T @ (e / se))
    ref, *_ = np.linalg.lstsq(ep, proj.r0, rcond=None)
    ref_ssr = float(np.sum((proj.r0 - ep @ ref) ** 2))
    calls = []
    monkeypatch.setattr(np.linalg, "lstsq", lambda *a, **k: calls.append(1) or (_ for _ in ()).throw(AssertionError))
    c, ssr = proj.fit(e)
    assert not calls  # closed form: no SVD solver for one column
    assert c[0] == pytest.approx(ref[0] / se[0], rel=1e-12)
    assert c[0] == pytest.approx(500.0, rel=1e-3)  # the planted coefficient
    assert ssr == pytest.approx(ref_ssr, rel=1e-12)


def test_a_zero_column_after_projection_gets_no_coefficient() -> None:
    a0, _, y = _problem(2000, 2)
    proj = Projector(a0, y)
    c, ssr = proj.fit(np.zeros((2000, 1)))
    assert c[0] == 0.0 and ssr == pytest.approx(float(proj.r0 @ proj.r0))
