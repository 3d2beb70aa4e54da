"""``station acquire``: record N triggered impacts into an HDF5 session file.

    station acquire --device sim://duffing-smooth --impacts 5 --out session.h5 [--config bench.toml] [--json]

Shows a live status on stderr (armed / triggered / levels / progress), saves each capture as
soon as it completes, exits cleanly on Ctrl-C keeping what was saved. With a ``sim://``
device the simulated rig delivers the impacts itself, at varied force levels and at fixed
sample times (the same seed gives the same captures, however busy the machine).
"""

from __future__ import annotations

import argparse
import sys
import time
from typing import TYPE_CHECKING, Any

from station.argtypes import finite_positive, positive_seconds
from station.cli import EXIT_INTERRUPTED, EXIT_USER_ERROR
from station.errors import ConfigError
from station.output import emit

if TYPE_CHECKING:  # imported by the handler: `station acquire --help` stays light
    from station.capture import AcquireResult, Status
    from station.config import BenchConfig
    from station.storage import CaptureWriter


def register(subparsers: Any) -> None:
    """Add the ``acquire`` sub-command."""
    p = subparsers.add_parser("acquire", help="record triggered impacts into an HDF5 session file",
                              description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--device", metavar="URL", help="device URL (sim://SYSTEM, serial:///dev/ttyACM0, usb://...); "
                   "default: device.url of the configuration")
    p.add_argument("--impacts", type=int, required=True, metavar="N", help="accepted captures to record")
    p.add_argument("--out", required=True, metavar="FILE", help="HDF5 session file (created, or appended to)")
    p.add_argument("--config", metavar="FILE", help="bench configuration (TOML, docs/bench-config.md)")
    p.add_argument("--notes", help="operator notes stored with every capture (replaces the configuration's)")
    p.add_argument("--mass", type=finite_positive, metavar="KG", help="oscillating mass [kg] (replaces the configuration's)")
    p.add_argument("--driving-point", metavar="CHANNEL",
                   help="multi-DOF: the response channel at the hammer, stored with every capture (replaces the "
                        "configuration's [specimen] driving_point; default: the simulated rig's, else none)")
    p.add_argument("--idle-timeout", type=positive_seconds, default=None, metavar="S",
                   help="give up when no data comes for S seconds (default: 10 s for sim://, else wait)")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=handle)


class LiveStatus:
    """Live status on stderr: one rewritten line on a terminal, else one line per event."""

    def __init__(self, enabled: bool) -> None:
        self.enabled = enabled
        self.tty = enabled and sys.stderr.isatty()
        self._last_key: tuple[Any, ...] | None = None
        self._last_t = 0.0
        self._last_message = ""

    def __call__(self, s: Status) -> None:
        if not self.enabled:
            return
        levels = "  ".join(f"{k} {v:.3g} {s.units.get(k, '')}" for k, v in s.levels.items())
        line = (f"[{s.saved}/{s.target}] {s.state:<9} {100 * s.progress:5.1f}%  {levels}  "
                f"dropped {s.dropped_samples}  rejected {s.rejected}  {s.message}")
        if self.tty:
            now = time.monotonic()
            if now - self._last_t >= 0.1 or s.message != self._last_message:
                sys.stderr.write("\r\x1b[K" + line)
                sys.stderr.flush()
                self._last_t = now
                self._last_message = s.message
            return
        key = (s.state, s.saved, s.rejected, s.message)
        if key != self._last_key:
            sys.stderr.write(line + "\n")
            sys.stderr.flush()
            self._last_key = key

    def close(self) -> None:
        if self.tty:
            sys.stderr.write("\n")


def _config(args: argparse.Namespace) -> BenchConfig:
    from station.config import load_config, parse_config

    cfg = load_config(args.config) if args.config else parse_config({})
    data = cfg.model_dump()
    if args.device:
        data["device"] = {**(data.get("device") or {}), "url": args.device}
    if args.notes is not None:
        data["notes"] = args.notes
    if args.mass is not None:
        data["specimen"] = {**data["specimen"], "mass_kg": args.mass}
    if args.driving_point is not None:
        data["specimen"] = {**data["specimen"], "driving_point": args.driving_point}
    cfg = parse_config(data, "options")
    if cfg.device is None:
        raise ConfigError("--device: expected a device URL (or device.url in --config), got none")
    return cfg


def handle(args: argparse.Namespace) -> int:
    """Run ``station acquire``; return the exit code."""
    if args.impacts < 1:
        raise ConfigError(f"--impacts: expected at least 1, got {args.impacts}")
    cfg = _config(args)
    assert cfg.device is not None
    url = cfg.device.url
    simulated = url.startswith("sim://")
    from station.output_safety import check_output

    check_output(args.out, "hdf5", [args.config] if args.config else [], option="--out", append=True)
    from station.storage import CaptureWriter

    # one writer per session file: held for the whole run (a second acquire or import waits, then exits 2)
    writer = CaptureWriter(args.out, session={"bench_config": cfg.model_dump_json()}).hold()
    live = LiveStatus(enabled=not args.json)
    try:
        result, stats = _run(args, cfg, url, simulated, writer, live)
    finally:
        writer.close()
    live.close()
    return _report(args, result, stats)


def _run(args: argparse.Namespace, cfg: BenchConfig, url: str, simulated: bool, writer: CaptureWriter,
         live: LiveStatus) -> tuple[AcquireResult, Any]:
    from station.capture import acquire, configure_device, default_impacts, device_metadata
    from station.devices import open_device

    with open_device(url) as daq:
        configure_device(daq, cfg)
        channels = cfg.resolve_channels(daq.info.channels)
        settings = cfg.trigger_settings(channels, daq.info.rate_hz)
        plan = (default_impacts(cfg, settings, channels, args.impacts, daq.info.scenario_json).scheduled(settings)
                if simulated else None)
        idle = args.idle_timeout if args.idle_timeout is not None else (10.0 if simulated else None)
        result = acquire(daq, cfg, writer, args.impacts, impacts=plan, on_status=live, idle_timeout_s=idle,
                         device_meta=device_metadata(daq, url))
        stats = daq.stats
    return result, stats


def _report(args: argparse.Namespace, result: AcquireResult, stats: Any) -> int:
    obj = result.as_dict()
    obj["link_dropped_samples"] = int(getattr(stats, "dropped_samples", 0))
    obj["crc_errors"] = int(getattr(stats, "crc_errors", 0))
    text = (f"{result.captures} capture(s) saved to {result.file}"
            + (f" (indices {result.indices[0]}..{result.indices[-1]})" if result.indices else "")
            + f"; rejected {len(result.rejected)}; dropped samples {result.dropped_samples}"
            + (f"; capture {result.partial_index} is partial" if result.partial_index is not None else ""))
    emit(args.json, text, obj)
    if result.error is not None:
        print(f"station: error: {result.error}; {result.captures} capture(s) saved in {result.file} are kept",
              file=sys.stderr)
        return EXIT_USER_ERROR
    if result.interrupted:
        print(f"station: interrupted; {result.captures} capture(s) saved in {result.file} are kept", file=sys.stderr)
        return EXIT_INTERRUPTED
    return 0
