"""``station rig``: the simulated rig as a device of its own.

    station rig serve --system duffing-smooth --link rig.port --control rig.ctl   # until Ctrl-C
    station rig strike --control rig.ctl --force-n 300                            # a hammer blow
    station rig qemu --system duffing                 # the open firmware (firmware/) in QEMU, on a pty

``serve`` powers the rig on (physics built, simulator compiled) and then serves its firmware
on a pty, printing the port; any host opens it as ``serial://PORT``. ``strike`` delivers a
blow to a served rig through its control socket, without a terminal.
"""

from __future__ import annotations

import argparse
import threading
import time


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``rig`` sub-command and its own sub-commands (each a small function below)."""
    p = subparsers.add_parser("rig", help="the simulated rig: serve it on a pty, strike it; the firmware in QEMU",
                              description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="rig_command", metavar="RIG_COMMAND")
    sub.required = True
    _register_serve(sub)
    _register_strike(sub)
    _register_qemu(sub)


def _register_serve(sub: argparse._SubParsersAction) -> None:
    s = sub.add_parser("serve", help="serve the simulated DAQ on a pty (prints the port) until Ctrl-C")
    s.add_argument("--system", required=True, help="a simulated system (`station devices` lists them)")
    s.add_argument("--seed", type=int, default=None, help="noise seed")
    s.add_argument("--unpaced", action="store_true", help="run as fast as the host reads, not in real time")
    s.add_argument("--link", default=None, metavar="PATH", help="also make a symlink to the pty at this path")
    s.add_argument("--control", default=None, metavar="PATH",
                   help="UNIX socket that `station rig strike --control PATH` strikes the rig through")
    s.add_argument("--block-size", type=int, default=256, help="samples per frame at power-on")
    s.add_argument("--duration-s", type=float, default=None, metavar="S", help="stop after S seconds")
    s.add_argument("--json", action="store_true", help="print one JSON object (the port) first")
    s.set_defaults(func=serve)


def _register_qemu(sub: argparse._SubParsersAction) -> None:
    q = sub.add_parser("qemu", help="run the open DAQ firmware (firmware/) in QEMU on a pty (prints the port) "
                       "until Ctrl-C")
    q.add_argument("--system", default="duffing",
                   help="oscillator the firmware synthesises: duffing (its built-in default), duffing-soft, "
                        "duffing-stiff, linear")
    q.add_argument("--machine", default="netduinoplus2", help="QEMU machine (STM32F405): netduinoplus2")
    q.add_argument("--no-build", action="store_true", help="do not run make first (use the existing image)")
    q.add_argument("--link", default=None, help="also make a symlink to the pty at this path")
    q.add_argument("--corrupt-data-frame", type=int, default=None, metavar="K",
                   help="fault injection: change one byte of the K-th DATA frame on its way to the host")
    q.add_argument("--duration-s", type=float, default=None, help="stop after this many seconds")
    q.add_argument("--json", action="store_true", help="print one JSON object (the port) first")
    q.set_defaults(func=qemu)


def _register_strike(sub: argparse._SubParsersAction) -> None:
    s = sub.add_parser("strike", help="strike a served rig (through its --control socket)")
    s.add_argument("--control", required=True, metavar="PATH", help="the control socket of `station rig serve`")
    s.add_argument("--force-n", type=float, required=True, metavar="N", help="peak force of the blow [N]")
    s.add_argument("--double-hit", action="store_true", help="add the hammer's second, smaller pulse")
    s.add_argument("--json", action="store_true", help="print one JSON object")
    s.set_defaults(func=strike)


def serve(args: argparse.Namespace) -> int:
    """Run ``station rig serve``; return the exit code."""
    from station.errors import ConfigError
    from station.output import emit

    if args.duration_s is not None and not args.duration_s > 0:
        raise ConfigError(f"--duration-s: expected > 0 s, got {args.duration_s}")
    if not 1 <= args.block_size <= 4096:
        raise ConfigError(f"--block-size: expected 1..4096 samples, got {args.block_size}")
    from drivers.errors import DeviceNotFoundError
    from simulated_rig.serve import PtyServer, build_firmware
    from station.devices import simulated_systems

    if args.system not in simulated_systems():
        raise DeviceNotFoundError(f"no simulated system {args.system!r}; known: {', '.join(simulated_systems())}")
    firmware = build_firmware(args.system, args.seed, args.block_size)
    server = PtyServer(firmware, paced=not args.unpaced, link=args.link, control=args.control).start()
    url = f"serial://{args.link or server.port}"
    emit(
        args.json,
        f"serving {args.system} on {server.port} ({'unpaced' if args.unpaced else 'real time'}): "
        f"open {url}" + (f"; strike with `station rig strike --control {args.control} --force-n N`"
                         if args.control else "") + "; Ctrl-C stops",
        {"system": args.system, "port": server.port, "url": url, "paced": not args.unpaced,
         "control": args.control},
    )
    done = threading.Event()
    deadline = None if args.duration_s is None else time.monotonic() + args.duration_s
    try:
        while not done.wait(0.2):
            if server.error is not None:
                raise server.error
            if deadline is not None and time.monotonic() >= deadline:
                break
    except KeyboardInterrupt:
        pass
    finally:
        server.close()
    return 0


def strike(args: argparse.Namespace) -> int:
    """Run ``station rig strike``; return the exit code."""
    from simulated_rig.serve import strike as strike_rig
    from station.errors import ConfigError
    from station.output import emit

    if not (args.force_n > 0 and args.force_n < float("inf")):
        raise ConfigError(f"--force-n: expected a finite force > 0 N, got {args.force_n}")
    at = strike_rig(args.control, args.force_n, args.double_hit)
    emit(args.json, f"struck the rig at {args.control} with {args.force_n:g} N at device sample {at}",
         {"control": args.control, "peak_force_n": args.force_n, "double_hit": args.double_hit, "at_sample": at})
    return 0


def qemu(args: argparse.Namespace) -> int:
    """``station rig qemu``: build the firmware if needed, run it in QEMU, serve its port."""
    from drivers.errors import DeviceNotFoundError
    from simulated_rig.qemu import FIRMWARE_SYSTEMS, QemuRig
    from station.output import emit

    if args.system not in FIRMWARE_SYSTEMS:
        raise DeviceNotFoundError(f"no firmware system {args.system!r}; known: {', '.join(FIRMWARE_SYSTEMS)}")
    if args.corrupt_data_frame is not None and args.corrupt_data_frame < 1:
        raise DeviceNotFoundError(f"--corrupt-data-frame: expected a frame number >= 1, got {args.corrupt_data_frame}")
    rig = QemuRig(args.system, machine=args.machine, build=not args.no_build, link=args.link,
                  corrupt_data_frame=args.corrupt_data_frame)
    rig.start()
    try:
        emit(
            args.json,
            f"firmware ({args.system}) running in QEMU {args.machine} on {rig.port} (QEMU's own pty "
            f"{rig.qemu_port}): open {rig.url}; Ctrl-C stops",
            {"system": args.system, "machine": args.machine, "port": rig.port, "qemu_port": rig.qemu_port,
             "url": rig.url, "corrupt_data_frame": args.corrupt_data_frame},
        )
        done = threading.Event()
        deadline = None if args.duration_s is None else time.monotonic() + args.duration_s
        try:
            while not done.wait(0.2):
                if rig.error is not None:
                    raise rig.error
                if deadline is not None and time.monotonic() >= deadline:
                    break
        except KeyboardInterrupt:
            pass
    finally:
        rig.close()
    return 0
