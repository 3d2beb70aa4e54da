"""Bench configuration: the example loads, every invalid field is named in one line."""

from __future__ import annotations

from pathlib import Path

import pytest

from drivers.channels import ChannelInfo
from station.config import load_config, parse_config
from station.errors import ConfigError

REPO = Path(__file__).resolve().parents[2]
FORCE = ChannelInfo("force", "force", "N", scale=1e-3, range_si=4000.0, adc_bits=24, sensitivity=2.0, sensitivity_unit="mV/N")
ACC = ChannelInfo("acc", "acceleration", "m/s^2", scale=1e-4, range_si=500.0, adc_bits=24, sensitivity=1.0)


def test_example_loads_and_converts_to_samples() -> None:
    cfg = load_config(REPO / "examples" / "bench.toml")
    assert cfg.device is not None and cfg.device.url == "sim://duffing-smooth" and cfg.device.rate_hz == 19200
    from station.devices import parse_sim_url

    assert parse_sim_url(cfg.device.url).system == "duffing-smooth"  # a system the rig has (issue 11)
    assert cfg.specimen.mass_kg == 0.815  # paper: 0.815 kg
    s = cfg.trigger_settings((FORCE, ACC), 19200.0)
    # pre-trigger 1 s (paper), record 15 s, hold-off 25 s (the rig at rest before the next blow) at 19200 Hz
    assert (s.channel, s.level, s.pretrigger_samples, s.posttrigger_samples, s.holdoff_samples) == (0, 5.0, 19200, 288000, 480000)


def test_defaults_and_level_from_range() -> None:
    cfg = parse_config({})
    s = cfg.trigger_settings((ACC, FORCE), 1000.0)
    assert s.channel == 1 and s.level == pytest.approx(0.05 * 4000.0) and s.pretrigger_samples == 1000


def test_sensitivity_override_rescales() -> None:
    cfg = parse_config({"channels": [{"name": "force", "quantity": "force", "sensitivity": 2.5, "range": 1000.0}]})
    force, acc = cfg.resolve_channels((FORCE, ACC))
    # volts per count fixed: scale * sensitivity = 1e-3 * 2.0 mV/count -> scale = 2e-3 / 2.5
    assert force.scale == pytest.approx(0.8e-3) and force.sensitivity == 2.5 and force.range_si == 1000.0
    assert acc == ACC
    bad = parse_config({"channels": [{"name": "force", "quantity": "acceleration"}], "trigger": {"channel": "force"}})
    with pytest.raises(ConfigError, match="channels.force.quantity: the device reports 'force'"):
        bad.resolve_channels((FORCE, ACC))
    missing = parse_config({"channels": [{"name": "hammer", "quantity": "force"}], "trigger": {"channel": "hammer"}})
    with pytest.raises(ConfigError, match=r"\['hammer'\] not found on the device"):
        missing.resolve_channels((FORCE, ACC))


@pytest.mark.parametrize(
    ("data", "message"),
    [
        ({"device": {"url": "duffing"}}, "device.url: expected a URL"),
        ({"device": {"url": "sim://x", "rate_hz": -5}}, "device.rate_hz: Input should be greater than 0"),
        ({"device": {"url": "sim://x", "rate": 5}}, "device.rate: unknown field"),
        ({"channels": [{"name": "f", "quantity": "pressure"}], "trigger": {"channel": "f"}}, "channels.0.quantity: Input should be"),
        ({"channels": [{"name": "force", "quantity": "force", "sensitivity": 0}]}, "channels.0.sensitivity: Input should be greater than 0"),
        ({"channels": [{"name": "acc", "quantity": "acceleration"}]}, "trigger.channel: expected one of the channels ['acc']"),
        ({"channels": [{"name": "force", "quantity": "force"}, {"name": "force", "quantity": "force"}]}, "given twice"),
        ({"trigger": {"slope": "up"}}, "trigger.slope: Input should be 'rising', 'falling' or 'either'"),
        ({"trigger": {"pretrigger_s": -1}}, "trigger.pretrigger_s: Input should be greater than or equal to 0"),
        ({"trigger": {"record_s": 0}}, "trigger.record_s: Input should be greater than 0"),
        ({"trigger": {"level_n": "high"}}, "trigger.level_n: Input should be a valid number"),
        ({"trigger": {"level_n": 0}}, "trigger.level_n: expected a finite non-zero level"),
        ({"trigger": {"on_overload": "drop"}}, "trigger.on_overload: Input should be 'flag' or 'reject'"),
        ({"specimen": {"mass_kg": 0}}, "specimen.mass_kg: Input should be greater than 0"),
        ({"identify": {"stiffness": ["x", "x^^3"]}}, "identify.stiffness: unknown term 'x^^3'"),
        ({"identify": {"damping": ["v", "v"]}}, "identify.damping: term 'v' is given twice"),
        ({"identify": {"damping": []}}, "identify.damping: expected at least one term"),
        ({"simulation": {"peak_force_n": [50, 10]}}, "simulation.peak_force_n: expected 0 < low <= high"),
        ({"colour": "red"}, "colour: unknown field"),
    ],
)
def test_each_invalid_field_is_named(data: dict, message: str) -> None:
    with pytest.raises(ConfigError) as info:
        parse_config(data, "bench.toml")
    text = str(info.value)
    assert text.startswith("bench.toml: ") and message in text and "\n" not in text


def test_all_invalid_fields_reported_together(tmp_path: Path) -> None:
    p = tmp_path / "b.toml"
    p.write_text('[trigger]\nslope = "up"\nrecord_s = -1\n[specimen]\nmass_kg = -2\n')
    with pytest.raises(ConfigError) as info:
        load_config(p)
    text = str(info.value)
    assert "trigger.slope" in text and "trigger.record_s" in text and "specimen.mass_kg" in text


def test_file_errors(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="no such configuration file"):
        load_config(tmp_path / "none.toml")
    p = tmp_path / "bad.toml"
    p.write_text("[trigger\nlevel_n = 3\n")
    with pytest.raises(ConfigError, match=r"not valid TOML \(.*line 1"):
        load_config(p)
