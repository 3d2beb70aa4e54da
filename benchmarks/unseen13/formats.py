"""Sensor chains and the files other tools write (nothing imported from the station; unseen6-11's, extended).

Chain (``measure``): the DAQ samples the true signal at its own clock (``ppm`` off the stamped rate),
through an optional first-order AC coupling (IEPE conditioner), a sensitivity error (``gain``, which
may drift linearly over the record), white noise at ``snr_db`` below the signal's peak after the
trigger, an optional clipping level (the conditioner's output stage) and quantisation to ``bits``
over a full scale ``range_x`` times the record's peak.

Files (``write``): ``csv-si`` (the station's own ``t,force,acc``), ``csv-export`` (a logger export:
``#`` notes, a ``Time [ms]`` column, force in kN or N, acceleration in g or mm/s^2, velocity in mm/s,
displacement in mm or um; tab or semicolon delimiters with a decimal comma), ``uff58`` (pyuff, one
load case, ordinate types 13/12/11/8, unit labels) and ``mat`` (scipy.io.savemat: ``fs`` and channel
variables, or one struct).
"""

from __future__ import annotations

import os

import numpy as np
from scipy import signal

G = 9.80665
Q_NAMES = {"acc": "Acceleration", "vel": "Velocity", "disp": "Displacement"}
UNIT_CHOICES = {"acc": [("m/s^2", 1.0), ("g", G), ("mm/s^2", 1e-3)], "vel": [("m/s", 1.0), ("mm/s", 1e-3)],
                "disp": [("m", 1.0), ("mm", 1e-3), ("um", 1e-6)], "force": [("N", 1.0), ("kN", 1e3)]}
UFF_TYPE = {"force": 13, "acc": 12, "vel": 11, "disp": 8}


def highpass(y, fs, corner_hz):
    """First-order AC coupling s / (s + wc), bilinear (the corner pre-warped)."""
    if not corner_hz:
        return y
    b, a = signal.bilinear([1.0, 0.0], [1.0, 2 * np.pi * corner_hz], fs=fs)
    return signal.lfilter(b, a, y)


def resonance(y, fs, mount):
    """An accelerometer's own mounted resonance (a second-order low-pass ``wr^2 / (s^2 + 2 z wr s + wr^2)``,
    flat below it, a peak of about 1 / (2 z) at it), bilinear with the resonance pre-warped."""
    if not mount:
        return y
    fr, z = mount
    wr = 2 * fs * np.tan(np.pi * fr / fs)  # pre-warped: the digital filter resonates at fr
    b, a = signal.bilinear([wr * wr], [1.0, 2 * z * wr, wr * wr], fs=fs)
    return signal.lfilter(b, a, y)


def lowpass(y, fs, aa):
    """The DAQ's anti-alias filter. ``aa``: ("butter", order, corner Hz) an analogue-style Butterworth (minimum
    phase, its delay not compensated) or ("fir", taps, corner Hz) a sigma-delta converter's linear-phase FIR whose
    group delay the DAQ takes out of the time stamps (zero phase: it rings before a sharp edge)."""
    if not aa:
        return y
    kind, n, fc = aa
    if kind == "butter":
        sos = signal.butter(int(n), fc, fs=fs, output="sos")
        return signal.sosfilt(sos, y)
    h = signal.firwin(int(n) | 1, fc, fs=fs)
    return np.convolve(y, h, mode="same")


def measure(y, fs, rng, snr_db, bits=24, range_x=2.0, gain=1.0, gain_drift=0.0, hp_hz=0.0, clip=None,
            peak=None, hum=None, step=None, mount=None, xtalk=None, sat=None, lsb=None, aa=None, hp2_hz=0.0,
            drift=None, dropout=None, settle=None, spikes=None):
    """One channel through the chain (see the module docstring). ``peak``: the level the SNR refers to.
    ``hum``: (amplitude, mains Hz, phase) - mains pickup with a third harmonic at a third of it;
    ``step``: (amplitude, sample index) - a DC offset that steps there (a conditioner's range switch).
    Eleventh set: ``mount`` (Hz, damping ratio) the sensor's mounted resonance; ``xtalk`` a signal added in the
    conditioner (the hammer channel's cross-talk); ``sat`` the level of the amplifier's soft saturation
    ``sat tanh(y / sat)``; ``lsb`` an absolute quantisation step (a displacement laser's resolution).
    Eleventh set: ``aa`` the anti-alias filter (``lowpass``), ``hp2_hz`` a second first-order high-pass (the
    sensor's own and the charge amplifier's), ``drift`` (ramp, bow) amplitudes of a slow offset over the record
    (a charge amplifier's leakage drift, a warming sensor)."""
    y = resonance(np.asarray(y, float), fs, mount)
    y = highpass(y, fs, hp_hz)
    y = highpass(y, fs, hp2_hz)
    y = lowpass(y, fs, aa)
    ramp = np.linspace(0.0, 1.0, len(y))
    y = y * gain * (1.0 + gain_drift * ramp)
    ref = peak if peak is not None else np.abs(y).max()
    if hum is not None:
        tt = np.arange(len(y)) / fs
        y = y + hum[0] * (np.sin(2 * np.pi * hum[1] * tt + hum[2]) + np.sin(6 * np.pi * hum[1] * tt + 2 * hum[2]) / 3)
    if step is not None:
        y = y + step[0] * (np.arange(len(y)) >= step[1])
    if drift is not None:
        s = np.linspace(0.0, 1.0, len(y))
        y = y + drift[0] * s + drift[1] * (4 * s * (1 - s))
    if xtalk is not None:
        y = y + xtalk
    if settle is not None:  # thirteenth set: a charge amplifier overdriven by the blow settles back slowly
        amp, tau, start = settle
        kk = np.arange(len(y)) - start
        y = y + np.where(kk >= 0, amp * np.exp(-np.maximum(kk, 0) / (tau * fs)), 0.0)
    if spikes is not None:  # thirteenth set: a whipping cable's triboelectric glitches (a short bipolar pulse)
        for at, amp, width in spikes:
            w = max(int(width), 2)
            y[at:at + w] += amp * np.sin(np.linspace(0, 2 * np.pi, w, endpoint=False))[:len(y[at:at + w])]
    y = y + rng.normal(0.0, ref * 10 ** (-snr_db / 20), len(y))
    if sat is not None:
        y = sat * np.tanh(y / sat)
    if clip is not None:
        y = np.clip(y, -clip, clip)
    if dropout is not None:  # a laser vibrometer losing its speckle: its decoder outputs zero for a few samples
        for start, length, value in dropout:
            y[start:start + length] = value
    if lsb is None:
        full = range_x * max(np.nanmax(np.abs(y)), 1e-30)
        lsb = 2 * full / 2 ** bits
    return np.round(y / lsb) * lsb


def _fmt(vals, comma):
    s = [f"{v:.9g}" for v in vals]
    return [x.replace(".", ",") for x in s] if comma else s


def write(path_base, fmt, t, channels, rng):
    """Write a record; returns the file name. ``channels``: ordered dict name -> SI values, names
    ``force`` and response names (``acc``, ``vel``, ``disp``, or ``acc_NAME``)."""
    if fmt == "csv-si":
        path = path_base + ".csv"
        cols = ["t"] + list(channels)
        data = np.column_stack([t] + list(channels.values()))
        np.savetxt(path, data, delimiter=",", header=",".join(cols), comments="", fmt="%.10g")
        return path
    if fmt == "csv-export":
        return _export(path_base, t, channels, rng)
    if fmt == "csv-export-jitter":
        return _export(path_base, t, channels, rng, jitter=True)
    if fmt == "uff58":
        return _uff(path_base, t, channels, rng)
    if fmt == "mat":
        return _mat(path_base, t, channels, rng)
    if fmt == "csv-unitsrow":
        return _unitsrow(path_base, t, channels, rng)
    if fmt == "csv-g-unlabelled":  # a logger that writes g under the station's SI header
        path = path_base + ".csv"
        cols = ["t"] + list(channels)
        data = np.column_stack([t] + [v / G if k == "acc" else v for k, v in channels.items()])
        np.savetxt(path, data, delimiter=",", header=",".join(cols), comments="", fmt="%.10g")
        return path
    if fmt == "csv-roundtime":  # time stamps rounded by a spreadsheet to the decade below a tenth of a period
        path = path_base + ".csv"
        d = int(np.ceil(np.log10(10.0 / float(t[1] - t[0]))))
        lines = ["t,force," + ",".join(list(channels)[1:])]
        data = np.column_stack(list(channels.values()))
        lines += [f"{tt:.{d}f}," + ",".join(f"{v:.9g}" for v in row) for tt, row in zip(t, data)]
        with open(path, "w") as fh:
            fh.write("\n".join(lines) + "\n")
        return path
    if fmt == "csv-lab":
        return _lab(path_base, t, channels, rng)
    if fmt == "mat73":
        return _mat73(path_base, t, channels, rng)
    if fmt == "csv-imperial":
        return _imperial(path_base, t, channels, rng)
    if fmt == "uff-mixed":
        return _uff_mixed(path_base, t, channels, rng)
    if fmt.startswith("csv-real"):
        return _real(path_base, t, channels, rng, jitter="jitter" in fmt)
    if fmt in TWELFTH:
        return TWELFTH[fmt](path_base, t, channels, rng)
    raise ValueError(fmt)


def _real(path_base, t, channels, rng, jitter=False):
    """A record as a lab's acquisition software writes it (eleventh set): a block of quoted ``"key";"value"``
    metadata lines (no comment sign: instrument, channel sensitivities, the rate), a blank line, names with
    units in brackets, semicolons, decimal commas; force in N, acceleration in g, velocity in mm/s,
    displacement in um. ``jitter``: the time column is the logger's own time stamp of each sample, read from a
    clock with 1-4 % of a sample period of jitter and printed with 7 significant digits (not a uniform grid)."""
    path = path_base + ".csv"
    tt = np.asarray(t, float)
    dt = float(tt[1] - tt[0])
    if jitter:
        tt = tt + rng.normal(0.0, rng.uniform(0.01, 0.04) * dt, len(tt))
    heads, cols = ["Time [s]"], [tt]
    for name, y in channels.items():
        q = _quantity(name)
        unit, fac = {"force": ("N", 1.0), "acc": ("g", G), "vel": ("mm/s", 1e-3), "disp": ("um", 1e-6)}[q]
        label = "Force" if q == "force" else Q_NAMES[q]
        if "_" in name:
            label = f"{label} {name.split('_', 1)[1]}"
        heads.append(f"{label} [{unit}]")
        cols.append(np.asarray(y) / fac)
    meta = ['"Instrument";"DAQ-8 S/N 41%03d"' % rng.integers(1000), '"Test";"hammer impact, point 3 +Z"',
            '"Start";"2026-11-24 09:%02d:%02d"' % (rng.integers(60), rng.integers(60)),
            f'"Sample rate [Hz]";"{1.0 / dt:.6g}"'.replace(".", ","), f'"Samples";"{len(tt)}"',
            '"Force sensitivity";"2,25 mV/N"', '"Response sensitivity";"%s"' % ("10,2 mV/g" if "Acc" in heads[-1]
                                                                              else "5 mm/s/V"), ""]
    lines = meta + [";".join(heads)]
    fmt7 = (lambda v: f"{v:.7g}") if jitter else (lambda v: f"{v:.9g}")
    for row in np.column_stack(cols):
        lines.append(";".join([fmt7(row[0]).replace(".", ",")] + _fmt(row[1:], True)))
    with open(path, "w") as fh:
        fh.write("\n".join(lines) + "\n")
    return path


def _lab(path_base, t, channels, rng):
    """A bench DAQ's export as it leaves a Windows PC: UTF-8 with a byte-order mark, CRLF line ends, a block of
    ``key;value`` lines (no comment sign) and a blank line before the names, a units row under them,
    semicolons, decimal commas, the time in ms from the start of the record (not from the trigger)."""
    path = path_base + ".csv"
    heads, units, cols = ["Time"], ["[ms]"], [(np.asarray(t) - t[0]) * 1e3]
    for name, y in channels.items():
        q = _quantity(name)
        unit, fac = {"force": ("N", 1.0), "acc": ("m/s^2", 1.0), "vel": ("mm/s", 1e-3), "disp": ("um", 1e-6)}[q]
        heads.append("Force" if q == "force" else Q_NAMES[q])
        units.append(f"[{unit}]")
        cols.append(np.asarray(y) / fac)
    fs = 1.0 / float(t[1] - t[0])
    meta = [f"Title;Impact bench {rng.integers(1, 9)}", "Operator;LB", "Date;24.11.2026", "Time of day;10:41:07",
            f"Sample rate;{fs:.6g}".replace(".", ","), f"Channels;{len(channels)}",
            f"Pretrigger samples;{int(np.sum(np.asarray(t) < 0))}", ""]
    lines = meta + [";".join(heads), ";".join(units)]
    lines += [";".join(_fmt(row, True)) for row in np.column_stack(cols)]
    with open(path, "w", encoding="utf-8-sig", newline="") as fh:
        fh.write("\r\n".join(lines) + "\r\n")
    return path


def _mat73(path_base, t, channels, rng):
    """MATLAB's -v7.3 format (HDF5 behind a 512-byte MAT header): ``fs`` and one column vector per channel,
    each ``double`` with its ``MATLAB_class`` attribute, as MATLAB writes them (an N x 1 vector is stored
    1 x N)."""
    import h5py

    path = path_base + ".mat"
    long = {"acc": "acceleration", "vel": "velocity", "disp": "displacement", "force": "force"}
    with h5py.File(path, "w", userblock_size=512) as h:
        def put(name, arr):
            ds = h.create_dataset(name, data=np.asarray(arr, float).reshape(1, -1))
            ds.attrs["MATLAB_class"] = np.bytes_(b"double")
        put("fs", [1.0 / float(t[1] - t[0])])
        for name, y in channels.items():
            put(long.get(name, name), y)
    head = b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Tue Nov 24 10:41:07 2026 HDF5 schema 1.00 ."
    head = head.ljust(116, b" ") + b"\x00" * 8 + b"\x00\x02" + b"IM"
    with open(path, "r+b") as fh:
        fh.write(head.ljust(512, b"\x00"))
    return path


def _unitsrow(path_base, t, channels, rng):
    """A DAQ-software export: names on one row, units on the next (``[s];[N];[g]``), semicolons, decimal comma."""
    path = path_base + ".csv"
    heads, units, cols = ["Time"], ["[s]"], [np.asarray(t)]
    for name, y in channels.items():
        q = _quantity(name)
        unit, fac = {"force": ("N", 1.0), "acc": ("g", G), "vel": ("mm/s", 1e-3), "disp": ("mm", 1e-3)}[q]
        heads.append("Force" if q == "force" else Q_NAMES[q])
        units.append(f"[{unit}]")
        cols.append(np.asarray(y) / fac)
    lines = [";".join(heads), ";".join(units)]
    lines += [";".join(_fmt(row, True)) for row in np.column_stack(cols)]
    with open(path, "w") as fh:
        fh.write("\n".join(lines) + "\n")
    return path


def _quantity(name):
    return "force" if name == "force" else name.split("_")[0].rstrip("0123456789")


def _export(path_base, t, channels, rng, jitter=False):
    """A logger's export (``#`` notes, ``Time [ms]``, tab or semicolon, decimal commas, units in brackets).
    ``jitter`` (eleventh set): the time column is the logger's own stamp of each sample, read from a clock with
    1-4 % of a sample period of jitter and printed with 7 significant digits (not a uniform grid)."""
    delim = ["\t", ";"][rng.integers(2)]
    comma = True
    path = path_base + (".tsv" if delim == "\t" else ".txt" if rng.random() < 0.5 else ".csv")
    tt = np.asarray(t, float)
    if jitter:
        tt = tt + rng.normal(0.0, rng.uniform(0.01, 0.04) * float(tt[1] - tt[0]), len(tt))
    heads, cols = ["Time [ms]"], [tt * 1e3]
    for name, y in channels.items():
        q = _quantity(name)
        unit, fac = UNIT_CHOICES[q][rng.integers(len(UNIT_CHOICES[q]))]
        label = "Force" if q == "force" else Q_NAMES[q]
        if "_" in name:
            label = f"{label} {name.split('_', 1)[1]}"
        heads.append(f"{label} [{unit}]")
        cols.append(np.asarray(y) / fac)
    lines = [f"# exported by logger unit {rng.integers(1, 99)}", f"# sample rate {1 / (t[1] - t[0]):.6g} Hz",
             delim.join(heads)]
    data = np.column_stack(cols)
    if jitter:
        lines += [delim.join([f"{row[0]:.7g}".replace(".", ",")] + _fmt(row[1:], comma)) for row in data]
    else:
        lines += [delim.join(_fmt(row, comma)) for row in data]
    with open(path, "w") as fh:
        fh.write("\n".join(lines) + "\n")
    return path


def _uff(path_base, t, channels, rng):
    import pyuff

    path = path_base + (".uff" if rng.random() < 0.5 else ".unv")
    binary = int(rng.random() < 0.5)
    sets = []
    for k, (name, y) in enumerate(channels.items()):
        q = _quantity(name)
        unit, fac = UNIT_CHOICES[q][rng.integers(len(UNIT_CHOICES[q]))] if q != "force" else ("N", 1.0)
        sets.append(pyuff.prepare_58(
            binary=binary, id1=f"{name} test", id2="unseen13", id3="NONE", id4="NONE", id5="NONE", func_type=1,
            load_case_id=1, rsp_ent_name="spec", rsp_node=k + 1, rsp_dir=3, ref_ent_name="spec", ref_node=1,
            ref_dir=3, abscissa_spacing=1, abscissa_spec_data_type=17, abscissa_axis_units_lab="s",
            ordinate_spec_data_type=UFF_TYPE[q], ordinate_axis_units_lab=unit, orddenom_spec_data_type=0,
            ordinate_len_unit_exp=0 if q == "force" else 1, ordinate_force_unit_exp=1 if q == "force" else 0,
            x=np.asarray(t, float), data=np.asarray(y, float) / fac))
    if os.path.exists(path):
        os.remove(path)
    pyuff.UFF(path).write_sets(sets, mode="add")  # pyuff's "overwrite" writes binary sets it cannot read back
    return path


def _mat(path_base, t, channels, rng):
    from scipy.io import savemat

    path = path_base + ".mat"
    fs = 1.0 / float(t[1] - t[0])
    long = {"acc": "acceleration", "vel": "velocity", "disp": "displacement", "force": "force"}
    rec = {}
    if rng.random() < 0.5:
        rec["fs"] = fs
    else:
        rec["time"] = np.asarray(t, float)
    for name, y in channels.items():
        rec[long[name] if name in long else name] = np.asarray(y, float)
    if rng.random() < 0.5:
        savemat(path, {"impact": rec}, do_compression=bool(rng.random() < 0.5))
    else:
        savemat(path, rec)
    return path


LBF = 4.4482216152605  # N
INCH = 0.0254  # m


def _imperial(path_base, t, channels, rng):
    """A US lab's export: force in lbf, acceleration in in/s^2 or g, velocity in in/s, displacement in mils or in;
    semicolons and a decimal comma (the PC's regional setting), ``Time [s]``."""
    path = path_base + ".csv"
    heads, cols = ["Time [s]"], [np.asarray(t)]
    for name, y in channels.items():
        q = _quantity(name)
        unit, fac = {"force": [("lbf", LBF)], "acc": [("in/s^2", INCH), ("g", G)], "vel": [("in/s", INCH)],
                     "disp": [("in", INCH), ("mil", INCH * 1e-3)]}[q][rng.integers(2 if q in ("acc", "disp") else 1)]
        label = "Force" if q == "force" else Q_NAMES[q]
        if "_" in name:
            label = f"{label} {name.split('_', 1)[1]}"
        heads.append(f"{label} [{unit}]")
        cols.append(np.asarray(y) / fac)
    lines = [";".join(heads)] + [";".join(_fmt(row, True)) for row in np.column_stack(cols)]
    with open(path, "w") as fh:
        fh.write("\n".join(lines) + "\n")
    return path


def _uff_mixed(path_base, t, channels, rng):
    """UFF58 as a modal analyser writes it: ASCII, force in kN (ordinate label ``kN``), the response in g or
    mm/s^2, node numbers of the test geometry (101, 2xx) and the direction -3 (the sensor on its head)."""
    import pyuff

    path = path_base + ".unv"
    sets = []
    for k, (name, y) in enumerate(channels.items()):
        q = _quantity(name)
        unit, fac = ("kN", 1e3) if q == "force" else UNIT_CHOICES[q][1 + rng.integers(len(UNIT_CHOICES[q]) - 1)]
        sets.append(pyuff.prepare_58(
            binary=0, id1=f"Point {201 + k} {Q_NAMES.get(q, 'Force')}", id2="run 3", id3="NONE", id4="NONE",
            id5="NONE", func_type=1, load_case_id=3, rsp_ent_name="bench", rsp_node=101 if q == "force" else 201 + k,
            rsp_dir=-3, ref_ent_name="bench", ref_node=101, ref_dir=-3, abscissa_spacing=1,
            abscissa_spec_data_type=17, abscissa_axis_units_lab="s", ordinate_spec_data_type=UFF_TYPE[q],
            ordinate_axis_units_lab=unit, orddenom_spec_data_type=0,
            ordinate_len_unit_exp=0 if q == "force" else 1, ordinate_force_unit_exp=1 if q == "force" else 0,
            x=np.asarray(t, float), data=np.asarray(y, float) / fac))
    if os.path.exists(path):
        os.remove(path)
    pyuff.UFF(path).write_sets(sets, mode="add")
    return path


# ----------------------------------------------------------------------------- twelfth set: other DAQs' files
def _unit_of(name, table):
    q = _quantity(name)
    return q, table[q]


def _label(name, q, names=None):
    names = names or {"force": "Force", **Q_NAMES}
    lab = names[q]
    return f"{lab} {name.split('_', 1)[1]}" if "_" in name else lab


def _lvm(path_base, t, channels, rng):
    """A LabVIEW Measurement file (``.lvm``, "Write to Measurement File" express VI, one header per segment):
    a file header and a segment header, each closed by ``***End_of_Header***``, tab-separated, ``X_Value`` the
    time from the start of the record [s] (``X_Columns One``), one column per channel named by the channel's
    label (no units: LabVIEW's scaling already gave N and m/s^2), a trailing empty ``Comment`` column."""
    path = path_base + ".lvm"
    tt = np.asarray(t, float) - float(t[0])
    dt = float(t[1] - t[0])
    labels = {"force": "Force", "acc": "Accel", "vel": "Velocity", "disp": "Displacement"}
    heads = [labels[_quantity(n)] + (f" {n.split('_', 1)[1]}" if "_" in n else "") for n in channels]
    nch = len(channels)
    tab = "\t"
    lines = ["LabVIEW Measurement\t", "Writer_Version\t2", "Reader_Version\t2", "Separator\tTab",
             "Decimal_Separator\t.", "Multi_Headings\tNo", "X_Columns\tOne", "Time_Pref\tRelative",
             "Operator\tlab", "Date\t2026/11/24", "Time\t10:41:%02d.%03d" % (rng.integers(60), rng.integers(1000)),
             "***End_of_Header***\t", "\t",
             "Channels\t" + tab.join([str(nch)] + [""] * (nch - 1)) + "\t",
             "Samples\t" + tab.join([str(len(tt))] * nch) + "\t",
             "Date\t" + tab.join(["2026/11/24"] * nch) + "\t",
             "Time\t" + tab.join(["10:41:07.000"] * nch) + "\t",
             "X_Dimension\t" + tab.join(["Time"] * nch) + "\t",
             "X0\t" + tab.join(["0.0000000000000000E+0"] * nch) + "\t",
             "Delta_X\t" + tab.join([f"{dt:.16E}"] * nch) + "\t",
             "***End_of_Header***\t",
             "X_Value\t" + tab.join(heads) + "\tComment"]
    data = np.column_stack([tt] + list(channels.values()))
    lines += [tab.join(f"{v:.9g}" for v in row) for row in data]
    with open(path, "w", newline="") as fh:
        fh.write("\r\n".join(lines) + "\r\n")
    return path


def _samples(path_base, t, channels, rng, with_time=False):
    """A DAQ's export whose first column is the sample number (``Sample``, from 0 at the record's first row),
    the rate stated in a ``#`` note only; ``with_time`` adds the time [s] as a second column (both kept)."""
    path = path_base + ".csv"
    fs = 1.0 / float(t[1] - t[0])
    heads = ["Sample"] + (["Time [s]"] if with_time else [])
    cols = [np.arange(len(t), dtype=float)] + ([np.asarray(t, float)] if with_time else [])
    for name, y in channels.items():
        q = _quantity(name)
        heads.append(f"{_label(name, q)} [{'N' if q == 'force' else {'acc': 'm/s^2', 'vel': 'm/s', 'disp': 'm'}[q]}]")
        cols.append(np.asarray(y, float))
    lines = ["# recorder export, channel group 1", f"# sample rate: {fs:.6g} Hz", ",".join(heads)]
    for row in np.column_stack(cols):
        lines.append(",".join([str(int(row[0]))] + [f"{v:.9g}" for v in row[1:]]))
    with open(path, "w") as fh:
        fh.write("\n".join(lines) + "\n")
    return path


def to_counts(y, rng, bits=16, range_x=(1.3, 2.5)):
    """Signed integer ADC counts of a channel and the scale [SI per count] over a full scale of ``range_x``
    times its peak (the record's own quantisation is kept: counts * scale reproduces it to the last bit)."""
    full = float(rng.uniform(*range_x)) * float(np.abs(y).max())
    scale = 2 * full / 2 ** bits
    c = np.clip(np.round(np.asarray(y, float) / scale), -2 ** (bits - 1), 2 ** (bits - 1) - 1)
    return c.astype(np.int64), scale


def _counts(path_base, t, channels, rng):
    """A raw export of a 16-bit DAQ: every channel as integer counts (``[counts]`` in the header), the scale of
    each channel (SI per count) in a ``#`` note above the names, as the DAQ's software documents it."""
    path = path_base + ".csv"
    heads, cols, notes = ["Time [s]"], [np.asarray(t, float)], []
    for name, y in channels.items():
        q = _quantity(name)
        c, sc = to_counts(y, rng)
        unit = {"force": "N", "acc": "m/s^2", "vel": "m/s", "disp": "m"}[q]
        heads.append(f"{_label(name, q)} [counts]")
        notes.append(f"# scale {_label(name, q)}: {sc:.9g} {unit}/count")
        cols.append(c)
    lines = ["# raw export (int16), 16-bit DAQ", f"# sample rate: {1 / float(t[1] - t[0]):.6g} Hz"] + notes
    lines.append(",".join(heads))
    for row in zip(*cols):
        lines.append(",".join([f"{row[0]:.9g}"] + [str(int(v)) for v in row[1:]]))
    with open(path, "w") as fh:
        fh.write("\n".join(lines) + "\n")
    return path


def _mat_int16(path_base, t, channels, rng):
    """A MATLAB file of raw DAQ data: ``Fs`` and each channel as an int16 vector (``force``, ``acc``...) with
    its scale [SI per count] in a double ``force_scale``, ``acc_scale`` (the acquisition toolbox's raw mode)."""
    from scipy.io import savemat

    path = path_base + ".mat"
    rec = {"Fs": 1.0 / float(t[1] - t[0])}
    for name, y in channels.items():
        c, sc = to_counts(y, rng)
        rec[name] = c.astype(np.int16)
        rec[f"{name}_scale"] = float(sc)
    savemat(path, rec)
    return path


def _german(path_base, t, channels, rng):
    """A German-language DAQ export: ``Zeit [ms]``, ``Kraft [N]``, ``Beschleunigung [m/s^2]`` / ``Geschwindigkeit
    [mm/s]``, semicolons, decimal commas, no notes."""
    path = path_base + ".csv"
    names = {"force": "Kraft", "acc": "Beschleunigung", "vel": "Geschwindigkeit", "disp": "Weg"}
    units = {"force": ("N", 1.0), "acc": ("m/s^2", 1.0), "vel": ("mm/s", 1e-3), "disp": ("mm", 1e-3)}
    heads, cols = ["Zeit [ms]"], [np.asarray(t, float) * 1e3]
    for name, y in channels.items():
        q = _quantity(name)
        u, fac = units[q]
        heads.append(f"{_label(name, q, names)} [{u}]")
        cols.append(np.asarray(y, float) / fac)
    lines = [";".join(heads)] + [";".join(_fmt(row, True)) for row in np.column_stack(cols)]
    with open(path, "w", encoding="utf-8") as fh:
        fh.write("\n".join(lines) + "\n")
    return path


def _reordered(path_base, t, channels, rng):
    """The response channels first and the force last (``Time [s],Acceleration [g],Force [N]``; several
    responses in a shuffled order), comma-delimited, decimal points: names in the header say which is which."""
    path = path_base + ".csv"
    order = [n for n in channels if n != "force"]
    order = [order[i] for i in rng.permutation(len(order))] + ["force"]
    units = {"force": ("N", 1.0), "acc": ("g", G), "vel": ("mm/s", 1e-3), "disp": ("mm", 1e-3)}
    heads, cols = ["Time [s]"], [np.asarray(t, float)]
    for name in order:
        q = _quantity(name)
        u, fac = units[q]
        heads.append(f"{_label(name, q)} [{u}]")
        cols.append(np.asarray(channels[name], float) / fac)
    lines = [",".join(heads)] + [",".join(f"{v:.9g}" for v in row) for row in np.column_stack(cols)]
    with open(path, "w") as fh:
        fh.write("\n".join(lines) + "\n")
    return path


def _thousands(v, decimals):
    """A number as a German spreadsheet prints it: ``.`` between thousands, ``,`` before the decimals."""
    txt = f"{abs(v):,.{decimals}f}".replace(",", "_").replace(".", ",").replace("_", ".")
    return ("-" if v < 0 and float(f"{abs(v):.{decimals}f}") != 0 else "") + txt


def _spreadsheet(path_base, t, channels, rng):
    """A record saved from a spreadsheet in a German locale: semicolons, decimal commas and a ``.`` between
    thousands (``35.123,456``), fixed decimals; force in mN and acceleration in mm/s^2 (so that the large values
    carry the separators), time in s."""
    path = path_base + ".csv"
    units = {"force": ("mN", 1e-3), "acc": ("mm/s^2", 1e-3), "vel": ("mm/s", 1e-3), "disp": ("um", 1e-6)}
    heads, cols, dec = ["Time [s]"], [np.asarray(t, float)], [6]
    for name, y in channels.items():
        q = _quantity(name)
        u, fac = units[q]
        heads.append(f"{_label(name, q)} [{u}]")
        vals = np.asarray(y, float) / fac
        cols.append(vals)
        dec.append(max(0, 5 - int(np.floor(np.log10(max(np.abs(vals).max(), 1e-30))))))
    lines = [";".join(heads)]
    for row in np.column_stack(cols):
        lines.append(";".join(_thousands(v, d) for v, d in zip(row, dec)))
    with open(path, "w") as fh:
        fh.write("\n".join(lines) + "\n")
    return path


def _micro(path_base, t, channels, rng):
    """A DAQ that stamps each sample with an integer number of microseconds since the record's start
    (``Time [us]``): the stamps are the true grid rounded to 1 us (a documented unit; at most half a step)."""
    path = path_base + ".csv"
    heads, cols = ["Time [us]"], [np.round((np.asarray(t, float) - float(t[0])) * 1e6)]
    for name, y in channels.items():
        q = _quantity(name)
        heads.append(f"{_label(name, q)} [{ {'force': 'N', 'acc': 'm/s^2', 'vel': 'm/s', 'disp': 'm'}[q]}]")
        cols.append(np.asarray(y, float))
    lines = [",".join(heads)]
    for row in np.column_stack(cols):
        lines.append(",".join([str(int(row[0]))] + [f"{v:.9g}" for v in row[1:]]))
    with open(path, "w") as fh:
        fh.write("\n".join(lines) + "\n")
    return path


TWELFTH = {"csv-thousands": _spreadsheet, "csv-us": _micro, "lvm": _lvm, "csv-sample": _samples, "csv-sample-time": lambda *a: _samples(*a, with_time=True),
           "csv-counts": _counts, "mat-int16": _mat_int16, "csv-german": _german, "csv-reordered": _reordered}
