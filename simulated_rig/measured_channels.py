"""What a rig source's digitised channels report: clip counts and noise levels (one copy for every source)."""

from __future__ import annotations

import numpy as np

from drivers.channels import ChannelInfo
from simulated_rig.sensors import SensorSpec


class MeasuredChannels:
    """Mixin for a rig source with ``channels`` (:class:`ChannelInfo`), ``sensors`` and ``clip_counts``."""

    channels: tuple[ChannelInfo, ...] | list[ChannelInfo]
    sensors: tuple[SensorSpec, ...]
    clip_counts: dict[str, int]

    def _count_clips(self, counts: np.ndarray) -> None:
        """Add the samples of ``counts`` (n, channels) at either end of each ADC's range."""
        for j, ch in enumerate(self.channels):
            self.clip_counts[ch.name] += int(np.count_nonzero((counts[:, j] == ch.max_count)
                                                              | (counts[:, j] == ch.min_count)))

    @property
    def clipped(self) -> tuple[str, ...]:
        """Channels that have clipped so far."""
        return tuple(name for name, c in self.clip_counts.items() if c > 0)

    @property
    def noise_rms(self) -> dict[str, float]:
        """Noise standard deviation of each channel [SI]."""
        return {s.name: float(s.noise_rms_si or 0.0) for s in self.sensors}
