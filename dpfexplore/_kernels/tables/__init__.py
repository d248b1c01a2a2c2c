"""From design arrays to the tables every other kernel reads (Numba).

Modules
-------
design_tables
    Status codes, per-unit parameter tables and their derivative tables of a batch of designs,
    in one compiled pass over a constants set and the beam constants.
model_forms
    The model's closed forms and validation rules (plain Python in :mod:`dpfexplore.model`),
    compiled inline into the kernels.
set_forms
    A constants set's closed forms evaluated a block of domes at a time.
form_loops
    The closed forms of many domes, by a constants set and by the paper's compiled forms
    (``dpfexplore bench identify``).
"""
