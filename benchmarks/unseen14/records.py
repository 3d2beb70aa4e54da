"""The records of the fourteenth blind set: equations of motion integrated by RK4 (numba), the sensor chain
that samples them, and the file writers. Used by generate.py only; nothing is imported from the station.
"""

from __future__ import annotations

import codecs
import hashlib
import json
import math

import numpy as np
from numba import njit
from scipy.interpolate import CubicSpline
from scipy.signal import butter, fftconvolve, firwin, sosfilt

SUB = 8  # integration steps per output sample (the analogue signal the chain sees)


# ----------------------------------------------------------------------------- one DOF
# p: 0 c1 v, 1 cq |v|v, 2 c3 v^3, 3 cxxv x^2 v, 4 k1 x, 5 k2 x^2, 6 k3 x^3, 7 k5 x^5, 8 kabs |x| (bilinear),
# 9 kstop one-sided stop, 10 gstop, 11 kgap symmetric gap, 12 ggap, 13 Fc Coulomb, 14 vs, 15 eta*k Reid |x| sgn v,
# 16 Fy Bouc-Wen, 17 dy, 18 n, 19 k4 x^4
NP = 20


@njit(cache=True)
def _force(p, x, v, z):
    f = p[0] * v + p[1] * abs(v) * v + p[2] * v ** 3 + p[3] * x * x * v
    f += p[4] * x + p[5] * x * x + p[6] * x ** 3 + p[19] * x ** 4 + p[7] * x ** 5 + p[8] * abs(x)
    if x > p[10]:
        f += p[9] * (x - p[10])
    if abs(x) > p[12]:
        f += p[11] * (abs(x) - p[12]) * (1.0 if x > 0 else -1.0)
    if p[14] > 0:
        th = math.tanh(v / p[14])
        f += p[13] * th + p[15] * abs(x) * th
    f += p[16] * z
    return f


@njit(cache=True)
def _dz(p, v, z):
    if p[16] == 0.0:
        return 0.0
    s = 1.0 if v * z > 0 else (0.0 if v * z == 0 else -1.0)
    return v / p[17] * (1.0 - abs(z) ** p[18] * (s + 1.0) / 2.0)


@njit(cache=True)
def _sdof(p, m, h, n, x0, P, t0, tau):
    """RK4 from (x0, 0) with a half-sine blow P sin(pi (t - t0) / tau); returns x, v, a, F at every step."""
    xs = np.zeros(n)
    vs = np.zeros(n)
    acc = np.zeros(n)
    fs = np.zeros(n)
    x, v, z = x0, 0.0, 0.0
    for i in range(n):
        t = i * h
        fi = P * math.sin(math.pi * (t - t0) / tau) if t0 <= t < t0 + tau else 0.0
        xs[i], vs[i], fs[i] = x, v, fi
        acc[i] = (fi - _force(p, x, v, z)) / m
        ks = np.zeros((4, 3))
        for j in range(4):
            dt = 0.0 if j == 0 else (h if j == 3 else h / 2)
            xx = x + dt * ks[j - 1, 0] if j else x
            vv = v + dt * ks[j - 1, 1] if j else v
            zz = z + dt * ks[j - 1, 2] if j else z
            tt = t + dt
            ff = P * math.sin(math.pi * (tt - t0) / tau) if t0 <= tt < t0 + tau else 0.0
            ks[j, 0] = vv
            ks[j, 1] = (ff - _force(p, xx, vv, zz)) / m
            ks[j, 2] = _dz(p, vv, zz)
        x += h / 6 * (ks[0, 0] + 2 * ks[1, 0] + 2 * ks[2, 0] + ks[3, 0])
        v += h / 6 * (ks[0, 1] + 2 * ks[1, 1] + 2 * ks[2, 1] + ks[3, 1])
        z += h / 6 * (ks[0, 2] + 2 * ks[1, 2] + 2 * ks[2, 2] + ks[3, 2])
    return xs, vs, acc, fs


# ----------------------------------------------------------------------------- chains of masses
@njit(cache=True)
def _mdof_acc(M, K, C, kc3, d, x, v, f):
    """Lumped chain: ground spring/damper on mass 0, springs between i-1 and i, a cubic spring between 0 and 1."""
    n = M.shape[0]
    r = np.zeros(n)
    r[0] += K[0] * x[0] + C[0] * v[0]
    for i in range(1, n):
        s = K[i] * (x[i] - x[i - 1]) + C[i] * (v[i] - v[i - 1])
        if i == 1:
            s += kc3 * (x[1] - x[0]) ** 3
        r[i] += s
        r[i - 1] -= s
    a = -r / M
    a[d] += f / M[d]
    return a


@njit(cache=True)
def _mdof(M, K, C, kc3, d, h, n, P, t0, tau):
    nm = M.shape[0]
    xs = np.zeros((n, nm))
    acc = np.zeros((n, nm))
    fs = np.zeros(n)
    x = np.zeros(nm)
    v = np.zeros(nm)
    for i in range(n):
        t = i * h
        fi = P * math.sin(math.pi * (t - t0) / tau) if t0 <= t < t0 + tau else 0.0
        tm = t + h / 2
        fm = P * math.sin(math.pi * (tm - t0) / tau) if t0 <= tm < t0 + tau else 0.0
        te = t + h
        fe = P * math.sin(math.pi * (te - t0) / tau) if t0 <= te < t0 + tau else 0.0
        xs[i], fs[i] = x, fi
        a1 = _mdof_acc(M, K, C, kc3, d, x, v, fi)
        acc[i] = a1
        a2 = _mdof_acc(M, K, C, kc3, d, x + h / 2 * v, v + h / 2 * a1, fm)
        a3 = _mdof_acc(M, K, C, kc3, d, x + h / 2 * (v + h / 2 * a1), v + h / 2 * a2, fm)
        a4 = _mdof_acc(M, K, C, kc3, d, x + h * v + h * h / 2 * a3, v + h * a3, fe)
        x = x + h * v + h * h / 6 * (a1 + a2 + a3)
        v = v + h / 6 * (a1 + 2 * a2 + 2 * a3 + a4)
    return xs, acc, fs


# ----------------------------------------------------------------------------- the sensor chain
def chain(sig, fs_fine, fs, rng, c, peak, is_acc=True):
    """The analogue signal (at fs_fine) through the chain ``c`` to samples at fs; returns samples."""
    y = np.array(sig, float)
    if c.get("hp_hz") and is_acc:  # first-order AC coupling s / (s + wc), bilinear at the fine rate
        a = math.tan(math.pi * c["hp_hz"] / fs_fine)
        y = sosfilt([[1 / (1 + a), -1 / (1 + a), 0, 1, (a - 1) / (1 + a), 0]], y)
    if c.get("aa_frac") and (is_acc or c.get("aa_both")):
        y = sosfilt(butter(c.get("aa_order", 4), c["aa_frac"] * fs, fs=fs_fine, output="sos"), y)
    # the DAQ's own decimation filter (a sigma-delta converter's linear-phase FIR, on every channel): a delay of
    # 32 samples and nothing left above 0.45 fs
    y = fftconvolve(y, _daq_fir(fs_fine, fs), mode="full")[: len(y)]
    n = len(y) // SUB
    tf = np.arange(len(y)) / fs_fine
    ts = np.arange(n) / fs
    if c.get("jitter") and is_acc:
        ts = ts + rng.normal(0, c["jitter"] / fs, n)
        y = CubicSpline(tf, y)(np.clip(ts, 0, tf[-1]))
        ts = np.arange(n) / fs
    else:
        y = y[::SUB][:n]
    if is_acc:
        y = y * (1 + c.get("gain", 0.0)) + c.get("dc", 0.0) * peak
        if c.get("hum"):
            ph = rng.uniform(0, 2 * np.pi, 3)
            for k, share in ((1, 1.0), (3, 0.35), (5, 0.12)):
                y = y + c["hum"] * peak * share * np.sin(2 * np.pi * c["mains"] * k * ts + ph[k // 2])
    snr = c.get("snr_acc" if is_acc else "snr_force", 50.0)
    y = y + rng.normal(0, peak * 10 ** (-snr / 20), n)
    if c.get("bits") and (is_acc or c.get("quant_both")):
        rng_x = c.get("range_x", 2.0) * peak
        lsb = 2 * rng_x / 2 ** c["bits"]
        y = np.clip(np.round(y / lsb) * lsb, -rng_x, rng_x - lsb)
    if c.get("clip") and is_acc:
        y = np.clip(y, -c["clip"], c["clip"])
    return y


def _daq_fir(fs_fine, fs):
    return firwin(64 * SUB + 1, 0.45 * fs, fs=fs_fine)


# ----------------------------------------------------------------------------- files
def write_csv(path, cols, layout="si"):
    """cols: ordered dict name -> array (t first, SI). layout: si, eu (semicolon, decimal comma, ms/kN/g),
    utf16, kgf (force in kilogram-force)."""
    names = list(cols)
    data = np.column_stack([cols[k] for k in names])
    if layout == "eu":
        conv = {"t": ("Zeit [ms]", 1e3), "force": ("Kraft [kN]", 1e-3)}
        head, scale = [], []
        for k in names:
            h, s = conv.get(k, (f"{k.replace('acc', 'Acceleration ').strip()} [g]", 1 / 9.80665)
                               if k.startswith("acc") else (k, 1.0))
            head.append(h)
            scale.append(s)
        head = [h.replace("Zeit", "Time").replace("Kraft", "Force") for h in head]
        rows = ["# exported by DAQ-Logger 3.2; Messung 7", ";".join(head)]
        for r in data * np.array(scale):
            rows.append(";".join(f"{x:.9g}".replace(".", ",") for x in r))
        text = "\n".join(rows) + "\n"
        with open(path, "w", encoding="utf-8") as fh:
            fh.write(text)
        return
    head = list(names)
    if layout == "kgf":
        head = ["Time [s]", "Force [kgf]", "Acceleration [m/s^2]"]
        data = data / np.array([1.0, 9.80665, 1.0])
    rows = [",".join(head)] + [",".join(f"{x:.9g}" for x in r) for r in data]
    text = "\n".join(rows) + "\n"
    if layout == "utf16":
        with open(path, "wb") as fh:
            fh.write(codecs.BOM_UTF16_LE + text.replace("\n", "\r\n").encode("utf-16-le"))
        return
    with open(path, "w") as fh:
        fh.write(text)


def write_h5(path, t, force, acc, mass):
    """A capture file in the layout docs/capture-format.md describes (SI encoding)."""
    import h5py
    with h5py.File(path, "w") as f:
        f.attrs["format"] = "eddi-station-captures"
        f.attrs["format_version"] = np.int64(2)
        f.attrs["created_utc"] = "2026-11-25T09:00:00+00:00"
        f.attrs["software"] = "lab-script"
        cap = f.create_group("captures")
        cap.attrs["count"] = np.int64(1)
        g = cap.create_group("0000")
        rate = 1.0 / (t[1] - t[0])
        for k, v in dict(index=0, n_samples=len(t), pretrigger_samples=0, trigger_sample=0, first_sample=0,
                         dropped_samples=0, dropped_before_total=0, session_index=0).items():
            g.attrs[k] = np.int64(v)
        g.attrs["rate_hz"] = float(rate)
        g.attrs["trigger_time_s"] = 0.0
        g.attrs["mass_kg"] = float(mass)
        g.attrs["channel_order"] = json.dumps(["force", "acc"])
        for k in ("double_hit", "overload", "partial"):
            g.attrs[k] = np.bool_(False)
        g.attrs["overload_channels"] = "[]"
        g.attrs["checksum_algorithm"] = "sha256"
        ch = g.create_group("channels")
        for name, arr, q, u in (("force", force, "force", "N"), ("acc", acc, "acceleration", "m/s^2")):
            ds = ch.create_dataset(name, data=np.asarray(arr, "<f8"), compression="gzip", shuffle=True)
            ds.attrs.update(encoding="si", quantity=q, unit=u, scale=1.0, offset=0.0, adc_bits=np.int64(0))
            ds.attrs["sha256"] = hashlib.sha256(np.asarray(arr, "<f8").tobytes()).hexdigest()
        g.create_dataset("gaps", data=np.zeros((0, 2), np.int64))


# ----------------------------------------------------------------------------- records
def one_dof_record(rng, sysd, level, chain_c, free=False):
    """One blow at ``level`` x the top blow (or a release from level x the top displacement when ``free``)."""
    m, fn, fs = sysd["mass"], sysd["fn_hz"], sysd["fs"]
    w = 2 * np.pi * fn
    tau = sysd["tau"]
    A = sysd["A"] * level
    P = 0.0 if free else A * m * w * np.pi / (2 * tau)  # impulse 2 P tau / pi = m v0, v0 = w A
    n = int(sysd["dur"] * fs)
    n_pre = max(100, n // 20)  # the pretrigger: 5 % of the record, at least 100 samples
    n += n_pre
    lead = n_pre - 32  # the DAQ filter delays by 32 samples: the blow (or release) lands at t = 0
    p = np.array(sysd["p"], float)
    if free:  # held at x0 (acceleration 0) until the release at t = lead / fs
        x, v, a, f = _sdof(p, m, 1 / (fs * SUB), (n - lead) * SUB, A, 0.0, 0.0, tau)
        x, a = np.r_[np.full(lead * SUB, A), x], np.r_[np.zeros(lead * SUB), a]
    elif sysd.get("mode2"):  # a second, unmeasured mass behind a spring (only mass 0 carries a sensor)
        m2, k2, c2 = sysd["mode2"]
        xs, accs, f = _mdof(np.array([m, m2]), np.array([p[4], k2]), np.array([p[0], c2]), 0.0, 0,
                            1 / (fs * SUB), n * SUB, P, lead / fs, tau)
        x, a = xs[:, 0], accs[:, 0]
    else:
        x, v, a, f = _sdof(p, m, 1 / (fs * SUB), n * SUB, 0.0, P, lead / fs, tau)
        if chain_c.get("double_hit") and level >= 0.8:  # the hammer bounces: a second blow 2.5 periods later
            x2, v2, a2, f2 = _sdof(p, m, 1 / (fs * SUB), n * SUB, 0.0, 0.3 * P, lead / fs + 2.5 / fn, tau)
            x, a, f = x + x2, a + a2, f + f2  # superposition: the double-hit case is linear
    peak = np.max(np.abs(a))
    acc = chain(a, fs * SUB, fs, rng, chain_c, peak, True)
    force = None if free else chain(f, fs * SUB, fs, rng, chain_c, max(np.max(np.abs(f)), 1e-12), False)
    return (np.arange(n) - n_pre) / fs, force, acc, x[::SUB][:n]


def draw_sdof(rng, m_lo, m_hi, f_lo, f_hi, zeta=(0.005, 0.02)):
    m = float(np.exp(rng.uniform(np.log(m_lo), np.log(m_hi))))
    fn = float(np.exp(rng.uniform(np.log(f_lo), np.log(f_hi))))
    z = float(rng.uniform(*zeta))
    k = m * (2 * np.pi * fn) ** 2
    fs_choices = [256, 512, 1024, 2048, 2560, 5120, 10240, 12800, 25600, 51200]
    fs = float(min([r for r in fs_choices if r >= 20 * fn] or [fs_choices[-1]]))
    A = float(np.exp(rng.uniform(np.log(2e-5), np.log(2e-3))) * (10 / fn) ** 0.5)
    p = np.zeros(NP)
    p[0], p[4] = 2 * z * m * 2 * np.pi * fn, k
    dur = min(np.log(300) / (z * 2 * np.pi * fn), 40000 / fs)  # down to ~0.3 % of the first peak
    return {"mass": m, "fn_hz": fn, "zeta": z, "k1": k, "fs": fs, "A": A, "tau": max(0.12 / fn, 5 / fs),
            "dur": float(dur),
            "p": p}
