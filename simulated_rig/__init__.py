"""The simulated rig: oscillator physics, hammer and sensor models, hidden effects, scenarios.

Public API::

    from simulated_rig import impact_test, get_system, SYSTEMS, HammerSpec, SensorSpec
    rec = impact_test("duffing-smooth", 600.0)   # an ImpactRecord (measured + truth)

See ``docs/rig.md``.
"""

from simulated_rig.bench import ImpactRecord, impact_test
from simulated_rig.errors import RigError, ScenarioError
from simulated_rig.hammer import TIP_PULSE_WIDTH_S, HammerSpec, hammer_force, pulse_impulse
from simulated_rig.sensors import SensorSpec, accelerometer, active_rms, force_sensor
from simulated_rig.systems import DEFAULT_SYSTEM, SYSTEMS, SystemInfo, get_system, system_info

__all__ = [
    "DEFAULT_SYSTEM",
    "SYSTEMS",
    "TIP_PULSE_WIDTH_S",
    "HammerSpec",
    "ImpactRecord",
    "RigError",
    "ScenarioError",
    "SensorSpec",
    "SystemInfo",
    "accelerometer",
    "active_rms",
    "force_sensor",
    "get_system",
    "hammer_force",
    "impact_test",
    "pulse_impulse",
    "system_info",
]
