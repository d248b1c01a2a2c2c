"""The multi-aperture gripper scene (MODEL.md §9, paper opti_multi).

Modules
-------
spec
    The ``[gripper]`` table (:class:`~.spec.GripperSpec`).
problem
    :class:`~.problem.GripperProblem`: apertures of the grasp states through the base transform.
solve
    :func:`~.solve.solve_gripper`: apertures per state, stiffness, the metastable tip unit.
windows
    Pressure windows of each state from snap pressures.
report
    :class:`~.report.GripperResult`: the verified gripper; ``gripper.toml`` and figures.
summary
    The text summary of the result.
kind
    The scene's record.
sorting
    The optional sorting objective (``[gripper.sorting]``): object classes the loop must sort.
sorting_search
    The apertures that give the classes the largest margin (derivative-free, on the engine).
sorting_stage
    The scene's solve: :func:`~.solve.solve_gripper`, then the sorting objective if any.
sorting_check
    The written design re-solved and its classes' samples sorted (``sort_objects``).
sorting_plot
    The sorting map of the verified gripper with the classes' boxes.
"""
