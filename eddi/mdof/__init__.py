"""Several coordinates: coupled nonlinear equations of motion identified from several channels.

``model`` (the equation of motion as data, schema version 2), ``terms`` (monomials in several
coordinates), ``simulate`` (compiled RK4), ``modal`` (linear modal analysis of free decays),
``identify`` (EDDI per coordinate with coupling terms), ``validate`` (per-channel errors).
"""
