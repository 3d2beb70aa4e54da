"""``station campaign``: one task over many captures, in parallel on Dask, as one table.

    station campaign SOURCE... --out DIR [--task identify|validate|diagnose] [--mass KG]
                     [--damping TERMS] [--stiffness TERMS] [--route R] [--[no-]refine]
                     [--model MODEL.json] [--scheduler tcp://HOST:PORT | --workers N]
                     [--chunk K] [--retry-errors] [--json]

SOURCE is a CSV file, an HDF5 session (every capture; FILE.h5:N for one), a folder (every CSV
and HDF5 file below it) or a quoted glob ('runs/**/*.h5'). Each capture is read on a worker
and processed as `station identify` (or validate / diagnose) does; DIR receives results.csv
and results.parquet (one row per capture: coefficients in SI units, nrmse, cause, warnings,
error), the models as JSON, and a journal that makes a second run skip what is done. A
capture that fails is a row with its error in one line; the campaign goes on.

The default cluster is a local one: one worker process per core, one thread each. Give
--scheduler to use a running Dask scheduler (see docs/campaigns.md for Slurm, PBS and
Kubernetes).
"""

from __future__ import annotations

import argparse
import errno
import math
from pathlib import Path
from typing import Any

from eddi.terms import DEFAULT_DAMPING, DEFAULT_STIFFNESS
from station.argtypes import damping_terms, finite_positive, stiffness_terms
from station.errors import ConfigError, InputFileError, StationError
from station.output import emit


def register(subparsers: Any) -> None:
    """Add the ``campaign`` sub-command."""
    p = subparsers.add_parser("campaign", help="identify / validate / diagnose many captures in parallel (Dask)",
                              description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("sources", nargs="+", metavar="SOURCE", help="CSV, FILE.h5[:N], folder or quoted glob")
    p.add_argument("--out", required=True, metavar="DIR", help="output folder (tables, models, journal)")
    p.add_argument("--task", choices=("identify", "validate", "diagnose"), default="identify",
                   help="what to do with each capture (default: %(default)s)")
    p.add_argument("--mass", type=finite_positive, metavar="KG", help="mass [kg]; default: the one each capture records")
    p.add_argument("--damping", type=damping_terms, default=",".join(DEFAULT_DAMPING), metavar="TERMS",
                   help="damping candidates (default: %(default)s)")
    p.add_argument("--stiffness", type=stiffness_terms, default=",".join(DEFAULT_STIFFNESS), metavar="TERMS",
                   help="stiffness candidates (default: %(default)s)")
    p.add_argument("--route", choices=("auto", "potential", "lagrangian"), default="auto",
                   help="phase-two route (default: %(default)s)")
    p.add_argument("--refine", action=argparse.BooleanOptionalAction, default=None,
                   help="output-error refinement after EDDI (identify; default: as station identify)")
    p.add_argument("--model", metavar="MODEL.json", help="the model to validate (--task validate)")
    p.add_argument("--scheduler", metavar="tcp://HOST:PORT", help="use a running Dask scheduler")
    p.add_argument("--workers", type=int, metavar="N", help="local worker processes (default: the cores)")
    p.add_argument("--chunk", type=int, default=None, metavar="K",
                   help="captures per Dask task (default: enough for 8 tasks per worker, at most 8)")
    p.add_argument("--retry-errors", action="store_true", help="run again the captures whose row is an error")
    p.add_argument("--json", action="store_true", help="print one JSON object (no progress bar)")
    p.set_defaults(func=handle)


def _options(args: argparse.Namespace) -> Any:
    from station.campaign.tasks import TaskOptions

    if args.mass is not None and not (math.isfinite(args.mass) and args.mass > 0):
        raise ConfigError(f"--mass must be a number > 0 [kg], got {args.mass:g}")
    model_json = None
    if args.task == "validate":
        if not args.model:
            raise ConfigError("--task validate needs --model MODEL.json")
        from station.session import load_model_file

        load_model_file(args.model)  # one clear line now rather than one per capture
        model_json = Path(args.model).read_text(encoding="utf-8")
    elif args.model:
        raise ConfigError("--model is for --task validate")
    if args.workers is not None and args.workers < 1:
        raise ConfigError(f"--workers must be >= 1, got {args.workers}")
    if args.scheduler and args.workers is not None:
        raise ConfigError("--workers sizes a local cluster; with --scheduler the cluster has its own workers")
    return TaskOptions(task=args.task, mass=args.mass, damping=args.damping, stiffness=args.stiffness,
                       route=args.route, refine=args.refine, model_json=model_json)


def _text(obj: dict[str, Any]) -> str:
    lines = [f"campaign ({obj['task']}): {obj['processed']} capture(s) processed, {obj['failed']} failed, "
             f"{obj['skipped']} already done, of {obj['total']}"]
    if obj["processed"]:
        lines.append(f"  {obj['captures_per_s']:.3g} captures/s on {obj['workers']} worker(s) "
                     f"({obj['wall_s']:.3g} s; warm-up {obj['warm_up_s']:.2g} s)")
    lines.append(f"  table: {obj['csv']} and {obj['parquet']} ({obj['rows']} rows)")
    for e in obj["first_errors"]:
        lines.append(f"  error: {e}")
    return "\n".join(lines)


#: Errors of writing the results (the others are the cluster's or the sources').
_WRITE_ERRNOS = (errno.ENOSPC, errno.EFBIG, errno.EROFS, errno.EDQUOT)


def handle(args: argparse.Namespace) -> int:
    """Run ``station campaign``; return the exit code."""
    from station.campaign.run import dask_client, run_campaign
    from station.campaign.sources import expand_sources
    from station.campaign.table import Journal, check_out_folder
    from station.output_safety import check_output

    check_output(args.out, "dir", [*args.sources, *([args.model] if args.model else [])], option="--out")
    check_out_folder(args.out)
    opts = _options(args)
    refs = expand_sources(list(args.sources), exclude=args.out)
    if not refs:
        raise InputFileError("no capture found in the sources (outside --out)")
    journal = Journal(args.out, opts.as_dict())
    errors: list[str] = []

    def keep_error(row: dict[str, Any]) -> None:
        if row["status"] != "ok" and len(errors) < 5:
            where = row["file"] + ("" if row["capture"] is None else f":{row['capture']}")
            errors.append(f"{where}: {row['error']}")

    try:
        with dask_client(args.scheduler, args.workers) as client:
            res = run_campaign(client, refs, opts, journal, chunk=args.chunk, retry_errors=args.retry_errors,
                               quiet=args.json, on_row=keep_error)
    except OSError as exc:  # the --out folder filled up or turned read-only: say where, and what is kept
        if exc.errno not in _WRITE_ERRNOS:
            raise
        what = "disk full" if exc.errno == errno.ENOSPC else (exc.strerror or str(exc))
        raise StationError(f"{args.out}: cannot write the campaign's results ({what}); the rows already in its "
                           f"journal are kept: run the same command again to resume") from None
    obj = {"task": opts.task, "total": res.total, "processed": res.processed, "failed": res.failed,
           "skipped": res.skipped, "rows": res.rows, "wall_s": res.wall_s, "warm_up_s": res.warm_up_s,
           "captures_per_s": res.captures_per_s, "workers": res.workers, "scheduler": res.scheduler,
           "csv": str(res.csv), "parquet": str(res.parquet), "models": str(Path(args.out) / "models"),
           "peak_memory_mb": res.peak_memory_mb, "first_errors": errors}
    emit(args.json, _text(obj), obj)
    return 0
