"""Sweeps: job specs, Latin-hypercube plans, chunked evaluation into Parquet, engines.

Modules
-------
space, _jobfile
    Job specs (TOML) and their validation.
sampling
    Latin-hypercube plans per ``N`` (scipy.stats.qmc), generated chunk by chunk.
evaluation
    What a job computes for a batch of designs (statics, reset times) as columns.
store
    Parquet schema, chunk files, the manifest and reads of committed chunks.
chunks
    The plan of chunks and what a worker does with one.
warmup
    Compiling the kernels a job needs before any worker starts.
engines
    Where chunks run: this process or Dask workers.
driver
    :func:`~.driver.run_sweep`: the whole job, resumable.
datasets
    What a sweep directory holds now: committed chunks, content checksum, verified reads.
variables
    :class:`~.variables.DesignVariables`: bounds and constraints as an exact map of the unit
    box (shared by lookup's polish and inverse design).
"""
