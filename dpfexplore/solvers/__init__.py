"""Solvers: the Python API that validates designs, packs them for the kernels and wraps results.

Modules
-------
lattice
    From designs to kernel arrays; :func:`~.lattice.spring_constants`.
statics
    :func:`~.statics.find_state`, :func:`~.statics.enumerate_states`,
    :func:`~.statics.solve_batch` (MODEL.md §6-§7).
sensitivities
    :class:`~.sensitivities.Sensitivities`: derivatives of a state's outputs in the design.
follower
    Follower-force stiffness (the paper's quasi-static ramp; a validation path).
dynamics_common
    Methods, controls, results and the batch runner shared by the dynamics front ends.
dynamics_scipy
    The trusted baseline: the same equations through ``scipy.integrate.solve_ivp``.
reduced
    The release model, a reduced reset-time model with its error measured.
fast_reset, fast_reset_model, fast_reset_train
    The fast reset-time model (``reset_times_batch(..., method="fast")``): physical core,
    fitted correction and interval, fallback; its JSON model file; its training.
dynamics
    :func:`~.dynamics.simulate` and :func:`~.dynamics.reset_times_batch` (MODEL.md §8).
resetmaps
    The paper's metastable-dome maps (reset time against H, t and hold time).
ramp
    Inversion pressures from slow pressure ramps (extrapolated to the quasi-static fold).
leg_kinematics, leg
    Legs (MODEL.md §10): sections simulated alone under their phases, composed into a 3D tip
    path; :func:`~.leg.simulate_leg`, :func:`~.leg.load_leg`.
"""
