"""Many dome units: a job of geometries traced in parallel into the identification table.

A job (TOML) names the geometries, as a grid or a Latin hypercube, and the run's options::

    [grid]                      # the Cartesian product of the lists
    H = [3.0, 3.5, 4.0, 4.5, 5.0]
    t = [0.5, 0.75, 1.0]
    r_b = [5.0]
    E = [26.0]
    nu = [0.35]

    # or: [lhs] n = 200, seed = 0, and [low, high] bounds per parameter (a fixed value is
    # [v, v]); sampled by scipy.stats.qmc.LatinHypercube, scaled explicitly.

    [options]                   # all optional
    n_elements = 128
    travel = 2.2                # in dome heights
    chunk = 8                   # geometries per chunk file
    max_steps = 3000

:func:`run_unitcell_sweep` traces every geometry with :func:`~.shell.unit_cell_curve` on
``workers`` local processes, or on a Dask cluster (``engine="dask"``: a ``LocalCluster`` of
``workers`` processes, or the running scheduler at ``scheduler``; the workers send their chunks
back and this process writes them, so remote workers need no shared disk). The kernels are
compiled in this process first: several processes writing Numba's cache at once is a known
source of crashes. Each chunk is written as two Parquet files
under ``DIR/chunks/`` by a write-then-rename, so an interrupted sweep resumes where it stopped
(chunks present are skipped; the job's fingerprint in ``DIR/job.json`` must match). At the end
``DIR/curves.parquet`` (the table ``identify fit`` reads, every point of every path with its
branch), ``DIR/designs.parquet`` (one row per geometry: status, message, initial stiffness,
first fold, ``tip_dis`` and ``tip_kind``: the inverted rest's travel, or a monostable dome's
ghost's) and, last, ``DIR/manifest.json``. ``identify`` takes ``tip_dis`` for every curve or
for none, so ``curves.parquet`` leaves the column out when some dome has neither a rest nor a
ghost (``designs.parquet`` keeps it, and the manifest counts them). A geometry that
fails is a row with its status and message; it never stops the sweep.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import math
import os
import tomllib
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field
from multiprocessing import get_context
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

__all__ = ["UnitCellJob", "read_job", "run_unitcell_sweep"]

PARAMETERS = ("H", "t", "r_b", "E", "nu")
_DEFAULTS = {"r_b": 5.0, "E": 26.0, "nu": 0.35}
_OPTIONS = {"n_elements": 128, "travel": 2.2, "chunk": 8, "max_steps": 3000}


@dataclass(frozen=True)
class UnitCellJob:
    """The geometries of a sweep and the options of every run.

    Attributes
    ----------
    geometries : ndarray of shape (n, 5)
        ``H, t, r_b`` (mm), ``E`` (MPa), ``nu`` per geometry.
    options : dict
        ``n_elements``, ``travel`` (in dome heights), ``chunk``, ``max_steps``.
    source : dict
        The job as read (recorded in ``job.json``).
    """

    geometries: np.ndarray
    options: dict[str, Any]
    source: dict[str, Any] = field(repr=False)

    @property
    def fingerprint(self) -> str:
        """SHA-256 of the geometries and options: a sweep resumes only under the same job."""
        digest = hashlib.sha256(np.ascontiguousarray(self.geometries).tobytes())
        digest.update(json.dumps(self.options, sort_keys=True).encode())
        return digest.hexdigest()


def _values(table: dict, name: str, where: str) -> list[float]:
    value = table.get(name, _DEFAULTS.get(name))
    if value is None:
        raise ValueError(f"{where}.{name}: missing (give a list of values)")
    values = value if isinstance(value, list) else [value]
    if not values or not all(
        isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v) for v in values
    ):
        raise ValueError(f"{where}.{name}={value!r}: must be a number or a list of numbers")
    return [float(v) for v in values]


def job_from_dict(source: dict[str, Any]) -> UnitCellJob:
    """A job from its TOML tables (module docstring); ``ValueError`` naming the bad entry."""
    unknown = set(source) - {"grid", "lhs", "options"}
    if unknown:
        raise ValueError(f"unknown table(s) {', '.join(sorted(unknown))}: use grid or lhs, options")
    if ("grid" in source) == ("lhs" in source):
        raise ValueError("give exactly one of [grid] or [lhs]")
    if "grid" in source:
        grid = source["grid"]
        columns = [_values(grid, name, "grid") for name in PARAMETERS]
        geometries = np.array(list(itertools.product(*columns)), dtype=float)
    else:
        from scipy.stats import qmc

        lhs = source["lhs"]
        n, seed = lhs.get("n"), lhs.get("seed", 0)
        if not isinstance(n, int) or isinstance(n, bool) or not 1 <= n <= 1_000_000:
            raise ValueError(f"lhs.n={n!r}: must be an integer between 1 and 1e6")
        if not isinstance(seed, int) or isinstance(seed, bool):
            raise ValueError(f"lhs.seed={seed!r}: must be an integer")
        bounds = []
        for name in PARAMETERS:
            values = _values(lhs, name, "lhs")
            low, high = (values * 2)[:2] if len(values) == 1 else values[:2]
            if len(values) > 2 or high < low:
                raise ValueError(f"lhs.{name}={values!r}: give [low, high] with low <= high")
            bounds.append((low, high))
        unit = qmc.LatinHypercube(d=len(PARAMETERS), seed=seed).random(n)
        low, high = np.array(bounds).T
        geometries = low + unit * (high - low)
    options = dict(_OPTIONS)
    for key, value in source.get("options", {}).items():
        if key not in _OPTIONS:
            raise ValueError(f"options.{key}: unknown (one of {', '.join(_OPTIONS)})")
        kind = float if key == "travel" else int
        if isinstance(value, bool) or not isinstance(value, int | float) or value <= 0:
            raise ValueError(f"options.{key}={value!r}: must be a positive number")
        options[key] = kind(value)
    return UnitCellJob(geometries, options, source)


def read_job(path: str | Path) -> UnitCellJob:
    """Read a job file (TOML); ``ValueError`` in one line naming the file and the entry."""
    path = Path(path)
    try:
        source = tomllib.loads(path.read_text())
    except FileNotFoundError:
        raise ValueError(f"{path}: no such file") from None
    except (OSError, tomllib.TOMLDecodeError) as exc:
        raise ValueError(f"{path}: cannot read ({str(exc).splitlines()[0]})") from None
    try:
        return job_from_dict(source)
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from None


def _trace_chunk(rows: list[tuple[int, tuple[float, ...]]], options: dict) -> tuple[list, list]:
    """Trace every geometry of a chunk (in a worker): frames of curves, rows of designs."""
    from .shell import unit_cell_curve

    frames, designs = [], []
    for index, (H, t, r_b, E, nu) in rows:
        record = {"design": index, "H": H, "t": t, "r_b": r_b, "E": E, "nu": nu}
        try:
            run = unit_cell_curve(
                H,
                t,
                r_b,
                E,
                nu,
                travel=options["travel"] * H,
                n_elements=options["n_elements"],
                max_steps=options["max_steps"],
            )
        except ValueError as exc:
            designs.append({**record, "status": "invalid", "message": str(exc)})
            continue
        except Exception as exc:  # one bad geometry never stops the sweep
            designs.append({**record, "status": "error", "message": f"{type(exc).__name__}: {exc}"})
            continue
        designs.append(
            {
                **record,
                "status": run.status,
                "message": run.message,
                "steps": run.n_steps,
                "seconds": run.elapsed,
                "initial_stiffness": run.initial_stiffness,
                "first_fold": float(run.folds[0]) if run.folds.size else math.nan,
                "tip_dis": math.nan if run.tip_dis is None else run.tip_dis,
                "tip_kind": run.tip_kind or "",
                "bistable": run.bistable,
            }
        )
        if run.status in ("reached", "partial"):
            frames.append(run.to_frame(curve=f"d{index:06d}"))
    return frames, designs


def _write(frame: pd.DataFrame, path: Path) -> None:
    staging = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    frame.to_parquet(staging, index=False)
    os.replace(staging, path)  # a chunk is there whole or not at all


def _warm() -> None:
    from .shell import _announce

    _announce()


def _dask_results(chunks, pending, options, workers, scheduler):
    """``(chunk index, result)`` of the pending chunks as Dask workers finish them."""
    import logging

    from distributed import Client, LocalCluster
    from distributed import as_completed as completed

    cluster = None
    if scheduler is None:
        cluster = LocalCluster(
            n_workers=workers,
            threads_per_worker=1,
            processes=True,
            dashboard_address=None,
            silence_logs=logging.ERROR,
        )
    client = Client(scheduler if scheduler is not None else cluster)
    try:
        client.run(_warm)  # each worker loads the kernels this process compiled
        futures = {client.submit(_trace_chunk, chunks[k], options, pure=False): k for k in pending}
        for future in completed(futures):
            yield futures[future], future.result()
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


def run_unitcell_sweep(
    job: UnitCellJob,
    out: str | Path,
    *,
    workers: int = 1,
    progress=None,
    engine: str = "local",
    scheduler: str | None = None,
) -> dict[str, Any]:
    """Trace every geometry of ``job`` into ``out`` (module docstring); resumes a partial run.

    ``engine``: ``"local"`` (``workers`` processes; one: this process) or ``"dask"`` (a
    ``LocalCluster`` of ``workers`` processes, or the scheduler at ``scheduler``, e.g.
    ``tcp://host:8786``). Returns the manifest: counts of designs per status, chunk count, paths.
    """
    out = Path(out)
    if not isinstance(workers, int) or workers < 1:
        raise ValueError(f"workers={workers!r}: must be a positive integer")
    if engine not in ("local", "dask"):
        raise ValueError(f"engine={engine!r}: choose 'local' or 'dask'")
    if scheduler is not None and engine != "dask":
        raise ValueError("scheduler: only with engine='dask'")
    chunks_dir = out / "chunks"
    chunks_dir.mkdir(parents=True, exist_ok=True)
    marker = out / "job.json"
    if marker.exists():
        previous = json.loads(marker.read_text()).get("fingerprint")
        if previous != job.fingerprint:
            raise ValueError(f"{out}: holds a sweep of another job; give a new directory")
    else:
        marker.write_text(json.dumps({"fingerprint": job.fingerprint, "job": job.source}))
    size = job.options["chunk"]
    indexed = list(enumerate(map(tuple, job.geometries.tolist())))
    chunks = [indexed[i : i + size] for i in range(0, len(indexed), size)]
    pending = [
        k for k in range(len(chunks)) if not (chunks_dir / f"designs-{k:05d}.parquet").exists()
    ]
    _warm()  # compile here, before any worker loads the cache
    done = len(chunks) - len(pending)

    def commit(k: int, frames: list, designs: list) -> None:
        nonlocal done
        if frames:
            _write(pd.concat(frames, ignore_index=True), chunks_dir / f"curves-{k:05d}.parquet")
        _write(pd.DataFrame(designs), chunks_dir / f"designs-{k:05d}.parquet")  # written last
        done += 1
        if progress is not None:
            progress(done, len(chunks))

    if engine == "dask" and pending:
        for k, result in _dask_results(chunks, pending, job.options, workers, scheduler):
            commit(k, *result)
    elif workers == 1:
        for k in pending:
            commit(k, *_trace_chunk(chunks[k], job.options))
    elif pending:
        with ProcessPoolExecutor(
            workers, mp_context=get_context("spawn"), initializer=_warm
        ) as pool:
            futures = {pool.submit(_trace_chunk, chunks[k], job.options): k for k in pending}
            for future in as_completed(futures):
                commit(futures[future], *future.result())
    designs = pd.concat(
        [pd.read_parquet(chunks_dir / f"designs-{k:05d}.parquet") for k in range(len(chunks))],
        ignore_index=True,
    ).sort_values("design", ignore_index=True)
    curve_files = sorted(chunks_dir.glob("curves-*.parquet"))
    curves = (
        pd.concat([pd.read_parquet(p) for p in curve_files], ignore_index=True)
        if curve_files
        else pd.DataFrame(columns=["curve", *PARAMETERS, "displacement", "energy", "force"])
    )
    without_tip = 0
    if "tip_dis" in curves:
        # identify takes tip_dis for every curve or none: a dome with no rest and no ghost has none
        without_tip = int(curves.groupby("curve")["tip_dis"].first().isna().sum())
        if without_tip:
            curves = curves.drop(columns="tip_dis")
    _write(curves, out / "curves.parquet")
    _write(designs, out / "designs.parquet")
    manifest = {
        "fingerprint": job.fingerprint,
        "designs": len(designs),
        "chunks": len(chunks),
        "status": {str(k): int(v) for k, v in designs["status"].value_counts().items()},
        "curves": "curves.parquet",
        "curves_without_tip_dis": without_tip,
        "summary": "designs.parquet",
    }
    staging = out / f".manifest.{os.getpid()}.tmp"
    staging.write_text(json.dumps(manifest, indent=2) + "\n")
    os.replace(staging, out / "manifest.json")
    return manifest
