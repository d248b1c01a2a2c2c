"""The walker-leg scene (MODEL.md §10): zones that keep time.

Modules
-------
spec
    The ``[walker]`` table of a scene file and its records.
inversion
    Inversion pressures of each unit (quasi-static continuation).
legs
    Legs composed from section runs; requirement violations.
search
    The runs a search is made of: section runs, batch scans, inversion pressures, bounds.
zones
    The purple and green zones (shared by every leg).
action
    The front and middle legs' action units.
solve
    :func:`~.solve.solve_walker`: front and middle legs from the zones and action units.
report
    Verified leg records; the leg files and figures.
summary
    The text summary of the legs.
kind
    The scene's record.
"""
