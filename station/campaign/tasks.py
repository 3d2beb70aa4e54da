"""The work of one capture, run on a Dask worker: read it, call the pipeline, return one row.

This module is the campaign's only contact with the station's pipeline (the one import line
marked below). A capture is read here, on the worker, from its path and index
(:class:`~station.campaign.sources.CaptureRef`); the arrays never travel. Whatever happens, a
capture gives a row: a failure is a row with ``status="error"`` and the failure in one line,
so one bad file never stops a campaign.

A row is a plain dict (cheap to pickle back to the client)::

    file, capture, task, status, error, mass_kg, route, nrmse, nmte, diverged, unstable, driven_by,
    cause, gain, warnings, seconds, worker,
    coefficients = {"b[v]": ..., "k[x^3]": ...}      # [SI] of each term
    ci95 = {"b[v]": half-width, ...}                 # when the pipeline gives them
    units = {"b[v]": "N s/m", ...}                   # SI unit of each coefficient
    model = JSON text of the model (identify, diagnose), written to a file by the client
"""

from __future__ import annotations

import functools
import math
import os
import socket
import time
from dataclasses import dataclass
from typing import Any, Mapping, Sequence

# The station's pipeline, as its commands run it (issue 9 renames station/pipeline.py: only
# this import line follows; ``run_identify`` is exactly what ``station identify`` runs).
from station import session as station_pipeline
from station.commands.identify import run_identify
from station.campaign.sources import CaptureRef

#: Tasks a campaign runs on each capture.
TASKS = ("identify", "validate", "diagnose")


@dataclass(frozen=True)
class TaskOptions:
    """What to do with every capture (the same for the whole campaign).

    Attributes
    ----------
    task : {"identify", "validate", "diagnose"}
    mass : float or None
        [kg]; None to use the mass each capture records.
    damping, stiffness : str
        Candidate terms, comma-separated (``station identify``'s defaults).
    route : {"auto", "potential", "lagrangian"}
    refine : bool or None
        Output-error refinement after EDDI (identify); None: the pipeline's default.
    model_json : str or None
        The model to validate (JSON text, shipped once with the options), for ``validate``.
    """

    task: str = "identify"
    mass: float | None = None
    damping: str = ""
    stiffness: str = ""
    route: str = "auto"
    refine: bool | None = None
    model_json: str | None = None

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready (the model as its text)."""
        return {"task": self.task, "mass": self.mass, "damping": self.damping, "stiffness": self.stiffness,
                "route": self.route, "refine": self.refine, "model_json": self.model_json}


def _worker_name() -> str:
    return f"{socket.gethostname()}:{os.getpid()}"


def _one_line(exc: BaseException) -> str:
    """The failure in one line: the message of a user error, else ``Type: message``."""
    from station.cli import is_user_error

    text = (str(exc).strip().splitlines() or [""])[0]
    if not is_user_error(exc) or not text:
        text = f"{type(exc).__name__}: {text}".rstrip(": ")
    return text[:500]


def _mass(opts: TaskOptions, meas: Any) -> float:
    from station.errors import ConfigError

    m = opts.mass if opts.mass is not None else meas.mass
    if m is None:
        raise ConfigError(f"no mass: {meas.source} does not record it; give --mass KG")
    if not (math.isfinite(m) and m > 0):
        raise ConfigError(f"mass must be a number > 0 [kg], got {m:g}")
    return float(m)


def _capture_warnings(meas: Any) -> list[str]:
    md = meas.metadata or {}
    return [w for w, flag in (("double hit", md.get("double_hit")), ("overload", md.get("overload")),
                              ("partial record", md.get("partial"))) if flag]


def _coefficients(eom: Any) -> dict[str, float]:
    """``{"b[v]": ..., "k[x]": ...}`` of an equation of motion ({} for a modal-sum model)."""
    out = {f"b[{t}]": float(c) for t, c in getattr(eom, "damping", {}).items()}
    out.update({f"k[{t}]": float(c) for t, c in getattr(eom, "stiffness", {}).items()})
    return out


def _ci95(coefs: Mapping[str, float], *holders: Any) -> dict[str, float]:
    """Half-widths of the 95 % intervals the pipeline gives, keyed like :func:`_coefficients`.

    Reads a ``ci95`` mapping on the first of ``holders`` that has one, in any of the forms
    ``{"damping": {"v": hw}, "stiffness": {"x": hw}}`` (the pipeline's), ``{"b[v]": hw}`` or
    ``{"v": hw}``, a value being a half-width or a ``(low, high)`` pair. {} when none.
    """
    def half(val: Any) -> float:
        return (float(val[1]) - float(val[0])) / 2.0 if isinstance(val, (tuple, list)) else float(val)

    for h in holders:
        ci = getattr(h, "ci95", None)
        if not isinstance(ci, Mapping) or not ci:
            continue
        out: dict[str, float] = {}
        for group, prefix in (("damping", "b"), ("stiffness", "k")):
            if isinstance(ci.get(group), Mapping):
                out.update({f"{prefix}[{t}]": half(v) for t, v in ci[group].items() if f"{prefix}[{t}]" in coefs})
        for name, val in ci.items():
            if isinstance(val, Mapping):
                continue
            key = next((k for k in (name, f"b[{name}]", f"k[{name}]") if k in coefs), None)
            if key is not None:
                out[key] = half(val)
        return out
    return {}


def _units(units: Any) -> dict[str, str]:
    """``{"damping": {"v": "N s/m"}, "stiffness": {...}}`` -> ``{"b[v]": "N s/m", ...}``."""
    if not isinstance(units, Mapping):
        return {}
    out: dict[str, str] = {}
    for group, prefix in (("damping", "b"), ("stiffness", "k")):
        if isinstance(units.get(group), Mapping):
            out.update({f"{prefix}[{t}]": str(u) for t, u in units[group].items()})
    return out


def _pipeline_warnings(*holders: Any) -> list[str]:
    for h in holders:
        w = getattr(h, "warnings", None)
        if w:
            return [str(x) for x in w]
    return []


def _identify(meas: Any, opts: TaskOptions) -> dict[str, Any]:
    """Condition, identify and validate one record (``station identify``'s pipeline)."""
    from station.readers import require_one_coordinate

    require_one_coordinate(meas, "campaign")  # station identify's refusal, not the engine's
    mass = _mass(opts, meas)
    kw = {} if opts.refine is None else {"refine": opts.refine}
    res = run_identify(meas, mass, opts.damping, opts.stiffness, opts.route, **kw)
    eom, val = res.model.eom, res.validation
    warnings = _pipeline_warnings(res, res.model)
    from station.coupling import add_coupling_check  # station identify's checks: the same warnings

    found: dict[str, Any] = {"conditioning": {}, "warnings": []}
    add_coupling_check(meas, res, opts.damping, opts.stiffness, opts.route, found,
                       search=not meas.metadata.get("ac_coupling_s"))
    warnings += found["warnings"]
    if val.diverged or not math.isfinite(val.nrmse):
        warnings.append("the model's simulation diverges from the record")
    return {"mass_kg": mass, "route": res.model.route, "nrmse": float(val.nrmse), "nmte": val.nmte,
            "diverged": bool(val.diverged), "unstable": bool(res.unstable),
            "driven_by": "force" if res.driven_by_force else "initial state",
            "coefficients": _coefficients(eom), "ci95": _ci95(_coefficients(eom), res, res.model),
            "units": _units(getattr(res, "units", None)),
            "warnings": warnings,
            "model": eom.to_json()}


@functools.lru_cache(maxsize=4)
def _model_from_json(text: str) -> Any:
    from eddi.multimode import load_any_model

    return load_any_model(text)


def _validate(meas: Any, opts: TaskOptions) -> dict[str, Any]:
    """Simulate the campaign's model for one record and score it (``station validate``)."""
    from station.errors import ConfigError

    if not opts.model_json:
        raise ConfigError("validate: no model given")
    check = station_pipeline.validate_measurement(_model_from_json(opts.model_json), meas)
    warnings = ["the model's simulation diverges from the record"] if check.diverged else []
    return {"nrmse": float(check.nrmse), "nmte": check.nmte, "diverged": bool(check.diverged),
            "unstable": bool(check.diverged),
            "driven_by": check.driven_by, "warnings": warnings}


def _diagnose(meas: Any, opts: TaskOptions) -> dict[str, Any]:
    """Diagnose one record alone (its ring-down split into amplitude bands), exactly as
    ``station diagnose FILE:N`` does with the campaign's options (the pipeline's baseline, the
    chain's tolerances, the coupling check: :func:`station.commands.diagnose.diagnosis_object`)."""
    from station.commands.diagnose import default_args, diagnosis_object
    from station.readers import require_one_coordinate

    require_one_coordinate(meas, "campaign --task diagnose")
    mass = _mass(opts, meas)
    given: dict[str, Any] = {"mass": mass}
    given.update({k: v for k, v in (("damping", opts.damping), ("stiffness", opts.stiffness)) if v})
    if opts.refine is not None:
        given["refine"] = opts.refine
    diag, obj, _ = diagnosis_object([meas], default_args(**given))
    eom = diag.extended.model
    return {"mass_kg": mass, "nrmse": float(diag.extended.nrmse), "nmte": diag.extended.nmte,
            "cause": diag.cause, "gain": float(diag.gain), "coefficients": _coefficients(eom),
            "unstable": bool(obj["unstable"]), "warnings": [*obj["warnings"], *obj.get("notes", [])],
            "model": eom.to_json() if hasattr(eom, "to_json") else None}


_RUNNERS = {"identify": _identify, "validate": _validate, "diagnose": _diagnose}


def run_capture(ref: CaptureRef, opts: TaskOptions) -> dict[str, Any]:
    """Process one capture; never raises (a failure is a row with its error).

    Parameters
    ----------
    ref : CaptureRef
    opts : TaskOptions

    Returns
    -------
    dict
        The row (see the module docstring).
    """
    from station.readers import read_measurement

    t0 = time.perf_counter()
    row: dict[str, Any] = {"file": ref.file, "capture": ref.capture, "task": opts.task, "status": "ok",
                           "error": "", "worker": _worker_name()}
    try:
        meas = read_measurement(ref.spec)
        found = _RUNNERS[opts.task](meas, opts)
        found["warnings"] = _capture_warnings(meas) + list(found.get("warnings", ()))
        row.update(found)
    except Exception as exc:  # noqa: BLE001 - a campaign never stops on one capture
        row.update(status="error", error=_one_line(exc))
    row["seconds"] = time.perf_counter() - t0
    return row


def run_chunk(refs: Sequence[CaptureRef], opts: TaskOptions) -> list[dict[str, Any]]:
    """:func:`run_capture` over a few captures (one Dask task: less scheduling per capture)."""
    return [run_capture(r, opts) for r in refs]


def warm_up() -> float:
    """Import the pipeline and compile/load its kernels in this process; return the seconds.

    Run on every worker before a campaign (``client.run``) so the first captures do not pay the
    imports and the JIT cache loads. Identifies a noise-free linear oscillator (10 Hz, 1 %
    damping, 2 kHz, 2 s) struck by a 5 ms half-sine force, the path of a real impact record
    (force-driven validation, refinement, intervals), and imports the HDF5 reader.
    """
    import numpy as np

    from eddi.model import EquationOfMotion
    from eddi.simulate import simulate
    from station.readers import Measurement

    t0 = time.perf_counter()
    import station.storage  # noqa: F401 - h5py and the session reader (~0.1 s on the first capture)

    rate, f0, zeta = 2000.0, 10.0, 0.01
    t = np.arange(int(2.0 * rate)) / rate
    w = 2 * np.pi * f0
    force = np.where((t >= 0.1) & (t < 0.105), 50.0 * np.sin(np.pi * (t - 0.1) / 0.005), 0.0)
    try:
        eom = EquationOfMotion(mass=1.0, damping={"v": 2 * zeta * w}, stiffness={"x": w * w})
        acc = simulate(eom, t, force=force).a
        meas = Measurement(t=t, channels={"force": force, "acc": acc}, rate_hz=rate, pretrigger_samples=None,
                           mass=1.0, source="warm-up")
        run_identify(meas, 1.0, "v", "x")
    except Exception:  # noqa: BLE001 - best effort: the campaign reports real failures itself
        pass
    return time.perf_counter() - t0


def peak_memory_mb() -> float:
    """Peak resident memory of this process [MiB] (``getrusage``'s ``ru_maxrss``)."""
    import resource
    import sys

    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return rss / (1024.0 * 1024.0) if sys.platform == "darwin" else rss / 1024.0
