"""The design scenes: one package per kind (MODEL.md §9-§10).

Packages and modules
--------------------
gripper
    The multi-aperture gripper: apertures per state, pressure windows, stiffness.
pickplace
    Pick-and-place units: reset times by design (screening, brackets, roots, fronts).
walker
    Walker-leg zones that keep time: legs composed from section runs, inversion pressures.
timing_spec
    Scene files of the two timing scenes (pick-and-place and walker leg): the format, and the
    parsers of :mod:`.pickplace.spec` and :mod:`.walker.spec` by name.
timing_fields
    Checks of scene-file values both timing scenes use.
"""
