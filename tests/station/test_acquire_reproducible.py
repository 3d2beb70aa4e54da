"""Impacts in sample time: the same seed gives the same captures, bit for bit (issue 11, item 3).

The rig is told where each blow lands (IMPACT_AT, a device sample counter), so the captures
do not depend on how fast the host reads or how busy the machine is.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from station.cli import main
from station.storage import list_captures, read_capture

CONFIG = """
[trigger]
channel = "force"
level_n = 20.0
pretrigger_s = 0.1
record_s = 0.6
holdoff_s = 0.1

[specimen]
mass_kg = 0.815

[simulation]
peak_force_n = [150.0, 450.0]
seed = 2
"""


def _acquire(tmp: Path, name: str, seed: int, capsys: pytest.CaptureFixture[str]) -> tuple[dict, list]:
    config = tmp / "bench.toml"
    config.write_text(CONFIG)
    out = tmp / f"{name}.h5"
    rc = main(["acquire", "--device", f"sim://duffing-smooth?seed={seed}", "--impacts", "2", "--out", str(out),
               "--config", str(config), "--json"])
    obj = json.loads(capsys.readouterr().out)
    assert rc == 0, obj
    return obj, [read_capture(out, c.index) for c in list_captures(out)]


def test_the_same_seed_gives_the_same_captures_bit_for_bit(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    _, first = _acquire(tmp_path, "a", 7, capsys)
    _, again = _acquire(tmp_path, "b", 7, capsys)
    _, other = _acquire(tmp_path, "c", 8, capsys)
    assert len(first) == len(again) == len(other) == 2
    settings_pre = first[0].pretrigger_samples
    for a, b, c in zip(first, again, other):
        assert a.trigger_sample == b.trigger_sample == c.trigger_sample  # blows at fixed sample times
        for name in ("force", "acc"):
            np.testing.assert_array_equal(a.channels[name].counts, b.channels[name].counts)
        assert not np.array_equal(a.channels["acc"].counts, c.channels["acc"].counts)  # another noise seed
    # the blows land where the plan puts them: pretrigger + margin, then one period later
    # (record + hold-off + pretrigger + margin), each a little after its scheduled sample
    rate = first[0].rate_hz
    margin = settings_pre // 2 + 1
    at0 = settings_pre + margin
    period = round(0.6 * rate) + round(0.1 * rate) + settings_pre + margin
    for k, cap in enumerate(first):
        delay = cap.trigger_sample - (at0 + k * period)
        assert 0 < delay < 0.02 * rate, (k, delay)  # the rig's 5 ms delay plus the force's rise
