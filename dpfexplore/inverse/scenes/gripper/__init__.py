"""The multi-aperture gripper scene (MODEL.md §9, paper opti_multi).

Modules
-------
solve
    :func:`~.solve.solve_gripper`: apertures per state, stiffness, the metastable tip unit.
windows
    Pressure windows of each state from snap pressures.
"""
