"""eddi.lsq: MINPACK's Levenberg-Marquardt in numpy, against exact solutions and scipy's lmder."""

import numpy as np
import pytest

from eddi.lsq import LsqResult, least_squares

T = np.linspace(0.0, 10.0, 400)
TRUTH = np.array([2.0, 0.3, 3.1, 0.4, 0.05])


def _ringdown(p):
    return p[0] * np.exp(-p[1] * T) * np.cos(p[2] * T + p[3]) + p[4]


def _ringdown_jac(p):
    e, c, s = np.exp(-p[1] * T), np.cos(p[2] * T + p[3]), np.sin(p[2] * T + p[3])
    return np.column_stack([e * c, -p[0] * T * e * c, -p[0] * e * s * T, -p[0] * e * s, np.ones_like(T)])


Y = _ringdown(TRUTH) + 0.01 * np.random.default_rng(0).standard_normal(T.size)


@pytest.mark.parametrize("x_scale", [1.0, "jac", np.array([1.0, 10.0, 0.1, 1e-3])])
def test_a_linear_problem_is_solved_exactly(x_scale):
    rng = np.random.default_rng(3)
    a = rng.standard_normal((50, 4))
    b = rng.standard_normal(50)
    exact = np.linalg.lstsq(a, b, rcond=None)[0]
    sol = least_squares(lambda p: a @ p - b, np.zeros(4), jac=lambda p: a, x_scale=x_scale, xtol=1e-12, ftol=1e-12)
    assert isinstance(sol, LsqResult) and sol.success
    np.testing.assert_allclose(sol.x, exact, rtol=1e-12, atol=1e-14)
    np.testing.assert_array_equal(sol.jac, a)
    assert sol.cost == pytest.approx(0.5 * float(np.sum((a @ exact - b) ** 2)), rel=1e-13)


def test_a_consistent_linear_system_ends_at_zero_residual_by_finite_differences():
    a = np.array([[2.0, 1.0], [1.0, 3.0], [0.0, 1.0]])
    x = np.array([0.7, -1.3])
    sol = least_squares(lambda p: a @ p - a @ x, np.array([5.0, 5.0]), jac="2-point")
    np.testing.assert_allclose(sol.x, x, rtol=1e-7)
    assert sol.cost < 1e-20


@pytest.mark.parametrize("x0", [[1.5, 0.2, 3.0, 0.0, 0.0], [1.0, 1.0, 2.9, 1.0, 0.0]])
@pytest.mark.parametrize("x_scale", [1.0, "jac", np.array([1.0, 0.1, 1.0, 1.0, 0.01])])
@pytest.mark.parametrize("jac", [_ringdown_jac, "2-point"])
def test_a_nonlinear_fit_follows_scipys_minpack(x0, x_scale, jac):
    from scipy.optimize import least_squares as scipy_least_squares

    def res(p):
        return _ringdown(p) - Y

    ref = scipy_least_squares(res, x0, jac=jac, method="lm", x_scale=x_scale, xtol=1e-12, ftol=1e-12)
    sol = least_squares(res, x0, jac=jac, x_scale=x_scale, xtol=1e-12, ftol=1e-12)
    # the same iterations (MINPACK's counts, its termination), the optimum to rounding
    assert (sol.status, sol.nfev) == (ref.status, ref.nfev)
    np.testing.assert_allclose(sol.x, ref.x, rtol=1e-9, atol=1e-12)
    assert sol.cost == pytest.approx(ref.cost, rel=1e-12)
    np.testing.assert_allclose(sol.jac, ref.jac, rtol=1e-6, atol=1e-6)
    assert np.max(np.abs(sol.x - TRUTH)) < 0.02


def test_the_evaluation_limit_ends_the_fit_with_status_0():
    sol = least_squares(lambda p: _ringdown(p) - Y, [1.0, 1.0, 2.9, 1.0, 0.0], jac=_ringdown_jac, max_nfev=3)
    assert sol.status == 0 and sol.nfev == 3 and not sol.success


def test_ftol_ends_earlier_than_rounding():
    def res(p):
        return _ringdown(p) - Y

    loose = least_squares(res, [1.0, 1.0, 2.9, 1.0, 0.0], jac=_ringdown_jac, ftol=1e-2)
    tight = least_squares(res, [1.0, 1.0, 2.9, 1.0, 0.0], jac=_ringdown_jac, ftol=1e-12, xtol=1e-12)
    assert loose.status == 2 and loose.nfev < tight.nfev
    assert loose.cost >= tight.cost


def test_the_switch_runs_scipys_solver(monkeypatch):
    monkeypatch.setenv("EDDI_LSQ", "scipy")
    sol = least_squares(lambda p: _ringdown(p) - Y, [1.5, 0.2, 3.0, 0.0, 0.0], jac=_ringdown_jac)
    assert not isinstance(sol, LsqResult) and sol.success


def test_fewer_residuals_than_variables_is_a_value_error():
    with pytest.raises(ValueError, match="at least as many residuals"):
        least_squares(lambda p: np.array([p[0] + p[1]]), np.zeros(2), jac="2-point")
