"""Terms, the equation-of-motion schema and the compiled simulator."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from eddi import Effect, EquationOfMotion, ModelError, TermError, parse_term, parse_terms, simulate


@pytest.mark.parametrize(
    "text, exps",
    [
        ("x", (1, 0, 0, 0, 0, 0)),
        ("x^2*v", (2, 1, 0, 0, 0, 0)),
        ("v^3", (0, 3, 0, 0, 0, 0)),
        ("sign(v)", (0, 0, 0, 0, 0, 1)),
        ("abs(v)*v", (0, 1, 0, 1, 0, 0)),
        (" x ^ 2 * v ", (2, 1, 0, 0, 0, 0)),
    ],
)
def test_parse_term_exponents(text: str, exps: tuple[int, ...]) -> None:
    assert parse_term(text).exponents == exps


@pytest.mark.parametrize("bad", ["y", "x^", "x**2", "exp(x)", "", "x*", "__import__('os')", "x^99"])
def test_bad_term_raises_naming_it(bad: str) -> None:
    with pytest.raises(TermError):
        parse_term(bad)


def test_duplicate_terms_refused() -> None:
    with pytest.raises(TermError, match="twice"):
        parse_terms("x^2*v,v*x^2")


def test_term_values() -> None:
    x = np.array([-2.0, 0.0, 3.0])
    v = np.array([1.5, -1.0, -2.0])
    np.testing.assert_allclose(parse_term("abs(v)*v")(x, v), [2.25, -1.0, -4.0])
    np.testing.assert_allclose(parse_term("x^2*v")(x, v), [6.0, 0.0, -18.0])
    np.testing.assert_allclose(parse_term("sign(v)")(x, v), [1.0, -1.0, -1.0])


def test_model_json_round_trip_with_effects() -> None:
    eom = EquationOfMotion.create(
        mass=0.815,
        damping={"v": 0.196, "x^2*v": -20441.0},
        stiffness={"x": 390.0, "x^3": 1.3e7},
        effects=[Effect(name="clearance", params={"gap_m": 1e-3, "stiffness_n_per_m": 2000.0})],
    )
    back = EquationOfMotion.from_json(eom.to_json())
    assert back == eom
    assert back.effects[0].params == {"gap_m": 1e-3, "stiffness_n_per_m": 2000.0}


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"mass": 0.0}, "mass"),
        ({"mass": 1.0, "stiffness": {"x*v": 1.0}}, "depends on v"),
        ({"mass": 1.0, "damping": {"q": 1.0}}, "unknown term"),
        ({"mass": 1.0, "effects": [{"name": "magic", "params": {}}]}, "unknown effect"),
        ({"mass": 1.0, "effects": [{"name": "clearance", "params": {"gap_m": 1.0}}]}, "stiffness_n_per_m"),
    ],
)
def test_invalid_model_is_one_line_model_error(kwargs: dict, match: str) -> None:
    with pytest.raises(ModelError, match=match) as info:
        EquationOfMotion.create(**kwargs)
    assert "\n" not in str(info.value)


def test_from_json_rejects_garbage() -> None:
    with pytest.raises(ModelError, match="not valid JSON"):
        EquationOfMotion.from_json("{mass: 1")


def _reference(rhs, y0, t):
    sol = solve_ivp(rhs, (t[0], t[-1]), y0, t_eval=t, rtol=1e-12, atol=1e-14, method="DOP853")
    return sol.y


def test_simulate_matches_dop853_on_paper_duffing() -> None:
    # Paper Sec. 3.1, Eq. 17: m=0.05, b=0.5, b_nl=4000, k=300, k_nl=3e8, x(0)=0, v(0)=10.
    eom = EquationOfMotion.create(mass=0.05, damping={"v": 0.5, "x^2*v": 4000.0},
                                  stiffness={"x": 300.0, "x^3": 3e8})
    t = np.arange(5001) / 1e4
    res = simulate(eom, t, v0=10.0)

    def rhs(_t, s):
        x, v = s
        return [v, -(0.5 * v + 4000 * x * x * v + 300 * x + 3e8 * x**3) / 0.05]

    ref = _reference(rhs, [0.0, 10.0], t)
    assert np.linalg.norm(res.x - ref[0]) / np.linalg.norm(ref[0]) < 1e-7
    assert not res.diverged


def test_simulate_second_mode_and_effects_match_dop853() -> None:
    eom = EquationOfMotion.create(
        mass=1.0, damping={"v": 0.5}, stiffness={"x": 1000.0},
        effects=[
            Effect(name="second_mode", params={"mass_kg": 0.1, "stiffness_n_per_m": 900.0,
                                               "damping_n_s_per_m": 0.2, "coupling_n_per_m": 50.0}),
            Effect(name="quadratic_damping", params={"coefficient": 2.0}),
            Effect(name="clearance", params={"gap_m": 0.02, "stiffness_n_per_m": 3000.0}),
        ],
    )
    t = np.arange(4001) / 2000.0

    def rhs(_t, s):
        x, v, y, w = s
        fx = 0.5 * v + 1000 * x + 2.0 * abs(v) * v + 3000 * np.sign(x) * max(abs(x) - 0.02, 0) + 50 * (x - y)
        fy = 0.2 * w + 900 * y + 50 * (y - x)
        return [v, -fx, w, -fy / 0.1]

    ref = _reference(rhs, [0.0, 2.0, 0.0, 0.0], t)
    res = simulate(eom, t, v0=2.0, substeps=8)
    assert np.linalg.norm(res.x - ref[0]) / np.linalg.norm(ref[0]) < 1e-5
    assert np.linalg.norm(res.y - ref[2]) / np.linalg.norm(ref[2]) < 1e-4


def test_simulate_forced_from_rest_linear_impulse_response() -> None:
    # A short pulse of impulse I on a linear oscillator gives x(t) ~ I/(m wd) e^{-z wn t} sin(wd t).
    m, c, k, fs = 0.5, 0.4, 2000.0, 20000.0
    eom = EquationOfMotion.create(mass=m, damping={"v": c}, stiffness={"x": k})
    n = 20000
    force = np.zeros(n)
    force[:3] = [0.0, 1.0, 0.0]  # triangle of area 1/fs N s
    res = simulate(eom, rate_hz=fs, n_samples=n, force=force)
    impulse = 1.0 / fs
    wn = np.sqrt(k / m)
    z = c / (2 * np.sqrt(k * m))
    wd = wn * np.sqrt(1 - z * z)
    t = res.t - 1.0 / fs
    expected = np.where(t > 0, impulse / (m * wd) * np.exp(-z * wn * t) * np.sin(wd * t), 0.0)
    assert np.linalg.norm(res.x - expected) / np.linalg.norm(expected) < 2e-3


def test_divergence_is_flagged_not_raised() -> None:
    eom = EquationOfMotion.create(mass=1.0, damping={"v": -50.0}, stiffness={"x": 1.0, "x^3": -5.0})
    res = simulate(eom, rate_hz=100.0, n_samples=5000, x0=1.0, substeps=1)
    assert res.diverged
    assert np.isnan(res.x[-1])


def test_parse_term_remembers_and_still_refuses() -> None:
    """parse_term is cached (session 11: one identification parsed the same terms ~500 times):
    the same frozen Term comes back; bad input still raises TermError every time."""
    from eddi.errors import TermError
    from eddi.terms import parse_term

    assert parse_term("x^2*v") is parse_term("x^2*v")
    assert parse_term(" x^2 * v ").exponents == (2, 1, 0, 0, 0, 0)
    for bad in ("x^13", "y", ["x"], 3):
        for _ in range(2):
            with pytest.raises(TermError):
                parse_term(bad)


def test_integer_powers_are_repeated_products() -> None:
    """Session 11: a term's power above 2 is a product of the factor with itself (numpy's
    ``y**3`` calls ``pow``, ~40 ns a sample: 14 % of a diagnosis' CPU), so ``x^3`` is
    ``x * x * x`` bit for bit (pow differs from it by an ulp on part of the samples) and
    within a few ulps of ``pow``."""
    from eddi.terms import parse_term

    rng = np.random.default_rng(2)
    x = rng.normal(size=20_000) * 1e-3
    v = rng.normal(size=20_000)
    assert np.array_equal(parse_term("x^3")(x, v), x * x * x)
    assert np.array_equal(parse_term("x^2*v^3")(x, v), (x * x) * (v * v * v))
    assert np.array_equal(parse_term("abs(v)^4")(x, v), np.abs(v) * np.abs(v) * np.abs(v) * np.abs(v))
    for text, ref in (("x^5", x**5), ("v^7", v**7), ("abs(x)^3*sign(v)", np.abs(x) ** 3 * np.sign(v))):
        assert np.allclose(parse_term(text)(x, v), ref, rtol=1e-15, atol=0.0)
    assert np.array_equal(parse_term("x^2")(x, v), x**2)  # numpy's square, as before
