"""``station demo``: the whole bench on the simulated rig, end to end, in one call.

:func:`run_demo` does what an operator does with a real rig, through the real code path:

1. opens ``sim://duffing-smooth`` (the simulated rig's firmware served on a pseudo-terminal,
   read by the serial driver), configures a force trigger;
2. records three impacts at three force levels (the system's demo levels: 246 N, 600 N and
   1110 N for ``duffing-smooth``, paper Sec. 3.3.1 / Fig. 12) into ``OUT/session.h5``, letting
   the structure come to rest between impacts (hold-off = the system's ring-down time);
3. identifies the equation of motion on the middle impact (``OUT/model.json``) and validates
   it on the low and high ones, simulated from rest with their measured forces (the paper
   identified on one impact and validated on the others);
4. writes the report (``OUT/report/index.html`` and its PNGs), with the rig's true
   coefficients beside the identified ones.
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable

from station.errors import ConfigError, StationError
from station.output_safety import write_text_atomic

if TYPE_CHECKING:  # imported when used: `station demo --help` stays light; the engine and
    # the report are imported while the rig powers on (warm_up_engine)
    from eddi.model import EquationOfMotion
    from station.capture import AcquireResult, Status
    from station.config import BenchConfig
    from station.session import SessionResult
    from station.report import Report

#: The README's first command runs on this device.
DEMO_DEVICE = "sim://duffing-smooth"
#: Record after the trigger [s] (the paper recorded 45 s; 8 s hold ~40 cycles here).
DEMO_RECORD_S = 8.0
#: Pre-trigger [s] (paper Sec. 3.3.1: 1 s).
DEMO_PRETRIGGER_S = 1.0
#: The candidate terms the demo identifies with: paper Eq. 21 and Eq. 22.
DEMO_DAMPING = ("v", "x^2*v", "v^3")
DEMO_STIFFNESS = ("x", "x^2", "x^3", "x^4", "x^5")
#: The notes of every capture the demo saves (how it knows its own session file again).
DEMO_NOTES = "station demo"


@dataclass(frozen=True)
class DemoResult:
    """What :func:`run_demo` did and wrote.

    Attributes
    ----------
    device : str
    session_file, model_file : Path
        ``OUT/session.h5`` and ``OUT/model.json``.
    report : Report or None
        ``OUT/report/index.html`` and its figures (None without matplotlib, the ``report`` extra).
    acquisition : AcquireResult
    link_dropped_samples, crc_errors : int
        Link statistics of the driver.
    session : SessionResult
        Identification on the middle impact, validation on the others.
    truth : EquationOfMotion or None
        The rig's physics, read back from the captures.
    levels_n : tuple of float
        Requested peak forces [N], in order.
    elapsed_s : dict of str to float
        Wall time of each stage [s].
    """

    device: str
    session_file: Path
    model_file: Path
    report: Report | None
    acquisition: AcquireResult
    link_dropped_samples: int
    crc_errors: int
    session: SessionResult
    truth: EquationOfMotion | None
    levels_n: tuple[float, ...]
    elapsed_s: dict[str, float]


def rig_truth(session_file: str | Path, capture: int = 0) -> EquationOfMotion | None:
    """The simulated rig's equation of motion stored with a capture (None for a real rig)."""
    from eddi.model import EquationOfMotion

    from station.storage import read_capture

    rig = read_capture(session_file, capture, verify=False).rig
    if not rig or not rig.get("scenario"):
        return None
    try:
        eom = json.loads(rig["scenario"]).get("equation_of_motion")
        return EquationOfMotion.model_validate(eom) if eom else None
    except (ValueError, TypeError, AttributeError):
        return None


#: What the demo says when matplotlib (the ``report`` extra) is not installed.
NO_REPORT = 'report skipped: matplotlib is not installed (pip install "eddi-station[report]")'


def report_available() -> bool:
    """True when the report's plotting library (the ``report`` extra) is installed."""
    import importlib.util

    return importlib.util.find_spec("matplotlib") is not None


def warm_up_engine() -> None:
    """Import the engine and the report and compile the simulator (before, not inside, any
    timed step: the demo runs it while the rig process powers on)."""
    import numpy as np

    import station.session  # noqa: F401  (conditioning, EDDI, validation)
    from eddi.model import EquationOfMotion
    from eddi.simulate import simulate

    if report_available():
        import station.report  # noqa: F401  (matplotlib)
    eom = EquationOfMotion(mass=1.0, damping={"v": 0.1}, stiffness={"x": 100.0, "x^3": 1.0})
    simulate(eom, rate_hz=1000.0, n_samples=8, force=np.zeros(8))
    simulate(eom, rate_hz=1000.0, n_samples=8, x0=0.1, v0=0.0, substeps=2)


def with_seed(device: str, seed: int) -> str:
    """``sim://SYSTEM[?...]`` with ``seed=N`` set (replacing one the URL had)."""
    import urllib.parse

    parts = urllib.parse.urlsplit(device)
    query = [(k, v) for k, v in urllib.parse.parse_qsl(parts.query, keep_blank_values=True) if k != "seed"]
    query.append(("seed", str(int(seed))))
    return urllib.parse.urlunsplit(parts._replace(query=urllib.parse.urlencode(query)))


def demo_config(device: str, mass_kg: float, levels_n: tuple[float, ...], record_s: float,
                holdoff_s: float) -> BenchConfig:
    """Bench configuration of the demo: force trigger at a quarter of the lowest level."""
    from station.config import parse_config

    return parse_config({
        "device": {"url": device, "block_size": 4096},  # few, large frames: less work per sample
        "trigger": {"channel": "force", "level_n": 0.25 * min(levels_n), "pretrigger_s": DEMO_PRETRIGGER_S,
                    "record_s": record_s, "holdoff_s": holdoff_s, "on_double_hit": "reject",
                    "on_overload": "reject"},
        "specimen": {"mass_kg": mass_kg, "name": device.removeprefix("sim://")},
        "notes": DEMO_NOTES,
    }, "demo")


def run_demo(
    out_dir: str | Path,
    *,
    device: str = DEMO_DEVICE,
    record_s: float = DEMO_RECORD_S,
    on_status: Callable[[Status], None] | None = None,
    refine: bool = True,
    seed: int | None = None,
) -> DemoResult:
    """Acquire three impacts on the simulated rig, identify on one, validate on two, report.

    Parameters
    ----------
    out_dir : str or Path
        Created; ``session.h5`` in it is replaced.
    device : str
        A ``sim://SYSTEM`` URL (the rig must deliver the impacts itself).
    record_s : float
        Record length after the trigger [s], > 0.
    on_status : callable, optional
        Live acquisition status (see :func:`station.capture.acquire`).
    refine : bool
        Follow EDDI with the output-error refinement seeded by it (:mod:`eddi.refine`); the
        plain EDDI estimate and its held-out validation are reported beside the refined model.
    seed : int, optional
        Noise seed of the rig (None: the URL's, else the system's default). The impacts come
        at fixed sample times, so the same seed gives the same captures, bit for bit.

    Returns
    -------
    DemoResult

    Raises
    ------
    ConfigError
        Not a ``sim://`` device, or a bad record length.
    StationError, DriverError, EddiError
        Acquisition or identification failed (one line).
    KeyboardInterrupt
        On Ctrl-C (the captures saved are kept).
    """
    if not device.startswith("sim://"):
        raise ConfigError(f"--device: the demo needs a simulated rig (sim://SYSTEM) to deliver the impacts, "
                          f"got {device!r}")
    if not record_s > 0:
        raise ConfigError(f"--record-s: expected > 0 s, got {record_s}")
    if seed is not None:
        device = with_seed(device, seed)
    from simulated_rig.systems import system_info
    from station.capture import ImpactPlan, acquire, configure_device, device_metadata
    from station.devices import open_device, parse_sim_url
    from station.storage import CaptureWriter, StorageError

    info = system_info(parse_sim_url(device).system)
    levels = tuple(float(f) for f in info.demo_forces_n[:3])
    out = Path(out_dir)
    session_file = out / "session.h5"
    refuse_foreign_session(session_file)
    try:
        out.mkdir(parents=True, exist_ok=True)
        session_file.unlink(missing_ok=True)
    except OSError as exc:
        raise StorageError(f"{out}: cannot prepare the output directory ({exc.strerror or exc})") from None
    # the structure rests between impacts for the system's ring-down time
    cfg = demo_config(device, info.eom.mass, levels, record_s, holdoff_s=info.record_s)
    elapsed: dict[str, float] = {}
    t0 = time.perf_counter()
    writer = CaptureWriter(session_file, session={"bench_config": cfg.model_dump_json()})
    with open_device(device, while_starting=warm_up_engine) as daq:
        configure_device(daq, cfg)
        settings = cfg.trigger_settings(cfg.resolve_channels(daq.info.channels), daq.info.rate_hz)
        # in sample time (reproducible); repeats for rejected impacts
        plan = ImpactPlan(levels * 3, (False,) * (3 * len(levels))).scheduled(settings)
        acq = acquire(daq, cfg, writer, len(levels), impacts=plan, on_status=on_status, idle_timeout_s=10.0,
                      device_meta=device_metadata(daq, device))
        stats = daq.stats
    elapsed["acquire"] = time.perf_counter() - t0
    if acq.interrupted:
        raise KeyboardInterrupt
    if acq.error is not None:
        raise StationError(f"acquisition stopped: {acq.error} ({acq.captures} capture(s) kept in {session_file})")
    from station.session import run_session, read_all

    t1 = time.perf_counter()
    session = run_session(read_all([str(session_file)]), damping=DEMO_DAMPING, stiffness=DEMO_STIFFNESS,
                          refine=refine)
    model_file = out / "model.json"
    try:
        write_text_atomic(model_file, session.fit.model.eom.to_json())
    except OSError as exc:
        raise StorageError(f"{model_file}: cannot write ({exc.strerror or exc})") from None
    elapsed["identify_validate"] = time.perf_counter() - t1
    truth = rig_truth(session_file)
    t2 = time.perf_counter()
    report = None
    if report_available():
        from station.report import write_report

        report = write_report(session, out / "report", truth=truth, title=f"EDDI Station demo: {device}")
    elapsed["report"] = time.perf_counter() - t2
    elapsed["total"] = time.perf_counter() - t0
    return DemoResult(device, session_file, model_file, report, acq, int(getattr(stats, "dropped_samples", 0)),
                      int(getattr(stats, "crc_errors", 0)), session, truth, levels, elapsed)


def refuse_foreign_session(session_file: Path) -> None:
    """The demo replaces its own ``session.h5`` (every capture's notes say ``station demo``), never
    captures of another origin that an ``--out`` folder happens to hold.

    Raises
    ------
    ConfigError
        ``session_file`` exists and is not an earlier demo's session (one line).
    """
    if not session_file.exists():
        return
    from station.storage import list_captures

    try:
        foreign = [c.index for c in list_captures(session_file) if c.notes != DEMO_NOTES]
    except StationError:  # not a capture file at all
        foreign = None
    if foreign is None or foreign:
        what = "is not a capture file" if foreign is None else f"holds captures not made by the demo ({len(foreign)})"
        raise ConfigError(f"--out: {session_file} {what}; the demo replaces only its own session.h5: "
                          f"choose another folder")


def demo_object(res: DemoResult) -> dict[str, Any]:
    """The ``--json`` object of ``station demo``."""
    from station.commands.identify import result_object
    from station.session import mean_of

    s = res.session
    fit_meas = s.measurements[s.fit_index]
    identified = result_object(fit_meas, s.fit)
    from station.coupling import session_coupling_check

    session_coupling_check(s, DEMO_DAMPING, DEMO_STIFFNESS, "auto", identified)  # as identify/replay/report
    obj: dict[str, Any] = {
        "device": res.device,
        "levels_n": list(res.levels_n),
        "captures": res.acquisition.captures,
        "rejected": len(res.acquisition.rejected),
        "dropped_samples": res.acquisition.dropped_samples,
        "link_dropped_samples": res.link_dropped_samples,
        "crc_errors": res.crc_errors,
        "fit_capture": fit_meas.source,
        "identified": identified,
        "method": "EDDI + output-error refinement" if s.eddi_held_out else "EDDI",
        "validation": {
            "nrmse": s.mean_nrmse,
            "nmte": s.mean_nmte,
            "held_out": [c.as_dict() for c in s.held_out],
        },
        "paths": {
            "session": str(res.session_file),
            "model": str(res.model_file),
            "report": str(res.report.index) if res.report is not None else None,
            "figures": [str(p) for p in res.report.figures] if res.report is not None else [],
        },
        "elapsed_s": dict(res.elapsed_s),
    }
    unrefined = s.fit.model.unrefined
    if unrefined is not None:
        obj["eddi"] = {"damping": dict(unrefined.damping), "stiffness": dict(unrefined.stiffness),
                       "validation": {"nrmse": mean_of([c.nrmse for c in s.eddi_held_out]),
                                      "held_out": [c.as_dict() for c in s.eddi_held_out]}}
    if res.truth is not None:
        eom = s.fit.model.eom
        obj["rig"] = {"damping": dict(res.truth.damping), "stiffness": dict(res.truth.stiffness),
                      "relative_error": {
                          term: (eom.stiffness[term] - c) / abs(c)
                          for term, c in res.truth.stiffness.items() if term in eom.stiffness and c}}
    return obj


def demo_text(obj: dict[str, Any]) -> str:
    """People-friendly summary of :func:`demo_object`."""
    ident = obj["identified"]
    lines = [f"{obj['device']}: {obj['captures']} impacts at {', '.join(f'{f:g}' for f in obj['levels_n'])} N "
             f"saved to {obj['paths']['session']} (dropped samples {obj['dropped_samples']}, "
             f"link {obj['link_dropped_samples']}, CRC errors {obj['crc_errors']})",
             f"identified on {obj['fit_capture']} ({obj['method']}): {ident['equation']}"]
    truth = obj.get("rig")
    ci95 = ident.get("ci95") or {}
    units = ident.get("units") or {}
    for kind in ("damping", "stiffness"):
        for term, c in ident[kind].items():
            half = ci95.get(kind, {}).get(term)
            unit = units.get(kind, {}).get(term, "")
            pm = f" ± {half:.2g}" if half is not None else " (no interval)"
            line = f"  {kind:<10} {term:<7} {c:+.5g}{pm} {unit}"
            if truth is not None and term in truth[kind]:
                tv = truth[kind][term]
                line += f"   rig {tv:+.5g}" + (f"  ({100 * (c - tv) / abs(tv):+.1f} %)" if tv else "")
            lines.append(line)
    for w in ident.get("warnings") or ():
        lines.append(f"  WARNING: {w}")
    v = obj["validation"]
    for c in v["held_out"]:
        lines.append(f"validated on {c['source']} ({c['peak_force_n']:.4g} N, from rest with its measured force): "
                     f"nrmse {c['nrmse']:.3g}")
    if v["nrmse"] is not None:
        lines.append(f"mean nrmse on the held-out impacts: {v['nrmse']:.3g}")
    plain = obj.get("eddi")
    if plain is not None and plain["validation"]["nrmse"] is not None:
        lines.append(f"  (plain EDDI, before the refinement: k1 {plain['stiffness'].get('x', float('nan')):.5g}, "
                     f"mean held-out nrmse {plain['validation']['nrmse']:.3g})")
    lines.append(f"model: {obj['paths']['model']}")
    if obj["paths"]["report"] is None:
        lines.append(NO_REPORT)
    else:
        lines.append(f"report: {obj['paths']['report']} ({len(obj['paths']['figures'])} figures)")
    lines.append(f"done in {obj['elapsed_s']['total']:.1f} s")
    return "\n".join(lines)
