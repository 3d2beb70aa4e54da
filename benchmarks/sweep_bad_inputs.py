"""Bad input across every command: each bad file through each reading command, then the bad
environments (full disk, read-only folder, output onto an input, an existing output, two
writers, Ctrl-C), each expected to end in one line, a non-zero exit and no input changed.

    python benchmarks/sweep_bad_inputs.py --out DIR [--files-only | --env-only] [--only TEXT]

Files: the bad files of ``tests/station/test_bad_inputs.py`` plus multi-channel ones (a NaN, a
dead sensor, a huge value, a truncated session), a truncated UFF, broken MATLAB files; each
through ``identify``, ``replay``, ``report``, ``validate``, ``diagnose``, ``diagnose --report
--save-model``, ``export`` and ``import``, in this process (``station.cli.main``): exit code 2,
one stderr line, no exception, no input changed. Environments (subprocesses): a tmpfs of 300 kB
where it can be mounted (root), else RLIMIT_FSIZE only; SIGINT to the process group, as a
terminal's Ctrl-C. Prints one line per run and ``not ok: N of M`` at the end. The fixtures (the
demo's session, a two-mass session, exports of one capture) are made first in ``DIR/fixtures``
(~1 min of CPU). Test-free: it only prints (the failures it found are tests in
tests/station/test_bad_inputs_every_command.py).
"""

from __future__ import annotations

import argparse
import contextlib
import hashlib
import io
import json
import os
import resource
import shutil
import signal
import subprocess
import sys
import time
import traceback
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(REPO), str(REPO / "tests" / "station")]

import numpy as np  # noqa: E402

from station.cli import main  # noqa: E402


def fixtures(d: Path) -> dict[str, Path]:
    """The demo's session (3 captures), a two-mass session (3), one capture as CSV and UFF."""
    from station.readers import read_measurement

    d.mkdir(parents=True, exist_ok=True)
    if not (d / "demo" / "session.h5").is_file():
        assert main(["demo", "--out", str(d / "demo"), "--seed", "1", "--json"]) == 0
    if not (d / "mdof.h5").is_file():
        assert main(["acquire", "--device", "sim://two-mass-cubic?seed=1", "--impacts", "3", "--out",
                     str(d / "mdof.h5")]) == 0
    m = read_measurement(f"{d / 'demo' / 'session.h5'}:1")
    np.savetxt(d / "cap1.csv", np.column_stack([m.t, m.channels["force"], m.channels["acc"]]), delimiter=",",
               header="t,force,acc", comments="", fmt="%.17g")
    if not (d / "cap1.uff").is_file():
        assert main(["export", f"{d / 'demo' / 'session.h5'}:1", "--uff", str(d / "cap1.uff")]) == 0
    return {"demo": d / "demo" / "session.h5", "model": d / "demo" / "model.json", "mdof": d / "mdof.h5",
            "csv": d / "cap1.csv", "uff": d / "cap1.uff"}


def bad_files(d: Path, fx: dict[str, Path]) -> dict[str, Path]:
    import scipy.io
    from test_bad_inputs import build_files

    from station.readers import read_measurement

    d.mkdir(parents=True)
    files = {k: v for k, v in build_files(d).items()
             if k not in ("good", "dollar", "session") and not k.startswith(("cfg_", "model_"))}
    m = read_measurement(f"{fx['mdof']}:0")
    names = list(m.channels)
    cols = np.column_stack([m.t] + [m.channels[k] for k in names])

    def mcsv(name: str, arr: np.ndarray) -> None:
        np.savetxt(d / f"{name}.csv", arr, delimiter=",", header=",".join(["t"] + names), comments="", fmt="%.17g")
        files[name] = d / f"{name}.csv"

    a = cols.copy(); a[500, 3] = np.nan; mcsv("mdof_nan", a)  # noqa: E702
    a = cols.copy(); a[:, 3] = 0.0; mcsv("mdof_dead_sensor", a)  # noqa: E702
    a = cols.copy(); a[600, 2] = 1e300; mcsv("mdof_huge", a)  # noqa: E702
    mcsv("mdof_short", cols[:40])
    raw = fx["mdof"].read_bytes()
    (d / "mdof_trunc.h5").write_bytes(raw[: len(raw) * 2 // 3]); files["mdof_trunc"] = d / "mdof_trunc.h5"  # noqa: E702
    u = fx["uff"].read_bytes()
    (d / "trunc.uff").write_bytes(u[: len(u) // 3]); files["uff_trunc"] = d / "trunc.uff"  # noqa: E702
    (d / "garbage.mat").write_bytes(b"MATLAB 5.0 MAT-file" + bytes(200)); files["mat_garbage"] = d / "garbage.mat"  # noqa: E702
    m1 = read_measurement(str(fx["csv"]))
    scipy.io.savemat(d / "mat_noacc.mat", {"t": m1.t, "force": m1.channels["force"]})
    files["mat_noacc"] = d / "mat_noacc.mat"
    acc = np.where(np.arange(m1.t.size) == 900, np.nan, m1.channels["acc"])
    scipy.io.savemat(d / "mat_nan.mat", {"t": m1.t, "force": m1.channels["force"], "acc": acc})
    files["mat_nan"] = d / "mat_nan.mat"
    files.update(_session19_files(d, fx))
    return files


def _session19_files(d: Path, fx: dict[str, Path]) -> dict[str, Path]:
    """Session 19's additions: a session of float channels (``station import``) holding a NaN, an
    inf or 1e300 with its checksum redone (only the value check can catch it), a capture whose
    force channel is gone, a valid HDF5 file that is not a session, UTF-16 and BOM-only CSVs."""
    import h5py

    files: dict[str, Path] = {}
    imp = d / "imported.h5"
    assert main(["import", str(fx["csv"]), "--out", str(imp), "--mass", "0.815"]) == 0
    for name, value in (("h5f_nan", np.nan), ("h5f_inf", np.inf), ("h5f_huge", 1e300)):
        q = d / f"{name}.h5"
        shutil.copy(imp, q)
        with h5py.File(q, "a") as f:
            ds = f["captures/0000/channels/acc"]
            a = ds[...]
            a[5000] = value
            ds[...] = a
            ds.attrs["sha256"] = hashlib.sha256(np.ascontiguousarray(a).tobytes()).hexdigest()
        files[name] = q
    q = d / "h5_no_force.h5"
    shutil.copy(fx["demo"], q)
    with h5py.File(q, "a") as f:
        for k in f["captures"]:
            del f[f"captures/{k}/channels/force"]
    files["h5_no_force"] = q
    with h5py.File(d / "h5_plain.h5", "w"):
        pass
    files["h5_plain"] = d / "h5_plain.h5"
    (d / "utf16.csv").write_bytes(fx["csv"].read_text()[:20000].encode("utf-16"))
    files["csv_utf16"] = d / "utf16.csv"  # read since session 20 (its mark); this one holds no blow
    (d / "utf16_nobom.csv").write_bytes(fx["csv"].read_text().encode("utf-16-le"))
    files["csv_utf16_nobom"] = d / "utf16_nobom.csv"  # refused: which byte order, not said
    (d / "bom_only.csv").write_bytes(b"\xef\xbb\xbf")
    files["csv_bom_only"] = d / "bom_only.csv"
    imp.unlink()
    return files


def digest(p: Path) -> str | None:
    return hashlib.sha256(p.read_bytes()).hexdigest() if p.is_file() else None


def sweep_files(out: Path, fx: dict[str, Path], only: str) -> tuple[int, int]:
    files = bad_files(out / "files", fx)
    model = fx["model"]
    cmds = {
        "identify": lambda f: ["identify", f, "--mass", "1"],
        "replay": lambda f: ["replay", f, "--mass", "1"],
        "report": lambda f: ["report", f, "--mass", "1", "--out", out / "rep"],
        "validate": lambda f: ["validate", model, f],
        "diagnose": lambda f: ["diagnose", f, "--mass", "1"],
        "diagrep": lambda f: ["diagnose", f, "--mass", "1", "--report", out / "drep", "--save-model", out / "dm.json"],
        "export": lambda f: ["export", f, "--uff", out / "x.uff"],
        "import": lambda f: ["import", f, "--out", out / "imp.h5", "--mass", "1"],
    }
    bad = total = 0
    for name, path in sorted(files.items()):
        for cname, mk in cmds.items():
            if only and only not in f"{name} {cname}":
                continue
            if (name, cname) == ("two_sensors", "import"):  # a valid multi-channel record to store
                continue
            for p in (out / "rep", out / "drep", out / "dm.json", out / "x.uff", out / "imp.h5"):
                shutil.rmtree(p, ignore_errors=True) if p.is_dir() else p.unlink(missing_ok=True)
            before = {k: digest(v) for k, v in files.items()}
            err = io.StringIO()
            tb = None
            with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
                try:
                    code = main([str(a) for a in mk(path)])
                except SystemExit as exc:
                    code = exc.code if isinstance(exc.code, int) else 2
                except BaseException as exc:  # noqa: BLE001 - what the sweep looks for
                    code, tb = "exception", "".join(traceback.format_exception(exc))[-800:]
            lines = [ln for ln in err.getvalue().splitlines() if ln.strip() and not ln.startswith("station: note:")]
            ok = code == 2 and len(lines) == 1 and tb is None and before == {k: digest(v) for k, v in files.items()}
            bad += not ok
            total += 1
            print(f"{'ok ' if ok else 'BAD'} {name:20} {cname:9} rc={code} {lines[0][:150] if lines else '(no stderr)'}",
                  flush=True)
            if tb:
                print("    " + tb.replace("\n", "\n    "), flush=True)
    return bad, total


class Env:
    """Subprocess runs of ``python -m station.cli`` (see :meth:`run`)."""

    def __init__(self, work: Path, only: str) -> None:
        self.work, self.only, self.bad, self.total = work, only, 0, 0

    def run(self, name: str, argv: list, *, fsize: int | None = None, sigint_once: Path | float | None = None,
            expect: tuple[int, ...] = (2,), keep: tuple[Path, ...] = ()) -> None:
        """One command line: ``fsize`` RLIMIT_FSIZE [bytes]; ``sigint_once``: SIGINT to the group once
        that file is written, or after that many seconds; ``keep``: files that must not change."""
        if self.only and self.only not in name:
            return

        def setup() -> None:
            signal.signal(signal.SIGINT, signal.SIG_DFL)  # a background job starts with SIGINT ignored
            if fsize is not None:
                resource.setrlimit(resource.RLIMIT_FSIZE, (fsize, fsize))

        before = [digest(p) for p in keep]
        t0 = time.monotonic()
        p = subprocess.Popen([sys.executable, "-m", "station.cli", *map(str, argv)], cwd=self.work, text=True,
                             env={**os.environ, "PYTHONPATH": str(REPO)}, stdout=subprocess.PIPE,
                             stderr=subprocess.PIPE, preexec_fn=setup, start_new_session=True)
        if sigint_once is not None:
            while p.poll() is None and time.monotonic() - t0 < 600:
                if (sigint_once.exists() and sigint_once.stat().st_size if isinstance(sigint_once, Path)
                        else time.monotonic() - t0 > sigint_once):
                    os.killpg(p.pid, signal.SIGINT)
                    break
                time.sleep(0.05)
        _, err = p.communicate(timeout=900)
        lines = [ln for ln in err.splitlines() if ln.strip() and not ln.startswith(("[", "station: note:"))]
        lost = [str(k) for k, b in zip(keep, before) if b is not None and digest(k) != b]
        ok = p.returncode in expect and "Traceback" not in err and not lost and (
            len(lines) == 1 if p.returncode not in (0, 1) else len(lines) <= 1)
        self.bad += not ok
        self.total += 1
        print(f"{'ok ' if ok else 'BAD'} {name:44} rc={p.returncode} {time.monotonic() - t0:5.1f}s "
              f"{lines[-1][:160] if lines else '(no stderr)'}" + (f" CHANGED {lost}" if lost else ""), flush=True)
        if not ok:
            print("    " + err[-1500:].replace("\n", "\n    "), flush=True)


def _session19_env(e: Env, work: Path, S: Path, M: Path, inputs: tuple[Path, ...], tiny: Path | None) -> None:
    """Session 19's additions: a saved model not replaced by an export; a model re-saved onto a
    full disk kept whole; a diverging --model flagged (exit 1) in one line; Ctrl-C on identify of
    a CSV and on diagnose --save-model."""
    (work / "kept.json").write_bytes(M.read_bytes())
    e.run("existing: export --sep005 onto a saved model", ["export", S, "--sep005", work / "kept.json"],
          keep=(work / "kept.json",))
    (work / "diverging.json").write_text(json.dumps({"schema_version": 1, "mass": 0.815, "damping": {"v": 0.2},
                                                     "stiffness": {"x": 1e300}}))
    e.run("diverging --model: diagnose (flagged, exit 1)", ["diagnose", f"{S}:0", "--model", work / "diverging.json",
                                                           "--mechanisms", "coulomb_friction"], expect=(1,),
          keep=inputs)
    if tiny is not None:
        fill(tiny, 8)
        (tiny / "m.json").write_text(json.dumps({"schema_version": 1, "mass": 0.815, "damping": {"v": 0.2},
                                                 "stiffness": {"x": 390.0}}))  # a saved model, then the disk is full
        (tiny / "pad2").write_bytes(b"\0" * max(0, shutil.disk_usage(tiny).free - 1024))
        before = (tiny / "m.json").read_bytes()
        e.run("full disk: diagnose --save-model over a saved model", ["diagnose", f"{S}:1", "--save-model",
                                                                       tiny / "m.json"], keep=(tiny / "m.json",))
        if (tiny / "m.json").read_bytes() != before:
            print("    the model saved before was changed", flush=True)
    e.run("Ctrl-C: identify a CSV", ["identify", work / "cap1.csv", "--mass", "0.815"], sigint_once=2.5,
          expect=(130, 0), keep=inputs)
    e.run("Ctrl-C: diagnose --save-model", ["diagnose", S, "--save-model", work / "int.json"], sigint_once=6.0,
          expect=(130, 0), keep=inputs)


def full_folder(base: Path) -> Path | None:
    """A 300 kB tmpfs (needs root), or None."""
    d = base / "tiny"
    d.mkdir(exist_ok=True)
    r = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=300k", "tmpfs", str(d)], capture_output=True)
    return d if r.returncode == 0 else None


def read_only_folder(base: Path) -> Path | None:
    d = base / "ro"
    d.mkdir(exist_ok=True)
    r = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=64k,ro", "tmpfs", str(d)], capture_output=True)
    return d if r.returncode == 0 else None


def fill(d: Path, leave_kb: int) -> None:
    for x in d.iterdir():
        shutil.rmtree(x) if x.is_dir() else x.unlink()
    free = shutil.disk_usage(d).free
    (d / "pad").write_bytes(b"\0" * max(0, free - leave_kb * 1024))


def sweep_env(out: Path, fx: dict[str, Path], only: str) -> tuple[int, int]:
    work = out / "env"
    shutil.rmtree(work, ignore_errors=True)
    work.mkdir(parents=True)
    for k in ("demo", "model", "csv", "mdof"):
        shutil.copy(fx[k], work / fx[k].name)
    S, M, C, MD = work / "session.h5", work / "model.json", work / "cap1.csv", work / "mdof.h5"
    inputs = (S, M, C, MD)
    e = Env(work, only)
    tiny, ro = full_folder(out), read_only_folder(out)
    try:
        if tiny is not None:
            for name, argv, leave in [
                    ("full disk: report", ["report", S, "--out", tiny / "rep"], 60),
                    ("full disk: export --uff", ["export", S, "--uff", tiny / "x.uff"], 40),
                    ("full disk: export --sep005", ["export", S, "--sep005", tiny / "x.json"], 40),
                    ("full disk: import", ["import", C, "--out", tiny / "i.h5", "--mass", "0.815"], 200),
                    ("full disk: acquire", ["acquire", "--device", "sim://duffing-smooth", "--impacts", "2", "--out",
                                            tiny / "a.h5"], 200),
                    ("full disk: demo", ["demo", "--out", tiny / "demo"], 200),
                    ("full disk: campaign", ["campaign", S, "--out", tiny / "camp", "--workers", "1"], 12),
                    ("full disk: diagnose --save-model --report", ["diagnose", f"{S}:1", "--save-model", tiny / "m.json",
                                                                   "--report", tiny / "drep"], 8)]:
                fill(tiny, leave)
                e.run(name, argv, keep=inputs)
        grow = work / "grow.h5"
        shutil.copy(S, grow)
        e.run("file-size limit: acquire appending", ["acquire", "--device", "sim://duffing-smooth", "--impacts", "2",
                                                     "--out", grow], fsize=grow.stat().st_size + 100_000)
        e.run("file-size limit: import appending", ["import", C, "--out", grow, "--mass", "0.815"],
              fsize=grow.stat().st_size + 50_000)
        e.run("file-size limit: export", ["export", S, "--uff", work / "big.uff"], fsize=200_000)
        if ro is not None:
            for name, argv in [("report", ["report", S, "--out", ro / "rep"]),
                               ("export", ["export", S, "--uff", ro / "x.uff"]),
                               ("import", ["import", C, "--out", ro / "s.h5", "--mass", "0.815"]),
                               ("acquire", ["acquire", "--device", "sim://duffing-smooth", "--impacts", "1", "--out",
                                            ro / "s.h5"]),
                               ("campaign", ["campaign", S, "--out", ro / "camp", "--workers", "1"]),
                               ("demo", ["demo", "--out", ro / "demo"]),
                               ("diagnose --save-model", ["diagnose", f"{S}:1", "--save-model", ro / "m.json"]),
                               ("diagnose --report", ["diagnose", f"{S}:1", "--report", ro / "drep"])]:
                e.run(f"read-only folder: {name}", argv, keep=inputs)
        _session19_env(e, work, S, M, inputs, tiny)
        e.run("onto input: diagnose --save-model = --model", ["diagnose", f"{S}:1", "--model", M, "--save-model", M],
              keep=inputs)
        e.run("onto input: diagnose --report = capture", ["diagnose", f"{S}:1", "--report", S], keep=inputs)
        e.run("onto input: MDOF diagnose --save-model", ["diagnose", f"{MD}:0", f"{MD}:1", "--save-model", MD],
              keep=inputs)
        e.run("onto input: campaign --out = the sources' folder", ["campaign", S, "--out", work], keep=inputs)
        theirs = work / "lab"
        theirs.mkdir()
        shutil.copy(MD, theirs / "session.h5")
        e.run("existing: demo --out a folder with a session", ["demo", "--out", theirs], keep=(theirs / "session.h5",))
        (work / "existing.uff").write_text("notes\n")
        e.run("existing: export --uff onto a text file", ["export", S, "--uff", work / "existing.uff"],
              keep=(work / "existing.uff",))
        for name, argv, when in [("identify", ["identify", S], 3.0), ("replay", ["replay", S], 3.0),
                                 ("report", ["report", S, "--out", work / "rep_int"], 4.0),
                                 ("validate", ["validate", M, S], 2.0),
                                 ("diagnose --report", ["diagnose", S, "--report", work / "drep_int"], 8.0),
                                 ("MDOF diagnose", ["diagnose", MD], 8.0),
                                 ("campaign", ["campaign", S, C, "--out", work / "camp_int", "--mass", "0.815",
                                               "--workers", "2"], work / "camp_int" / "rows.jsonl"),
                                 ("demo", ["demo", "--out", work / "demo_int"], 10.0),
                                 ("replay --through-device", ["replay", S, "--through-device"], 5.0)]:
            e.run(f"Ctrl-C: {name}", argv, sigint_once=when, expect=(130, 0), keep=inputs)
        g2 = work / "grow2.h5"
        shutil.copy(S, g2)
        e.run("Ctrl-C: acquire appending", ["acquire", "--device", "sim://duffing-smooth", "--impacts", "3", "--out",
                                            g2], sigint_once=10.0, expect=(130, 0))
        tw = work / "two.h5"
        first = subprocess.Popen([sys.executable, "-m", "station.cli", "acquire", "--device", "sim://duffing-smooth",
                                  "--impacts", "2", "--out", str(tw)], cwd=work, env={**os.environ,
                                  "PYTHONPATH": str(REPO)}, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        time.sleep(4)
        e.run("two writers: import while an acquire writes", ["import", C, "--out", tw, "--mass", "0.815",
                                                              "--lock-wait", "1"])
        first.communicate()
    finally:
        for d in (tiny, ro):
            if d is not None:
                subprocess.run(["umount", str(d)], capture_output=True)
    if tiny is None:
        print("note: no tmpfs could be mounted (not root?): the full-disk runs were skipped")
    return e.bad, e.total


def main_(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", required=True, type=Path)
    ap.add_argument("--files-only", action="store_true")
    ap.add_argument("--env-only", action="store_true")
    ap.add_argument("--only", default="", help="run the cases whose name contains this text")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    shutil.rmtree(args.out / "files", ignore_errors=True)
    fx = fixtures(args.out / "fixtures")
    print(f"load average {os.getloadavg()[0]:.1f}", flush=True)
    results = []
    if not args.env_only:
        results.append(("files x commands", *sweep_files(args.out, fx, args.only)))
    if not args.files_only:
        results.append(("environments", *sweep_env(args.out, fx, args.only)))
    for what, bad, total in results:
        print(f"{what}: not ok: {bad} of {total}")
    return 0


if __name__ == "__main__":
    sys.exit(main_())
