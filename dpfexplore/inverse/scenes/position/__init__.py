"""The position scene (paper eq. opti_pos): tips of a targeted state at target points.

Modules
-------
spec
    Its targets and ``[objective]`` (:class:`~.spec.PositionSpec`); ``--seeds``.
problem
    :class:`~.problem.PositionProblem`: the tip of one state minus its target.
solve
    :func:`~.solve.solve_position_target`: candidates and refinements over every N.
report
    :class:`~.report.PositionResult`: verified rows; the target TOMLs and figures.
summary
    The text table of the results.
kind
    The scene's record.
"""
