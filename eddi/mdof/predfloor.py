"""The prediction floor of a held-out fold: what a model of the identified class, identified from the
other captures, is expected to leave on the held-out one (session 19, issue 14 item 4).

A multi-channel diagnosis judges each model by its held-out nrmse per channel. Before session 19 the
verdict compared it with the acceleration noise alone (:func:`eddi.mdof.validate.noise_floor`), and
session 18 added, for the ``none`` judgement only, the held-out capture's impulse uncertainty
(:func:`eddi.mdof.validate.force_floor`). Both are what the TRUE equations leave. A held-out fold's
model is not the truth: it was identified from ``N - 1`` noisy captures, and its own errors reach the
held-out prediction. The largest, measured on linear nulls of ``benchmarks/bench_mdof_nulls.py``: the
modal masses come from the training captures' measured impulses (the driving-point residues), so
each training blow's impulse error (``u_j``, the force noise over the blow) scales the model's
response; the fold's prediction then misses by the held-out blow's impulse error MINUS the training
blows' mean one. On t11-nulln (0.45 + 0.11 kg, 36.6 dB, 0.5-1.3 N blows, impulse errors -1.3 /
+2.4 / +0.1 / +1.2 % drawn from ``u`` = 1.0 / 0.8 / 0.4 / 0.45 %) the fold holding out the first
blow left 0.029 where the truth leaves 0.018 and the noise 0.0034: -1.3 % - (+1.2 %) = -2.5 %.
Frequencies, damping ratios and shapes identified from noisy ring-downs add their own scatter.

**The estimate** (:func:`fold_floor`): per held-out capture ``k`` and channel ``c``,
``P_kc = sqrt(noise_kc^2 + impulse_kc^2 + ident_kc^2)``, with

- ``noise_kc``: :func:`eddi.mdof.validate.noise_floor` of capture ``k``;
- ``impulse_kc``: :func:`eddi.mdof.validate.force_floor` of fold ``k``'s model on capture ``k``;
- ``ident_kc``: the identification's own uncertainty carried to capture ``k``, the jackknife over the
  folds: every fold's model predicts capture ``k``, and ``sqrt(sum_j ||y_j - mean_j y_j||^2) /
  ||y_k||`` (:func:`jackknife_spread`). The jackknife's ``(N-1)/N sum_j (.)^2`` estimates the variance
  of a model identified from all ``N`` captures; a fold's model uses ``N - 1``, ``N/(N-1)`` times
  that variance: the plain sum. It carries the training impulses' errors through whatever weights
  the identification gives them, and the scatter of frequencies, damping and shapes, with no model of
  either (on t11-nulln 0.009: the training means' spread of the impulse errors, 0.92 %).

The floor of a channel over the folds is the mean of ``P_kc`` (the held-out figure is the mean of the
folds' nrmse), at least :data:`eddi.mdof.verdict.MDOF_MIN_FLOOR`.

Limits: the jackknife is of the unpolished fold models (with ``--refine`` the polished ones are
judged: their spread is not measured); a model class that misses a real effect identifies
differently from different blow sets and its spread grows - the floor of a wrong model is then
higher than a right one's (measured in docs/multi-dof.md, session 19: the hidden-coupling tests still
name). A fold model that diverges on another capture is left out of that capture's spread.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class FoldFloors:
    """The prediction floor's parts per held-out capture (rows) and channel (columns).

    Attributes
    ----------
    noise, impulse, ident : ndarray, shape (n_records, n_channels)
        Nrmse of each part (module notes).
    """

    noise: np.ndarray
    impulse: np.ndarray
    ident: np.ndarray

    @property
    def total(self) -> np.ndarray:
        """``sqrt(noise^2 + impulse^2 + ident^2)`` per capture and channel."""
        return np.sqrt(self.noise**2 + self.impulse**2 + self.ident**2)

    def take(self, rows: Sequence[int]) -> "FoldFloors":
        """The captures ``rows`` only (e.g. the folds on which the baseline ran)."""
        idx = list(rows)
        return FoldFloors(self.noise[idx], self.impulse[idx], self.ident[idx])

    def training_floors(self, names: Sequence[str], least: float) -> dict[str, float]:
        """Per channel the mean over the captures of ``sqrt(noise^2 + impulse^2)``, at least ``least``:
        what the true equations leave on a capture the model was fitted on (no identification part)."""
        tot = np.hypot(self.noise, self.impulse)
        return {c: max(least, float(np.mean(tot[:, k]))) for k, c in enumerate(names)}

    def channel_floors(self, names: Sequence[str], least: float) -> dict[str, float]:
        """Per channel the mean over the captures of :attr:`total`, at least ``least``."""
        tot = self.total
        return {c: max(least, float(np.mean(tot[:, k]))) for k, c in enumerate(names)}

    def fold_floors(self, least: float) -> list[float]:
        """Per held-out capture the mean over the channels of :attr:`total`, each at least ``least``
        (the one floor per fold of :func:`eddi.mdof.verdict.excess_gain`)."""
        return [float(np.mean(np.maximum(row, least))) for row in self.total]

    def parts(self, names: Sequence[str]) -> dict[str, dict[str, float]]:
        """Mean over the captures of each part, per channel (the JSON evidence)."""
        return {part: {c: float(np.mean(getattr(self, part)[:, k])) for k, c in enumerate(names)}
                for part in ("noise", "impulse", "ident")}


def jackknife_spread(simulated: Sequence[np.ndarray], measured: np.ndarray) -> np.ndarray:
    """``sqrt(sum_j ||y_j - mean y||^2) / ||y||`` per channel (module notes): ``simulated`` the
    folds' predictions of one capture over its free window (each ``(n_channels, k)``, NaN or inf for
    a model that diverged: left out), ``measured`` the capture's displacement there. Zeros with fewer
    than two finite predictions."""
    ys = [np.asarray(y, float) for y in simulated if np.all(np.isfinite(y))]
    n_ch = np.asarray(measured).shape[0]
    if len(ys) < 2:
        return np.zeros(n_ch)
    arr = np.array(ys)
    dev = np.sum(np.sum((arr - arr.mean(axis=0)) ** 2, axis=2), axis=0)
    return np.sqrt(dev) / np.maximum(np.linalg.norm(measured, axis=1), 1e-300)


def capture_floor(models: Sequence, k: int, record) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The three parts for held-out capture ``k`` (``models[j]``: fold ``j``'s model, ``models[k]`` the
    one that did not see ``record``)."""
    from eddi.mdof.validate import force_floor, noise_floor, validate_mdof

    noise = np.nan_to_num(np.asarray(noise_floor(record), float), nan=0.0)
    try:
        imp = np.nan_to_num(np.asarray(force_floor(models[k], record), float), nan=0.0, posinf=0.0)
    except (ValueError, FloatingPointError, np.linalg.LinAlgError):
        imp = np.zeros_like(noise)
    sims = []
    for m in models:
        try:
            v = validate_mdof(m, record)
        except (ValueError, FloatingPointError, np.linalg.LinAlgError):
            continue
        if not v.diverged:
            sims.append(v.simulated)
    w0, w1 = record.window
    ident = jackknife_spread(sims, record.x[:, w0:w1])
    return noise, imp, ident


def fold_floor(models: Sequence, records: Sequence, mapper=None) -> FoldFloors:
    """:class:`FoldFloors` of the held-out folds (``models[k]``: the model identified without
    ``records[k]``); ``mapper(fn, items)`` may run the captures in forked workers."""
    mapper = mapper if mapper is not None else (lambda fn, items: [fn(x) for x in items])
    got = mapper(lambda k: capture_floor(models, k, records[k]), list(range(len(records))))
    return FoldFloors(*(np.array([g[i] for g in got]) for i in range(3)))
