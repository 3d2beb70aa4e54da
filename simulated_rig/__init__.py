"""The simulated rig: oscillator physics, hammer and sensor models, hidden effects, scenarios.

Public API (imported lazily, so ``import simulated_rig.errors`` stays cheap)::

    from simulated_rig import impact_test, get_system, SYSTEMS, load_scenario, RigSource
    rec = impact_test("duffing-smooth", 600.0)   # an ImpactRecord (measured + truth)

See ``docs/rig.md``.
"""

from __future__ import annotations

import importlib
from typing import Any

_EXPORTS: dict[str, str] = {
    "ImpactRecord": "simulated_rig.bench",
    "impact_test": "simulated_rig.bench",
    "RigError": "simulated_rig.errors",
    "ScenarioError": "simulated_rig.errors",
    "TIP_PULSE_WIDTH_S": "simulated_rig.hammer",
    "HammerSpec": "simulated_rig.hammer",
    "hammer_force": "simulated_rig.hammer",
    "pulse_impulse": "simulated_rig.hammer",
    "SensorSpec": "simulated_rig.sensors",
    "accelerometer": "simulated_rig.sensors",
    "active_rms": "simulated_rig.sensors",
    "force_sensor": "simulated_rig.sensors",
    "Scenario": "simulated_rig.scenario",
    "builtin_scenarios": "simulated_rig.scenario",
    "load_scenario": "simulated_rig.scenario",
    "RigSource": "simulated_rig.source",
    "DEFAULT_SYSTEM": "simulated_rig.systems",
    "SYSTEMS": "simulated_rig.systems",
    "SystemInfo": "simulated_rig.systems",
    "get_system": "simulated_rig.systems",
    "hide_effect": "simulated_rig.systems",
    "system_info": "simulated_rig.systems",
    "typical_state": "simulated_rig.systems",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str) -> Any:
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'simulated_rig' has no attribute {name!r}")
    return getattr(importlib.import_module(module), name)


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_EXPORTS))
