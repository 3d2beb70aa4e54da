"""The campaign's results: an append-only journal, the CSV and Parquet tables, the models.

Layout of the output folder::

    campaign.json      the task and its options (a resumed campaign must use the same ones)
    rows.jsonl         one JSON row per processed capture, appended and flushed as it arrives:
                       the source of truth, and what a resumed campaign skips
    results.csv        one row per capture (the last row of each in the journal), sorted by
    results.parquet    file and capture; written from the journal at the end (and on Ctrl-C)
    models/            one model JSON per identified capture (``model_json`` column)

Columns: ``file, capture`` (empty for a CSV record), ``task, status`` (``ok`` / ``error``),
``error`` (one line), ``mass_kg`` [kg], ``route``, ``nrmse``, ``nmte``, ``diverged``,
``unstable`` (the model is flagged as ``station identify`` flags it: exit code 1 there),
``driven_by``, ``cause`` and ``gain`` (diagnose), ``warnings`` (``; ``-separated), then one
column per coefficient, ``b[TERM]`` (damping) and ``k[TERM]`` (stiffness) in SI units
(N s/m for ``b[v]``, N/m for ``k[x]``, N/m^3 for ``k[x^3]``...), each followed by
``b[TERM]_ci95`` (half-width of the 95 % interval) when the pipeline gives one (in Parquet
each coefficient field carries its unit as field metadata ``unit``), and last
``model_json``, ``seconds`` (time on the worker) and ``worker`` (``host:pid``).

Why a journal beside the tables: a row is durable the moment its line is flushed, without
rewriting a table per capture (which would be O(N^2) over a campaign); the tables are written
in one streaming pass (constant memory per batch of rows) when the campaign ends.
"""

from __future__ import annotations

import contextlib
import csv
import hashlib
import json
import math
import os
from pathlib import Path
from typing import IO, Any, Iterator

from station.errors import ConfigError, InputFileError

LEAD = ("file", "capture", "task", "status", "error", "mass_kg", "route", "nrmse", "nmte", "diverged",
        "unstable", "driven_by", "cause", "gain", "warnings")
TAIL = ("model_json", "seconds", "worker")
_STR = {"file", "task", "status", "error", "route", "driven_by", "cause", "warnings", "model_json", "worker"}
_BATCH = 20000

JOURNAL = "rows.jsonl"
OPTIONS = "campaign.json"
CSV_NAME = "results.csv"
PARQUET_NAME = "results.parquet"
MODELS = "models"


def row_key(row: dict[str, Any]) -> tuple[str, int]:
    """``(file, capture)``, capture -1 when there is none (as :attr:`CaptureRef.key`)."""
    c = row.get("capture")
    return (str(row["file"]), -1 if c is None or c == "" else int(c))


def _finite_or_none(v: Any) -> Any:
    """JSON-safe: a non-finite float becomes None (null), inside mappings too."""
    if isinstance(v, dict):
        return {k: _finite_or_none(x) for k, x in v.items()}
    return v if not isinstance(v, float) or math.isfinite(v) else None


def check_out_folder(out: str | os.PathLike[str]) -> Path:
    """The output folder, if it is new, empty or a campaign's own (one line otherwise).

    Raises
    ------
    InputFileError
        ``out`` exists and is not a folder, or is a folder of other files.
    """
    p = Path(out)
    if p.exists() and not p.is_dir():
        raise InputFileError(f"--out {p}: exists and is not a folder")
    if p.is_dir() and not (p / OPTIONS).exists() and any(p.iterdir()):
        raise InputFileError(f"--out {p}: a folder of other files, not a campaign's; "
                             f"choose a new folder (it is created)")
    return p


class Journal:
    """The output folder of a campaign: journal, options, models and tables.

    Parameters
    ----------
    out : str or Path
        Folder (created if missing).
    options : dict
        The campaign's task and options; must equal those of a campaign already in ``out``.

    Raises
    ------
    ConfigError
        ``out`` holds a campaign with other options.
    InputFileError
        ``out`` exists and is not a folder, or is a folder of other files (a campaign writes
        only into a new folder or its own).
    """

    def __init__(self, out: str | os.PathLike[str], options: dict[str, Any]) -> None:
        self.out = check_out_folder(out)
        opt_path = self.out / OPTIONS
        (self.out / MODELS).mkdir(parents=True, exist_ok=True)
        if opt_path.exists():
            old = json.loads(opt_path.read_text(encoding="utf-8"))
            if old != json.loads(json.dumps(options)):
                diff = sorted(k for k in set(old) | set(options) if old.get(k) != options.get(k))
                raise ConfigError(f"--out {self.out}: holds a campaign with other options ({', '.join(diff)}); "
                                  f"resume it with the same options or choose another folder")
        else:
            opt_path.write_text(json.dumps(options, indent=2) + "\n", encoding="utf-8")
        self._fh: IO[str] | None = None

    @property
    def journal_path(self) -> Path:
        return self.out / JOURNAL

    def rows(self) -> Iterator[dict[str, Any]]:
        """Every row of the journal, in order (a torn last line from a crash is skipped)."""
        if not self.journal_path.exists():
            return
        with open(self.journal_path, encoding="utf-8") as fh:
            for line in fh:
                if line.endswith("\n"):
                    yield json.loads(line)

    def done(self, retry_errors: bool = False) -> set[tuple[str, int]]:
        """Keys of the captures already processed (with ``retry_errors``: only those that succeeded)."""
        last: dict[tuple[str, int], str] = {}
        for row in self.rows():
            last[row_key(row)] = row["status"]
        return {k for k, s in last.items() if s == "ok" or not retry_errors}

    def _model_path(self, row: dict[str, Any]) -> Path:
        p = Path(row["file"])
        h = hashlib.sha1(str(p).encode()).hexdigest()[:8]
        cap = "" if row.get("capture") is None else f"-{int(row['capture']):04d}"
        return self.out / MODELS / f"{p.stem}-{h}{cap}.json"

    def append(self, row: dict[str, Any]) -> None:
        """Write the row's model file, then the row (one flushed line)."""
        row = dict(row)
        model = row.pop("model", None)
        row["model_json"] = ""
        if model:
            path = self._model_path(row)
            path.write_text(model + "\n", encoding="utf-8")
            row["model_json"] = str(path.relative_to(self.out))
        if self._fh is None:
            # repair a torn last line left by a crash, so the new rows start on a line of their own
            if self.journal_path.exists() and self.journal_path.stat().st_size:
                with open(self.journal_path, "rb") as fh:
                    fh.seek(-1, os.SEEK_END)
                    torn = fh.read(1) != b"\n"
                if torn:
                    with open(self.journal_path, "a", encoding="utf-8") as fh:
                        fh.write("\n")
            self._fh = open(self.journal_path, "a", encoding="utf-8")
        row = {k: _finite_or_none(v) for k, v in row.items()}
        self._fh.write(json.dumps(row, allow_nan=False) + "\n")
        self._fh.flush()

    def close(self) -> None:
        if self._fh is not None:
            self._fh.close()
            self._fh = None

    # ------------------------------------------------------------------------------ tables
    def _index(self) -> tuple[list[int], list[str], dict[str, str]]:
        """Byte offsets of the last row of each capture (sorted by key), the columns, their units."""
        last: dict[tuple[str, int], int] = {}
        units: dict[str, str] = {}
        coef: set[str] = set()
        ci: set[str] = set()
        if self.journal_path.exists():
            with open(self.journal_path, "rb") as fh:
                while True:
                    pos = fh.tell()
                    line = fh.readline()
                    if not line.endswith(b"\n"):
                        break
                    if not line.strip():
                        continue
                    row = json.loads(line)
                    last[row_key(row)] = pos
                    coef.update(row.get("coefficients") or {})
                    ci.update(row.get("ci95") or {})
                    for name, unit in (row.get("units") or {}).items():
                        units.setdefault(name, unit)
                        units.setdefault(f"{name}_ci95", unit)
        cols = list(LEAD)
        for name in sorted(coef, key=lambda n: (n[0], n)):
            cols.append(name)
            if name in ci:
                cols.append(f"{name}_ci95")
        cols += TAIL
        return [last[k] for k in sorted(last)], cols, units

    def _flat(self, offsets: list[int], cols: list[str]) -> Iterator[list[dict[str, Any]]]:
        """Rows as flat dicts, in batches."""
        batch: list[dict[str, Any]] = []
        with open(self.journal_path, "rb") as fh:
            for off in offsets:
                fh.seek(off)
                row = json.loads(fh.readline())
                flat = {c: row.get(c) for c in LEAD + TAIL}
                flat["warnings"] = "; ".join(row.get("warnings") or [])
                for name, val in (row.get("coefficients") or {}).items():
                    flat[name] = val
                for name, val in (row.get("ci95") or {}).items():
                    flat[f"{name}_ci95"] = val
                batch.append(flat)
                if len(batch) >= _BATCH:
                    yield batch
                    batch = []
        if batch:
            yield batch

    def write_tables(self) -> tuple[Path, Path, int]:
        """Write ``results.csv`` and ``results.parquet`` from the journal; return them and the row count."""
        import pyarrow as pa
        import pyarrow.parquet as pq

        offsets, cols, units = self._index()
        types = {c: (pa.string() if c in _STR else pa.int64() if c == "capture" else
                     pa.bool_() if c in ("diverged", "unstable") else pa.float64()) for c in cols}
        units.update({"mass_kg": "kg", "seconds": "s"})
        schema = pa.schema([pa.field(c, types[c], metadata={"unit": units[c]} if c in units else None)
                            for c in cols])
        csv_path, pq_path = self.out / CSV_NAME, self.out / PARQUET_NAME
        csv_tmp, pq_tmp = csv_path.with_suffix(".csv.tmp"), pq_path.with_suffix(".parquet.tmp")
        try:
            with open(csv_tmp, "w", newline="", encoding="utf-8") as fh, pq.ParquetWriter(pq_tmp, schema) as pw:
                w = csv.writer(fh)
                w.writerow(cols)
                for batch in (self._flat(offsets, cols) if offsets else ()):
                    w.writerows([["" if r.get(c) is None else r[c] for c in cols] for r in batch])
                    pw.write_table(pa.Table.from_pylist([{c: r.get(c) for c in cols} for r in batch], schema=schema))
        except BaseException:  # a full disk, Ctrl-C: no half table left beside the journal
            for tmp in (csv_tmp, pq_tmp):
                with contextlib.suppress(OSError):
                    tmp.unlink(missing_ok=True)
            raise
        os.replace(csv_tmp, csv_path)
        os.replace(pq_tmp, pq_path)
        return csv_path, pq_path, len(offsets)
