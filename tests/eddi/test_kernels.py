"""eddi.kernels: the kernels built ahead of time give the JIT's numbers bit for bit, load
without numba, and are never used when the source changed."""

from __future__ import annotations

import importlib
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from eddi.kernels import Kernels, build
from eddi.model import EquationOfMotion

REPO = Path(__file__).resolve().parents[2]
simulate_mod = importlib.import_module("eddi.simulate")
sensitivity_mod = importlib.import_module("eddi.sensitivity")

DUFFING = EquationOfMotion.create(mass=0.815, damping={"v": 0.9, "x^2*v": 40.0, "v^3": 0.05},
                                  stiffness={"x": 2.1e4, "x^2": -3e5, "x^3": 4.0e7})
WITH_EFFECTS = EquationOfMotion.create(
    mass=0.815, damping=dict(DUFFING.damping), stiffness=dict(DUFFING.stiffness), effects=[
        {"name": "clearance", "params": {"gap_m": 1e-3, "stiffness_n_per_m": 5e3}},
        {"name": "coulomb_friction", "params": {"force_n": 0.3, "velocity_scale": 1e-3}},
        {"name": "second_mode", "params": {"mass_kg": 0.1, "stiffness_n_per_m": 4e4,
                                           "damping_n_s_per_m": 0.5, "coupling_n_per_m": 2e3}}])


@pytest.fixture(scope="module")
def aot_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    d = tmp_path_factory.mktemp("aot")
    build(d)
    return d


def _fresh(module: str, aot_dir: Path | None) -> Kernels:
    """The module's kernels resolved anew: ahead of time from ``aot_dir``, or the JIT (None)."""
    mod = importlib.import_module(module)
    k = Kernels(mod.__dict__, mod._KERNELS._signatures, mod._KERNELS._callees)
    sys.modules.pop("eddi._aot_kernels", None)
    env = {"EDDI_AOT_DIR": str(aot_dir)} if aot_dir else {"EDDI_JIT": "1"}
    saved = {key: os.environ.get(key) for key in ("EDDI_AOT_DIR", "EDDI_JIT")}
    os.environ.pop("EDDI_AOT_DIR", None)
    os.environ.pop("EDDI_JIT", None)
    os.environ.update(env)
    try:
        k._load()
    finally:
        for key, val in saved.items():
            if val is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = val
        sys.modules.pop("eddi._aot_kernels", None)
    return k


def _simulations(k_sim: Kernels, k_sens: Kernels, monkeypatch: pytest.MonkeyPatch) -> list[np.ndarray]:
    monkeypatch.setattr(simulate_mod, "_KERNELS", k_sim)
    monkeypatch.setattr(sensitivity_mod, "_KERNELS", k_sens)
    t = np.arange(6000) / 5000.0
    force = np.where(t < 2e-3, 200.0 * np.sin(np.pi * t / 2e-3), 0.0)
    out = []
    for eom in (DUFFING, WITH_EFFECTS):
        s = simulate_mod.simulate(eom, t, force=force)
        out += [s.x, s.v, s.a]
        out.append(simulate_mod.internal_force(eom, s.x, s.v))
    dense = simulate_mod.simulate_dense(DUFFING, t, force=force, x_scale=2e-3, v_scale=0.5)
    out += [dense.x, dense.v]
    resp, jac, _ = sensitivity_mod.free_response_sensitivities(DUFFING, 2e-4, 6000, 1e-3, 0.0,
                                                               np.full(5999, 2), jacobian=True)
    out += [resp, np.nan_to_num(jac)]
    return out


def test_ahead_of_time_kernels_give_the_jits_numbers_bit_for_bit(aot_dir: Path,
                                                                 monkeypatch: pytest.MonkeyPatch) -> None:
    aot_sim, aot_sens = _fresh("eddi.simulate", aot_dir), _fresh("eddi.sensitivity", aot_dir)
    assert (aot_sim.source, aot_sens.source) == ("ahead of time", "ahead of time")
    jit_sim, jit_sens = _fresh("eddi.simulate", None), _fresh("eddi.sensitivity", None)
    assert jit_sim.source == "numba JIT"
    built = _simulations(aot_sim, aot_sens, monkeypatch)
    jitted = _simulations(jit_sim, jit_sens, monkeypatch)
    assert len(built) == len(jitted) == 12
    for a, b in zip(built, jitted):
        assert np.array_equal(a, b)
    assert np.ptp(built[0]) > 1e-4  # the response moved (the comparison is of something)


def test_kernels_edited_since_the_build_are_compiled_by_numba(aot_dir: Path) -> None:
    mod = importlib.import_module("eddi.simulate")
    ns = dict(mod.__dict__)
    ns["_E_QUAD"] = 99  # a constant the kernels read, changed after the build
    sys.modules.pop("eddi._aot_kernels", None)
    os.environ["EDDI_AOT_DIR"] = str(aot_dir)
    try:
        stale = Kernels(ns, mod._KERNELS._signatures, mod._KERNELS._callees)
        assert stale.fingerprint() != mod._KERNELS.fingerprint()
        stale._load()
        assert stale.source == "numba JIT"
    finally:
        os.environ.pop("EDDI_AOT_DIR")
        sys.modules.pop("eddi._aot_kernels", None)


def test_the_fingerprint_follows_the_kernels_code_not_its_lines() -> None:
    """Session 18: the fingerprint hashes the kernels' bytecode, names and constants (no tokenizing of
    the source at every start): an edited operator or constant changes it, the same kernel moved
    down the file (other line numbers, a comment) does not, and it is cheap."""
    import time

    mod = importlib.import_module("eddi.bspline")

    def variant(body: str) -> int:
        ns = dict(mod.__dict__)
        exec(compile(body, mod.__file__, "exec"), ns)  # noqa: S102 - a kernel's variant, for its hash
        return Kernels(ns, mod._KERNELS._signatures, mod._KERNELS._callees).fingerprint()

    src = """def _banded_matvec(start, values, x, out):
    w = values.shape[1]
    for r in range(values.shape[0]):
        s = out[r]
        c = start[r]
        for j in range(w):
            s += values[r, j] * x[c + j]
        out[r] = s
"""
    same = variant(src)
    assert variant("\n\n# moved\n\n" + src) == same  # lines and comments do not count
    assert variant(src.replace("s += values[r, j] * x[c + j]", "s -= values[r, j] * x[c + j]")) != same
    assert variant(src.replace("s = out[r]", "s = out[r] * 1.0000001")) != same
    assert variant(src.replace("s = out[r]", "s = out[r] * 1.0000002")) != variant(
        src.replace("s = out[r]", "s = out[r] * 1.0000001"))
    kernels = [importlib.import_module(name)._KERNELS
               for name in ("eddi.simulate", "eddi.calculus", "eddi.bspline", "eddi.conditioning.kinematics")]
    t0 = time.process_time()
    for k in kernels:
        k.fingerprint()
    assert time.process_time() - t0 < 0.005  # (the source's tokenizing took 7-15 ms for all modules)


def test_arguments_outside_the_built_signatures_fall_back_to_the_jit(aot_dir: Path) -> None:
    k = _fresh("eddi.simulate", aot_dir)
    assert k.source == "ahead of time"
    x = np.linspace(-1e-3, 1e-3, 40)[::2]  # not contiguous: the built signature wants C order
    v = np.linspace(-0.1, 0.1, 40)[::2]
    from eddi.terms import exponent_table

    exps = exponent_table(DUFFING.damping_terms() + DUFFING.stiffness_terms())
    coefs = np.array(list(DUFFING.damping.values()) + list(DUFFING.stiffness.values()))
    out = np.empty(x.size)
    k._internal_many(x, v, exps, coefs, simulate_mod._effect_vector(DUFFING), out)
    assert np.allclose(out, DUFFING.restoring_force(x, v), rtol=1e-12, atol=0)


def test_identify_with_built_kernels_imports_no_numba(aot_dir: Path) -> None:
    # the whole process (`station` ends with os._exit since session 15: no code runs after the
    # command, so the imports are read from -X importtime's lines)
    csv = REPO / "station" / "examples" / "duffing-impact.csv"
    env = {**os.environ, "PYTHONPATH": str(REPO), "EDDI_AOT_DIR": str(aot_dir)}
    env.pop("EDDI_JIT", None)
    done = subprocess.run([sys.executable, "-X", "importtime", "-m", "station.cli", "identify", str(csv),
                           "--mass", "0.815", "--json"], capture_output=True, text=True, env=env)
    assert done.returncode == 0, done.stderr[-500:]
    imported = [ln.rsplit("|", 1)[-1].strip() for ln in done.stderr.splitlines() if ln.startswith("import time:")]
    # the engine ran (the simulator, the refinement's least squares: eddi.lsq since session 17,
    # not scipy.optimize) with the B-spline solver built too
    assert "eddi.simulate" in imported and "eddi.lsq" in imported and "eddi.bspline" in imported
    assert "scipy.optimize" not in imported
    assert not [m for m in imported if m.split(".")[0] in ("numba", "llvmlite")]
    assert json.loads(done.stdout)["validation"]["nrmse"] < 0.1


def test_the_hysteresis_kernels_are_built_and_give_the_jits_numbers_bit_for_bit(aot_dir: Path) -> None:
    # the Bouc-Wen candidate runs in every diagnosis: with its kernels built, a diagnosis
    # imports no numba (~0.45 s of CPU per process, session 12)
    mod = importlib.import_module("eddi.hysteresis")
    aot, jit = _fresh("eddi.hysteresis", aot_dir), _fresh("eddi.hysteresis", None)
    assert (aot.source, jit.source) == ("ahead of time", "numba JIT")
    rng = np.random.default_rng(7)
    x = np.cumsum(rng.normal(0.0, 1e-4, 4000)) + 2e-3 * np.sin(np.arange(4000) / 9.0)
    need = np.flatnonzero(rng.random(4000) < 0.6).astype(np.int64)
    got = []
    for k in (aot, jit):
        outs = []
        for n_exp in (0.7, 1.0, 2.5, 8.0):
            g0, d = np.empty(mod._R_CELLS + 1), np.empty(mod._R_CELLS + 1)
            k._bw_table(n_exp, mod._R_STEP, g0, d)
            z = np.zeros(need.size)
            k._bw_exact(x, 1.5e-3, n_exp, need, mod._R_STEP, g0, d, z)
            rk2 = np.zeros(x.size)
            k._bw_path(x, 1.5e-3, n_exp, rk2)
            outs += [g0, d, z, rk2]
        eom = EquationOfMotion.create(mass=0.5, damping={"v": 0.3}, stiffness={"x": 8e3, "x^3": 5e8})
        from eddi.simulate import _effect_vector
        from eddi.terms import exponent_table

        exps = exponent_table(eom.damping_terms() + eom.stiffness_terms())
        coefs = np.array(list(eom.damping.values()) + list(eom.stiffness.values()))
        force = np.where(np.arange(3000) < 10, 50.0, 0.0)
        sim = np.empty((3000, 4))
        div = k._rk4_hyst(force, 2e-4, 3, np.array([0.0, 0.0, 0.0]), 2.0, exps, coefs, _effect_vector(eom),
                          4.0, 1e-3, 1.5, sim)
        outs += [sim, np.array([div])]
        got.append(outs)
    assert len(got[0]) == len(got[1]) == 18
    for a, b in zip(*got):
        assert np.array_equal(a, b)
    assert np.ptp(got[0][2]) > 0.5 and np.ptp(got[0][16][:, 0]) > 1e-4  # z and x moved


def test_the_hysteresis_operator_with_built_kernels_imports_no_numba(aot_dir: Path) -> None:
    code = ("import sys\nimport numpy as np\nfrom eddi.hysteresis import bouc_wen_z\n"
            "z = bouc_wen_z(np.sin(np.arange(500) / 7.0), 0.3, 2.0)\n"
            "print(round(float(np.ptp(z)), 6), 'NUMBA' if 'numba' in sys.modules else 'NO-NUMBA')\n")
    env = {**os.environ, "PYTHONPATH": str(REPO), "EDDI_AOT_DIR": str(aot_dir)}
    env.pop("EDDI_JIT", None)
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
    assert done.returncode == 0, done.stderr[-500:]
    ptp, numba = done.stdout.split()
    assert numba == "NO-NUMBA" and float(ptp) > 1.0


def test_the_module_is_built_for_this_processor_and_not_used_on_another(aot_dir: Path,
                                                                         monkeypatch: pytest.MonkeyPatch) -> None:
    # numba's generic target made the sensitivity kernel 1.8-2.3x slower than the JIT (session 12):
    # the module is built for the host, stamped with it, and refused elsewhere (no illegal
    # instruction: the JIT runs)
    import eddi.kernels as kernels

    assert kernels.cpu_stamp() > 0
    assert _fresh("eddi.sensitivity", aot_dir).source == "ahead of time"
    sys.modules.pop("eddi._aot_kernels", None)
    monkeypatch.setattr(kernels, "cpu_stamp", lambda: 12345)
    assert _fresh("eddi.sensitivity", aot_dir).source == "numba JIT"


def test_the_one_function_signature_check_agrees_with_the_per_argument_checks() -> None:
    # session 12: one check per call instead of a closure per argument (~8 -> ~4 us a call)
    from eddi.kernels import _arg_checks, _signature_check

    sig = "i8(f8[::1], f8, i8, f8[:, ::1], i8[::1], f8[:])"
    fast, slow = _signature_check(sig), _arg_checks(sig)
    good = [np.zeros(5), 0.5, 3, np.zeros((4, 3)), np.arange(4, dtype=np.int64), np.zeros(9)[::3]]
    variants = {
        0: [np.zeros(10)[::2], np.zeros(5, dtype=np.float32), np.zeros((5, 1)), [0.0] * 5, np.zeros(5).view(np.matrix)],
        1: [1, np.float64(0.5), np.int32(2), True, "0.5", None, 1 + 0j],
        2: [np.int64(3), 3.0, False, np.uint8(3)],
        3: [np.zeros((4, 3), order="F"), np.zeros((3, 4)).T, np.zeros(12), np.zeros((4, 3), dtype=np.int64)],
        4: [np.arange(4), np.arange(4, dtype=np.int32), np.arange(8, dtype=np.int64)[::2]],
        5: [np.zeros(9), np.zeros((3, 3)), np.zeros(9, dtype=np.int64)],
    }
    cases = [good, good[:-1], good + [1.0]]
    for k, alts in variants.items():
        for alt in alts:
            cases.append(good[:k] + [alt] + good[k + 1:])
    seen = set()
    for args in cases:
        want = len(args) == len(slow) and all(ok(a) for ok, a in zip(slow, args))
        assert fast(tuple(args)) == want
        seen.add(want)
    assert seen == {True, False}


def test_hermite_fill_reads_no_grid_point_past_the_last_sample() -> None:
    """A segment whose last sample sits on the grid has no grid point after it; the fill must
    not read one (compiled, that read was garbage: a NaN last sample on CI's machine)."""
    fill = simulate_mod._hermite_fill  # the Python source the kernels compile: bounds checked
    q, n = 4, 9  # samples 0..8, grid 0, 4, 8: the last sample is the last grid point
    xc, vc, ac = np.array([0.0, 1.0, 2.0]), np.array([1.0, 1.0, 1.0]), np.zeros(3)
    x, v, a = np.empty(n), np.empty(n), np.empty(n)
    fill(xc, vc, ac, simulate_mod.hermite_weights(q, 1.0), x, v, a)
    assert x[-1] == 2.0 and v[-1] == 1.0 and a[-1] == 0.0
    assert x[4] == 1.0 and np.allclose(x, np.arange(n) / 4.0)  # linear data: Hermite is exact


def _hermite_per_sample(xc, vc, ac, q, h, x, v, a):
    """The fill as it was before session 18 (each sample's offset divided out): the reference."""
    for j in range(x.shape[0]):
        k = j // q
        s = (j - k * q) / q
        if s == 0.0:
            x[j], v[j], a[j] = xc[k], vc[k], ac[k]
            continue
        s2 = s * s
        s3 = s2 * s
        h00, h10, h01, h11 = 2.0 * s3 - 3.0 * s2 + 1.0, s3 - 2.0 * s2 + s, -2.0 * s3 + 3.0 * s2, s3 - s2
        x[j] = h00 * xc[k] + h10 * h * vc[k] + h01 * xc[k + 1] + h11 * h * vc[k + 1]
        v[j] = h00 * vc[k] + h10 * h * ac[k] + h01 * vc[k + 1] + h11 * h * ac[k + 1]
        a[j] = (1.0 - s) * ac[k] + s * ac[k + 1]


@pytest.mark.parametrize("q, n", [(4, 9), (4, 10), (7, 700), (23, 1000), (23, 1013), (1, 5), (40, 40)])
def test_hermite_fill_is_the_per_sample_formula_bit_for_bit(q: int, n: int) -> None:
    # session 18 forms the basis once per offset instead of per sample: the same floats
    rng = np.random.default_rng(q * 1000 + n)
    nk = -(-n // q) + 1
    xc, vc, ac = rng.standard_normal((3, nk))
    h = 1.3e-3 * q
    want = [np.empty(n) for _ in range(3)]
    _hermite_per_sample(xc, vc, ac, q, h, *want)
    for fill in (simulate_mod._hermite_fill, simulate_mod._KERNELS._hermite_fill):  # the source, compiled
        got = [np.full(n, np.nan) for _ in range(3)]
        fill(xc, vc, ac, simulate_mod.hermite_weights(q, h), *got)
        for g, w in zip(got, want):
            assert np.array_equal(g, w)


def test_if_stale_keeps_a_current_module_and_finds_none_where_there_is_none(aot_dir: Path,
                                                                           tmp_path: Path) -> None:
    # the editable installation's step (setup.py) runs `python -m eddi.kernels --if-stale`: a
    # reinstall with the same source and processor must not pay the ~9 s build again
    import eddi.kernels as kernels

    so = next(p for p in aot_dir.iterdir() if p.name.startswith("_aot_kernels"))
    mtime = so.stat().st_mtime_ns
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    env.pop("EDDI_AOT_DIR", None)
    done = subprocess.run([sys.executable, "-m", "eddi.kernels", "--if-stale", "--output-dir", str(aot_dir)],
                          env=env, cwd=REPO, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == f"{so} (current: not rebuilt)"
    assert so.stat().st_mtime_ns == mtime
    sys.modules.pop("eddi._aot_kernels", None)
    try:
        assert kernels.current_module(tmp_path) is None  # nothing built there: --if-stale builds
        assert kernels.current_module(aot_dir) == so
    finally:
        sys.modules.pop("eddi._aot_kernels", None)


def test_the_conditioning_kernels_are_built_and_give_the_jits_numbers(aot_dir: Path) -> None:
    # session 16: the conditioning's integral and crossings (eddi.calculus, eddi.conditioning.levels)
    from eddi.kernels import KERNEL_MODULES

    assert {"eddi.calculus", "eddi.conditioning.levels"} <= set(KERNEL_MODULES)
    rng = np.random.default_rng(9)
    y = np.cumsum(rng.normal(size=5000))
    res = []
    for where in (aot_dir, None):
        kc, kl = _fresh("eddi.calculus", where), _fresh("eddi.conditioning.levels", where)
        assert kc.source == kl.source == ("ahead of time" if where else "numba JIT")
        out = np.empty(y.size)
        kc._integrate_sum(y, 1e-3, 17, out)
        cr = np.empty(y.size)
        k = kl._crossing_scan(y - np.mean(y), 2.0, 3.0, cr)
        res.append((out, cr[:k]))
    assert np.array_equal(res[0][0], res[1][0]) and np.array_equal(res[0][1], res[1][1]) and res[0][1].size > 5
    # and the simulator's local frequency (eddi.local_frequency._tangent_max, session 16)
    exps = np.array([[1, 0, 0, 0, 0, 0], [0, 1, 0, 0, 0, 0], [3, 0, 0, 0, 0, 0], [2, 1, 0, 0, 0, 0],
                     [0, 0, 0, 1, 0, 1]], dtype=np.int64)
    coefs = np.array([2.1e4, 0.9, 4e7, 40.0, 0.3])
    tans = []
    for where in (aot_dir, None):
        ks = _fresh("eddi.local_frequency", where)
        tan = np.empty(2)
        ks._tangent_max(exps, coefs, np.linspace(-0.01, 0.01, 257), np.linspace(-2.0, 2.0, 257), 0.01, 2.0, tan)
        tans.append(tan)
    assert np.array_equal(tans[0], tans[1]) and tans[0][0] > 2.1e4
    # and the input checks (eddi.conditioning.checks, session 16)
    t = np.arange(3000) / 19200.0
    verdicts = []
    for where in (aot_dir, None):
        kk = _fresh("eddi.conditioning.checks", where)
        steps = np.empty(2)
        verdicts.append((kk._finite(t), kk._finite(np.append(t, np.nan)), kk._steps(t, steps), tuple(steps),
                         kk._time_on_grid(t, 1.0 / 19200.0), kk._time_on_grid(t[::-1].copy(), -1.0 / 19200.0)))
    assert verdicts[0] == verdicts[1] and verdicts[0][:3] == (True, False, True) and verdicts[0][4:] == (True, False)
    # and the drift spline's evaluation (eddi.conditioning.kinematics, session 16)
    fills = []
    for where in (aot_dir, None):
        kk = _fresh("eddi.conditioning.kinematics", where)
        d, dd = np.zeros(3000), np.ones(3000)
        kk._horner_fill(t, np.array([0, 1000], dtype=np.int64), np.array([1000, 3000], dtype=np.int64),
                        np.array([0.0, t[1000]]), np.array([[1.0, -2.0, 3.0, 4.0], [5.0, 6.0, -7.0, 8.0]]), 1, d, dd)
        fills.append((d, dd))
    assert np.array_equal(fills[0][0], fills[1][0]) and np.array_equal(fills[0][1], fills[1][1]) and fills[0][0][0] == -4.0
    assert importlib.import_module("eddi.calculus")._KERNELS is not None
    # and the noise level's third difference and median bracket (eddi.calculus, eddi.median, session 17)
    assert "eddi.median" in KERNEL_MODULES
    noise = []
    for where in (aot_dir, None):
        kc, km = _fresh("eddi.calculus", where), _fresh("eddi.median", where)
        assert km.source == ("ahead of time" if where else "numba JIT")
        d3 = np.empty(y.size - 3)
        kc._abs_diff3(y, d3)
        inside, counts = np.empty(d3.size), np.zeros(3, dtype=np.int64)
        km._bracket_split(d3, 0.5, 1.5, inside, counts)
        noise.append((d3, inside[: counts[1]], tuple(counts)))
    assert np.array_equal(noise[0][0], noise[1][0]) and np.array_equal(noise[0][1], noise[1][1])
    assert noise[0][2] == noise[1][2] and sum(noise[0][2]) == y.size - 3 and noise[0][2][1] > 100
    # and the block-mean model of a Jacobian (eddi.refine_grid._through_sampling, session 17)
    assert "eddi.refine_grid" in KERNEL_MODULES
    jac = rng.normal(size=(500, 7))
    passes = []
    for where in (aot_dir, None):
        kr = _fresh("eddi.refine_grid", where)
        assert kr.source == ("ahead of time" if where else "numba JIT")
        out = np.empty_like(jac)
        kr._through_sampling(jac, 0.04, -0.0013, 1, out)
        passes.append(out)
    assert np.array_equal(passes[0], passes[1]) and not np.array_equal(passes[0], jac)


def test_the_csv_pass_is_built_and_gives_the_jits_numbers(aot_dir: Path) -> None:
    # session 19: the CSV reader's pass (eddi.decimal_text), used only when built ahead of time
    from eddi.kernels import KERNEL_MODULES

    assert "eddi.decimal_text" in KERNEL_MODULES
    rng = np.random.default_rng(4)
    rows = np.column_stack([np.arange(3000) / 19200.0, rng.normal(size=3000), 1e-4 * rng.normal(size=3000)])
    rows[5, 1] = 1e-300  # one number for float
    raw = ("t,force,acc\n" + "".join(",".join(f"{x:.9g}" for x in r) + "\n" for r in rows)).encode()
    buf = np.frombuffer(raw, dtype=np.uint8)
    got = []
    for where in (aot_dir, None):
        k = _fresh("eddi.decimal_text", where)
        assert k.source == ("ahead of time" if where else "numba JIT")
        out, hard = np.zeros((3, 3000)), np.zeros((64, 4), dtype=np.int64)
        got.append((k._parse_columns(buf, 12, ord(","), out, hard), out, hard.copy()))
    assert got[0][0] == got[1][0] == 1 and np.array_equal(got[0][1].view(np.int64), got[1][1].view(np.int64))
    assert np.array_equal(got[0][2][:1], got[1][2][:1]) and tuple(got[0][2][0, :2]) == (1, 5)
