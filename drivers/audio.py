"""USB audio-class sensors (and any PortAudio input) behind the DAQ API: ``audio://DEVICE``.

Digital accelerometers and hammers that enumerate as USB audio devices (e.g. PCB 333D01-type
digital accelerometers, USB IEPE interfaces) are sound cards to the host. :class:`AudioDaq`
reads them through ``sounddevice`` (PortAudio) and offers what :class:`drivers.daq.Daq`
offers (``info``, ``configure``, ``start``, ``read_block``, ``stop``, ``stats``), so
``station acquire --device audio://...`` runs unchanged.

URL::

    audio://DEVICE?channels=force,acc&sensitivity=2.25,1.02&fullscale_v=1.0[&rate=48000][&blocksize=1024]

* ``DEVICE``: a PortAudio input device, by index or by (part of) its name, URL-quoted
  (``audio://USB%20Audio``); ``default`` for the default input.
* ``channels``: names of the device's first channels, in order; the quantity follows from the
  name (``force*`` force [N], ``acc*`` acceleration [m/s^2], ``vel*``, ``disp*``) or is given as
  ``name:quantity``. Default: one ``acc`` channel.
* ``sensitivity``: mV per SI unit, one per channel (or one for all): mV/N for force,
  mV/(m/s^2) for acceleration. Default 1. A bench configuration's ``channels.sensitivity``
  replaces it (calibration from the bench config, as for every device).
* ``fullscale_v``: volts at digital full scale (1.0 for a sensor whose sensitivity is given
  per full scale).
* ``rate``: sample rate [Hz]; default: the device's own default rate.
* ``blocksize``: frames per read (default 1024).

Samples are read as 32-bit integers and kept as 24-bit counts (``value >> 8``; no USB audio
ADC resolves more). Loss accounting: the reader thread reads only when the block queue has
room, so the host never drops what PortAudio delivered; when the host is too slow PortAudio
reports an input overflow, which is counted (:attr:`Stats.lost_frames`, one per overflowed
read) and the lost samples are estimated from the stream clock into ``dropped_before``.
"""

from __future__ import annotations

import threading
import time
import urllib.parse
from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np

from drivers.blocks import BlockQueue
from drivers.channels import QUANTITY_UNITS, ChannelInfo
from drivers.daq import Block, DeviceInfo, Stats
from drivers.errors import BadUrlError, DeviceError, DeviceGoneError, DeviceNotFoundError
from drivers.protocol import PROTOCOL_VERSION

#: Sensitivity unit of each quantity (per SI unit).
SENSITIVITY_UNITS = {"force": "mV/N", "acceleration": "mV/(m/s^2)", "velocity": "mV/(m/s)", "displacement": "mV/m"}
_PREFIXES = (("force", "force"), ("hammer", "force"), ("acc", "acceleration"), ("vel", "velocity"),
             ("disp", "displacement"))
_OPTIONS = {"channels", "sensitivity", "fullscale_v", "rate", "blocksize"}
FULL_SCALE_COUNTS = float(1 << 23)


@dataclass(frozen=True)
class AudioUrl:
    """A parsed ``audio://`` URL (see the module docstring)."""

    device: str | int
    names: tuple[str, ...]
    quantities: tuple[str, ...]
    sensitivities: tuple[float, ...]
    fullscale_v: float = 1.0
    rate_hz: float | None = None
    block_size: int = 1024


def _quantity(name: str) -> str:
    for prefix, quantity in _PREFIXES:
        if name.lower().startswith(prefix):
            return quantity
    raise BadUrlError(f"audio channel {name!r}: cannot tell its quantity from the name; "
                      f"write {name}:QUANTITY with QUANTITY one of {', '.join(QUANTITY_UNITS)}")


def _positive(key: str, value: str) -> float:
    try:
        v = float(value)
    except ValueError:
        raise BadUrlError(f"audio option {key} must be a number, got {value!r}") from None
    if not v > 0:
        raise BadUrlError(f"audio option {key} must be > 0, got {value!r}")
    return v


def parse_audio_url(url: str) -> AudioUrl:
    """``audio://DEVICE?channels=force,acc&sensitivity=2.25,1.02`` -> :class:`AudioUrl`.

    Raises
    ------
    BadUrlError
        On a missing device, an unknown option or a malformed value.
    """
    parts = urllib.parse.urlsplit(url)
    dev = urllib.parse.unquote(parts.netloc + parts.path).strip("/")
    if parts.scheme != "audio" or not dev:
        raise BadUrlError(f"expected audio://DEVICE?channels=force,acc&sensitivity=2.25,1.02, got {url!r}")
    opts = dict(urllib.parse.parse_qsl(parts.query, keep_blank_values=True))
    unknown = sorted(set(opts) - _OPTIONS)
    if unknown:
        raise BadUrlError(f"unknown audio option {unknown[0]!r} in {url!r}; expected one of {sorted(_OPTIONS)}")
    names, quantities = [], []
    for item in (opts.get("channels") or "acc").split(","):
        name, _, quantity = item.strip().partition(":")
        if not name:
            raise BadUrlError(f"audio option channels: empty channel name in {url!r}")
        if quantity and quantity not in QUANTITY_UNITS:
            raise BadUrlError(f"audio channel {name}: quantity must be one of {', '.join(QUANTITY_UNITS)}, "
                              f"got {quantity!r}")
        names.append(name)
        quantities.append(quantity or _quantity(name))
    if len(set(names)) != len(names):
        raise BadUrlError(f"audio option channels: names must be unique, got {names}")
    sens = [_positive("sensitivity", s) for s in (opts.get("sensitivity") or "1").split(",")]
    if len(sens) == 1:
        sens *= len(names)
    if len(sens) != len(names):
        raise BadUrlError(f"audio option sensitivity: expected 1 or {len(names)} values, got {len(sens)}")
    block = opts.get("blocksize", "1024")
    if not block.isdigit() or not 1 <= int(block) <= 65535:
        raise BadUrlError(f"audio option blocksize must be 1..65535 frames, got {block!r}")
    device: str | int = int(dev) if dev.isdigit() else dev
    return AudioUrl(device, tuple(names), tuple(quantities), tuple(sens),
                    _positive("fullscale_v", opts["fullscale_v"]) if "fullscale_v" in opts else 1.0,
                    _positive("rate", opts["rate"]) if "rate" in opts else None, int(block))


def audio_channels(spec: AudioUrl) -> tuple[ChannelInfo, ...]:
    """Channel descriptions: 24-bit counts, ``scale = fullscale_v / 2**23 / sensitivity``."""
    out = []
    for name, quantity, s in zip(spec.names, spec.quantities, spec.sensitivities):
        v_per_si = s * 1e-3
        out.append(ChannelInfo(name=name, quantity=quantity, unit=QUANTITY_UNITS[quantity],
                               scale=spec.fullscale_v / FULL_SCALE_COUNTS / v_per_si, offset=0.0,
                               range_si=spec.fullscale_v / v_per_si, adc_bits=24, sensitivity=s,
                               sensitivity_unit=SENSITIVITY_UNITS[quantity]))
    return tuple(out)


def samples_lost_on_overflow(stream_time_s: float, start_time_s: float, rate_hz: float, first_sample: int,
                             next_sample: int, read_now: int, still_buffered: int) -> int:
    """Samples PortAudio discarded, estimated when a read reports an input overflow.

    The stream clock says how many samples the device has produced since the start
    (``first_sample + (stream_time - start_time) * rate``); the host has taken ``next_sample``
    of them before this read, takes ``read_now`` in it, and ``still_buffered`` wait in
    PortAudio: the rest were lost. Never negative (a clock that lags counts nothing).
    """
    produced = first_sample + int(round((stream_time_s - start_time_s) * rate_hz))
    return max(0, produced - next_sample - read_now - still_buffered)


def _sounddevice() -> Any:
    try:
        import sounddevice
    except ImportError:
        raise DeviceNotFoundError("audio:// needs the sounddevice package (pip install sounddevice)") from None
    except OSError as exc:  # the PortAudio library is missing
        raise DeviceNotFoundError(f"audio:// needs PortAudio (apt-get install libportaudio2): {exc}") from None
    return sounddevice


class AudioDaq:
    """A PortAudio input device as a DAQ (a context manager; see the module docstring).

    Parameters
    ----------
    url : str
        ``audio://...``
    timeout_s : float
        Longest wait of :meth:`read_block` by default, [s].
    queue_blocks : int
        Blocks the reader may hold before it stops reading (then PortAudio's own buffer fills
        and, on a real device, overflows: counted).

    Raises
    ------
    BadUrlError, DeviceNotFoundError
        Malformed URL; no such input device, too few channels or an unsupported rate.
    """

    def __init__(self, url: str, *, timeout_s: float = 2.0, queue_blocks: int = 1024) -> None:
        self.url = url
        self.timeout_s = timeout_s
        self.queue_blocks = queue_blocks
        self.spec = parse_audio_url(url)
        self._sd = _sounddevice()
        try:
            dev = self._sd.query_devices(self.spec.device, "input")
        except (ValueError, self._sd.PortAudioError) as exc:
            names = [d["name"] for d in self._sd.query_devices() if d["max_input_channels"] > 0]
            raise DeviceNotFoundError(f"no audio input {self.spec.device!r} ({exc}); inputs: {names}") from None
        if dev["max_input_channels"] < len(self.spec.names):
            raise DeviceNotFoundError(f"audio input {dev['name']!r} has {dev['max_input_channels']} channel(s), "
                                      f"the URL names {len(self.spec.names)}")
        self.device_index = int(dev["index"])
        self.device_name = str(dev["name"])
        hostapi = self._sd.query_hostapis(dev["hostapi"])["name"]
        self._model = f"{self.device_name} ({hostapi}, PortAudio)"
        self._channels = audio_channels(self.spec)
        self._mask = (1 << len(self._channels)) - 1
        self._block = self.spec.block_size
        self._rate = self._check_rate(self.spec.rate_hz or float(dev["default_samplerate"]))
        self._queue = BlockQueue(url, queue_blocks)
        self._stream: Any = None
        self._reader: threading.Thread | None = None
        self._stop = threading.Event()
        self._next = 0          # sample counter: frames since the last configure, lost included
        self._samples = 0
        self._dropped = 0
        self._overflows = 0
        self.streaming = False
        self.start_reply: dict[str, Any] = {}
        self.info = self._make_info()

    # ------------------------------------------------------------------ information
    def _check_rate(self, rate: float) -> float:
        try:
            self._sd.check_input_settings(device=self.device_index, channels=len(self._channels),
                                          dtype="int32", samplerate=rate)
        except (ValueError, self._sd.PortAudioError) as exc:
            raise DeviceError(f"{self.url}: the device refuses {rate:g} Hz, {len(self._channels)} channel(s), "
                              f"32-bit ({exc})") from None
        return float(rate)

    def _make_info(self) -> DeviceInfo:
        active = tuple(c for i, c in enumerate(self._channels) if self._mask >> i & 1)
        return DeviceInfo(model=self._model, serial=str(self.device_index),
                          firmware=f"PortAudio {self._sd.get_portaudio_version()[1]}",
                          protocol_version=PROTOCOL_VERSION, rate_hz=self._rate, channels=active,
                          block_size=self._block, available_channels=self._channels, channel_mask=self._mask,
                          scenario_json=None)

    def identify(self) -> DeviceInfo:
        return self.info

    def configure(self, rate_hz: float | None = None, channels: Sequence[str | int] | None = None,
                  block_size: int | None = None) -> DeviceInfo:
        """Rate [Hz] (checked with PortAudio), channels (names or indices), frames per block.

        Resets the sample counter. Raises :class:`DeviceError` when streaming or on a refused value.
        """
        if self.streaming:
            raise DeviceError(f"{self.url}: configure while streaming: stop first")
        mask = self._mask
        if channels is not None:
            names = [c.name for c in self._channels]
            mask = 0
            for ch in channels:
                idx = names.index(ch) if isinstance(ch, str) and ch in names else ch
                if not isinstance(idx, int) or not 0 <= idx < len(names):
                    raise DeviceError(f"unknown channel {ch!r}; the audio device has {names}")
                mask |= 1 << idx
            if not mask:
                raise DeviceError("at least one channel must be selected, got none")
        if block_size is not None and not 1 <= int(block_size) <= 65535:
            raise DeviceError(f"block size must be 1..65535 frames, got {block_size}")
        rate = self._check_rate(float(rate_hz)) if rate_hz else self._rate
        self._rate, self._mask = rate, mask
        self._block = int(block_size or self._block)
        self._next = 0
        self.info = self._make_info()
        return self.info

    # ------------------------------------------------------------------ streaming
    def start(self) -> None:
        """Open the PortAudio stream and start the reader thread."""
        if self.streaming:
            return
        try:
            self._stream = self._sd.InputStream(device=self.device_index, channels=len(self._channels),
                                                samplerate=self._rate, dtype="int32", blocksize=self._block)
            self._stream.start()
        except (ValueError, self._sd.PortAudioError) as exc:
            raise DeviceGoneError(f"{self.url}: cannot start the audio stream ({exc})") from None
        self._stop.clear()
        self.start_reply = {"first_sample": self._next, "started_at_s": time.monotonic()}
        self._t0 = self._stream.time
        self._read0 = self._next
        self.streaming = True
        self._reader = threading.Thread(target=self._read_loop, name=f"audio reader {self.url}", daemon=True)
        self._reader.start()

    def stop(self) -> None:
        """Stop the stream; blocks already read stay readable."""
        if not self.streaming:
            return
        self._stop.set()
        with self._queue.cond:
            self._queue.cond.notify_all()
        if self._reader is not None:
            self._reader.join(timeout=5.0)
        try:
            self._stream.stop()
            self._stream.close()
        except self._sd.PortAudioError:
            pass
        self._stream = None
        self.streaming = False

    def status(self) -> dict[str, Any]:
        return {"streaming": self.streaming, "next_sample": self._next, "rate_hz": self._rate,
                "overflows": self._overflows}

    def impact(self, peak_force_n: float, double_hit: bool = False) -> int | None:
        raise DeviceError(f"{self.url}: an audio device has no hammer")

    def _read_loop(self) -> None:
        cols = [i for i in range(len(self._channels)) if self._mask >> i & 1]
        scale = np.array([self._channels[i].scale for i in cols])
        offset = np.array([self._channels[i].offset for i in cols])
        try:
            while not self._stop.is_set():
                # flow control: read only when there is room for the block
                self._queue.wait_for_room(go_on=lambda: not self._stop.is_set())
                if self._stop.is_set():
                    break
                data, overflowed = self._stream.read(self._block)
                self._put(np.asarray(data), bool(overflowed), cols, scale, offset)
        except Exception as exc:  # PortAudio errors: the device went away
            self._queue.fail(DeviceGoneError(f"{self.url}: audio device gone while reading ({exc})"))

    def _put(self, data: np.ndarray, overflowed: bool, cols: list[int], scale: np.ndarray,
             offset: np.ndarray) -> None:
        lost = 0
        if overflowed:
            self._overflows += 1
            lost = samples_lost_on_overflow(self._stream.time, self._t0, self._rate, self._read0, self._next,
                                            data.shape[0], int(self._stream.read_available))
            self._dropped += lost
            self._next += lost
        counts = (data[:, cols] >> 8).astype(np.int32)
        block = Block(self._next, counts, counts * scale + offset, lost)
        self._next += counts.shape[0]
        self._samples += counts.shape[0]
        self._queue.put(block, go_on=lambda: False)  # room was waited for before the read

    def read_block(self, timeout_s: float | None = None) -> Block | None:
        """The next block, or None within ``timeout_s`` [s]; DeviceGoneError once the device is gone."""
        return self._queue.get(self.timeout_s if timeout_s is None else timeout_s)

    def read_samples(self, n: int, timeout_s: float | None = None) -> tuple[int, np.ndarray, np.ndarray, int]:
        """At least ``n`` samples: ``(first_sample, counts, si, dropped)``."""
        return self._queue.read_samples(n, self.timeout_s if timeout_s is None else timeout_s)

    @property
    def overflows(self) -> int:
        """Reads PortAudio flagged with an input overflow."""
        return self._overflows

    @property
    def stats(self) -> Stats:
        """Counters: ``samples`` read, ``dropped_samples`` (estimated on overflow), ``lost_frames``
        (overflowed reads). No framing on this link: CRC and framing counters stay 0."""
        return Stats(frames=self._samples // max(1, self._block), samples=self._samples,
                     dropped_samples=self._dropped, lost_frames=self._overflows, queue_max=self._queue.max_seen)

    # ------------------------------------------------------------------ lifetime
    def close(self) -> None:
        if self._queue.closed:
            return
        self.stop()
        self._queue.close()

    def __enter__(self) -> "AudioDaq":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def open_audio(url: str, *, timeout_s: float = 2.0, queue_blocks: int = 1024) -> AudioDaq:
    """Open ``audio://...`` (see :class:`AudioDaq`)."""
    return AudioDaq(url, timeout_s=timeout_s, queue_blocks=queue_blocks)
