"""The noise floor's perturbed records done beforehand (``draw_jobs``, a mapper's ``done``).

``station diagnose`` queues them with :meth:`station.forkmap.ForkMap.beside` while the
pipeline's baseline is fitted; :func:`eddi.diagnosis.measure.noise_floor` takes what was done,
as it comes back from a worker (pickled), for these very record objects and seeds only, and
conditions the rest itself: the floor is the same bit for bit (docs/performance.md, session 15).
"""

from __future__ import annotations

import pickle

import numpy as np

from eddi.conditioning import condition
from eddi.diagnosis import Record
from eddi.diagnosis.measure import DRAWS, SEED_STEP, _perturbed, draw_jobs
from eddi.diagnosis.mapping import serial_map
from eddi.model import EquationOfMotion
from simulated_rig.bench import impact_test

SYSTEM = EquationOfMotion.create(mass=0.1, damping={"v": 0.06}, stiffness={"x": 600.0, "x^3": 2e7})


def _records() -> list[Record]:
    out = []
    for i, f in enumerate((20.0, 30.0)):
        r = impact_test(SYSTEM, f, rate_hz=4000.0, pretrigger_s=0.2, record_s=1.0, snr_db=40.0, seed=i)
        c = condition(r.t, acc=r.acc_m_s2, force=r.force_n, pretrigger_samples=r.pretrigger_samples)
        out.append(Record.from_conditioned(c, label=f"c{i}", pretrigger_samples=r.pretrigger_samples))
    return out


class _Beside:
    """A mapper that did some of the queued jobs beforehand (each result pickled, as a forked
    worker hands it back) and counts what it is asked for."""

    def __init__(self, jobs, which) -> None:  # type: ignore[no-untyped-def]
        self.ready = {key: pickle.loads(pickle.dumps(job())) for k, (key, job) in enumerate(jobs) if k in which}
        self.asked: list = []
        self.mapped: list = []

    def done(self, key):  # type: ignore[no-untyped-def]
        self.asked.append(key)
        return (True, self.ready.pop(key)) if key in self.ready else (False, None)

    def __call__(self, fn, items):  # type: ignore[no-untyped-def]
        self.mapped.extend(items)
        return serial_map(fn, items)


def _same(a: list[Record], b: list[Record]) -> bool:
    return all(np.array_equal(p.x, q.x) and np.array_equal(p.v, q.v) and np.array_equal(p.a, q.a)
               and p.noise_rms == q.noise_rms for p, q in zip(a, b)) and len(a) == len(b)


def test_draws_done_beforehand_give_the_same_records_and_the_rest_are_mapped() -> None:
    recs = _records()
    plain = _perturbed(recs, 1, None)
    assert len(plain) == DRAWS * len(recs)
    jobs = draw_jobs(recs)
    assert len(jobs) == DRAWS * len(recs) == len({key for key, _ in jobs})
    mapper = _Beside(jobs, which={0, 3, 5})
    got = _perturbed(recs, 1, mapper)
    assert _same(got, plain)
    assert len(mapper.asked) == DRAWS * len(recs)
    # the three done beforehand (draw-major: (0, 0), (1, 1), (2, 1)) are not conditioned again
    assert mapper.mapped == [(0, 1), (1, 0), (2, 0)]
    # the draws differ from one another and from the record (a perturbation, not a copy)
    assert not np.array_equal(got[0].x, recs[0].x) and not np.array_equal(got[0].x, got[len(recs)].x)


def test_draws_of_other_records_or_seeds_are_not_taken() -> None:
    recs = _records()
    twins = [r.replace(label=r.label) for r in recs]  # equal numbers, other objects
    assert all(t is not r and np.array_equal(t.x, r.x) for t, r in zip(twins, recs))
    for jobs in (draw_jobs(twins), draw_jobs(recs, seed=1 + SEED_STEP * DRAWS)):
        mapper = _Beside(jobs, which=set(range(len(jobs))))
        got = _perturbed(recs, 1, mapper)
        assert len(mapper.mapped) == DRAWS * len(recs)  # nothing was taken: all conditioned here
        assert _same(got, _perturbed(recs, 1, None))
