"""A sample source that serves stored ADC counts, for replaying a capture through the
emulated DAQ firmware (:class:`simulated_rig.device.EmulatedDaq`) and the real driver.

It has the ``RigSource`` interface (``rate_hz``, ``channels``, ``scenario_json``,
``read(n)``, ``configure``, ``deliver_impact``).
"""

from __future__ import annotations

import numpy as np

from drivers.channels import ChannelInfo
from simulated_rig.errors import RigError


class ReplaySource:
    """A sample source (the ``RigSource`` interface) that serves stored ADC counts.

    Parameters
    ----------
    counts : ndarray, shape (n, n_channels), int32
        The samples to serve, in order; zeros follow them.
    channels : tuple of ChannelInfo
        One per column of ``counts``.
    rate_hz : float
        Sample rate [Hz]; the only rate :meth:`configure` accepts.
    scenario_json : str
        Reported to the host in IDENTIFY.

    Attributes
    ----------
    sample_index : int
        Samples served so far.
    """

    def __init__(self, counts: np.ndarray, channels: tuple[ChannelInfo, ...], rate_hz: float,
                 scenario_json: str = "") -> None:
        counts = np.asarray(counts)
        if counts.ndim != 2 or counts.shape[1] != len(channels) or counts.dtype.kind not in "iu":
            raise RigError(f"replay: expected integer counts of shape (n, {len(channels)}), got "
                           f"{counts.dtype} {counts.shape}")
        self.counts = np.ascontiguousarray(counts, dtype=np.int32)
        self.channels = tuple(channels)
        self.rate_hz = float(rate_hz)
        self.scenario_json = scenario_json
        self.sample_index = 0

    def read(self, n: int) -> np.ndarray:
        """The next ``n`` stored samples, shape (n, n_channels) int32 (zeros past the end)."""
        n = int(n)
        out = np.zeros((n, len(self.channels)), dtype=np.int32)
        k = self.sample_index
        take = max(0, min(n, self.counts.shape[0] - k))
        out[:take] = self.counts[k:k + take]
        self.sample_index += n
        return out

    def configure(self, rate_hz: float | None = None) -> None:
        """Accept only the stored rate; restart from the first sample."""
        if rate_hz is not None and float(rate_hz) != self.rate_hz:
            raise RigError(f"replay: the capture was recorded at {self.rate_hz:g} Hz, cannot serve {rate_hz:g} Hz")
        self.sample_index = 0

    def deliver_impact(self, peak_force_n: float, double_hit: bool = False) -> None:
        """A replay plays what was recorded: no impact can be added."""
        raise RigError("replay: a stored capture cannot take a new impact")
