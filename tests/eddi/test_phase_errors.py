"""identify() refuses bad input with one-line errors of the right class."""

from __future__ import annotations

import numpy as np
import pytest

from eddi import IdentificationError, ModelError, SignalError, TermError, identify


@pytest.fixture()
def decay():
    t = np.arange(3000) / 1000.0
    w = 2 * np.pi * 5
    x = np.exp(-0.5 * t) * np.sin(w * t)
    v = np.exp(-0.5 * t) * (w * np.cos(w * t) - 0.5 * np.sin(w * t))
    return t, x, v


def _one_line(exc: pytest.ExceptionInfo) -> str:
    msg = str(exc.value)
    assert "\n" not in msg
    return msg


def test_nan_input(decay):
    t, x, v = decay
    x = x.copy()
    x[17] = np.nan
    with pytest.raises(SignalError, match=r"x contains 1 NaN or infinite values \(first at index 17\)") as exc:
        identify(t, x, v, 1.0)
    _one_line(exc)


def test_non_uniform_time(decay):
    t, x, v = decay
    t = t.copy()
    t[100:] += 0.0004
    with pytest.raises(SignalError, match="uniform") as exc:
        identify(t, x, v, 1.0)
    _one_line(exc)


def test_non_increasing_time(decay):
    t, x, v = decay
    t = t.copy()
    t[5] = t[4]
    with pytest.raises(SignalError, match=r"strictly increasing; t\[5\]") as exc:
        identify(t, x, v, 1.0)
    _one_line(exc)


def test_length_mismatch(decay):
    t, x, v = decay
    with pytest.raises(SignalError, match=r"v has shape \(2999,\); expected \(3000,\)"):
        identify(t, x, v[:-1], 1.0)


def test_one_zero_crossing(decay):
    t, x, v = decay
    # the first 0.15 s hold t = 0 and 0.1 s: x(0) = 0 exactly, then one more crossing
    with pytest.raises(IdentificationError, match=r"found 2 zero crossings of x; need at least 4") as exc:
        identify(t[:150], x[:150], v[:150], 1.0, damping="v,x^2*v,v^3")
    _one_line(exc)
    with pytest.raises(IdentificationError, match=r"found 1 zero crossing of x; need at least 2"):
        identify(t[50:150], x[50:150], v[50:150], 1.0, damping="v")


@pytest.mark.parametrize("mass", [0.0, -1.0, float("nan")])
def test_mass_not_positive(decay, mass):
    t, x, v = decay
    with pytest.raises(ModelError, match="mass must be > 0") as exc:
        identify(t, x, v, mass)
    _one_line(exc)


def test_unknown_term(decay):
    t, x, v = decay
    with pytest.raises(TermError, match="unknown term 'exp\\(x\\)'"):
        identify(t, x, v, 1.0, stiffness="x,exp(x)")
    with pytest.raises(TermError, match="depends on v"):
        identify(t, x, v, 1.0, stiffness="x,x*v")


def test_bad_window_and_route(decay):
    t, x, v = decay
    with pytest.raises(SignalError, match="window"):
        identify(t, x, v, 1.0, window=(2000, 1000))
    with pytest.raises(SignalError, match="route must be one of"):
        identify(t, x, v, 1.0, route="magic")


def test_errors_are_also_value_errors(decay):
    t, x, v = decay
    with pytest.raises(ValueError):
        identify(t, x, v, -1.0)
