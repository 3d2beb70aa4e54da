"""A record whose force and response channels are swapped (the cables, or the column names).

A hammer force is a short pulse of one sign: nearly all of its energy above the noise lies within
the blow (a fraction of the structure's period), and it does not swing the other way beyond its
noise and a charge amplifier's small undershoot (little of its energy lies on the other side). A response rings: it swings both ways for as
long as the structure takes to decay, many blows' lengths. When the column read as the force
rings both ways far longer than every response column, and the response column with the
shortest energy span is a one-signed pulse, the two were swapped: the station would otherwise
refuse later with a message about the response ("found 0 zero crossings of x"; blind unseen12
seed 2718), or fit a pulse as a ring-down.

The spans are those holding the middle 80 % of each channel's energy above ``NOISE_SIGMAS``
robust standard deviations of its own rest before the blow; a channel with no rest of at least
:data:`MIN_REST` samples before its onset is not judged (the check says nothing).
"""

from __future__ import annotations

from typing import Mapping

import numpy as np

from station.errors import InputFileError

#: Samples below this many robust noise SDs of the channel's rest carry no energy here.
NOISE_SIGMAS = 5.0
#: The force's energy span must exceed every response's by this factor ...
SPAN_FACTOR = 3.0
#: ... and be at least this many samples (a pulse of a few samples is a blow whatever else).
MIN_SPAN = 10
#: A channel swings both ways when this share of its energy above the noise lies on its lesser side
#: (a ring-down ~0.3-0.5 - the blow's own peak sits on one side -, a blow ~0: its undershoot is small).
TWO_SIDED = 0.1
#: Fewest rest samples before a channel's onset for its noise to be measured.
MIN_REST = 16


def check_swapped_channels(cols: Mapping[str, np.ndarray], responses: Mapping[str, np.ndarray], where: str,
                           rate_hz: float) -> None:
    """Refuse a record whose ``force`` column rings like a response while a response column is a
    one-signed pulse like a blow (module notes). ``responses``: the response columns by name.

    Raises
    ------
    InputFileError
        The two columns named, with what each looks like.
    """
    force = cols.get("force")
    if force is None or not responses:
        return
    f = _shape(np.asarray(force, dtype=float))
    if f is None or f[0] < MIN_SPAN or f[1] < TWO_SIDED:
        return
    shapes = {name: _shape(np.asarray(y, dtype=float)) for name, y in responses.items()}
    if any(s is None for s in shapes.values()):
        return
    pulse = min(shapes, key=lambda n: shapes[n][0])  # type: ignore[index]
    span, sided = shapes[pulse]  # type: ignore[misc]
    if not (f[0] > SPAN_FACTOR * max(s[0] for s in shapes.values()) and sided < TWO_SIDED):  # type: ignore[index]
        return
    raise InputFileError(
        f"{where}: columns 'force' and {pulse!r} look swapped: 'force' swings both ways over {f[0] / rate_hz:.3g} s "
        f"(like a response ringing down), while {pulse!r} is a one-signed pulse of {span / rate_hz:.3g} s (like a "
        f"hammer blow); swap the cables or the column names and read the record again")


def _shape(y: np.ndarray) -> tuple[float, float] | None:
    """The channel's energy span [samples] and two-sidedness (the share of its energy above the
    noise on its lesser side of its rest level), None without a rest to measure its noise on."""
    from eddi.median import median

    if y.size < 4 * MIN_REST:
        return None
    level = median(y[:MIN_REST])
    dev = y - level
    peak = float(np.max(np.abs(dev)))
    if not peak > 0:
        return None
    onset = int(np.argmax(np.abs(dev) > 0.5 * peak))
    if onset < MIN_REST:
        return None
    rest = y[:onset]
    level = median(rest)
    dev = y - level
    noise = 1.4826 * median(np.abs(rest - level))
    e = np.where(np.abs(dev) > NOISE_SIGMAS * noise, dev * dev, 0.0)
    cum = np.cumsum(e)
    if not cum[-1] > 0:
        return None
    lo, hi = np.searchsorted(cum, (0.1 * cum[-1], 0.9 * cum[-1]))
    up = float(np.sum(e[dev > 0]))
    return float(hi - lo + 1), float(min(up, cum[-1] - up) / cum[-1])
