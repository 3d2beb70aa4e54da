"""Records read from disk when used: many long captures are never all in memory at once.

:class:`Records` is the sequence of measurements that ``station identify`` (several records),
``report`` and ``replay`` hand to :func:`station.session.run_session`. Building it reads every
record once, in turn, so a bad file is still refused before any identification starts, and
keeps only what choosing the fit record and labelling need (:class:`RecordInfo`); indexing or
iterating reads a record again. Fifty 45 s captures at 19.2 kHz were 2.4 GB held at once
(issue 13); streamed, the peak is about one capture and its conditioned signals
(``benchmarks/bench_session_memory.py``).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from typing import Any, overload

import numpy as np

from station.readers import Measurement, read_measurement, require_one_coordinate


@dataclass(frozen=True)
class RecordInfo:
    """What a session keeps of a record without its samples.

    Attributes
    ----------
    source : str
        ``file`` or ``file:capture``.
    mass : float or None
        [kg], when the record stores it.
    peak_force_n : float or None
        Largest ``|force|`` [N], None without a force channel.
    ac_coupling_s : float or None
        The accelerometer's declared AC coupling (time constant [s]), None when none is declared.
    """

    source: str
    mass: float | None
    peak_force_n: float | None
    ac_coupling_s: float | None = None

    @classmethod
    def of(cls, meas: Measurement) -> RecordInfo:
        """The summary of a record in memory."""
        return cls(meas.source, meas.mass, peak_force(meas), meas.metadata.get("ac_coupling_s") or None)


def peak_force(meas: Measurement | RecordInfo) -> float | None:
    """Largest ``|force|`` of a record [N], None without a force channel."""
    if isinstance(meas, RecordInfo):
        return meas.peak_force_n
    f = meas.channels.get("force")
    return None if f is None or f.size == 0 else float(np.nanmax(np.abs(f)))


class Records(Sequence[Measurement]):
    """The records named by ``specs``, read on each access (one at a time).

    Parameters
    ----------
    specs : sequence of str
        ``FILE`` or ``FILE:CAPTURE`` (already expanded: see :func:`station.session.expand_specs`).
    read : callable, optional
        ``spec -> Measurement`` (default :func:`station.readers.read_measurement`).

    Raises
    ------
    InputFileError, CaptureFormatError
        When a record cannot be read, or has several response sensors (a multi-DOF capture),
        at construction, for the first bad one.
    """

    def __init__(self, specs: Sequence[str], read: Callable[[str], Measurement] = read_measurement,
                 command: str = "identify") -> None:
        self.specs = tuple(specs)
        self._read = read
        self.info = tuple(self._check(read(spec), command) for spec in self.specs)

    @staticmethod
    def _check(meas: Measurement, command: str) -> RecordInfo:
        require_one_coordinate(meas, command)
        return RecordInfo.of(meas)

    def __len__(self) -> int:
        return len(self.specs)

    @overload
    def __getitem__(self, i: int) -> Measurement: ...

    @overload
    def __getitem__(self, i: slice) -> list[Measurement]: ...

    def __getitem__(self, i: Any) -> Any:
        if isinstance(i, slice):
            return [self._read(s) for s in self.specs[i]]
        return self._read(self.specs[i])

    def __iter__(self) -> Iterator[Measurement]:
        return (self._read(s) for s in self.specs)

    @property
    def sources(self) -> tuple[str, ...]:
        """``source`` of every record, without reading any."""
        return tuple(r.source for r in self.info)


class LazyMap(Sequence[Any]):
    """``func(items[i])`` for the chosen indices, computed on each access and never kept.

    Handed to :meth:`eddi.fit_record.Pipeline.fit` as the held-out records, so that each is
    read and conditioned when validated and dropped after (the fit iterates them once, twice
    when it weighs the refinement).
    """

    def __init__(self, items: Sequence[Any], indices: Sequence[int], func: Callable[[Any], Any]) -> None:
        self._items, self._indices, self._func = items, tuple(indices), func

    def __len__(self) -> int:
        return len(self._indices)

    def __getitem__(self, j: Any) -> Any:
        if isinstance(j, slice):
            return [self._func(self._items[i]) for i in self._indices[j]]
        return self._func(self._items[self._indices[j]])

    def __iter__(self) -> Iterator[Any]:
        return (self._func(self._items[i]) for i in self._indices)
