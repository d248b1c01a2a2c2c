"""From design arrays to the tables every other kernel reads (Numba).

Modules
-------
design_tables
    Status codes, per-unit parameter tables and their derivative tables of a batch of designs,
    in one compiled pass over a constants set and the beam constants.
form_loops
    The closed forms of many domes, by a constants set and by the paper's compiled forms
    (``dpfexplore bench identify``).
"""
