"""The damped lattice in time: equations of motion, integrators, events, batches (Numba).

Modules
-------
motion
    Right-hand side of the damped lattice under pressure and its Jacobians (MODEL.md §8).
events
    Solver controls, dense output, threshold crossings, early stop: what every integrator
    shares.
stepping
    The step driver every integrator runs: step cap, early stop, knots, rejections, step sizes.
rosenbrock
    Rodas4 on the analytic Jacobian (full and overdamped models).
explicit
    Dormand-Prince 5(4).
batch
    One simulation from rest, its per-unit summary, and the ``prange`` batch over designs.
ids
    Ids of the integrators, in a module without Numba.
"""
