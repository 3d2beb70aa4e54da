"""``station rig serve --system S``: the simulated rig as a serial device on a pty."""

from __future__ import annotations

import argparse
import threading
import time

from drivers.errors import DeviceNotFoundError
from station.devices import simulated_systems
from station.output import emit


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser("rig", help="the simulated rig")
    sub = p.add_subparsers(dest="rig_command", metavar="RIG_COMMAND")
    sub.required = True
    s = sub.add_parser("serve", help="serve the simulated DAQ on a pty (prints the port) until Ctrl-C")
    s.add_argument("--system", required=True, help=f"one of: {', '.join(simulated_systems())}")
    s.add_argument("--seed", type=int, default=None, help="noise seed")
    s.add_argument("--unpaced", action="store_true", help="run as fast as the host reads, not in real time")
    s.add_argument("--link", default=None, help="also make a symlink to the pty at this path")
    s.add_argument("--block-size", type=int, default=256, help="samples per frame at power-on")
    s.add_argument("--duration-s", type=float, default=None, help="stop after this many seconds")
    s.add_argument("--json", action="store_true", help="print one JSON object (the port) first")
    s.set_defaults(func=serve)
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


def serve(args: argparse.Namespace) -> int:
    from simulated_rig.device import EmulatedDaq
    from simulated_rig.serve import PtyServer
    from simulated_rig.source import RigSource

    if args.system not in simulated_systems():
        raise DeviceNotFoundError(f"no simulated system {args.system!r}; known: {', '.join(simulated_systems())}")
    source = RigSource.from_system(args.system, seed=args.seed)
    firmware = EmulatedDaq(source, model=f"EDDI-SIM ({args.system})", serial=f"SIM-{args.system}",
                           block_size=args.block_size)
    server = PtyServer(firmware, paced=not args.unpaced, link=args.link).start()
    url = f"serial://{args.link or server.port}"
    emit(
        args.json,
        f"serving {args.system} on {server.port} ({'unpaced' if args.unpaced else 'real time'}): "
        f"open {url}; Ctrl-C stops",
        {"system": args.system, "port": server.port, "url": url, "paced": not args.unpaced},
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


def qemu(args: argparse.Namespace) -> int:
    """``station rig qemu``: build the firmware if needed, run it in QEMU, serve its port."""
    from simulated_rig.qemu import FIRMWARE_SYSTEMS, QemuRig

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
