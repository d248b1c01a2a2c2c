"""The pick-and-place scene (MODEL.md §9, paper opti_pick_and_place): reset times by design.

Modules
-------
spec
    The ``[pickplace]`` table of a scene file and its records.
problem
    :class:`~.problem.ResetProblem`: reset times of box points; brackets and roots on lines.
screen
    Screening the box for reachable reset times, and checks of a design.
front
    The two-profile difference front.
solve
    :func:`~.solve.solve_pickplace`: targets and fronts.
report
    Verified result records; the result TOMLs.
figures
    The report's figures: reset map, objective history, difference front.
summary
    The text summary of the results.
kind
    The scene's record.
"""
