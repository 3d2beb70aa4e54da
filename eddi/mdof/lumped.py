"""Lumped masses joined by springs and dashpots: identification in physical coordinates.

When every response channel sits on a mass (a chain, an oscillator with an attachment), the
equations of motion are those of elements between the masses and the ground (node 0)::

    m_i x_i'' + sum_e (c_e dV_e/dv_i + k_e dU_e/dx_i + k3_e dW_e/dx_i) = u_i F(t)

with, for an element between nodes ``a`` and ``b`` (``d = x_a - x_b``, ``x_0 = 0``), a dashpot
``c_e d'``, a linear spring ``k_e d`` and a cubic spring ``k3_e d^3`` acting with opposite signs
on its two ends (Newton's third law). Every unknown (the masses and the element constants)
enters linearly, so one least-squares fit over all equations at once determines them, each
element constant shared by the two equations it appears in. That sharing is what the
per-coordinate library (:mod:`eddi.mdof.identify`) lacks: there a cubic spring between two
masses is four free monomials per equation (their marginal intervals are +-15-35 % on the
two-mass chain), here it is one number. It also suits a coordinate with no linear mode (a
nonlinear energy sink: ``k = 0``, only ``k3``), where the per-coordinate energy balance has
no zero crossings to stand on.

Scale: the equations in the free window are homogeneous, so the driven mass is set to 1 for
the fit and its value comes from the hammer pulse (``m_d x_d'' + B_d + K_d = F``,
:func:`driven_mass`): no mass needs to be given. During the pulse the conditioned
displacement lacks its quasi-static part (the drift filter is zero-phase, so it acts before
and during the blow too); :func:`eddi.mdof.physical.identify_lumped` restores it from the
fitted model's receptance and takes the scale again (measured on the two-mass chain: driven
mass 0.92-0.98 kg without, 1.005-1.008 kg with, true 1).

Rows: the free window from ``settle`` s after its start (the column filter's response to the
blow, where the conditioned and the true displacement differ most, is left out: on the
two-mass chain at 45 dB, starting at the impact gave frequencies 0.12 / 0.22 % high and a
worst cubic coefficient of 1.8 %; half a period of the filter's cut-off later, 0.01 / 0.03 %
and 0.4 %).

Conditioning: the columns (and the force) pass through the drift high-pass of the
conditioning before the windows are cut (:func:`eddi.mdof.equations._design`): the conditioned
displacement lacks its slow part, where a cubic spring puts ``2 f_1 - f_2`` and other
combination tones; filtered alike, both sides of the equation lose that band.

Elements whose force is below ``prune`` of the equations' inertia force are dropped and the fit
repeated. Intervals: delete-one-block jackknife of the joint fit
(:func:`eddi.mdof.intervals.block_jackknife_ci95`) over interleaved blocks
(:func:`_jackknife_blocks`), carried to the monomials.

No I/O: arrays in, frozen results out.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from eddi.mdof.intervals import JACKKNIFE_BLOCKS, jackknife_lstsq_ci95
from eddi.mdof.signals import highpass
from eddi.phase_one import scaled_lstsq

#: Cut-off of the column filter relative to the conditioning's drift high-pass: measured on
#: the two-mass chain (45 dB; ratio 1, 1.5, 2, 3: worst cubic coefficient 3.3, 2.0, 1.8, 1.7 %,
#: held-out nrmse 0.09-0.10, 0.09-0.10, 0.08, 0.07): the conditioned displacement deviates from
#: the true one in the filter's transition band, not only below the cut-off.
PREFILTER_RATIO = 2.0


#: Element kinds: (power of the stretch, acts on the rate). ``c`` dashpot, ``k`` linear spring,
#: ``k3`` cubic spring, ``k2`` quadratic (asymmetric) spring ``k2 d^2``, ``c3`` cubic damper
#: ``c3 d'^3`` (session 13: the last two between masses; :func:`candidate_elements`).
KINDS = {"c": (1, True), "k": (1, False), "k3": (3, False), "k2": (2, False), "c3": (3, True)}
#: Kinds that are a nonlinear coupling when between two masses (the determinacy rule of :func:`fit_lumped`).
NONLINEAR_KINDS = ("k3", "k2", "c3")
#: Kinds tried between two masses only (a quadratic spring or a cubic damper to the ground is not a
#: candidate: not asked for, and every extra column costs the nulls' variance).
COUPLING_ONLY_KINDS = ("k2", "c3")


@dataclass(frozen=True)
class Element:
    """One element constant: ``kind`` in :data:`KINDS` between nodes ``a < b`` (0 = ground)."""

    kind: str
    a: int
    b: int

    @property
    def label(self) -> str:
        return f"{self.kind}({self.a}-{self.b})"

    @property
    def power(self) -> int:
        """Power of the stretch (or of its rate) in the element's force."""
        return KINDS[self.kind][0]

    @property
    def on_rate(self) -> bool:
        """True for a damper (the force depends on the stretch's rate)."""
        return KINDS[self.kind][1]

    @property
    def coupling(self) -> bool:
        """True for a nonlinear element between two masses (not to the ground)."""
        return self.a > 0 and self.kind in NONLINEAR_KINDS


def candidate_elements(n: int) -> list[Element]:
    """Dashpot, linear and cubic spring between every pair of nodes (ground included); between
    two masses also a quadratic spring and a cubic damper (:data:`COUPLING_ONLY_KINDS`)."""
    out = []
    for a, b in itertools.combinations(range(n + 1), 2):
        out += [Element(kind, a, b) for kind in ("c", "k", "k3")]
        out += [Element(kind, a, b) for kind in COUPLING_ONLY_KINDS if a > 0]
    return out


def _stretch(e: Element, x: np.ndarray) -> np.ndarray:
    """``x_a - x_b`` with ``x_0 = 0``, per sample."""
    xa = x[e.a - 1] if e.a else 0.0
    return xa - x[e.b - 1]


def element_column(e: Element, x: np.ndarray, v: np.ndarray) -> np.ndarray:
    """The element's force on its end ``a`` per unit constant (``-`` of it acts on ``b``)."""
    d = _stretch(e, v if e.on_rate else x)
    d = np.broadcast_to(d, x.shape[1:]) if np.ndim(d) == 0 else d
    return d if e.power == 1 else d**e.power


def element_terms(e: Element, n: int) -> dict[int, dict[str, float]]:
    """Monomials (model text -> factor) the element adds to each equation ``i`` (0-based)."""
    from eddi.mdof.terms import monomial

    out: dict[int, dict[str, float]] = {}
    ends = [(e.a - 1, 1.0), (e.b - 1, -1.0)] if e.a else [(e.b - 1, -1.0)]
    # stretch d = x_a - x_b (x_0 = 0) as {coord: sign}
    lin = {k: s for k, s in ends}
    for eq, sign in ends:
        terms: dict[str, float] = {}
        for combo in itertools.product(lin.items(), repeat=e.power):
            powers: dict[int, int] = {}
            fac = 1.0
            for k, s in combo:
                powers[k] = powers.get(k, 0) + 1
                fac *= s
            t = monomial(powers, n, rate=e.on_rate)
            terms[t] = terms.get(t, 0.0) + sign * fac
        out[eq] = {t: c for t, c in terms.items() if c != 0.0}
    return out


@dataclass(frozen=True)
class LumpedFit:
    """Result of :func:`fit_lumped`.

    Attributes
    ----------
    masses : ndarray, shape (n,), [kg] (per unit driven mass when no force)
    constants : dict of Element to float
        Element constants kept [N s/m, N/m, N/m^3].
    ci95 : dict of Element to float
        95 % half-widths, same units.
    residual : ndarray, shape (n,)
        RMS force-balance residual of each equation relative to its inertia force.
    undetermined : tuple of Element
        Couplings dropped because their interval held zero (:func:`undetermined_couplings`), in
        the order dropped (for :func:`eddi.mdof.physical.identify_lumped`'s training-error check).
    """

    masses: np.ndarray
    constants: dict[Element, float]
    ci95: dict[Element, float]
    residual: np.ndarray
    undetermined: tuple = ()


def _columns(x, v, a, force, elements, n, d):
    """Per equation ``i``: (inertia column, element columns, force column), whole record."""
    cols = {e: element_column(e, x, v) for e in elements}
    out = []
    for i in range(n):
        el = np.column_stack([cols[e] * (1.0 if e.a - 1 == i else -1.0 if e.b - 1 == i else 0.0)
                              for e in elements]) if elements else np.zeros((x.shape[1], 0))
        f = force if (force is not None and i == d) else np.zeros(x.shape[1])
        out.append(np.column_stack([a[i], el, f]))
    return out


def _stack(records: Sequence[tuple], elements: list[Element], n: int, d: int, prefilter: bool):
    """Rows of all equations over the free windows, each equation scaled by its inertia RMS.

    Unknowns: ``m_i`` (``i != d``), the element constants, ``g`` (the filtered force's nuisance
    coefficient, equation ``d``); ``m_d = 1`` moves to the right-hand side.
    """
    per_eq = [[] for _ in range(n)]
    for x, v, a, force, (s, e), rate, fc in records:
        cols = _columns(x, v, a, force, elements, n, d)
        for i in range(n):
            c = highpass(cols[i].T, rate, PREFILTER_RATIO * fc, 1).T if prefilter else cols[i]
            per_eq[i].append(c[s:e])
    ne = len(elements)
    rows, rhs, eq_of = [], [], []
    for i in range(n):
        c = np.vstack(per_eq[i])
        scale = float(np.sqrt(np.mean(c[:, 0] ** 2))) or 1.0
        mcols = np.zeros((c.shape[0], n))
        mcols[:, i] = c[:, 0]
        big = np.hstack([np.delete(mcols, d, axis=1), c[:, 1:1 + ne], -c[:, 1 + ne:]])
        target = -c[:, 0] if i == d else np.zeros(c.shape[0])
        rows.append(big / scale)
        rhs.append(target / scale)
        eq_of.append(np.full(c.shape[0], i))
    return np.vstack(rows), np.concatenate(rhs), np.concatenate(eq_of)


def _relative_force(forces: np.ndarray, eq_of: np.ndarray, other_masses: np.ndarray, n: int, d: int) -> np.ndarray:
    """Each element's force RMS relative to the inertia force of the equation where it is largest.

    The rows of equation ``i`` are scaled by the RMS of ``a_i`` (:func:`_stack`), so a force of 1
    there is the inertia force of a mass equal to the driven one; dividing by ``m_i`` (per unit
    driven mass) makes it the fraction of mass ``i``'s own inertia force. Before (session 7) the
    force was averaged over all rows unscaled by ``m_i``: a light mass's elements counted at the
    mass ratio, and the 0.045 kg sink's dashpot on a 1.5 kg primary (2.4 % of the sink's inertia
    force) was pruned as 0.27 %, leaving a sink with no damping (training nrmse 2.9).
    """
    masses = np.ones(n)
    masses[[i for i in range(n) if i != d]] = np.abs(other_masses)
    rel = np.zeros(forces.shape[1])
    for i in range(n):
        rows = eq_of == i
        if np.any(rows) and masses[i] > 0:
            rel = np.maximum(rel, np.sqrt(np.mean(forces[rows] ** 2, axis=0)) / masses[i])
    return rel


#: Chunks per record dealt round-robin to the jackknife blocks (:func:`_jackknife_blocks`).
JACKKNIFE_CHUNKS = 40


def _jackknife_blocks(lengths: Sequence[int]) -> np.ndarray:
    """Jackknife block of every row of one equation: five interleaved blocks per record.

    Each record is cut into :data:`JACKKNIFE_CHUNKS` contiguous chunks (a chunk spans many
    samples, so the residual's correlation stays inside it) dealt round-robin to five blocks.
    Session 7: with five contiguous blocks the first one held most of what determines a weak
    cubic spring (the large-amplitude start of a ring-down), so deleting it inflated the spread:
    on a 3 % cubic coupling (``bench_mdof.py --coupling-sweep 4``) the printed ci95 averaged
    62 % against a 2.7 % RMS error, while on a 30 % one 3 of 4 intervals missed. Interleaved,
    on the same records: 4.2-34 % (4 of 4 cover) and 0.35-4.2 % (4 of 4 cover).
    """
    out = []
    for j, m in enumerate(lengths):
        chunk = max(1, m // JACKKNIFE_CHUNKS)
        out.append(np.minimum(np.arange(m) // chunk, JACKKNIFE_CHUNKS - 1) % JACKKNIFE_BLOCKS + JACKKNIFE_BLOCKS * j)
    return np.concatenate(out)


def fit_lumped(records: Sequence[tuple], impacts: Sequence[tuple], n: int, d: int, *,
               elements: list[Element] | None = None, prune: float = 3e-3, prefilter: bool = True,
               instruments: Sequence[tuple] | None = None, keep: frozenset | set = frozenset(),
               mass_prior: tuple[np.ndarray, np.ndarray] | None = None) -> LumpedFit:
    """Masses and element constants from the records (module docstring).

    Parameters
    ----------
    records : sequence of tuple
        Per record ``(x, v, a, force, window, rate_hz, cutoff_hz)``: whole-record states of
        shape (n, n_samples) [m, m/s, m/s^2], the force [N] or None, the free window
        ``(start, stop)``, the sample rate and the drift high-pass cut-off [Hz].
    impacts : sequence of tuple
        Per record ``(x, v, a, force)`` over the hammer pulse (unfiltered), for the scale.
    n : int
        Masses (= channels).
    d : int
        Driving-point mass (0-based).
    elements : list of Element, optional
        Candidates; default every dashpot, linear and cubic spring (:func:`candidate_elements`).
    prune : float
        An element whose force (RMS) is below this fraction of the inertia force is dropped.
    prefilter : bool
        Filter the columns through the drift high-pass (module docstring).
    instruments : sequence of tuple, optional
        Per record the same tuple with states free of the measurement's noise (a simulation of a
        first model, conditioned as the records were): instrumental variables. The columns are
        replaced by their projection on the instruments' columns (two-stage least squares), so
        the noise in the measured displacement - an error in the variables, which biases an
        ordinary least squares towards zero - no longer enters the normal equations; residuals
        and forces are those of the measured columns. The intervals take the projected design as
        known (the first stage's own spread is not in them).
    keep : set of Element, optional
        Elements never dropped for a small force (a weak cubic spring whose effect the simulated
        training records show: :func:`eddi.mdof.physical.identify_lumped`).
    mass_prior : (ndarray, ndarray), optional
        ``(ratios, weights)``: each mass per unit driven mass expected from the modal masses
        (:mod:`eddi.mdof.massprior`) and the weight of that expectation per row of its equation,
        one extra row per mass other than the driven one, ``sqrt(N_i) w_i (m_i - ratio_i) = 0``
        (``N_i`` rows of equation ``i``, each scaled to an inertia RMS of 1: a mass ``1 / w_i`` off
        the expectation costs as much as a residual of 1 inertia RMS on every row of its
        equation). The rows are in every jackknife fit.
    """
    elements = list(candidate_elements(n) if elements is None else elements)
    lengths = [r[4][1] - r[4][0] for r in records]
    # the columns of a subset of elements are those columns of the whole design (each element's
    # column is filtered on its own): stacked once, not once per pruning round
    full, b, eq_of = _stack(records, elements, n, d, prefilter)
    inst = _stack(instruments, elements, n, d, prefilter)[0] if instruments is not None else None
    n_data = full.shape[0]
    if mass_prior is not None:
        full, b, eq_of, inst = _prior_rows(full, b, eq_of, inst, mass_prior, n, d, sum(lengths))
    where = {e: n - 1 + k for k, e in enumerate(elements)}
    rest = list(range(n - 1 + len(elements), full.shape[1]))
    blocks = np.tile(_jackknife_blocks(lengths), n)  # the same blocks in every equation
    dropped: list[Element] = []
    for _round in range(len(elements) + 1):  # one element dropped per round; the last round drops none
        cols = list(range(n - 1)) + [where[e] for e in elements] + rest
        a_mat = full[:, cols]
        a_fit = a_mat if inst is None else _projected(inst[:, cols], a_mat)
        p, _ = scaled_lstsq(a_fit, b)
        ne = len(elements)
        ecoef = p[n - 1: n - 1 + ne]
        force_rms = _relative_force(a_mat[:, n - 1: n - 1 + ne] * ecoef, eq_of, p[: n - 1], n, d)
        small = [e for e, f in zip(elements, force_rms) if f < prune and e not in keep]
        # a dashpot or linear spring with a negative constant is not passive: it stands in for
        # what the drift filter removed (or for noise), not for an element (a cubic may soften)
        active = [e for e, c in zip(elements, ecoef) if e.kind not in ("k3", "k2") and c < 0]
        if small or active:
            elements.remove(min(small or active, key=lambda e: force_rms[elements.index(e)]))
            continue
        ci = _jackknife(a_fit, b, blocks, n_data, slice(n - 1, n - 1 + ne))
        loose = undetermined_couplings(elements, ecoef, ci, keep)
        if not loose:
            break
        elements.remove(loose[0])
        dropped.append(loose[0])
    masses = np.ones(n)
    masses[[i for i in range(n) if i != d]] = p[: n - 1]
    consts = dict(zip(elements, ecoef))
    resid = (a_mat @ p - b)[:n_data]
    eq_of = eq_of[:n_data]
    residual = np.array([float(np.sqrt(np.mean(resid[eq_of == i] ** 2))) for i in range(n)])
    scale = driven_mass(impacts, masses, consts, d)
    return LumpedFit(masses * scale, {e: c * scale for e, c in consts.items()},
                     {e: float(h) * scale for e, h in zip(elements, ci)}, residual, tuple(dropped))


def _prior_rows(full: np.ndarray, b: np.ndarray, eq_of: np.ndarray, inst: np.ndarray | None,
                mass_prior: tuple[np.ndarray, np.ndarray], n: int, d: int, rows_per_eq: int) -> tuple:
    """The design with :func:`fit_lumped`'s ``mass_prior`` rows appended (equation index ``n``: in
    no equation's residual or force)."""
    ratios, weights = (np.asarray(v, float) for v in mass_prior)
    others = [i for i in range(n) if i != d]
    rows = np.zeros((len(others), full.shape[1]))
    for k, i in enumerate(others):
        rows[k, k] = np.sqrt(rows_per_eq) * weights[i]
    rhs = np.array([np.sqrt(rows_per_eq) * weights[i] * ratios[i] for i in others])
    out_inst = None if inst is None else np.vstack([inst, rows])
    return (np.vstack([full, rows]), np.concatenate([b, rhs]), np.concatenate([eq_of, np.full(len(others), n)]),
            out_inst)


def _jackknife(a: np.ndarray, b: np.ndarray, blocks: np.ndarray, n_data: int, keep: slice) -> np.ndarray:
    """:func:`jackknife_lstsq_ci95` over the data rows ``[:n_data]``; rows after them (the mass prior)
    are in every delete-one fit (each block holds them at ``1 / sqrt(g - 1)`` of their weight, so
    the ``g - 1`` blocks of a fit hold them once)."""
    if a.shape[0] == n_data:
        return jackknife_lstsq_ci95(a, b, blocks, keep)
    ids = np.unique(blocks)
    g = max(ids.size - 1, 1)
    extra_a, extra_b = a[n_data:] / np.sqrt(g), b[n_data:] / np.sqrt(g)
    a_all = np.vstack([a[:n_data]] + [extra_a] * ids.size)
    b_all = np.concatenate([b[:n_data]] + [extra_b] * ids.size)
    blocks_all = np.concatenate([blocks] + [np.full(extra_a.shape[0], k) for k in ids])
    return jackknife_lstsq_ci95(a_all, b_all, blocks_all, keep)


def undetermined_couplings(elements: Sequence[Element], values: Sequence[float], ci95: Sequence[float],
                           keep: frozenset | set = frozenset()) -> list[Element]:
    """Nonlinear elements between two masses (:attr:`Element.coupling`) whose 95 % interval holds
    zero (half-width at least the value), the least determined first; those in ``keep`` excepted.

    Why (session 13, held-out case c2-3 of ``bench_mdof_wide.py --seed 2``: 7.1 + 1.0 kg joined by
    a link 5x stiffer than the ground spring, a cubic spring to the ground on mass 1): on a nearly
    rigid link the relative displacement ``x1 - x2`` is 3 % of ``x1`` (RMS), a small difference of
    two noisy signals, so the column of a cubic spring across it is ~1e-5 of the ground cubic's
    and made largely of the displacements' noise; it correlates with what the other columns leave,
    its force passes the pruning rule (:func:`fit_lumped`'s ``prune``) while its interval is 28x
    its value (-1.2e14 +- 3.4e15 N/m^3, rows from 0.6 periods), and a coupling that is not there
    was kept. A coupling the records do not determine is not kept; refitted without it.
    """
    rel = [(abs(float(h)) / max(abs(float(c)), 1e-300), e) for e, c, h in zip(elements, values, ci95)
           if e.coupling and e not in keep and not abs(float(c)) > abs(float(h))]
    return [e for _r, e in sorted(rel, key=lambda t: -t[0])]


def _projected(z: np.ndarray, a: np.ndarray) -> np.ndarray:
    """The columns of ``a`` projected on the span of the instruments ``z`` (first stage of two-stage
    least squares; columns scaled to unit norm for the solve)."""
    norms = np.linalg.norm(z, axis=0)
    norms[norms == 0] = 1.0
    zn = z / norms
    coef, *_ = np.linalg.lstsq(zn, a, rcond=None)
    return zn @ coef


def driven_mass(impacts: Sequence[tuple], masses: np.ndarray, consts: dict, d: int) -> float:
    """Scale [kg per unit of ``masses[d]``] from ``m_d x_d'' + B_d + K_d = F`` over the hammer pulses.

    ``masses`` and ``consts`` per unit driven mass (or any scale: the result multiplies them);
    1 without force.
    """
    num = den = 0.0
    for x, v, a, f in impacts:
        r = masses[d] * a[d]
        for e, c in consts.items():
            sign = 1.0 if e.a - 1 == d else -1.0 if e.b - 1 == d else 0.0
            if sign:
                r = r + sign * c * element_column(e, x, v)
        num += float(f @ r)
        den += float(r @ r)
    return num / den if den > 0 and num > 0 else 1.0
