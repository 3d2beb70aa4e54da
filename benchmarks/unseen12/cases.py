"""The case kinds of the twelfth scorecard; every number is drawn per seed (``draw.py``).

``CASES``: (id, manifest section, maker, in the quick set). A maker writes its records into the data folder
and returns the case's manifest entry: the truth the scorer judges against, the pass rule in words with its
reason (``rule``, ``reason``) and the case's limit of CPU seconds per command (``limit_cpu_s``). The kinds are
new against unseen1-11 (written before the station was run on any of them):

- multi-channel captures (issue 14) of systems outside the rig's catalogue: a two-mass chain whose link has a
  quadratic and a hardening cubic term of their own sizes, a grounded softening spring, masses ten times apart,
  two close modes (a linear null), a three-mass linear null whose masses span ten times; plain numbered columns
  (`t,force,acc1,acc2`), named columns in a shuffled order with the force last, HDF5 sessions of several
  channels (imported), the driving point never the first channel, no mass given;
- one-DOF records as other DAQs write them: a LabVIEW measurement file, a sample-number column with the rate in
  a note (alone, or beside a time column), raw int16 counts with each channel's scale in a note, a MATLAB file of
  int16 channels and their scales, a German export, the response columns before the force, the force and
  response cables swapped at the DAQ.
"""

from __future__ import annotations

import os

import numpy as np

import draw
import formats
import physics

MIDDLE = dict(m_rng=(0.3, 20.0), f_rng=(8.0, 80.0), x_rng=(2e-4, 2e-3))
IDENT_LIMIT = 300  # CPU s per identify / validate command (a one-DOF record of <= 60 000 samples: 5-40 s)
MDOF_LIMIT = 600  # CPU s per multi-DOF diagnose (2-3 channels, folds and polish: 25-90 s CPU in unseen9-11)


def system(rng, m_rng, f_rng, x_rng, z_rng=(0.004, 0.025), kind="hardening"):
    """A single-DOF cubic system (mass, frequency, damping ratio, reference amplitude log-uniform)."""
    m, fn, X = draw.loguni(rng, *m_rng), draw.loguni(rng, *f_rng), draw.loguni(rng, *x_rng)
    zeta = draw.loguni(rng, *z_rng)
    k = m * (2 * np.pi * fn) ** 2
    c = 2 * zeta * np.sqrt(k * m)
    k3 = k * rng.uniform(0.06, 0.3) / X ** 2 if kind == "hardening" else -k * rng.uniform(0.04, 0.1) / X ** 2
    return {"scale": "custom", "mass": m, "fn_hz": fn, "X_ref": X, "zeta": zeta,
            "laws": [{"law": "poly", "i": 0, "k": {1: k, 3: k3}, "c": {1: c}, "cx2v": 0.0}]}


def _captures(rng, cid, out, sysd, levels, fmt, chain=None, snr=(40.0, 56.0), max_samples=60000, swap=False):
    """One capture per level of a single-DOF system (one session, a calibrated chain); returns (files, meta).
    ``swap``: the force and response columns exchanged (the cables swapped at the DAQ's inputs)."""
    fs = draw.pick_rate(rng, sysd["fn_hz"])
    pre, post = draw.timing(rng, sysd["fn_hz"], sysd["zeta"], fs, max_samples=max_samples)
    tip, files, meta = None, [], []
    for c, s in enumerate(draw.sessions(rng, len(levels), snr=snr, two=False)):
        s.update(chain or {})
        p, tip = draw.hammer(rng, sysd, sysd["fn_hz"], levels[c], tip=tip, fs=fs)
        t, ch = draw.record(rng, physics.System([sysd["mass"]], sysd["laws"]), [p], fs, pre, post, s)
        if swap:
            ch = {"force": ch["acc"], "acc": ch["force"]}
        files.append(os.path.basename(formats.write(os.path.join(out, f"{cid}-{c}"), fmt, t, ch, rng)))
        meta.append({"level": float(levels[c]), "session": s})
    return files, {"fs": fs, "pre_s": pre, "post_s": post, "fmt": fmt, "tip": tip, "sensor": "acc",
                   "captures": meta}


# ----------------------------------------------------------------------------- one-DOF records (family F)
TIME_WORDS = [r"\bsample", r"\btime", r"\brate", r"index", r"\bcolumn"]
SAMPLE_WORDS = [r"\bsample", r"\bcolumn", r"index", r"unknown"]
LVM_WORDS = [r"header", r"\blvm\b", r"labview", r"\bcolumn", r"format", r"x_value", r"file type", r"extension"]
COUNT_WORDS = [r"int16", r"integer", r"\bcounts?\b", r"\braw\b", r"sensitivit", r"scale factor",
               r"\bscale (it|them|the|each|every)"]
GERMAN_WORDS = [r"\bcolumn", r"header", r"unknown", r"zeit", r"kraft", r"beschleunigung", r"geschwindigkeit",
                r"\bname"]
NUMBER_WORDS = [r"thousand", r"separator", r"not a (finite )?number", r"\bline \d", r"\brow \d", r"\bvalue",
                r"\bnumber", r"pars", r"decimal"]
APPEND_WORDS = [r"header", r"\bline \d", r"\btime", r"monoton", r"backward", r"repeat", r"second", r"increas",
                r"not a (finite )?number", r"\bsort"]
SWAP_WORDS = [r"swap", r"exchang", r"interchang", r"wir(ed|ing)", r"\blabel", r"hammer", r"impulse", r"momentum",
              r"no (blow|impact|hit|pulse)", r"not an? (blow|impact|hammer|pulse)",
              r"(force|response) (channel|column)s? (look|is|are|seem|ring|oscillat)"]
RECORDS = {
    # defect: (file layout, words a warning must hold, words a refusal must hold (None: a refusal fails), rule,
    # reason)
    "lvm": ("lvm", LVM_WORDS, LVM_WORDS,
            "coefficients in 1.5 x ci95 and held-out nrmse <= max(0.10, 2 x noise); or one refusal line (exit 2) "
            "naming the file's header, layout or a column",
            "a LabVIEW .lvm is plain tab-separated text in N and m/s^2 with its time in X_Value: a lab expects it "
            "read, or refused in one line that says what is not understood (docs/capture-format.md lists the "
            "layouts read; .lvm is not among them)"),
    "sample": ("csv-sample", TIME_WORDS, TIME_WORDS,
               "coefficients in 1.5 x ci95 and held-out nrmse <= max(0.10, 2 x noise) (the rate read from the "
               "note); or one refusal line (exit 2) naming the sample column, the time or the rate",
               "the first column counts samples and the rate is only in a `#` note: a station that takes sample "
               "numbers for seconds gets every coefficient wrong by fs^2 or fs; a one-line refusal is right (no "
               "option gives the rate of a CSV)"),
    "sampletime": ("csv-sample-time", SAMPLE_WORDS, SAMPLE_WORDS,
                   "coefficients in 1.5 x ci95 and held-out nrmse <= max(0.10, 2 x noise); or one refusal line "
                   "(exit 2) naming the extra sample column",
                   "a sample-number column beside the time column: the time is there, so reading it is best; the "
                   "documented refusal of an unknown column name is honest too"),
    "counts": ("csv-counts", COUNT_WORDS, COUNT_WORDS + [r"\bunit"],
               "one refusal line (exit 2) naming the counts unit or the scale; or, when the scales of the notes "
               "are applied, coefficients in 1.5 x ci95 and held-out nrmse <= max(0.10, 2 x noise)",
               "raw int16 counts: no documented option takes a CSV channel's scale (docs/capture-format.md refuses "
               "a column in volts for the same reason), so counts read as N and m/s^2 give a wrong model; a lab "
               "expects a refusal that says to scale the columns"),
    "matint16": ("mat-int16", COUNT_WORDS, COUNT_WORDS + [r"\bclass", r"\bdtype", r"data type"],
                 "one refusal line (exit 2) naming the integer type, counts or scale; or, with the `*_scale` "
                 "variables applied, coefficients in 1.5 x ci95 and held-out nrmse <= max(0.10, 2 x noise)",
                 "docs/capture-format.md reads MATLAB channels as SI values: int16 vectors beside `force_scale` / "
                 "`acc_scale` are raw counts, and reading them as N and m/s^2 is a silent wrong model"),
    "german": ("csv-german", GERMAN_WORDS, GERMAN_WORDS,
               "coefficients in 1.5 x ci95 and held-out nrmse <= max(0.10, 2 x noise); or one refusal line "
               "(exit 2) naming the unknown column names",
               "`Zeit [ms];Kraft [N];Beschleunigung [m/s^2]` is a German DAQ's export; the documented names are "
               "English, so a refusal naming the column is the documented answer and reading it right is better"),
    "reordered": ("csv-reordered", None, None,
                  "coefficients in 1.5 x ci95 and held-out nrmse <= max(0.10, 2 x noise); a refusal fails",
                  "`Time [s],Acceleration [g],Force [N]`: every name and unit is documented and the header says "
                  "which column is which; the order of the columns must not matter"),
    "thousands": ("csv-thousands", NUMBER_WORDS, NUMBER_WORDS,
                  "coefficients in 1.5 x ci95 and held-out nrmse <= max(0.10, 2 x noise); or one refusal line "
                  "(exit 2) naming the number, the line or the separator it cannot read",
                  "a spreadsheet in a German locale prints `35.123,456` (a point between thousands, a decimal "
                  "comma): a value read as 35.123 is a silent factor of 1000 on some rows; reading it right or "
                  "refusing in one line are what a lab expects"),
    "micro": ("csv-us", None, None,
              "coefficients in 1.5 x ci95 and held-out nrmse <= max(0.10, 2 x noise); a refusal fails",
              "`Time [us]` as integers: a documented unit, and docs/capture-format.md reads times printed with few "
              "digits as the least-squares grid while the last digit's unit is at most half a step (1 us here)"),
    "appended": ("csv-si", APPEND_WORDS, APPEND_WORDS,
                 "coefficients in 1.5 x ci95 and held-out nrmse <= max(0.10, 2 x noise) (from the first record or "
                 "both); or one refusal line (exit 2) naming the repeated header, its line or the time going back",
                 "a logger that appends each trigger to the same file: a second `t,force,acc` header and a second "
                 "blow follow the first record, the time restarting; read as one record the time runs backwards, "
                 "so a lab expects the records split or a one-line refusal that points at the second header"),
    "swapped": ("csv-si", SWAP_WORDS, SWAP_WORDS + [r"\bforce", r"\bacceleration", r"\bacc\b", r"\bresponse"],
                "one refusal line (exit 2) that names the swap or a channel (force, acceleration); or a model with a "
                "warning of identify / validate naming the swap, the hammer blow or the impulse; a model without "
                "such a warning fails (its coefficients are meaningless)",
                "the cables of the hammer and the accelerometer were swapped at the DAQ (a classic bench mistake): "
                "the `force` column rings for seconds and the `acc` column is a short pulse; a lab expects the "
                "station to notice before it reports an equation of motion"),
}


def record_case(defect):
    """Identification with the true terms on the level-1 blow, validation on a 55-75 % blow, both written in
    the case's layout (``RECORDS``)."""
    fmt, words, refusal, rule, reason = RECORDS[defect]

    def make(rng, cid, out):
        sysd = system(rng, **MIDDLE, kind=["hardening", "softening"][rng.integers(2)])
        levels = [1.0, float(rng.uniform(0.55, 0.75))] + ([float(rng.uniform(0.75, 0.9))] if defect == "appended"
                                                          else [])
        files, meta = _captures(rng, cid, out, sysd, levels, fmt, chain={"gain": 1.0, "ppm": 0.0},
                                swap=defect == "swapped")
        if defect == "appended":  # the third blow appended to the first file, header and all
            with open(os.path.join(out, files[0]), "a") as fh, open(os.path.join(out, files[2])) as extra:
                fh.write(extra.read())
            os.remove(os.path.join(out, files.pop()))
        damp, stiff = draw.truth_terms(sysd)
        return {"files": {"fit": files[0], "held": files[1]}, "truth": {"mass": sysd["mass"], "damping": damp,
                "stiffness": stiff}, "given_mass": sysd["mass"], "system": sysd, "meta": meta, "defect": defect,
                "warn_words": words, "refusal_ok": refusal, "args": [],
                "must_flag": defect == "swapped", "rule": rule, "reason": reason, "limit_cpu_s": IDENT_LIMIT}
    make.__doc__ = reason
    return make


# ----------------------------------------------------------------------------- multi-channel (family M)
def _stiffness_matrix(n, links, grounds):
    """K of a chain: ``links[i]`` between mass i and i-1 (i = 0: the ground), ``grounds`` {i: k} extra springs
    from mass i to the ground."""
    K = np.zeros((n, n))
    for i, kv in enumerate(links):
        K[i, i] += kv
        if i > 0:
            K[i - 1, i - 1] += kv
            K[i, i - 1] -= kv
            K[i - 1, i] -= kv
    for i, kv in grounds.items():
        K[i, i] += kv
    return K


def _shapes(ms, K):
    from scipy.linalg import eigh
    return eigh(K, np.diag(ms))[1]


def _draw_chain(rng, n, masses, scale):
    """Masses and springs of a chain whose modes the driving point sees (each mode's amplitude there >= 0.3 of
    its largest), the driving point never mass 0. ``masses``: ``"spread"`` (the last mass 8-12.5 x lighter or
    heavier than the first), ``"close"`` (two masses each on a spring to the ground, a weak link: modes 1.08-1.25
    apart), else masses within 0.4-1.5 x of each other with modes >= 1.35 apart and away from 1:2 and 1:3."""
    (m0, m1), (f0, f1), _ = draw.SCALES[scale]
    for _ in range(2000):
        ms = [draw.loguni(rng, m0, m1)]
        if masses == "spread":
            r = draw.loguni(rng, 8.0, 12.5) ** (1.0 / (n - 1)) * rng.choice([-1, 1]) if n > 1 else 1.0
            for _ in range(n - 1):
                ms.append(ms[-1] * (abs(r) if r > 0 else 1 / abs(r)) * draw.loguni(rng, 0.9, 1.1))
        else:
            for _ in range(n - 1):
                ms.append(ms[-1] * draw.loguni(rng, 0.4, 1.5))
        f_target = draw.loguni(rng, f0, f1)
        grounds = {}
        if masses == "close":
            links = [ms[0] * (2 * np.pi * f_target) ** 2, 0.0]
            grounds = {1: ms[1] * (2 * np.pi * f_target * rng.uniform(1.02, 1.12)) ** 2}
            links[1] = links[0] * draw.loguni(rng, 0.02, 0.12)
        else:
            links = [ms[i] * (2 * np.pi * f_target) ** 2 * draw.loguni(rng, 0.4, 2.5) for i in range(n)]
        K = _stiffness_matrix(n, links, grounds)
        fr = physics.linear_freqs(ms, K)
        rs = [fr[i + 1] / fr[i] for i in range(n - 1)]
        d = int(rng.integers(1, n))
        sh = _shapes(ms, K)
        seen = min(abs(sh[d, r]) / np.abs(sh[:, r]).max() for r in range(n))
        if masses == "close":
            ok = 1.08 <= rs[0] <= 1.25
        else:
            ok = min(rs) > 1.35 and all(abs(r - q) > 0.12 for r in rs for q in (2.0, 3.0))
        if ok and seen >= 0.3:
            spread = max(ms) / min(ms)
            if masses != "spread" or 8.0 <= spread <= 14.0:
                return ms, links, grounds, K, fr, d
    raise RuntimeError("no chain drawn")


MIXED_WORDS = [r"\bvel", r"velocity", r"\bmix", r"quantit", r"\bkind", r"same (kind|quantity|sensor)",
               r"\bchannel"]


def _coupling_effect(system_lin, system_nl, p, fs, post, names, kinds):
    """Per channel, the nrmse between the held blow's clean signal (the channel's own quantity) with the nonlinear
    terms and without them."""
    t = np.arange(0, int(post * fs)) / fs
    pulse = [tuple(p[:3]) + (tuple(p[3]),)]
    q = [{"disp": 0, "vel": 1, "acc": 2}[k] for k in kinds]
    s_nl, s_li = physics.simulate(system_nl, pulse, t), physics.simulate(system_lin, pulse, t)
    a_nl = np.array([s_nl[q[i]][i] for i in range(len(names))])
    a_li = np.array([s_li[q[i]][i] for i in range(len(names))])
    after = t > 2 * p[1]
    return {n: float(np.sqrt(np.mean((a_nl[i, after] - a_li[i, after]) ** 2) / np.mean(a_nl[i, after] ** 2)))
            for i, n in enumerate(names)}


MDOF_RULES = {
    None: ("`none` (exit 0 or 1); `modal_coupling` FALSE-COUPLING, `unexplained` or another name FALSE-ALARM; "
           "every channel's held-out nrmse <= max(0.05, 2 x its noise nrmse)",
           "a linear chain with classical (stiffness-proportional) damping: nothing is missing from a linear "
           "modal model, so a lab expects the diagnosis to say nothing and the model to predict every channel"),
    "quadcubic": ("`modal_coupling` correct, `unexplained` abstains, `none` only when the nonlinear terms move "
                  "no channel of the held blow by more than 2 x its noise; unless `unexplained`, every channel's "
                  "held-out nrmse <= max(0.05, 2 x its noise nrmse)",
                  "the link between two masses carries a quadratic and a hardening cubic term (15-40 % and 10-25 % "
                  "of its linear force at the largest blow): a coupling term in physical coordinates that issue 14 "
                  "asks diagnose to name"),
    "cubic": ("as quadcubic", "a hardening cubic link between two masses (15-40 % of its linear force at the "
              "largest blow): a coupling term in physical coordinates that issue 14 asks diagnose to name"),
    "dashpot": ("as quadcubic", "a cubic dashpot on the link between two masses (at the largest blow's peak "
                "relative speed 3-8 x the linear dashpot's force): a nonlinear damping coupling B(q, q') of issue "
                "14 outside the rig's catalogue"),
    "ground-soft": ("`none` correct, `unexplained` abstains, `modal_coupling` FALSE-COUPLING; unless "
                    "`unexplained`, every channel's held-out nrmse <= max(0.05, 2 x its noise nrmse)",
                    "a softening cubic spring from one mass to the ground (8-15 % of its linear force at the "
                    "largest blow) is no coupling term in physical coordinates (docs/multi-dof.md: "
                    "`modal_coupling` only with a nonlinear coupling term); unseen9-10's rule for grounded springs"),
}


def mdof_case(n, coupling=None, masses=None, names="numbered", fmt="csv-si", via_h5=False, scale="kilograms",
              sensors=None):
    """A chain of ``n`` masses (``_draw_chain``) struck at a mass other than the first, every mass measured by
    an accelerometer, four captures (three to diagnose, one held out), no mass given. ``coupling``: None (linear),
    ``"quadcubic"`` quadratic + cubic terms on a link, ``"cubic"`` a hardening cubic link, ``"ground-soft"`` a
    softening cubic spring from mass 0 to the ground. ``names``: ``"numbered"`` acc1..accN, else labelled
    channels (``Acceleration NAME [unit]``). ``via_h5``: the scorer imports the four CSVs into one HDF5 session
    (no mass) and diagnoses / validates its captures. ``coupling`` ``"dashpot"``: a cubic dashpot on the link
    (its force at the largest blow's peak relative speed 3-8 x the linear dashpot's). ``sensors``: the kind of
    each channel (``["acc", "vel"]``: a laser vibrometer on the second mass), named ``acc1``, ``vel2``..."""
    def make(rng, cid, out):
        ms, links, grounds, K, fr, d = _draw_chain(rng, n, masses, scale)
        beta = 2 * draw.loguni(rng, 0.004, 0.015) / (2 * np.pi * fr[0])  # classical damping C = beta K
        laws = [{"law": "poly", "i": i, "j": i - 1, "k": {1: kv}, "c": {1: beta * kv}} for i, kv in enumerate(links)
                if kv > 0]
        laws += [{"law": "poly", "i": i, "j": -1, "k": {1: kv}, "c": {1: beta * kv}} for i, kv in grounds.items()]
        lin = physics.System(ms, [dict(L, k=dict(L["k"])) for L in laws], drive=d)
        f_hi = max(fr)
        fs = draw.pick_rate(rng, f_hi)
        zeta1 = beta * 2 * np.pi * fr[0] / 2
        X = draw.loguni(rng, *draw.SCALES[scale][2])
        sysd = {"mass": ms[d], "fn_hz": fr[0], "X_ref": X}
        levels = [1.0] + list(rng.uniform(0.5, 0.95, 3))
        levels = [levels[i] for i in rng.permutation(4)]
        p1, tip = draw.hammer(rng, sysd, f_hi, 1.0, width_frac=0.1, tip="plastic", fs=fs)
        link = min(1, n - 1) if coupling in ("quadcubic", "cubic", "dashpot") else None
        if coupling == "quadcubic" and n > 2:
            link = int(rng.integers(1, n))
        if coupling:
            tp = np.arange(0, int(6 / fr[0] * fs)) / fs
            xp, vp = physics.simulate(lin, [tuple(p1[:3]) + (tuple(p1[3]),)], tp)[:2]
            L = laws[link] if link is not None else laws[0]
            s = np.abs(xp[L["i"]] - (xp[L["j"]] if L["j"] >= 0 else 0.0)).max()
            k1 = L["k"][1]
            if coupling == "dashpot":
                sd = np.abs(vp[L["i"]] - vp[L["j"]]).max()
                L["c"] = {1: L["c"][1], 3: float(L["c"][1] * rng.uniform(3.0, 8.0) / sd ** 2)}
            elif coupling == "quadcubic":
                L["k"] = {1: k1, 2: float(rng.choice([-1, 1]) * k1 * rng.uniform(0.15, 0.4) / s),
                          3: float(k1 * rng.uniform(0.1, 0.25) / s ** 2)}
            elif coupling == "cubic":
                L["k"] = {1: k1, 3: float(k1 * rng.uniform(0.15, 0.4) / s ** 2)}
            else:  # ground-soft: laws[0] is mass 0's spring to the ground
                L["k"] = {1: k1, 3: float(-k1 * rng.uniform(0.08, 0.15) / s ** 2)}
        system_ = physics.System(ms, laws, drive=d)
        kinds = sensors or ["acc"] * n
        if names == "numbered":
            cols = [f"{kinds[i]}{i + 1}" for i in range(n)]
        else:
            cols = ["acc_" + x for x in rng.choice(["base", "tip", "hub", "rim", "deck", "arm", "cab"], n,
                                                   replace=False)]
        pre, post = draw.timing(rng, fr[0], zeta1, fs, max_samples=30000)
        files, noise = [], []
        for c, s in enumerate(draw.sessions(rng, 4, snr=(40.0, 55.0))):
            s["names"] = cols
            s["sensors"] = kinds
            p, tip = draw.hammer(rng, sysd, f_hi, levels[c], width_frac=rng.uniform(0.05, 0.15), tip=tip, fs=fs)
            t, ch = draw.record(rng, system_, [p], fs, pre, post, s)
            noise.append(s["noise_nrmse_ch"])
            files.append(os.path.basename(formats.write(os.path.join(out, f"{cid}-{c}"), fmt, t, ch, rng)))
        effect = _coupling_effect(lin, system_, p, fs, post, cols, kinds) if coupling else {}
        rule, reason = MDOF_RULES[coupling]
        if coupling in ("cubic", "dashpot"):
            rule = MDOF_RULES["quadcubic"][0]
        if sensors:
            rule += ("; or one refusal line (exit 2) naming the mixed channel kinds (docs/multi-dof.md does not "
                     "promise a mix)")
            reason += ("; an accelerometer on one mass and a laser vibrometer (velocity) on the other, the usual "
                       "way to spare a light part a sensor's mass")
        reason += {"spread": "; the masses 8-14 x apart", "close": "; two modes 1.08-1.25 apart (a weak link between "
                   "two masses each on a spring to the ground)"}.get(masses, "")
        return {"files": {"train": files[:3], "held": files[3]}, "all_files": files, "driving_point": cols[d],
                "columns": cols, "coupling_effect_nrmse": effect, "freqs_hz": fr, "masses": ms, "laws": laws,
                "fs": fs, "coupling": coupling, "link": link, "gyro": False, "noise_nrmse": noise, "sensor": "acc",
                "sensors": kinds, "fmt": fmt, "via_h5": via_h5, "refusal_ok": MIXED_WORDS if sensors else None,
                "rule": rule, "reason": reason,
                "limit_cpu_s": MDOF_LIMIT, "levels": levels}
    return make


CASES = [
    ("mdof-2quad", "mdof", mdof_case(2, "quadcubic"), True),
    ("mdof-2groundsoft-h5", "mdof", mdof_case(2, "ground-soft", names="labelled", fmt="csv-export", via_h5=True),
     True),
    ("mdof-2spread-cubic", "mdof", mdof_case(2, "cubic", masses="spread", names="labelled", fmt="csv-reordered"),
     True),
    ("mdof-2close-lin", "mdof", mdof_case(2, None, masses="close", names="labelled", fmt="csv-reordered"), True),
    ("mdof-3spread-lin-h5", "mdof", mdof_case(3, None, masses="spread", via_h5=True), True),
    ("mdof-2close-cubic", "mdof", mdof_case(2, "cubic", masses="close"), True),
    ("mdof-2spread-lin-h5", "mdof", mdof_case(2, None, masses="spread", names="labelled", fmt="csv-export",
                                              via_h5=True), True),
    ("mdof-2dashpot", "mdof", mdof_case(2, "dashpot", names="labelled", fmt="csv-export"), True),
    ("mdof-2mixed-quad", "mdof", mdof_case(2, "quadcubic", sensors=["acc", "vel"]), True),
    ("mdof-3quad", "mdof", mdof_case(3, "quadcubic", names="labelled", fmt="csv-export"), False),
    ("mdof-3groundsoft", "mdof", mdof_case(3, "ground-soft", masses="spread", fmt="csv-reordered",
                                           names="labelled"), False),
    ("rec-lvm", "record", record_case("lvm"), True),
    ("rec-sample", "record", record_case("sample"), True),
    ("rec-sampletime", "record", record_case("sampletime"), True),
    ("rec-counts", "record", record_case("counts"), True),
    ("rec-matint16", "record", record_case("matint16"), True),
    ("rec-german", "record", record_case("german"), True),
    ("rec-reordered", "record", record_case("reordered"), True),
    ("rec-swapped", "record", record_case("swapped"), True),
    ("rec-thousands", "record", record_case("thousands"), True),
    ("rec-appended", "record", record_case("appended"), True),
    ("rec-micro", "record", record_case("micro"), True),
]
