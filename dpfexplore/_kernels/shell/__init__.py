"""The unit-cell shell model of one dome (:mod:`dpfexplore.unitcell`) (Numba).

Modules
-------
contact
    A flat wall in the shell's way: penalty contact and the state resting against it.
energy
    Energy, gradient and exact Hessian of the discretised axisymmetric shell.
path
    The shell's equilibrium path under apex displacement control (continuation).
records
    The shell's geometry record and the named records its path passes.
"""
