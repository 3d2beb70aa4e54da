"""``station devices``: serial ports, USB DAQs and the simulated rig's systems."""

from __future__ import annotations

import argparse

from station.output import emit


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser("devices", help="list serial ports, USB DAQs and simulated systems")
    p.add_argument("--probe", action="store_true", help="ask every serial port to identify itself")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=handler)


def handler(args: argparse.Namespace) -> int:
    from station.devices import list_devices

    entries = list_devices(probe=args.probe)
    mark = {True: "yes", False: "no", None: "?"}
    lines = [f"{'URL':40s} {'KIND':6s} {'EDDI':4s} DESCRIPTION"]
    lines += [f"{e.url:40s} {e.kind:6s} {mark[e.speaks_protocol]:4s} {e.description}" for e in entries]
    emit(args.json, "\n".join(lines), {"devices": [e.__dict__ for e in entries]})
    return 0
