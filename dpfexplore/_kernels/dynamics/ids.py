"""Ids of the Numba integrators, in a module without Numba (front ends name them cheaply)."""

INTEGRATOR_RODAS4 = 0
INTEGRATOR_DOPRI5 = 1
