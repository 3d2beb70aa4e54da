"""Multi-channel measurements -> conditioned :class:`eddi.mdof.identify.ChannelRecord`.

A record with more than one response channel (``acc1, acc2, ...`` or ``acc_NAME``; CSV or
HDF5, see :func:`station.readers.response_channels`) is a multi-DOF record. Every response
channel is integrated (or differentiated) by :func:`eddi.mdof.signals.kinematics`, which
keeps several modes in one channel intact; the impact is found on the shared force channel,
the free window runs from the latest start to the latest stop over the channels.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from eddi.mdof.identify import ChannelRecord
from eddi.mdof.signals import drift_cutoff_hz, kinematics, lowest_mode_hz
from station.errors import InputFileError
from station.readers import Measurement, is_multichannel_record, response_channels


def is_multichannel(meas: Measurement) -> bool:
    """True when the record has several response sensors (``acc1, acc2, ...``).

    Plain ``acc`` / ``vel`` / ``disp`` side by side are one coordinate measured several ways
    (conditioning uses them together), not several coordinates.
    """
    return is_multichannel_record(meas)


def channel_names(meas: Measurement) -> tuple[str, ...]:
    """Response channel names, in file order."""
    return tuple(response_channels(meas.channels))


def resolve_driving_point(meas: Measurement, driving_point: str | None) -> str:
    """The driving-point channel: ``driving_point`` if given (checked), else the first response."""
    names = channel_names(meas)
    if driving_point is None:  # the bench config's [specimen] driving_point, when the capture kept it
        driving_point = _configured_driving_point(meas)
    if driving_point is None:
        return names[0]
    if driving_point not in names:
        raise InputFileError(f"{meas.source}: --driving-point {driving_point!r} is not a response channel "
                             f"(channels: {', '.join(names)})")
    return driving_point


def driving_point_how(meas: Measurement, driving_point: str | None) -> str:
    """How the driving point was chosen, for :func:`eddi.mdof.collocation.check_driving_point`:
    ``"declared"`` (``--driving-point`` or a stored bench config), else the default (the first
    response channel)."""
    from eddi.mdof.collocation import DEFAULTED

    return DEFAULTED if driving_point is None and _configured_driving_point(meas) is None else "declared"


def _configured_driving_point(meas: Measurement) -> str | None:
    """The capture's stored driving point (``station acquire``), else ``specimen.driving_point`` of a
    bench config stored with it, if any."""
    import json

    if meas.metadata.get("driving_point"):
        return str(meas.metadata["driving_point"])
    cfg = meas.metadata.get("bench_config")
    if isinstance(cfg, str):
        try:
            cfg = json.loads(cfg)
        except ValueError:
            return None
    if isinstance(cfg, dict):
        dp = (cfg.get("specimen") or {}).get("driving_point")
        return str(dp) if dp else None
    return None


def condition_multichannel(meas: Measurement, driving_point: str | None = None) -> ChannelRecord:
    """Condition every response channel of a record (see the module docstring).

    Raises
    ------
    InputFileError
        No response channel; a channel that cannot be conditioned (named).
    """
    resp = response_channels(meas.channels)
    if not resp:
        raise InputFileError(f"{meas.source}: no response channel (expected acc, vel, disp or acc1, acc2, ...)")
    dp = resolve_driving_point(meas, driving_point)
    force = meas.channels.get("force")
    rest = int(meas.pretrigger_samples or 0)
    if rest == 0:  # no pre-trigger count: the samples before t = 0 (a CSV's time starts negative)
        rest = int(np.sum(np.asarray(meas.t) < 0))
    rate = float(meas.rate_hz)
    f_low = min(lowest_mode_hz(y[None, rest:], rate, qty) for qty, y in resp.values())
    cut = drift_cutoff_hz(f_low, (len(meas.t) - rest) / rate)  # one drift high-pass for every channel
    parts = []
    for name, (qty, y) in resp.items():
        try:
            parts.append(kinematics(meas.t, y[None, :], qty, force=force, rest=rest, highpass_hz=cut))
        except ValueError as exc:
            raise InputFileError(f"{meas.source}: channel {name!r}: {exc}") from None
    k0 = parts[list(resp).index(dp)]
    impact = k0.impact
    f, f_noise = None, 0.0
    if force is not None and impact[1] > impact[0]:
        f = np.zeros(force.size)
        f[impact[0]:impact[1]] = force[impact[0]:impact[1]] - np.median(force[:max(rest, 1)])
        f_noise = float(np.std(force[:rest])) if rest >= 8 else 0.0
    start = max(p.window[0] for p in parts)
    stop = max(p.window[1] for p in parts)
    return ChannelRecord(
        t=np.asarray(meas.t, float), x=np.vstack([p.x for p in parts]), v=np.vstack([p.v for p in parts]),
        a=np.vstack([p.a for p in parts]), force=f, impact=impact, window=(start, stop),
        noise=np.concatenate([p.noise for p in parts]), label=str(meas.source),
        highpass_hz=cut, force_noise=f_noise,
        acc_noise=np.concatenate([p.measured_noise if qty == "acc" and p.measured_noise is not None else [np.nan]
                                  for (qty, _y), p in zip(resp.values(), parts)]))


def condition_all(measurements: Sequence[Measurement], driving_point: str | None = None,
                  order: Sequence[str] | None = None) -> tuple[list[ChannelRecord], tuple[str, ...], str]:
    """Condition several records with the same channels; returns records, channels, driving point.

    Channels are matched by name: records that hold the same names in another column order are
    put in the first record's order (or in ``order``, e.g. a model's channels, when the names
    are the same).

    Raises
    ------
    InputFileError
        Records with different channels or sample rates.
    """
    names = channel_names(measurements[0])
    if order is not None and sorted(order) == sorted(names):
        names = tuple(order)
    rate = float(measurements[0].rate_hz)
    measurements = [_in_order(m, names) for m in measurements]
    for m in measurements[1:]:
        if channel_names(m) != names:
            raise InputFileError(f"{m.source}: channels {', '.join(channel_names(m))} differ from "
                                 f"{measurements[0].source}'s ({', '.join(names)})")
        if abs(float(m.rate_hz) - rate) > 1e-6 * rate:
            raise InputFileError(f"{m.source}: sample rate {m.rate_hz:g} Hz differs from {rate:g} Hz")
    for m in measurements:
        _refuse_copies(m)
    dp = resolve_driving_point(measurements[0], driving_point)
    return [condition_multichannel(m, dp) for m in measurements], names, dp


#: Two response channels whose difference is below this fraction of their rms are one signal.
SAME_SIGNAL = 1e-9


def _refuse_copies(meas: Measurement) -> None:
    """Refuse a record whose response channels include the same signal twice (a column copied,
    or one sensor logged on two channels): the coordinates cannot be told apart, and the model
    identified from it had a zero-frequency mode, returned with exit 0 (session 12)."""
    chans = response_channels(meas.channels)
    names = list(chans)
    for i, a in enumerate(names):
        xa = np.asarray(chans[a][1], dtype=float)
        scale = float(np.sqrt(np.mean(xa * xa))) if xa.size else 0.0
        for b in names[i + 1:]:
            xb = np.asarray(chans[b][1], dtype=float)
            if scale > 0 and xa.shape == xb.shape and float(np.sqrt(np.mean((xa - xb) ** 2))) <= SAME_SIGNAL * scale:
                raise InputFileError(f"{meas.source}: channels {a} and {b} hold the same signal (a copied column "
                                     "or one sensor logged twice): a multi-DOF model needs sensors at different "
                                     "points; drop one of them")


def _in_order(meas: Measurement, names: tuple[str, ...]) -> Measurement:
    """``meas`` with its response channels in the order ``names`` when it holds the same names in
    another column order (a logger or a spreadsheet that reorders columns); else as it is.
    Channels are matched by name, never by position."""
    from dataclasses import replace

    own = channel_names(meas)
    if own == names or sorted(own) != sorted(names):
        return meas
    rest = {k: v for k, v in meas.channels.items() if k not in own}
    return replace(meas, channels={**rest, **{n: meas.channels[n] for n in names}})


#: Samples of rest (pre-trigger) the rate reduction leaves at least, when the captures had them:
#: the conditioning reads the noise on 8 or more samples of rest and removes the offset with more
#: than 8 (:func:`eddi.mdof.signals.kinematics`); with fewer it takes the noise from the record's
#: last 5 %, which on a slow, lightly damped mode still rings (session 10). Session 11: a 400 +
#: 150 kg chain at 2 Hz, 10 kHz, a 5 ms pre-trigger (50 samples) reduced by means of 43 kept 1
#: sample of rest and was refused ("free decays too short for ERA"). (Fewer than 16 samples of rest
#: also left the driving point 1-3 % off without noise; that was the validation's filter, fixed in
#: :func:`eddi.mdof.signals.highpass`, not the rest.)
REST_KEPT = 9


def reduce_rate(measurements: Sequence[Measurement], samples_per_period: float | None = None
                ) -> tuple[list[Measurement], str | None]:
    """The captures at the working rate of a multi-DOF diagnosis (:mod:`eddi.mdof.rate`) and the
    note that says so (None when the rate is kept).

    One factor for every capture (the highest mode over all of them): block means of every
    channel, times at the blocks' centres, the pre-trigger count in whole blocks; never so long
    that a pre-trigger of :data:`REST_KEPT` samples or more keeps fewer than that many.
    """
    from dataclasses import replace

    from eddi.mdof.rate import (MAX_SAMPLES, MIN_SAMPLES_PER_PERIOD, SAMPLES_PER_PERIOD, block_mean, highest_mode_hz,
                                reduction_factor)

    spp = SAMPLES_PER_PERIOD if samples_per_period is None else samples_per_period
    rate = float(measurements[0].rate_hz)
    top = 0.0
    for m in measurements:
        rest = int(m.pretrigger_samples or 0) or int(np.sum(np.asarray(m.t) < 0))
        for qty, y in response_channels(m.channels).values():
            top = max(top, highest_mode_hz(np.asarray(y, float)[None, rest:], rate, qty))
    longest = max(np.asarray(m.t).size for m in measurements)
    d = want = reduction_factor(rate, top, spp, n_samples=longest, max_samples=MAX_SAMPLES)
    rests = [int(m.pretrigger_samples or 0) or int(np.sum(np.asarray(m.t) < 0)) for m in measurements]
    if min(rests) >= REST_KEPT:  # the pre-trigger keeps enough blocks for the noise and the offset
        d = min(d, min(rests) // REST_KEPT)
    if d <= 1:
        return list(measurements), None
    out = []
    for m in measurements:
        rest = int(m.pretrigger_samples or 0) or int(np.sum(np.asarray(m.t) < 0))
        out.append(replace(m, t=block_mean(m.t, d), channels={k: block_mean(v, d) for k, v in m.channels.items()},
                           rate_hz=rate / d, pretrigger_samples=rest // d))
    kept = longest // d
    note = (f"captures at {rate:g} Hz diagnosed at {rate / d:.6g} Hz (means of {d} samples; eddi.mdof.rate): the "
            f"highest mode ({top:.4g} Hz) keeps {rate / d / top:.0f} samples per period")
    if kept > MAX_SAMPLES:
        note += (f"; {kept} samples per capture, over the budget of {MAX_SAMPLES} (the rate is not reduced below "
                 f"{MIN_SAMPLES_PER_PERIOD:g} samples per period): the cost grows with the records' length")
    elif d > reduction_factor(rate, top, spp):
        note += f", fewer than {spp:g} to keep at most {MAX_SAMPLES} samples per capture (the cost is per sample)"
    if d < want:
        note += (f"; not reduced further (means of {want} wanted) so that the {min(rests)}-sample pre-trigger keeps "
                 f"{min(rests) // d} samples of rest (the noise and the offset are read there)")
    return out, note
