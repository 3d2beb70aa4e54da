"""``station demo --out DIR [--json]``: the whole bench on the simulated rig, end to end.

    station demo --out demo            # sim://duffing-smooth, three impacts, report in demo/report/

Records three impacts at three force levels from the simulated rig through the real serial
path into DIR/session.h5, identifies on the middle one (DIR/model.json), validates on the
other two and writes DIR/report/index.html. See docs/demo.md.
"""

from __future__ import annotations

import argparse
from typing import Any

from station.output import emit


def register(subparsers: Any) -> None:
    """Add the ``demo`` sub-command."""
    from station.argtypes import add_refine_option
    from station.demo import DEMO_DEVICE, DEMO_RECORD_S

    p = subparsers.add_parser("demo", help="acquire, identify, validate and report on the simulated rig",
                              description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", required=True, metavar="DIR", help="output directory (created)")
    p.add_argument("--device", default=DEMO_DEVICE, metavar="URL", help="simulated rig (default: %(default)s)")
    p.add_argument("--record-s", type=float, default=DEMO_RECORD_S, metavar="S",
                   help="record length after the trigger [s] (default: %(default)s)")
    p.add_argument("--seed", type=int, default=None, metavar="N",
                   help="noise seed of the rig (the impacts come at fixed sample times: the same seed gives "
                        "the same captures; default: the rig's)")
    add_refine_option(p)
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=handle)


def handle(args: argparse.Namespace) -> int:
    """Run ``station demo``; return the exit code."""
    from station.output_safety import check_output

    check_output(args.out, "dir", option="--out")
    from station.commands.acquire import LiveStatus
    from station.demo import demo_object, demo_text, run_demo

    live = LiveStatus(enabled=not args.json)
    try:
        res = run_demo(args.out, device=args.device, record_s=args.record_s, on_status=live,
                       refine=args.refine, seed=args.seed)
    finally:
        live.close()
    obj = demo_object(res)
    emit(args.json, demo_text(obj), obj)
    session = res.session
    if session.fit.unstable or any(c.diverged for c in session.held_out):
        from station.cli import flagged

        return flagged("demo", "the identified model is unstable or its simulation diverges")
    return 0
