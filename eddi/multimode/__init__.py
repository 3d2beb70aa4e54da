"""Several modes from one measured coordinate: separate, identify each with EDDI, recombine.

The EDDI method identifies single-degree-of-freedom oscillators. The paper's suggested route
to several degrees of freedom (Sec. 4) is to separate the modes, identify each with EDDI and
recombine. This module does that for free-decay (ring-down) records of one velocity channel:

1. **Calculus on the raw record.** Displacement and acceleration are derived from the measured
   velocity with high-order stencils (4th-order cumulative integration, 6th-order central
   difference) so that, at the modal frequencies, ``x``, ``v`` and ``a`` satisfy ``v = x'`` and
   ``a = v'`` to better than 1e-4 (a trapezoid would bias the identified frequency by
   ``(omega dt)^2 / 24``, 0.1 % at 122 Hz and 5120 Hz).
2. **Separation.** The same zero-phase Butterworth band-pass (``scipy.signal.sosfiltfilt``) is
   applied to ``x``, ``v`` and ``a`` of each mode's band. A linear zero-phase filter commutes
   with differentiation, so the modal ``x_k, v_k, a_k`` stay consistent, and it removes the
   integration drift. Filtering smears the record's ends, so identification drops the first
   and last ``trim_s`` seconds.
3. **Per-mode EDDI, stacked over records.** Phase one (paper Eqs. 7-11) writes, for each
   record and each zero crossing ``gamma_i`` of ``x_k``, the energy balance
   ``sum_j b_j int_{gamma_0}^{gamma_i} v B_j dt = T(gamma_0) - T(gamma_i)`` (unit mass,
   ``T = v^2 / 2``); rows of all records are stacked (each record's rows divided by its
   ``T(gamma_0)`` so every record weighs the same) and solved by least squares. Phase two
   (paper Eq. 16): with ``L = 2T - E`` and ``E' = -v B``, ``dL/dq - p q''/q'`` reduces
   analytically to ``a + B(x, v)``, the negative conservative force, so the conservative force
   ``K(x) = -a - B(x, v)`` is evaluated sample by sample (no division by ``v``, which the paper
   notes is noise-prone) and the stiffness library is fitted to it by least squares.
4. **Recombination.** The model's velocity is the sum of the modal velocities; each mode is an
   :class:`~eddi.model.EquationOfMotion` per unit mass simulated by :func:`eddi.simulate.simulate`.
5. **Initial state.** Prediction "from the measured initial state" needs every mode's
   ``(x_k, v_k)`` at the start. A zero-phase filter uses samples after ``t0``, so instead the
   modal states are fitted (nonlinear least squares) to the first ``initial_window_s`` seconds
   of the raw velocity after ``t0``: information from that short window only, as a delay
   embedding of the same length would use.

Modules: :mod:`~eddi.multimode.model` (the modal-sum model as data), :mod:`~eddi.multimode.separate`
(steps 1-2), :mod:`~eddi.multimode.fit` (step 3), :mod:`~eddi.multimode.predict` (steps 4-5).
No I/O, no threads: arrays in, frozen results out.
"""

import importlib
from typing import Any

#: Where each public name lives. The package imports a submodule only when one of its names is
#: first used (PEP 562): ``separate`` and ``fit`` import ``scipy.signal``, which imports
#: ``scipy.stats`` (~0.45 s of CPU), and ``station diagnose`` on records with one mode needs
#: only the model class and ``trajectory_errors`` (session 10, issue 13).
_WHERE = {
    "ModeFit": "fit", "identify_modes": "fit",
    "MODAL_DAMPING": "model", "MODAL_STIFFNESS": "model", "MODAL_SUM_SCHEMA_VERSION": "model",
    "ModalSumModel": "model", "as_modal_sum": "model", "load_any_model": "model",
    "ModalSimulation": "predict", "Prediction": "predict", "TrajectoryErrors": "predict",
    "estimate_initial_states": "predict", "impact_index": "predict", "predict_record": "predict",
    "simulate_modal": "predict", "trajectory_errors": "predict",
    "ModalComponents": "separate", "separate_modes": "separate", "suggest_bands": "separate",
    "suggest_bands_many": "separate", "welch_sum": "separate",
}


def __getattr__(name: str) -> Any:
    where = _WHERE.get(name)
    if where is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f"{__name__}.{where}"), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_WHERE))


__all__ = [
    "MODAL_DAMPING",
    "MODAL_STIFFNESS",
    "MODAL_SUM_SCHEMA_VERSION",
    "ModalComponents",
    "ModalSimulation",
    "ModalSumModel",
    "ModeFit",
    "Prediction",
    "TrajectoryErrors",
    "as_modal_sum",
    "estimate_initial_states",
    "identify_modes",
    "impact_index",
    "load_any_model",
    "predict_record",
    "separate_modes",
    "simulate_modal",
    "suggest_bands",
    "suggest_bands_many",
    "trajectory_errors",
    "welch_sum",
]
