"""Grasp of a rigid disk by the gripper's finger (Numba).

Modules
-------
records
    The named records the grasp kernels take (disk, controls, workspace) and the output columns.
contact
    Gap between the disk and each limiting-layer segment, the C² one-sided penalty, and the
    finger's energy with contact (gradient, Hessian).
equilibrium
    Globalised Newton on the energy with contact, augmented-Lagrangian updates of the penalty's
    shifts, and the disk grown into place from where it first touches.
batch
    A grasp's outputs, the pull-out path that gives a state's payload, and the ``prange`` sorting
    loop over many objects.
"""
