"""A lumped fit with a non-positive mass is dropped as a variant, not raised (session 13, s13three).

On a three-mass chain struck at mass 2 (0.54 / 1.74 / 11.6 kg, modes 7.8 / 45 / 105 Hz) one rows'
start fitted mass 1 at -0.0008 kg; ``_rescaled`` built the model before ``_scored`` could drop the
variant, the ModelError left ``identify_lumped`` and the diagnosis lost the lumped candidate for
every rows' start. Fails without the guard in ``eddi.mdof.physical._rescaled`` (ModelError); s13lump
added the same guard for a mass whose every element was pruned (merged first), this is its
three-mass regression test.
"""

from types import SimpleNamespace

import numpy as np

from eddi.mdof.lumped import Element, LumpedFit
from eddi.mdof.physical import _rescaled


def test_a_fit_with_a_negative_mass_comes_back_unscaled():
    fit = LumpedFit(np.array([-0.0008, 1.79, 9.96]), {Element("k", 1, 2): 4.6e4, Element("k", 2, 3): 6.6e5},
                    {Element("k", 1, 2): 1e3, Element("k", 2, 3): 1e4}, 0.1)
    records = [SimpleNamespace(force=np.ones(4))]
    assert _rescaled(fit, records, 3, 1) is fit
