"""Inverse design: from what a finger must do to verified designs.

Lookup over sweep datasets, surrogates, scenes and the optimiser that solves them build on the
solvers and sweeps below this package.

Modules: :mod:`.variables` (design variables as an exact reparametrisation of the unit box),
:mod:`.datasets` (what a sweep directory holds now, its content checksum), :mod:`.lookup_index`
(nearest-neighbour index over output columns), :mod:`.lookup_store` (the index saved beside its
dataset, refused when stale), :mod:`.refine` (polish a design with the exact model until it meets
a target), :mod:`.lookup` (the lookup itself: query, refine, verify), :mod:`.design_files`
(designs as TOML files).
"""
