"""The on-disk side of a sweep: what is written, how it is committed, how it is read back.

Modules
-------
schema
    Dataset columns with their units and descriptions; the metadata stored with every chunk.
store
    Parquet chunk files, atomic commits through the manifest, verified readers
    (:func:`~.store.read_results`).
row_filter
    ``--where`` row filters: parsed by a grammar, evaluated by Arrow on the columns, never run as
    code.
datasets
    What a sweep directory holds now: committed chunks, content checksum, verified reads.

The locks, atomic writes and chunk commits it uses are the ones every stage shares
(:mod:`dpfexplore.io`).
"""
