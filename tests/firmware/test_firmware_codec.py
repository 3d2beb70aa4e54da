"""The firmware's C codec (firmware/src/proto.c, json.c), built for the host with gcc, against
the protocol test vectors: every frame it encodes must be byte-identical to the vector, and
every vector it decodes must give the vector's fields."""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

import pytest

from drivers.protocol import FrameType, ReplyStatus

REPO = Path(__file__).resolve().parents[2]
VECTORS = json.loads((REPO / "tests" / "vectors" / "protocol_v1.json").read_text())
FRAMES = {f["name"]: f for f in VECTORS["frames"]}

pytestmark = pytest.mark.skipif(shutil.which("gcc") is None or shutil.which("make") is None,
                                reason="needs gcc and make to build the firmware codec for the host")


@pytest.fixture(scope="module")
def codec():
    proc = subprocess.run(["make", "-s", "-C", str(REPO / "firmware"), "host"], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    exe = REPO / "firmware" / "build" / "host" / "codec_check"

    def run(lines: list[str]) -> list[str]:
        out = subprocess.run([str(exe)], input="\n".join(lines) + "\n", capture_output=True, text=True, check=True)
        return out.stdout.splitlines()

    return run


def _data_line(d: dict) -> str:
    counts = d["counts"]
    flat = " ".join(str(v) for row in counts for v in row)
    return f"data {d['seq']} {d['first_sample']} {d['width']} {d['channel_mask']} {len(counts)} {len(counts[0])} {flat}"


def _reply_line(d: dict) -> str:
    (key, value), = d["content"].items()
    kind = "i" if isinstance(value, int) else "s"
    return (f"reply {d['seq']} {d['command_seq']} {int(FrameType[d['command_type']])} "
            f"{int(ReplyStatus[d['status']])} {kind} {key} {value}")


@pytest.mark.parametrize("name", [n for n, f in FRAMES.items() if f["decoded"].get("type") in ("DATA", "REPLY")])
def test_c_encoder_matches_vector(codec, name):
    vec = FRAMES[name]
    d = vec["decoded"]
    line = _data_line(d) if d["type"] == "DATA" else _reply_line(d)
    assert codec([line]) == [vec["frame_hex"]]


@pytest.mark.parametrize("name", list(FRAMES))
def test_c_decoder_matches_vector(codec, name):
    vec = FRAMES[name]
    d = vec["decoded"]
    lines = codec([f"decode {vec['frame_hex']}"])
    assert lines[-1] == "stats 0 0"
    (frame,) = lines[:-1]
    fields = frame.split(" ")
    assert fields[0] == "frame"
    if "error" in d:  # another protocol version: CRC-valid, and the version byte says so
        assert fields[1] == "2"
        return
    version, ftype, seq = (int(x) for x in fields[1:4])
    assert (version, ftype, seq) == (1, int(FrameType[d["type"]]), d["seq"])
    rest = fields[4:]
    if d["type"] == "CONFIGURE":
        assert (float(rest[0]), int(rest[1]), int(rest[2])) == (d["rate_hz"], d["channel_mask"], d["block_size"])
    elif d["type"] == "IMPACT":
        assert (float(rest[0]), bool(int(rest[1]))) == (d["peak_force_n"], d["double_hit"])
    elif d["type"] == "DATA":
        first, n, nch, width, mask = (int(x) for x in rest[:5])
        assert (first, width, mask) == (d["first_sample"], d["width"], d["channel_mask"])
        assert (n, nch) == (len(d["counts"]), len(d["counts"][0]))
        assert [int(x) for x in rest[5:]] == [v for row in d["counts"] for v in row]
    elif d["type"] == "REPLY":
        cseq, ctype, status = (int(x) for x in rest[:3])
        assert (cseq, ctype, status) == (d["command_seq"], int(FrameType[d["command_type"]]),
                                         int(ReplyStatus[d["status"]]))
        assert json.loads(" ".join(rest[3:])) == d["content"]


def test_c_decoder_counts_corrupt_frames_in_the_stream_vector(codec):
    """Garbage, a flipped bit: the firmware's receiver counts the same errors as the reference."""
    (stream,) = VECTORS["streams"]
    lines = codec([f"decode {stream['stream_hex']}"])
    crc, framing = (int(x) for x in lines[-1].split()[1:])
    assert (crc, framing) == (stream["stats"]["crc_errors"], stream["stats"]["framing_errors"])
    data = [ln.split() for ln in lines[:-1] if ln.split()[2] == str(int(FrameType.DATA))]
    assert [int(f[4]) for f in data] == [b["first_sample"] for b in stream["blocks"]]
    assert [[int(x) for x in f[9:]] for f in data] == [[v for row in b["counts"] for v in row]
                                                        for b in stream["blocks"]]


def test_c_crc_check_value_and_float_text(codec):
    """CRC-32 check value; the firmware's float text reads back to 9 significant digits."""
    values = [2000.0 / 2**23, 3906.25, 1.0e-9, -0.6, 5.0e6, 31250.0, 1.0 / 3.0]
    lines = codec(["crc 123456789"] + [f"f64 {v!r}" for v in values])
    assert lines[0] == "cbf43926"
    for v, text in zip(values, lines[1:]):
        assert float(text) == pytest.approx(v, rel=5e-9)
        assert json.loads(text) == float(text)
