"""Shared I/O: how every stage reads and writes what it leaves on disk, and reads it back checked.

The bottom of the pipeline beside :mod:`dpfexplore.numerics`: it knows no model, no dataset and
no job. Atomic files (:mod:`.files`), one writer per directory (:mod:`.lock`), chunk files
committed through a manifest with checksums (:mod:`.commits`), result directories that are
complete or absent (:mod:`.result_dirs`), and the one TOML field reader of jobs, scenes, legs and
design files (:mod:`.toml_fields`).
"""
