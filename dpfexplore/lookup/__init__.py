"""Lookup: from target outputs to verified designs of a sweep dataset.

A stage of its own between the sweep and inverse design: it reads a dataset
(:mod:`dpfexplore.sweep.storage.datasets`), indexes its outputs, answers nearest-design queries and
polishes candidates with the exact model. The optimiser's seeded candidates come from here.

Modules
-------
index
    Nearest-neighbour index over a dataset's output columns (``scipy.spatial.cKDTree``).
store
    The index saved beside its dataset; refused when stale.
polish
    Polish a design with the exact model until its outputs meet a target.
query
    :func:`~.query.lookup`: query, polish, verify, stage by stage.
rows
    Candidate rows read back from their chunks, re-solved and merged.
results
    :class:`~.results.Candidate` and :class:`~.results.LookupResult`, with provenance.
files
    Candidates written as ``[design]`` TOML files.
"""
