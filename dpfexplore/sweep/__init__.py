"""Sweeps: job specs, Latin-hypercube plans, chunked evaluation into Parquet, engines.

Modules
-------
space
    What a job is: the design space, what is computed, the validated :class:`~.space.JobSpec`.
job_file
    Job files (TOML): the format, read and validated into a job spec (the fields by
    :mod:`dpfexplore.io.toml_fields`).
sampling
    Latin-hypercube plans per ``N`` (scipy.stats.qmc), generated chunk by chunk.
evaluation
    What a job computes for a batch of designs (statics, reset times) as columns.
chunks
    The plan of chunks and what a worker does with one (the finger sweep's work).
work
    The contract between an engine and what a chunk computes (finger or unit-cell sweeps).
warmup
    Compiling the kernels a job needs before any worker starts.
engines
    Where chunks run: this process, local worker processes, or Dask workers.
driver
    :func:`~.driver.run_sweep`: the whole job, resumable.
repair
    Rebuilding a lost manifest from the chunks that verify.
progress
    The progress protocol and the log lines of a running sweep.
storage
    The on-disk side of a finger sweep: dataset schema, chunk files and manifest, row filters,
    what a sweep directory holds (on the shared I/O of :mod:`dpfexplore.io`).
"""
