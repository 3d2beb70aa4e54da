"""EDDI on the two simulated cases of the paper (Sec. 3.1 Duffing, Sec. 3.2 pendulum).

Exact states come from a tight ODE solve (scipy DOP853, rtol 1e-12). Each identified
coefficient is checked against its exact value, at or below the paper's EDDI error
(paper Tables 1-4), and the Duffing stiffness also below the paper's SINDy errors.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from eddi import identify, validate

DAMPING = "v,v^2,v^3,x^2*v"  # paper Eqs. 18 and 20
STIFFNESS = "x,x^2,x^3,x^4,x^5"  # paper Sec. 3.1 and 3.2

# paper Eq. 17
M, B, B_NL, K, K_NL = 0.05, 0.5, 4000.0, 300.0, 3e8
# paper Eq. 19
PM, PL, PB, G = 2.0, 0.8, 0.1, 9.81
INERTIA = PM * PL**2  # 1.28
MGL = PM * G * PL  # 15.696


def _solve(rhs, y0, duration_s, rate_hz):
    t = np.arange(int(round(duration_s * rate_hz)) + 1) / rate_hz
    sol = solve_ivp(rhs, (0.0, t[-1]), y0, method="DOP853", rtol=1e-12, atol=1e-14, t_eval=t)
    assert sol.success
    a = np.array(rhs(0.0, sol.y))[1]
    return t, sol.y[0], sol.y[1], a


def duffing_response():
    """Paper Eq. 17: x(0)=0, v(0)=10 m/s, 1 s at 10 kHz."""

    def rhs(_t, y):
        x, v = y
        return [v, -(B * v + B_NL * x * x * v + K * x + K_NL * x**3) / M]

    return _solve(rhs, [0.0, 10.0], 1.0, 1e4)


def pendulum_response():
    """Paper Eq. 19: theta(0)=pi/2, thetadot(0)=0, 100 s at 100 Hz."""

    def rhs(_t, y):
        th, w = y
        return [w, -(PB * PL**2 * w + MGL * np.sin(th)) / INERTIA]

    return _solve(rhs, [np.pi / 2, 0.0], 100.0, 100.0)


def rel(value: float, exact: float) -> float:
    return abs(value / exact - 1.0)


@pytest.fixture(scope="module")
def duffing():
    return duffing_response()


@pytest.fixture(scope="module")
def pendulum():
    return pendulum_response()


@pytest.fixture(scope="module")
def duffing_model(duffing):
    t, x, v, _a = duffing
    return identify(t, x, v, M, damping=DAMPING, stiffness=STIFFNESS)


def test_duffing_damping_beats_paper(duffing_model):
    b = duffing_model.eom.damping
    assert rel(b["v"], B) < 0.002e-2  # paper Table 1: EDDI 0.002 %
    assert rel(b["x^2*v"], B_NL) < 0.05e-2  # paper Table 1: EDDI 0.05 %
    # terms absent from the system stay negligible: their force at 10 m/s, 13 mm is
    # below 1e-4 of the linear damping force there
    assert abs(b["v^2"]) * 10**2 < 1e-4 * B * 10
    assert abs(b["v^3"]) * 10**3 < 1e-4 * B * 10


def test_duffing_stiffness_beats_paper_and_sindy(duffing_model):
    k = duffing_model.eom.stiffness
    assert duffing_model.route == "potential"
    # paper Table 2: EDDI k1 5.77 %, k3 0.1 %; SINDy k1 20.3 %, k3 0.42 %; target k1 < 0.5 %
    assert rel(k["x"], K) < 0.5e-2
    assert rel(k["x^3"], K_NL) < 0.1e-2
    # measured with this implementation: both about 2e-11 relative
    assert rel(k["x"], K) < 1e-8
    assert rel(k["x^3"], K_NL) < 1e-8
    # absent even terms: force at the largest amplitude (13 mm) below 1e-5 of k3 x^3 there
    xm = 0.013
    assert abs(k["x^2"]) * xm**2 < 1e-5 * K_NL * xm**3
    assert abs(k["x^4"]) * xm**4 < 1e-5 * K_NL * xm**3


def test_duffing_lagrangian_route_also_beats_paper(duffing):
    t, x, v, _a = duffing
    model = identify(t, x, v, M, damping=DAMPING, stiffness=STIFFNESS, route="lagrangian")
    k = model.eom.stiffness
    assert model.route == "lagrangian"
    assert model.phase_two.conservative_force is not None
    assert rel(k["x"], K) < 5.77e-2 / 10  # paper Table 2: EDDI 5.77 %
    assert rel(k["x^3"], K_NL) < 0.1e-2  # paper Table 2: EDDI 0.1 %


def test_duffing_paper_weighting_and_eq12_energy_still_beat_paper(duffing):
    """The paper's own formulation (cumulative rows, E from gamma_0) with this quadrature."""
    t, x, v, _a = duffing
    model = identify(t, x, v, M, damping=DAMPING, stiffness=STIFFNESS, route="potential",
                     weighting="paper", anchored=False)
    b, k = model.eom.damping, model.eom.stiffness
    assert rel(b["v"], B) < 0.002e-2  # paper Table 1
    assert rel(b["x^2*v"], B_NL) < 0.05e-2  # paper Table 1
    assert rel(k["x"], K) < 5.77e-2  # paper Table 2
    assert rel(k["x^3"], K_NL) < 0.1e-2  # paper Table 2


def test_duffing_phase_one_energies(duffing, duffing_model):
    t, x, v, _a = duffing
    p1 = duffing_model.phase_one
    # gamma_0 is t = 0 (x(0) = 0) and T(gamma_0) = m v0^2 / 2 = 2.5 J
    assert p1.gamma[0] == pytest.approx(0.0, abs=1e-12)
    assert p1.kinetic_at_gamma[0] == pytest.approx(0.5 * M * 10.0**2, rel=1e-9)
    # crossings alternate sign of v and are ~ half periods apart
    i0, i1 = p1.sample_slice
    e_exact = 0.5 * M * v[i0:i1] ** 2 + K * x[i0:i1] ** 2 / 2 + K_NL * x[i0:i1] ** 4 / 4
    # mechanical energy re-anchored at crossings: within 1e-7 of the local energy
    assert np.max(np.abs(p1.mechanical_anchored - e_exact) / e_exact) < 1e-7
    # Eq. 12 energy: within 2e-8 of the initial energy everywhere (1.5e-8 measured with the
    # full-cycle rows of phase one, 0.4e-8 with half-cycle rows: full cycles cancel the slow
    # velocity error of integrated records, eddi/phase_one.py; on this clean record they
    # leave the quadrature's error over one more half cycle per row)
    assert np.max(np.abs(p1.mechanical - e_exact)) < 2e-8 * 2.5
    # modelled dissipated energy matches the measured one at the crossings
    assert np.max(np.abs(p1.dissipated_model_at_gamma - p1.r_vector)) < 1e-8 * 2.5


def test_pendulum_beats_paper(pendulum):
    t, th, w, _a = pendulum
    model = identify(t, th, w, INERTIA, damping=DAMPING, stiffness=STIFFNESS,
                     coordinate="angle [rad]")
    b, k = model.eom.damping, model.eom.stiffness
    assert model.eom.coordinate == "angle [rad]"
    assert rel(b["v"], PB * PL**2) < 0.0094e-2  # paper Table 3: EDDI 9.4e-3 %
    # paper Table 4: EDDI k1 0.28 %, k3 1.34 %, k5 14.46 % (Taylor coefficients of mgl sin)
    assert rel(k["x"], MGL) < 0.28e-2
    assert rel(k["x^3"], -MGL / 6) < 1.34e-2
    assert rel(k["x^5"], MGL / 120) < 14.46e-2
    # also the SINDy k1 error of the paper (0.032 %, Table 4)
    assert rel(k["x"], MGL) < 0.032e-2


@pytest.mark.parametrize("route", ["potential", "lagrangian"])
def test_pendulum_both_routes_beat_paper(pendulum, route):
    t, th, w, _a = pendulum
    model = identify(t, th, w, INERTIA, damping=DAMPING, stiffness=STIFFNESS, route=route)
    k = model.eom.stiffness
    assert model.route == route
    assert rel(k["x"], MGL) < 0.28e-2  # paper Table 4
    assert rel(k["x^3"], -MGL / 6) < 1.34e-2  # paper Table 4
    assert rel(k["x^5"], MGL / 120) < 14.46e-2  # paper Table 4


def test_auto_route_keeps_the_better_simulation(pendulum):
    t, th, w, _a = pendulum
    model = identify(t, th, w, INERTIA, damping=DAMPING, stiffness=STIFFNESS)
    assert set(model.route_scores) == {"potential", "lagrangian"}
    assert model.route_scores[model.route] == min(model.route_scores.values())
    # and the chosen model reproduces the 100 s response closely
    assert validate(model.eom, t, th, v=w).nrmse < 2e-3


def test_window_selects_samples(duffing):
    t, x, v, _a = duffing
    model = identify(t, x, v, M, damping=DAMPING, stiffness=STIFFNESS, window=(2000, 9000))
    assert model.window == (2000, 9000)
    i0, i1 = model.phase_one.sample_slice
    assert 2000 <= i0 < i1 <= 9000
    assert model.phase_one.gamma[0] >= t[2000]
    assert model.phase_one.gamma[-1] <= t[8999]
    # the late, low-amplitude part still gives the linear terms
    assert rel(model.eom.damping["v"], B) < 1e-3
    assert rel(model.eom.stiffness["x"], K) < 1e-3


def test_acceleration_given_is_used(duffing):
    t, x, v, a = duffing
    model = identify(t, x, v, M, damping=DAMPING, stiffness=STIFFNESS, a=a, route="lagrangian")
    # exact dE/dt in the Lagrangian route: k1 to 1e-8 (6e-7 with a spline derivative of L)
    assert rel(model.eom.stiffness["x"], K) < 1e-7
    assert rel(model.eom.stiffness["x^3"], K_NL) < 1e-7


def test_refine_keeps_the_clean_duffing_exact(duffing, duffing_model):
    t, x, v, _a = duffing
    model = identify(t, x, v, M, damping=DAMPING, stiffness=STIFFNESS, refine=True)
    assert model.unrefined == duffing_model.eom
    assert model.refinement is not None and model.refinement.channel == "x"  # no a given
    assert model.refinement.nrmse_after <= model.refinement.nrmse_before
    assert model.refinement.x0 == pytest.approx(0.0, abs=1e-7)  # paper Eq. 17: x(0) = 0
    assert model.refinement.v0 == pytest.approx(10.0, rel=1e-6)  # paper Eq. 17: v(0) = 10
    assert rel(model.eom.damping["v"], B) < 1e-6
    assert rel(model.eom.damping["x^2*v"], B_NL) < 1e-6
    assert rel(model.eom.stiffness["x"], K) < 1e-6
    assert rel(model.eom.stiffness["x^3"], K_NL) < 1e-6


def test_refine_on_noisy_duffing_is_ten_times_closer(duffing):
    # white noise, 60 dB SNR over the whole record, on x and v (bench_paper_cases --noise 60)
    t, x, v, _a = duffing
    rng = np.random.default_rng(0)
    xn = x + rng.normal(0, np.std(x) * 1e-3, x.size)
    vn = v + rng.normal(0, np.std(v) * 1e-3, v.size)
    model = identify(t, xn, vn, M, damping=DAMPING, stiffness=STIFFNESS, refine=True)
    assert model.unrefined is not None
    for group, term, exact in (("damping", "v", B), ("damping", "x^2*v", B_NL),
                               ("stiffness", "x", K), ("stiffness", "x^3", K_NL)):
        before = rel(getattr(model.unrefined, group)[term], exact)
        after = rel(getattr(model.eom, group)[term], exact)
        assert after < 0.1 * before, term
    # and below the paper's EDDI errors on clean data (paper Tables 1-2)
    assert rel(model.eom.damping["v"], B) < 0.002e-2
    assert rel(model.eom.damping["x^2*v"], B_NL) < 0.05e-2
    assert rel(model.eom.stiffness["x"], K) < 5.77e-2
    assert rel(model.eom.stiffness["x^3"], K_NL) < 0.1e-2


def test_refine_needs_a_window_of_16_samples(duffing):
    # session 13 (s13noisy): the 64 was only the first stage's window; >= 16 samples and 4
    # compared values per fitted parameter (tests/eddi/test_refine_short_record.py)
    from eddi.errors import IdentificationError
    from eddi.refine import refine_output_error

    t, x, v, _a = duffing
    eom = identify(t, x, v, M, damping=DAMPING, stiffness=STIFFNESS).eom
    with pytest.raises(IdentificationError, match="needs >= 16 samples, got 15"):
        refine_output_error(eom, t[:15], x[:15], v[:15])
    from eddi.errors import SignalError

    with pytest.raises(SignalError, match="'a' \\(with a given\\).*got 'a' without a"):
        refine_output_error(eom, t, x, v, channel="a")
    with pytest.raises(SignalError, match="got 'force'"):
        refine_output_error(eom, t, x, v, channel="force")


def test_sindy_baseline_with_exact_acceleration(duffing):
    pytest.importorskip("pysindy")
    from eddi.sindy import sindy_identify

    t, x, v, a = duffing
    eom = sindy_identify(t, x, v, a, M, DAMPING, STIFFNESS, threshold=0.05)  # paper Sec. 3.1
    assert eom.mass == M
    assert rel(eom.damping["v"], B) < 1e-6
    assert rel(eom.stiffness["x^3"], K_NL) < 1e-6
    assert eom.stiffness["x^2"] == 0.0  # thresholded away
    # with a finite-difference acceleration EDDI's k1 beats SINDy's by orders of magnitude
    eom_fd = sindy_identify(t, x, v, np.gradient(v, t), M, DAMPING, STIFFNESS, threshold=0.05)
    eddi_k1 = identify(t, x, v, M, damping=DAMPING, stiffness=STIFFNESS).eom.stiffness["x"]
    assert rel(eddi_k1, K) * 1e3 < rel(eom_fd.stiffness["x"], K)


def test_sindy_as_in_the_paper_differentiates_the_state(duffing):
    # pysindy fed (x, v) only, its own FiniteDifference: near the paper's SINDy figures
    # (paper Tables 1-2: b1 0.5 %, b4 1.92 %, k1 20.3 %, k3 0.42 %), far from EDDI's
    pytest.importorskip("pysindy")
    from eddi.sindy import sindy_identify

    t, x, v, _a = duffing
    eom = sindy_identify(t, x, v, None, M, DAMPING, STIFFNESS, threshold=0.05)
    assert "differentiated by pysindy" in eom.notes
    assert 1e-3 < rel(eom.damping["v"], B) < 1e-2
    assert 1e-2 < rel(eom.stiffness["x"], K) < 0.203
    assert rel(eom.stiffness["x^3"], K_NL) < 0.42e-2
