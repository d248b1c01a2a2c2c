"""The position-and-stiffness scene (paper eq. opti_pos_stiff): tips and the stiffest designs.

The position scene's targets, problem, search, report and summary
(:mod:`dpfexplore.inverse.scenes.position`), with a stiffness front per target and the paper's
weighted sum.

Modules
-------
spec
    :class:`~.spec.PositionStiffnessSpec`: the position spec and its front and weights.
solve
    :func:`~.solve.solve_position_stiffness`: each target from every N, then its front.
kind
    The scene's record.
"""
