"""SINDy baseline (pysindy), with the same candidate terms as EDDI.

SINDy regresses the acceleration on the candidate library with sequentially thresholded
least squares (STLSQ): ``a = sum_f c_f f(x, v)``. Two variants: the acceleration is given
(a measured one: the stronger baseline), or ``a=None`` and pysindy differentiates the state
``(x, v)`` itself with its default ``FiniteDifference`` (second-order centred), as the paper
used SINDy (it is fed the state time series). With ``m a = -sum b_j B_j - sum k_n K_n``
the coefficients of the equation of motion are ``-m c_f``. pysindy is a test/benchmark
extra, so it is imported only when :func:`sindy_identify` runs.
"""

from __future__ import annotations

import numpy as np

from eddi.energy import check_series
from eddi.errors import IdentificationError, ModelError, TermError
from eddi.model import EquationOfMotion
from eddi.terms import DEFAULT_DAMPING, DEFAULT_STIFFNESS, Term, parse_terms


def _term_function(term: Term):
    def f(x: np.ndarray, v: np.ndarray) -> np.ndarray:
        return term(x, v)

    return f


def sindy_identify(
    t: np.ndarray,
    x: np.ndarray,
    v: np.ndarray,
    a: np.ndarray | None,
    mass: float,
    damping: str | tuple[str, ...] | list[str] = DEFAULT_DAMPING,
    stiffness: str | tuple[str, ...] | list[str] = DEFAULT_STIFFNESS,
    threshold: float = 0.05,
    coordinate: str = "displacement [m]",
) -> EquationOfMotion:
    """Fit ``m a = -sum b_j B_j(x, v) - sum k_n K_n(x)`` with pysindy's STLSQ.

    Parameters
    ----------
    t : ndarray, shape (n,), [s]
    x, v : ndarray, shape (n,)
        Coordinate and rate.
    a : ndarray, shape (n,), or None
        Acceleration given to SINDy; None: pysindy differentiates ``(x, v)`` itself
        (``FiniteDifference``, its default), the paper's usage.
    mass : float
        Mass or inertia (> 0).
    damping, stiffness : str or sequence of str
        Candidate terms, as for :func:`eddi.identify.identify`.
    threshold : float
        STLSQ threshold (paper: 0.05 Duffing, 0.005 pendulum), applied to the
        coefficients of ``a`` on column-normalised library terms.
    coordinate : str
        Stored in the model.

    Returns
    -------
    EquationOfMotion
        Terms that STLSQ zeroed are kept with coefficient 0.

    Raises
    ------
    ModelError, SignalError, TermError, IdentificationError
    """
    import pysindy as ps  # lazy: test/benchmark extra

    if not (np.isfinite(mass) and mass > 0):
        raise ModelError(f"mass must be > 0, got {mass!r}")
    d_terms = parse_terms(damping)
    k_terms = parse_terms(stiffness)
    for tm in k_terms:
        if tm.depends_on_v:
            raise TermError(f"stiffness term {tm.text!r} depends on v; put it in the damping library")
    t, sig = check_series(t, {"x": x, "v": v, "a": a})
    terms = d_terms + k_terms
    library = ps.CustomLibrary(
        library_functions=[_term_function(tm) for tm in terms],
        function_names=[(lambda name: (lambda p, q: name))(tm.text) for tm in terms],
    )
    # alpha=0: plain least squares between thresholding steps, as in the MATLAB
    # sparsifyDynamics the paper used. normalize_columns: the paper Duffing library spans
    # ~20 decades (x^5 ~ 1e-10, v^3 ~ 1e3); unnormalised, pysindy's normal-equation solve
    # loses k3 entirely even with the exact acceleration (measured: k3 = 1.2 N/m^3 instead
    # of 3e8). The threshold then applies to column-normalised coefficients.
    model = ps.SINDy(
        optimizer=ps.STLSQ(threshold=threshold, alpha=0.0, normalize_columns=True),
        feature_library=library,
    )
    states = np.column_stack([sig["x"], sig["v"]])
    if sig["a"] is None:
        model.fit(states, t=t, feature_names=["x", "v"])
    else:
        rates = np.column_stack([sig["v"], sig["a"]])
        model.fit(states, t=t, x_dot=rates, feature_names=["x", "v"])
    coef = np.asarray(model.coefficients())
    if coef.shape != (2, len(terms)):
        raise IdentificationError(f"SINDy returned coefficients of shape {coef.shape}; expected (2, {len(terms)})")
    c = -float(mass) * coef[1]
    return EquationOfMotion.create(
        mass=float(mass),
        damping={tm.text: float(ci) for tm, ci in zip(d_terms, c[: len(d_terms)])},
        stiffness={tm.text: float(ci) for tm, ci in zip(k_terms, c[len(d_terms):])},
        coordinate=coordinate,
        notes=f"identified by SINDy (STLSQ threshold {threshold}"
              + (", state differentiated by pysindy)" if sig["a"] is None else ", acceleration given)"),
    )
