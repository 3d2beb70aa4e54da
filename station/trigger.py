"""Triggered capture: a per-instance state machine fed sample blocks, emitting captures.

Contract (the tests derive their expected indices from this text, not from the code):

* Samples carry an absolute index (sample time). Blocks may have any size, down to one
  sample; a block whose first index is beyond the next expected one means the samples in
  between were dropped by the device or the link (a *gap*).
* **Crossing.** With slope ``"rising"`` the trigger fires at the first sample ``k`` such that
  ``f[k-1] < level <= f[k]`` on the trigger channel (SI units); with ``"falling"`` at the
  first ``k`` with ``f[k-1] > level >= f[k]``; ``"either"`` accepts both. Sample ``k-1`` must
  have been received (a sample right after a gap or the very first sample cannot trigger).
* **Window.** A capture triggered at ``k`` holds samples ``k - pretrigger_samples`` to
  ``k + posttrigger_samples - 1`` inclusive (``pretrigger_samples + posttrigger_samples``
  rows); the trigger sample is row ``pretrigger_samples``.
* **Arming.** The trigger is armed once ``pretrigger_samples`` samples (received or dropped)
  precede the candidate sample, so every capture has its full pre-trigger window. After a
  capture triggered at ``k`` it re-arms at ``k + posttrigger_samples + holdoff_samples``: no
  sample before that can trigger. Pre-trigger windows may overlap the previous record.
* **Gaps.** Missing samples inside a window are stored as count 0 and SI ``NaN``; the capture
  lists them in ``gaps`` (row, length) and counts them in ``dropped_samples``.
* **Double hit.** After the trigger the force must *release* (drop below
  ``release_fraction * level`` for a rising trigger, mirrored for falling); a later crossing of
  the trigger level inside the record flags ``double_hit``.
* **Overload.** A received sample at the ADC rails (``min_count`` or ``max_count`` of its
  channel), or beyond the channel's ``range_si`` in magnitude (when > 0; a configured sensor
  range may be below the ADC's), flags ``overload`` and names the channel in
  ``overload_channels``.
* :meth:`Trigger.flush` ends an unfinished capture early (device lost, Ctrl-C): it is returned
  truncated with ``partial=True``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal, Protocol, Sequence

import numpy as np

from drivers.channels import ChannelInfo
from station.errors import StationError

Slope = Literal["rising", "falling", "either"]
Policy = Literal["flag", "reject"]


class TriggerError(StationError, ValueError):
    """Invalid trigger settings or samples that go back in time."""


class BlockLike(Protocol):
    """What the trigger needs from a driver block (``drivers`` ``Block``)."""

    first_sample: int
    counts: np.ndarray
    si: np.ndarray


@dataclass(frozen=True)
class TriggerSettings:
    """Trigger settings in samples and SI units.

    Attributes
    ----------
    channel : int
        Column of the trigger channel (the force).
    level : float
        Trigger level [SI unit of the channel, N for force].
    slope : {"rising", "falling", "either"}
        Direction of the crossing.
    pretrigger_samples : int
        Rows kept before the trigger sample (the paper uses 1 s).
    posttrigger_samples : int
        Rows from the trigger sample on (trigger sample included), >= 1.
    holdoff_samples : int
        Extra samples after the end of a record before the trigger re-arms.
    release_fraction : float
        The force must fall below ``release_fraction * level`` before a second crossing
        counts as a double hit (0 < fraction < 1).
    """

    channel: int
    level: float
    slope: Slope = "rising"
    pretrigger_samples: int = 0
    posttrigger_samples: int = 1
    holdoff_samples: int = 0
    release_fraction: float = 0.5

    def __post_init__(self) -> None:
        if self.slope not in ("rising", "falling", "either"):
            raise TriggerError(f"trigger slope: expected 'rising', 'falling' or 'either', got {self.slope!r}")
        if self.channel < 0:
            raise TriggerError(f"trigger channel: expected a column index >= 0, got {self.channel}")
        if self.pretrigger_samples < 0:
            raise TriggerError(f"pre-trigger samples: expected >= 0, got {self.pretrigger_samples}")
        if self.posttrigger_samples < 1:
            raise TriggerError(f"post-trigger samples: expected >= 1, got {self.posttrigger_samples}")
        if self.holdoff_samples < 0:
            raise TriggerError(f"hold-off samples: expected >= 0, got {self.holdoff_samples}")
        if not 0.0 < self.release_fraction < 1.0:
            raise TriggerError(f"release fraction: expected 0 < fraction < 1, got {self.release_fraction}")
        if not np.isfinite(self.level):
            raise TriggerError(f"trigger level: expected a finite number, got {self.level}")

    @property
    def record_samples(self) -> int:
        """Rows of a complete capture."""
        return self.pretrigger_samples + self.posttrigger_samples


@dataclass(frozen=True, eq=False)
class Capture:
    """One triggered record (immutable; arrays are read-only).

    Attributes
    ----------
    counts : ndarray of int32, shape (n, n_channels)
        Raw ADC counts; 0 where samples are missing.
    si : ndarray of float64, shape (n, n_channels)
        ``counts * scale + offset`` per channel [SI units]; NaN where samples are missing.
    channels : tuple of ChannelInfo
        One per column.
    rate_hz : float
        Sample rate [Hz], from the device.
    first_sample : int
        Absolute index of row 0.
    trigger_sample : int
        Absolute index of the trigger sample.
    pretrigger_samples : int
        Rows before the trigger sample (``trigger_sample - first_sample``).
    double_hit, overload, partial : bool
        Flags (see the module contract).
    overload_channels : tuple of str
        Names of the clipped channels.
    gaps : tuple of (int, int)
        ``(row, length)`` of each run of missing samples.
    dropped_samples : int
        Missing samples inside the window (sum of gap lengths).
    """

    counts: np.ndarray
    si: np.ndarray
    channels: tuple[ChannelInfo, ...]
    rate_hz: float
    first_sample: int
    trigger_sample: int
    pretrigger_samples: int
    double_hit: bool = False
    overload: bool = False
    overload_channels: tuple[str, ...] = ()
    partial: bool = False
    gaps: tuple[tuple[int, int], ...] = ()
    dropped_samples: int = 0

    def __post_init__(self) -> None:
        counts = np.asarray(self.counts, dtype=np.int32)
        si = np.asarray(self.si, dtype=float)
        if counts.ndim != 2 or counts.shape != si.shape:
            raise TriggerError(f"capture arrays: expected counts and si of the same (n, ch) shape, got {counts.shape} and {si.shape}")
        if counts.shape[1] != len(self.channels):
            raise TriggerError(f"capture channels: expected {counts.shape[1]} channel descriptions, got {len(self.channels)}")
        if self.trigger_sample - self.first_sample != self.pretrigger_samples:
            raise TriggerError("capture time base: trigger_sample - first_sample must equal pretrigger_samples")
        counts.setflags(write=False)
        si.setflags(write=False)
        object.__setattr__(self, "counts", counts)
        object.__setattr__(self, "si", si)

    @property
    def n_samples(self) -> int:
        """Rows in the capture."""
        return int(self.counts.shape[0])

    @property
    def channel_names(self) -> tuple[str, ...]:
        """Channel names in column order."""
        return tuple(c.name for c in self.channels)

    @property
    def trigger_time_s(self) -> float:
        """Time of the trigger from the start of the acquisition [s] (``trigger_sample / rate``)."""
        return self.trigger_sample / self.rate_hz

    @property
    def t(self) -> np.ndarray:
        """Time of each row relative to the trigger, shape (n,) [s]."""
        return (np.arange(self.n_samples) - self.pretrigger_samples) / self.rate_hz

    def column(self, name: str) -> int:
        """Column of the channel called ``name``."""
        try:
            return self.channel_names.index(name)
        except ValueError:
            raise TriggerError(f"channel: expected one of {list(self.channel_names)}, got {name!r}") from None

    def rejection(self, on_double_hit: Policy = "flag", on_overload: Policy = "flag") -> str | None:
        """Why the capture is rejected under these policies, or None when it is kept."""
        if self.double_hit and on_double_hit == "reject":
            return "double hit"
        if self.overload and on_overload == "reject":
            return "overload on " + ", ".join(self.overload_channels)
        return None


@dataclass
class _Pending:
    """A capture being filled (internal, mutable)."""

    counts: np.ndarray
    si: np.ndarray
    valid: np.ndarray
    filled: int
    trigger_sample: int
    first_sample: int


@dataclass
class Trigger:
    """Level-and-slope trigger with pre-trigger history, hold-off and re-arm.

    Parameters
    ----------
    settings : TriggerSettings
    channels : sequence of ChannelInfo
        Description of every column of the blocks (for clipping and metadata).
    rate_hz : float
        Sample rate [Hz].
    """

    settings: TriggerSettings
    channels: Sequence[ChannelInfo]
    rate_hz: float
    _next: int | None = field(default=None, init=False)
    _armed_at: int = field(default=0, init=False)
    _prev: float | None = field(default=None, init=False)
    _history: "_Ring" = field(init=False)
    _pending: _Pending | None = field(default=None, init=False)
    _dropped_total: int = field(default=0, init=False)
    _n_triggered: int = field(default=0, init=False)

    def __post_init__(self) -> None:
        self.channels = tuple(self.channels)
        n_ch = len(self.channels)
        if self.settings.channel >= n_ch:
            raise TriggerError(f"trigger channel: expected a column index < {n_ch}, got {self.settings.channel}")
        if not self.rate_hz > 0:
            raise TriggerError(f"sample rate: expected > 0 Hz, got {self.rate_hz}")
        self._history = _Ring(self.settings.pretrigger_samples, n_ch)
        self._lo = np.array([c.min_count for c in self.channels], dtype=np.int64)
        self._hi = np.array([c.max_count for c in self.channels], dtype=np.int64)
        self._range = np.array([c.range_si for c in self.channels], dtype=float)

    # ------------------------------------------------------------------ state
    @property
    def state(self) -> str:
        """``"waiting"`` (filling the pre-trigger), ``"armed"``, ``"triggered"`` or ``"holdoff"``."""
        if self._pending is not None:
            return "triggered"
        if self._next is None or self._next < self._armed_at:
            return "holdoff" if self._n_triggered else "waiting"
        return "armed"

    @property
    def progress(self) -> float:
        """Fraction of the current capture filled (0 when none is in progress)."""
        if self._pending is None:
            return 0.0
        return self._pending.filled / self.settings.record_samples

    @property
    def next_sample(self) -> int | None:
        """Absolute index of the next expected sample (None before the first block)."""
        return self._next

    @property
    def dropped_total(self) -> int:
        """Samples missing between blocks since the start."""
        return self._dropped_total

    # --------------------------------------------------------------- feeding
    def feed(self, block: BlockLike) -> list[Capture]:
        """Take one block of samples and return the captures it completes.

        Parameters
        ----------
        block : Block
            ``first_sample`` (absolute index), ``counts`` int32 and ``si`` float, both of
            shape (n, n_channels).

        Returns
        -------
        list of Capture
            Completed captures in order (usually empty or one).
        """
        counts = np.asarray(block.counts)
        si = np.asarray(block.si, dtype=float)
        n_ch = len(self.channels)
        if counts.ndim != 2 or counts.shape[1] != n_ch or si.shape != counts.shape:
            raise TriggerError(f"block: expected counts and si of shape (n, {n_ch}), got {counts.shape} and {si.shape}")
        first = int(block.first_sample)
        out: list[Capture] = []
        if self._next is None:
            self._next = first
            self._armed_at = first + self.settings.pretrigger_samples
        if first < self._next:
            raise TriggerError(f"block order: expected first sample >= {self._next}, got {first}")
        if first > self._next:
            out.extend(self._gap(first - self._next))
        if counts.shape[0]:
            out.extend(self._samples(counts.astype(np.int32, copy=False), si))
        return out

    def flush(self) -> Capture | None:
        """End the capture in progress early; return it flagged ``partial`` (or None)."""
        if self._pending is None:
            return None
        p = self._pending
        self._pending = None
        self._armed_at = max(self._armed_at, p.trigger_sample + self.settings.posttrigger_samples + self.settings.holdoff_samples)
        return self._finish(p, partial=True)

    # --------------------------------------------------------------- internals
    def _gap(self, n_missing: int) -> list[Capture]:
        out: list[Capture] = []
        self._dropped_total += n_missing
        n_ch = len(self.channels)
        assert self._next is not None
        if self._pending is not None:
            p = self._pending
            take = min(n_missing, p.counts.shape[0] - p.filled)
            p.filled += take  # rows stay count 0 / NaN / invalid
            if p.filled == p.counts.shape[0]:
                out.append(self._finish(p))
                self._pending = None
        keep = min(n_missing, self.settings.pretrigger_samples)
        self._history.push(
            np.zeros((keep, n_ch), dtype=np.int32), np.full((keep, n_ch), np.nan), np.zeros(keep, dtype=bool)
        )
        self._next += n_missing
        self._prev = None
        return out

    def _find_crossing(self, f: np.ndarray, prev: float | None, start_abs: int) -> int | None:
        """Index into ``f`` of the first crossing at or after absolute ``self._armed_at``."""
        s = self.settings
        lead = max(0, self._armed_at - start_abs)
        if lead >= f.shape[0]:
            return None
        before = np.empty_like(f)
        before[0] = np.nan if prev is None else prev
        before[1:] = f[:-1]
        before, cur = before[lead:], f[lead:]
        hit = np.zeros(cur.shape[0], dtype=bool)
        with np.errstate(invalid="ignore"):
            if s.slope in ("rising", "either"):
                hit |= (before < s.level) & (cur >= s.level)
            if s.slope in ("falling", "either"):
                hit |= (before > s.level) & (cur <= s.level)
        idx = np.flatnonzero(hit)
        return int(idx[0]) + lead if idx.size else None

    def _samples(self, counts: np.ndarray, si: np.ndarray) -> list[Capture]:
        out: list[Capture] = []
        s = self.settings
        n = counts.shape[0]
        start_abs = self._next
        assert start_abs is not None
        f = si[:, s.channel]
        i = 0
        while i < n:
            if self._pending is not None:
                p = self._pending
                take = min(n - i, p.counts.shape[0] - p.filled)
                p.counts[p.filled : p.filled + take] = counts[i : i + take]
                p.si[p.filled : p.filled + take] = si[i : i + take]
                p.valid[p.filled : p.filled + take] = True
                p.filled += take
                i += take
                if p.filled == p.counts.shape[0]:
                    out.append(self._finish(p))
                    self._pending = None
                continue
            prev = self._prev if i == 0 else float(f[i - 1])
            k = self._find_crossing(f[i:], prev, start_abs + i)
            if k is None:
                break
            k += i
            trig_abs = start_abs + k
            pre = s.pretrigger_samples
            total = s.record_samples
            p = _Pending(
                counts=np.zeros((total, counts.shape[1]), dtype=np.int32),
                si=np.full((total, counts.shape[1]), np.nan),
                valid=np.zeros(total, dtype=bool),
                filled=pre,
                trigger_sample=trig_abs,
                first_sample=trig_abs - pre,
            )
            # pre-trigger rows: the history (before this block), then block rows [0, k)
            from_block = min(k, pre)
            self._history.copy_last(pre - from_block, p.counts, p.si, p.valid)
            p.counts[pre - from_block : pre] = counts[k - from_block : k]
            p.si[pre - from_block : pre] = si[k - from_block : k]
            p.valid[pre - from_block : pre] = True
            self._pending = p
            self._n_triggered += 1
            self._armed_at = trig_abs + s.posttrigger_samples + s.holdoff_samples
            i = k
        self._history.push(counts, si, None)
        self._prev = float(f[-1])
        self._next = start_abs + n
        return out

    def _finish(self, p: _Pending, partial: bool = False) -> Capture:
        s = self.settings
        n = p.filled
        counts, si, valid = p.counts[:n], p.si[:n], p.valid[:n]
        counts[~valid] = 0
        si[~valid] = np.nan
        # gaps: runs of invalid rows
        edges = np.diff(np.concatenate([[0], (~valid).astype(np.int8), [0]]))
        starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
        gaps = tuple((int(a), int(b - a)) for a, b in zip(starts, ends))
        # overload: any received sample at the rails
        c64 = counts.astype(np.int64)
        with np.errstate(invalid="ignore"):
            beyond = (self._range > 0) & (np.abs(si) > self._range)
        clipped = ((c64 <= self._lo) | (c64 >= self._hi) | beyond) & valid[:, None]
        over = tuple(self.channels[j].name for j in np.flatnonzero(clipped.any(axis=0)))
        return Capture(
            counts=counts.copy(),
            si=si.copy(),
            channels=tuple(self.channels),
            rate_hz=float(self.rate_hz),
            first_sample=p.first_sample,
            trigger_sample=p.trigger_sample,
            pretrigger_samples=s.pretrigger_samples,
            double_hit=_double_hit(si[s.pretrigger_samples :, s.channel], s),
            overload=bool(over),
            overload_channels=over,
            partial=partial,
            gaps=gaps,
            dropped_samples=int(sum(g[1] for g in gaps)),
        )


class _Ring:
    """The last ``size`` samples seen (counts, SI values, received flag), kept in place.

    A push writes only the rows of the new block (at most ``size``), so keeping the
    pre-trigger history costs O(block) per block, not O(pre-trigger) as re-concatenating it did.
    """

    def __init__(self, size: int, n_channels: int) -> None:
        self.size = size
        self.counts = np.zeros((size, n_channels), dtype=np.int32)
        self.si = np.full((size, n_channels), np.nan)
        self.valid = np.zeros(size, dtype=bool)
        self.pos = 0  # row the next sample goes to

    def push(self, counts: np.ndarray, si: np.ndarray, valid: np.ndarray | None) -> None:
        """Append rows (``valid`` None: all received)."""
        size = self.size
        n = counts.shape[0]
        if size == 0 or n == 0:
            return
        if n >= size:
            counts, si = counts[n - size :], si[n - size :]
            valid = None if valid is None else valid[n - size :]
            n = size
        first = min(n, size - self.pos)  # up to the end of the buffer, then from row 0
        for dst, src in ((slice(self.pos, self.pos + first), slice(0, first)), (slice(0, n - first), slice(first, n))):
            self.counts[dst] = counts[src]
            self.si[dst] = si[src]
            self.valid[dst] = True if valid is None else valid[src]
        self.pos = (self.pos + n) % size

    def copy_last(self, m: int, counts: np.ndarray, si: np.ndarray, valid: np.ndarray) -> None:
        """Write the last ``m`` rows, oldest first, into rows ``[0, m)`` of the given arrays."""
        if m <= 0:
            return
        rows = (self.pos - m + np.arange(m)) % self.size
        counts[:m] = self.counts[rows]
        si[:m] = self.si[rows]
        valid[:m] = self.valid[rows]


def _double_hit(after: np.ndarray, s: TriggerSettings) -> bool:
    """True when the force, after the trigger, releases and then crosses the level again.

    Parameters
    ----------
    after : ndarray, shape (m,)
        Trigger channel from the trigger sample on [SI]; NaN where missing.
    """
    f = np.asarray(after, dtype=float)
    if f.size < 2:
        return False
    with np.errstate(invalid="ignore"):
        if s.slope == "either":
            mag, lvl = np.abs(f), abs(s.level)
            released = mag < s.release_fraction * lvl
            up = mag >= lvl
        elif s.slope == "rising":
            released = f < s.release_fraction * s.level
            up = f >= s.level
        else:
            released = f > s.release_fraction * s.level
            up = f <= s.level
    rel = np.flatnonzero(released)
    if rel.size == 0:
        return False
    return bool(up[rel[0] :].any())
