"""Channel description shared by the device, the driver and the stored captures."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Physical quantities a channel may carry, with their SI unit.
QUANTITY_UNITS: dict[str, str] = {
    "force": "N",
    "acceleration": "m/s^2",
    "velocity": "m/s",
    "displacement": "m",
}


@dataclass(frozen=True)
class ChannelInfo:
    """One analog channel of a DAQ.

    Attributes
    ----------
    name : str
        Short name used everywhere (``"force"``, ``"acc"``).
    quantity : str
        One of :data:`QUANTITY_UNITS` (``"force"``, ``"acceleration"``...).
    unit : str
        SI unit of the scaled value (``"N"``, ``"m/s^2"``).
    scale : float
        SI units per ADC count: ``value = counts * scale + offset``.
    offset : float
        SI value at count 0.
    range_si : float
        Full-scale magnitude in SI units (values beyond it clip).
    adc_bits : int
        16 or 24.
    sensitivity : float
        Sensor sensitivity as printed on its calibration sheet (e.g. 2.25 mV/N).
    sensitivity_unit : str
        Unit of ``sensitivity`` (``"mV/N"``, ``"mV/(m/s^2)"``).
    """

    name: str
    quantity: str
    unit: str
    scale: float
    offset: float = 0.0
    range_si: float = 0.0
    adc_bits: int = 24
    sensitivity: float = 1.0
    sensitivity_unit: str = ""

    @property
    def max_count(self) -> int:
        """Largest count the ADC can report (two's complement)."""
        return (1 << (self.adc_bits - 1)) - 1

    @property
    def min_count(self) -> int:
        """Smallest count the ADC can report."""
        return -(1 << (self.adc_bits - 1))

    def to_si(self, counts: np.ndarray) -> np.ndarray:
        """Counts to SI values, shape kept."""
        return np.asarray(counts, dtype=float) * self.scale + self.offset

    def to_counts(self, values: np.ndarray) -> np.ndarray:
        """SI values to counts, rounded and clipped to the ADC range (int32)."""
        c = np.rint((np.asarray(values, dtype=float) - self.offset) / self.scale)
        return np.clip(c, self.min_count, self.max_count).astype(np.int32)
