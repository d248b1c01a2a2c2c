"""The design scenes: one package per kind (MODEL.md §9-§10).

Each package holds the kind's ``spec`` (its tables of a scene file and its record), its
``problem`` (what the engine solves), ``solve``, ``report`` (verified result records and the files
written), ``summary`` (the text summary) and ``kind`` (its
:class:`~dpfexplore.inverse.scene_kind.SceneKind`, one entry of
:data:`dpfexplore.inverse.kinds.SCENE_KINDS`).

Packages
--------
position
    Tip positions of a targeted state (paper eq. opti_pos).
position_stiffness
    Tip positions and the stiffest designs within each tolerance (opti_pos_stiff); reuses the
    position package's parser pieces, problem, search, report and summary.
gripper
    The multi-aperture gripper: apertures per state, pressure windows, stiffness.
pickplace
    Pick-and-place units: reset times by design (screening, brackets, roots, fronts).
walker
    Walker-leg zones that keep time: legs composed from section runs, inversion pressures.
"""
