"""Solvers: the Python API that validates designs, packs them for the kernels and wraps results.

Modules and packages
--------------------
lattice
    From designs to kernel arrays; :func:`~.lattice.spring_constants`.
statics
    :func:`~.statics.find_state`, :func:`~.statics.enumerate_states`,
    :func:`~.statics.solve_batch` (MODEL.md §6-§7).
row_plan
    The (design, requested state) rows a batch solve runs, and the sequential order.
sensitivities
    :class:`~.sensitivities.Sensitivities`: derivatives of a state's outputs in the design.
follower
    Follower-force stiffness (the paper's quasi-static ramp; a validation path).
compilation
    Which kernels are compiled already (the compile notices).
dynamics
    Simulation and reset times (MODEL.md §8): :func:`~.dynamics.simulate.simulate`,
    :func:`~.dynamics.simulate.reset_times_batch`, the SciPy baseline, the release and fast
    reset models, reset maps and inversion pressures from ramps.
snap
    :func:`~.snap.continuation.snap_pressures`: the states a slow pressure ramp visits, its snap
    pressures and each state's pressure window.
legs
    Legs (MODEL.md §10): sections simulated alone under their phases, composed into a 3D tip
    path; :func:`~.legs.leg.simulate_leg`, :func:`~.legs.leg.load_leg`.
"""
