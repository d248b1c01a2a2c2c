"""The walker-leg scene (MODEL.md §10): zones that keep time.

Modules
-------
inversion
    Inversion pressures of each unit (quasi-static continuation).
legs
    Legs composed from section runs; requirement violations.
solve
    :func:`~.solve.solve_walker`: front and middle legs.
report
    The walker report and its figures.
"""
