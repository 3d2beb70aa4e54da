"""Write ``protocol_v1.json``: frames of the wire protocol and what they decode to.

The vectors are the contract for any implementation (a firmware in C, a host in another
language): encoding the ``decoded`` values must give exactly ``frame_hex``, and decoding
``frame_hex`` must give exactly ``decoded``. Regenerate only when the protocol version changes::

    python tests/vectors/generate.py
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from drivers.protocol import (
    PROTOCOL_VERSION,
    FrameType,
    ReplyStatus,
    encode_command,
    encode_data,
    encode_frame,
    encode_reply,
)

HERE = Path(__file__).resolve().parent


def vectors() -> dict:
    frames = []

    def data(name: str, desc: str, seq: int, first: int, counts: list[list[int]], width: int, mask: int) -> None:
        arr = np.array(counts, dtype=np.int32)
        frames.append({
            "name": name, "description": desc,
            "frame_hex": encode_data(seq, first, arr, width, mask).hex(),
            "decoded": {"type": "DATA", "seq": seq, "first_sample": first, "width": width,
                        "channel_mask": mask, "counts": counts},
        })

    data("data-24bit-extremes", "24-bit samples at the ADC limits, zero and -1, two channels",
         5, 1000, [[8388607, -8388608], [0, -1], [1, 256]], 3, 0b11)
    data("data-16bit", "16-bit samples, three of four channels (mask 0b1011)",
         0xFFFFFFFF, 2**40 + 7, [[32767, -32768, 0], [-1, 1, 255]], 2, 0b1011)
    data("data-long-run", "a 300-byte run without zeros: COBS code 0xFF then the rest",
         1, 0, [[0x010101 + i] for i in range(100)], 3, 1)
    for name, cmd, kw in [
        ("cmd-identify", FrameType.IDENTIFY, {}),
        ("cmd-configure", FrameType.CONFIGURE, {"rate_hz": 51200.0, "channel_mask": 0b101, "block_size": 256}),
        ("cmd-start", FrameType.START, {}),
        ("cmd-stop", FrameType.STOP, {}),
        ("cmd-status", FrameType.STATUS, {}),
        ("cmd-impact", FrameType.IMPACT, {"peak_force_n": 250.5, "double_hit": True}),
    ]:
        frames.append({
            "name": name, "description": f"{cmd.name} command from the host",
            "frame_hex": encode_command(3, cmd, **kw).hex(),
            "decoded": {"type": cmd.name, "seq": 3, **kw},
        })
    for name, ctype, status, content in [
        ("reply-start", FrameType.START, ReplyStatus.OK, {"first_sample": 0}),
        ("reply-stop", FrameType.STOP, ReplyStatus.OK, {"next_sample": 51200}),
        ("reply-refused", FrameType.CONFIGURE, ReplyStatus.BAD_VALUE, {"error": "rate must be one of [10000] Hz"}),
    ]:
        frames.append({
            "name": name, "description": f"reply to {ctype.name}, status {status.name}",
            "frame_hex": encode_reply(9, 3, ctype, status, content).hex(),
            "decoded": {"type": "REPLY", "seq": 9, "command_seq": 3, "command_type": ctype.name,
                        "status": status.name, "content": content},
        })
    frames.append({
        "name": "other-version", "description": "an IDENTIFY frame of protocol version 2: must be refused",
        "frame_hex": encode_frame(FrameType.IDENTIFY, 0, b"", version=2).hex(),
        "decoded": {"error": "ProtocolVersionError"},
    })

    # a stream: garbage, three data frames of which the middle one has a flipped bit, a STOP reply
    good = [encode_data(k, 4 * k, np.full((4, 1), k + 1, dtype=np.int32), 3, 1) for k in range(3)]
    bad = bytearray(good[1])
    bad[10] ^= 0x04
    stream = b"\x13\x37garbage" + good[0] + bytes(bad) + good[2]
    stream += encode_reply(3, 1, FrameType.STOP, ReplyStatus.OK, {"next_sample": 16})
    streams = [{
        "name": "stream-corrupt-middle",
        "description": "garbage, block 0, block 1 with a bit flipped, block 2, STOP reply "
                       "(device sample counter 16): the decoder delivers blocks 0 and 2 and counts "
                       "4 samples dropped before block 2 and 4 more after it",
        "expect_sample": 0,
        "stream_hex": stream.hex(),
        "blocks": [{"first_sample": 0, "dropped_before": 0, "counts": [[1]] * 4},
                   {"first_sample": 8, "dropped_before": 4, "counts": [[3]] * 4}],
        "stats": {"crc_errors": 1, "framing_errors": 1, "dropped_samples": 8, "lost_frames": 1},
    }]
    return {"protocol_version": PROTOCOL_VERSION, "frames": frames, "streams": streams}


if __name__ == "__main__":
    (HERE / "protocol_v1.json").write_text(json.dumps(vectors(), indent=1) + "\n")
