"""A session of records: read captures -> identify on one -> validate on the others.

The paper identified each system on one impact and validated the model on impacts not used
for the fit (Lopez et al., EDDI, Sec. 3.3.1 and Fig. 12). :func:`run_session` does the same on
measurements read by :func:`station.readers.read_measurement`:

* :func:`choose_fit_index` picks the impact of the middle force level (the paper's
  identification case lies between its two validation impacts of 246 N and 1110 N);
* the fit is :meth:`eddi.fit_record.Pipeline.fit` (the one pipeline every command uses), with
  the other records held out: they decide whether the output-error refinement is kept;
* every other record is validated by :func:`validate_measurement`: simulated from rest driven
  by its measured impact force (force sensor fused with ``m a`` when the acceleration was
  measured, as :mod:`eddi.fit_record` does), or from its measured initial state when it has no
  force. A modal-sum model (:class:`eddi.multimode.ModalSumModel`) predicts a velocity record
  from its initial state (:func:`eddi.multimode.predict_record`).

No numerics of its own, no printing: the commands and :mod:`station.report` present the result.
"""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Sequence

import numpy as np

from eddi.conditioning import ConditionedSignal
from eddi.model import EquationOfMotion
from eddi.fit_record import Pipeline, PipelineResult, validate_conditioned
from eddi.validate import Validation
from station.errors import ConfigError, InputFileError
from station.readers import Measurement, read_measurement, split_spec  # noqa: F401 (read_measurement: re-export)
from station.records import LazyMap, RecordInfo, Records, peak_force  # noqa: F401 (peak_force: re-export)

if TYPE_CHECKING:  # eddi.multimode imports scipy.signal (~0.3 s): only when a modal-sum model is used
    from eddi.multimode import ModalSumModel


@dataclass(frozen=True)
class RecordCheck:
    """One record simulated with a model and compared with the measurement.

    Attributes
    ----------
    source : str
        ``file`` or ``file:capture``.
    nrmse : float
        ``||x_sim - x|| / ||x||`` over the compared window (for a modal-sum model: of the
        velocity); ``inf`` when the simulation diverged.
    nmte : float or None
        ``mean |v_sim - v| / max |v|`` over the window.
    driven_by : str
        ``"force"`` (simulated from rest with the measured impact force) or
        ``"initial state"`` (free response from the measured state).
    peak_force_n : float or None
        Largest measured force [N], None without a force channel.
    t : ndarray, shape (k,), [s]
        Times compared.
    measured, simulated : ndarray, shape (k,)
        Displacement [m] (velocity [m/s] for a modal-sum model) over the window.
    quantity : str
        ``"displacement"`` or ``"velocity"``: what ``measured`` / ``simulated`` are.
    diverged : bool
        The simulation blew up, grew, or does not decay where the record does.
    warnings : tuple of str
        Why (:func:`eddi.stability.response_warnings`).
    """

    source: str
    nrmse: float
    nmte: float | None
    driven_by: str
    peak_force_n: float | None
    t: np.ndarray
    measured: np.ndarray
    simulated: np.ndarray
    quantity: str
    diverged: bool
    warnings: tuple[str, ...] = ()

    def as_dict(self) -> dict[str, object]:
        """JSON-ready figures of merit (no arrays)."""
        return {"source": self.source, "nrmse": self.nrmse, "nmte": self.nmte, "driven_by": self.driven_by,
                "peak_force_n": self.peak_force_n, "window_s": [float(self.t[0]), float(self.t[-1])],
                "diverged": self.diverged, "warnings": list(self.warnings)}


@dataclass(frozen=True)
class SessionResult:
    """A model identified on one record and checked on the others.

    Attributes
    ----------
    measurements : sequence of Measurement
        All records, in the order given (:class:`station.records.Records`: read on access).
    fit_index : int
        Position in ``measurements`` of the record identified on.
    fit : PipelineResult
        Identification (and self-validation) on that record.
    held_out : tuple of RecordCheck
        Validation on every other record, in order.
    eddi_held_out : tuple of RecordCheck
        With ``refine``: the same validation of the plain EDDI estimate (empty otherwise).
    """

    measurements: Sequence[Measurement]
    fit_index: int
    fit: PipelineResult
    held_out: tuple[RecordCheck, ...]
    eddi_held_out: tuple[RecordCheck, ...] = ()

    @property
    def sources(self) -> tuple[str, ...]:
        """``source`` of every record (without reading streamed ones)."""
        recs = self.measurements
        return recs.sources if isinstance(recs, Records) else tuple(m.source for m in recs)

    @property
    def mean_nrmse(self) -> float | None:
        """Mean nrmse over the held-out records (None when there are none)."""
        return mean_of([c.nrmse for c in self.held_out])

    @property
    def mean_nmte(self) -> float | None:
        """Mean nmte over the held-out records that have one."""
        return mean_of([c.nmte for c in self.held_out if c.nmte is not None])


def mean_of(values: Sequence[float]) -> float | None:
    """Arithmetic mean, None for an empty sequence (``inf`` if any value is)."""
    return float(np.mean(values)) if len(values) else None


def expand_specs(specs: Sequence[str]) -> list[str]:
    """``FILE.h5`` (no ``:CAPTURE``) -> one spec per capture in it; other specs unchanged.

    Raises
    ------
    InputFileError, CaptureFormatError
        Missing or foreign file.
    """
    out: list[str] = []
    for spec in specs:
        path, capture = split_spec(spec)
        if capture is None and path.suffix.lower() in (".h5", ".hdf5"):
            from station.storage import check_file  # local: h5py only for HDF5 files

            if not path.is_file():
                raise InputFileError(f"{path}: no such file")
            count = check_file(path)
            if count == 0:
                raise InputFileError(f"capture file {path}: holds no capture")
            out += [f"{path}:{i}" for i in range(count)]
        else:
            out.append(spec)
    return out


def read_all(specs: Sequence[str], command: str = "identify") -> Records:
    """Every record of :func:`expand_specs` (``FILE.h5`` means all its captures), read on use.

    Each is read once here (a bad one is refused now) and again when used: never all at once
    (:class:`station.records.Records`).
    """
    return Records(expand_specs(specs), command=command)


def on_one_grid(measurements: Sequence[Measurement]) -> tuple[list[Measurement], str | None]:
    """Records whose clocks differ by up to 200 ppm, resampled onto the first one's rate.

    Returns
    -------
    measurements : list of Measurement
        Unchanged when the rates agree within 1 ppm.
    note : str or None
        What was resampled (to be said), None when nothing was.

    Raises
    ------
    InputFileError
        When rates differ by more than 200 ppm (:data:`eddi.calculus.RATE_TOLERANCE`).
    """
    from dataclasses import replace

    from eddi.calculus import common_rate, resample

    recs = list(measurements)
    if not recs:
        return recs, None
    try:
        rate = common_rate([m.rate_hz for m in recs])
    except ValueError as exc:
        raise InputFileError(f"{recs[0].source} and the others: {exc}") from None
    if rate is None:
        return recs, None
    out: list[Measurement] = []
    moved: list[str] = []
    for m in recs:
        if abs(m.rate_hz - rate) <= 1e-6 * rate:
            out.append(m)
            continue
        chans = {}
        t_new = m.t
        for name, y in m.channels.items():
            t_new, chans[name] = resample(m.t, y, rate)
        pre = None if m.pretrigger_samples is None else int(round(m.pretrigger_samples * rate / m.rate_hz))
        out.append(replace(m, t=t_new, channels=chans, rate_hz=rate, pretrigger_samples=pre))
        moved.append(f"{m.source} ({(m.rate_hz / rate - 1) * 1e6:+.0f} ppm)")
    return out, (f"resampled onto {rate:.6g} Hz (5th-order spline): " + ", ".join(moved))


def session_mass(measurements: Sequence[Measurement] | Sequence[RecordInfo], mass: float | None) -> float:
    """The mass given, else the one the first record stores.

    Raises
    ------
    ConfigError
        When neither gives a positive finite mass [kg].
    """
    m = mass if mass is not None else next((r.mass for r in measurements if r.mass is not None), None)
    if m is None:
        raise ConfigError(f"--mass is required: {measurements[0].source} does not record the mass")
    if not (math.isfinite(m) and m > 0):
        raise ConfigError(f"--mass must be a number > 0 [kg], got {m:g}")
    return float(m)


def condition_measurement(meas: Measurement, pipeline: Pipeline | None = None) -> ConditionedSignal:
    """Condition a record as every command does (:meth:`eddi.fit_record.Pipeline.condition`).

    The DAQ's decimation filter comes from the record's metadata (``adc_sinc_order``,
    ``adc_osr``: stored with a capture by ``station import --adc-filter``, or set by
    :func:`with_adc_filter` from a command's ``--adc-filter``).

    Raises
    ------
    EddiError
        The engine's error, its message prefixed with the record (``file:capture``), so a
        command over many records says which one failed.
    """
    from eddi.errors import EddiError

    ch = meas.channels
    try:
        return (pipeline or Pipeline()).condition(
            meas.t, acc=ch.get("acc"), vel=ch.get("vel"), disp=ch.get("disp"), force=ch.get("force"),
            pretrigger_samples=meas.pretrigger_samples, ac_coupling_s=meas.metadata.get("ac_coupling_s"),
            adc_sinc_order=_stated_int(meas.metadata.get("adc_sinc_order")),
            adc_osr=meas.metadata.get("adc_osr") or None)
    except EddiError as exc:
        raise type(exc)(f"{meas.source}: {exc}") from None


def _stated_int(value: object) -> int | None:
    """A stated sampling kernel order (0: point samples, stated) or None (not stated)."""
    return None if value is None or value == "" else int(value)  # type: ignore[call-overload]


def with_adc_filter(meas: Measurement, adc: tuple[int, int | None] | None) -> Measurement:
    """``meas`` with the DAQ's decimation filter ``(K, R or None)`` in its metadata (``None``:
    unchanged; ``(0, None)``: point samples, overriding what the file records)."""
    if adc is None:
        return meas
    import dataclasses

    meta = {**meas.metadata, "adc_sinc_order": int(adc[0]), "adc_osr": int(adc[1] or 0)}
    return dataclasses.replace(meas, metadata=meta)


def with_sensor_highpass(meas: Measurement, corner_hz: float | None) -> Measurement:
    """``meas`` with the accelerometer's first-order AC coupling declared in its metadata
    (``ac_coupling_s = 1 / (2 pi f_c)``, inverted by the conditioning; ``None``: unchanged;
    ``0``: DC-coupled, overriding what the file records)."""
    if corner_hz is None:
        return meas
    import dataclasses

    meta = dict(meas.metadata)
    meta.pop("ac_coupling_s", None)
    if corner_hz > 0:
        meta["ac_coupling_s"] = 1.0 / (2.0 * math.pi * float(corner_hz))
    return dataclasses.replace(meas, metadata=meta)


def choose_fit_index(measurements: Sequence[Measurement] | Sequence[RecordInfo]) -> int:
    """The record of the median peak force (the lower middle one for an even count).

    Without force channels: the first record.
    """
    peaks = [peak_force(m) for m in measurements]
    if any(p is None for p in peaks) or not peaks:
        return 0
    order = sorted(range(len(peaks)), key=lambda i: peaks[i])  # type: ignore[arg-type,return-value]
    return order[(len(order) - 1) // 2]


def is_modal_sum(model: object) -> bool:
    """True for a :class:`~eddi.multimode.ModalSumModel` (without importing that module: a model
    of that class exists only once it is imported)."""
    mm = sys.modules.get("eddi.multimode")
    return mm is not None and isinstance(model, mm.ModalSumModel)


def validate_measurement(model: EquationOfMotion | ModalSumModel, meas: Measurement) -> RecordCheck:
    """Simulate ``model`` for one record and score it (see :func:`validate_conditioned`).

    A :class:`~eddi.multimode.ModalSumModel` predicts the measured velocity (``vel``
    channel, else the conditioned rate) from its initial state at the largest ``|v|``
    (:func:`eddi.multimode.predict_record`); its ``nrmse`` and ``nmte`` are of the velocity.

    Raises
    ------
    SignalError, InputFileError
        When the record cannot be conditioned or predicted, or has several response sensors.
    """
    from station.readers import is_multichannel_record, response_channels

    if is_multichannel_record(meas):  # not the engine's "no acc, vel or disp" deep inside
        names = ", ".join(response_channels(meas.channels))
        raise InputFileError(f"{meas.source}: {len(response_channels(meas.channels))} response sensors ({names}); "
                             f"expected one for a single-coordinate model (a multi-DOF model, saved by `station "
                             f"diagnose --save-model` on such captures, predicts every sensor)")
    pf = peak_force(meas)
    if is_modal_sum(model):
        from eddi.multimode import predict_record

        v = meas.channels.get("vel")
        if v is None:
            v = condition_measurement(meas).v
        p = predict_record(model, meas.t, v)
        return RecordCheck(meas.source, p.errors.nrmse, p.errors.nmte, "initial state", pf, p.t,
                           p.v_measured, p.v_predicted, "velocity", not math.isfinite(p.errors.nrmse))
    cond = condition_measurement(meas)
    val, by_force = validate_conditioned(model, cond)
    from station.impulse_check import check_signal, impulse_warning, lag_warning

    chk = check_signal(cond, float(model.mass))  # the hammer impulse at the model's mass, as identify
    said = () if chk is None else tuple(w for w in (lag_warning(chk, "the record"), impulse_warning(chk, "the record"))
                                        if w is not None)
    return record_check(meas, val, by_force, said)


def record_check(meas: Measurement | RecordInfo, val: Validation, by_force: bool,
                 more: tuple[str, ...] = ()) -> RecordCheck:
    """A :class:`RecordCheck` of a validation of ``meas`` (``more``: warnings beside the validation's)."""
    return RecordCheck(meas.source, val.nrmse, val.nmte, "force" if by_force else "initial state",
                       peak_force(meas), val.t, val.x_measured, val.x_simulated, "displacement", val.diverged,
                       tuple(val.warnings) + more)


def run_session(
    measurements: Sequence[Measurement],
    mass: float | None = None,
    *,
    damping: str | Sequence[str] | None = None,
    stiffness: str | Sequence[str] | None = None,
    route: str = "auto",
    fit_index: int | None = None,
    refine: bool = True,
    pipeline: Pipeline | None = None,
    conditioned: Sequence[ConditionedSignal] | None = None,
) -> SessionResult:
    """Identify on one record, validate on all the others.

    Parameters
    ----------
    measurements : sequence of Measurement
        At least one record.
    mass : float, optional
        [kg]; default the mass the records store.
    damping, stiffness : str or sequence of str, optional
        Candidate terms (default: the pipeline's default library).
    route : {"auto", "potential", "lagrangian"}
    fit_index : int, optional
        Record to identify on (negative counts from the end); default
        :func:`choose_fit_index`.
    refine : bool
        Try the output-error refinement (:mod:`eddi.refine`), kept when it lowers the mean
        held-out nrmse; the EDDI estimate stays in ``fit.model.unrefined`` and is validated
        in ``eddi_held_out``.
    pipeline : Pipeline, optional
        Overrides ``damping``, ``stiffness``, ``route`` and ``refine``.
    conditioned : sequence of ConditionedSignal, optional
        The records already conditioned by :func:`condition_measurement` (same order, same
        length): used as they are instead of conditioning them again (conditioning does not
        depend on the pipeline's terms or options).

    Raises
    ------
    ConfigError
        No record, bad fit index, no mass, or ``conditioned`` of another length.
    EddiError
        When identification fails on the fit record (one line).
    """
    recs = measurements if isinstance(measurements, Records) else tuple(measurements)
    if not len(recs):
        raise ConfigError("expected at least one record, got none")
    info = recs.info if isinstance(recs, Records) else tuple(RecordInfo.of(r) for r in recs)
    m = session_mass(info, mass)
    k = fit_record_index(info, fit_index)
    pipe = pipeline if pipeline is not None else Pipeline.create(damping, stiffness, route, refine)
    others = [i for i in range(len(recs)) if i != k]
    if conditioned is not None:
        if len(conditioned) != len(recs):
            raise ConfigError(f"{len(conditioned)} conditioned records for {len(recs)} records")
        fit = pipe.fit(conditioned[k], m, held_out=[conditioned[i] for i in others])
    elif isinstance(recs, Records):  # streamed: each held-out record read and conditioned when validated
        held_out: Sequence[ConditionedSignal] = LazyMap(recs, others, lambda r: condition_measurement(r, pipe))
    else:
        held_out = [condition_measurement(recs[i], pipe) for i in others]
    if conditioned is None:
        fit = pipe.fit(condition_measurement(recs[k], pipe), m, held_out=held_out)
    held = tuple(record_check(info[i], v, fit.driven_by_force_of(j)) for j, (i, v) in enumerate(zip(others, fit.held_out)))
    eddi_held = tuple(record_check(info[i], v, fit.driven_by_force_of(j))
                      for j, (i, v) in enumerate(zip(others, fit.eddi_held_out)))
    return SessionResult(recs, k, fit, held, eddi_held)


def fit_record_index(recs: Sequence[Measurement] | Sequence[RecordInfo], fit_index: int | None) -> int:
    """``fit_index`` checked (negative from the end), or :func:`choose_fit_index`.

    Raises
    ------
    ConfigError
        Out of range.
    """
    if fit_index is None:
        return choose_fit_index(recs)
    k = int(fit_index) + (len(recs) if fit_index < 0 else 0)
    if not 0 <= k < len(recs):
        raise ConfigError(f"--fit: expected a record index 0..{len(recs) - 1}, got {fit_index}")
    return k


def load_model_file(path: str | Path) -> EquationOfMotion | ModalSumModel:
    """Read a model JSON file (equation of motion or modal sum, :func:`eddi.multimode.load_any_model`).

    Raises
    ------
    InputFileError
        Missing or unreadable file, or text that is not a model (one line).
    """
    from eddi.errors import ModelError
    from eddi.multimode import load_any_model

    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise InputFileError(f"{p}: no such model file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputFileError(f"{p}: cannot read the model ({getattr(exc, 'strerror', None) or exc})") from None
    try:
        return load_any_model(text)
    except ModelError as exc:
        raise InputFileError(f"{p}: {exc}") from None
