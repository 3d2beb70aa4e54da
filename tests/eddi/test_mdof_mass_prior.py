"""Masses expected from the modal masses of the driving-point residues (:mod:`eddi.mdof.massprior`).

Exact modes of a diagonal mass matrix give its masses back (the shapes scaled to a largest entry
of 1, as ERA gives them, the modal masses for those shapes); a shape error shows in the
residue scattered over the records widens its mass's interval; fewer modes than channels or a missing modal mass
give no expectation. New module: fails on the old code (ImportError).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.linalg import eigh

from eddi.mdof.massprior import MIN_MASS_STD, mass_prior, prior_weights


def _modes(masses, k):
    m = np.diag(masses)
    _w2, phi = eigh(k, m)
    phi = phi / np.max(np.abs(phi), axis=0)  # largest entry 1 (ERA's scaling)
    return phi, np.diag(phi.T @ m @ phi)


K = np.array([[3e6, -1e6, 0.0], [-1e6, 4e6, -3e6], [0.0, -3e6, 3e6]])  # ground-1, 1-2, 2-3 (1 / 0.5 / 2 kg chain)


@pytest.mark.parametrize("masses", [(1.0, 0.5, 2.0), (24.0, 1.5, 1.0), (0.6, 1.5, 3.0)])
def test_exact_modes_give_the_masses(masses):
    phi, mm = _modes(np.array(masses), K)
    got = mass_prior(phi, mm, np.zeros(3))
    assert got is not None
    np.testing.assert_allclose(got.masses, masses, rtol=1e-9)
    assert got.off_diagonal < 1e-9
    np.testing.assert_allclose(got.rel_std, MIN_MASS_STD)
    assert "1 / 0.5 / 2 kg" in mass_prior(*_modes(np.array([1.0, 0.5, 2.0]), K)).note()


def test_a_spread_residue_widens_its_mass_interval():
    # mode 2 of this chain is mass 1's (largest entry there); its residue scattered over the records
    # by 50 % (a nonlinear mode's early residue moves with the blow) leaves mass 1 less certain
    phi, mm = _modes(np.array([1.0, 0.5, 2.0]), K)
    top = np.argmax(np.abs(phi), axis=0)
    mode = int(np.flatnonzero(top == 0)[0])
    spread = np.zeros(3)
    spread[mode] = 0.5
    got = mass_prior(phi, mm, spread)
    assert got.rel_std[0] > 0.15 and np.all(got.rel_std[1:] <= got.rel_std[0] - 0.04)  # 0.157 vs 0.10, 0.10
    np.testing.assert_allclose(got.masses, [1.0, 0.5, 2.0], rtol=1e-9)  # exact residues: exact masses


def test_no_expectation_without_a_full_set_of_modal_masses():
    phi, mm = _modes(np.array([1.0, 0.5, 2.0]), K)
    assert mass_prior(phi[:, :2], mm[:2]) is None  # fewer modes than channels
    assert mass_prior(phi, np.array([mm[0], np.nan, mm[2]])) is None
    assert mass_prior(phi, np.array([mm[0], -1.0, mm[2]])) is None


def test_weights_scale_with_the_residual_and_the_interval():
    phi, mm = _modes(np.array([1.0, 0.5, 2.0]), K)
    got = mass_prior(phi, mm, np.zeros(3))

    class Plain:
        residual = np.array([0.2, 0.05, 0.1])

    ratios, w = prior_weights(got, Plain, 1)
    np.testing.assert_allclose(ratios, [2.0, 1.0, 4.0], rtol=1e-9)
    # one standard deviation (10 %) of the expected mass costs the equation's residual per row
    np.testing.assert_allclose(w * ratios * MIN_MASS_STD, Plain.residual, rtol=1e-9)
