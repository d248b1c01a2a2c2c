"""Walker legs (MODEL.md §10): chains of independent lattices composed kinematically.

Modules
-------
kinematics
    The implementation's composition of section nodes into the leg's 3D tip path.
leg
    :func:`~.leg.simulate_leg`, :func:`~.leg.load_leg`: sections simulated under their phases.
"""
