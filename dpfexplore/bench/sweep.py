"""``dpfexplore bench sweep``: sweep jobs end to end (sampling, kernels, Parquet), local vs Dask.

What it runs, all with the shipped job files (``jobs/``):

* compile: :func:`dpfexplore.sweep.warmup.compile_kernels` in a fresh process with an empty Numba
  cache (cold) and again with the cache filled (load), apart from every run time below;
* the paper's design-space job (9000 designs) end to end on the local engine, Parquet included
  (median of ``--repeats`` runs into fresh directories); the goal is <= 2 s on 2 cores. Baselines:
  the paper's model at 0.66 s per design (its Table sim_time; quoted, not run), and - run here -
  the same designs one at a time through the same solver (no batching, no parallel chunks) on a
  subset, extrapolated; error: the largest difference between the two on that subset;
* the same job on the Dask engine with a LocalCluster it starts (worker processes x 1 thread):
  wall time with and without cluster start-up, ratio to local, largest difference to local;
* the overnight job's outputs (sequential states, stiffness, reset times) on a subsample of each
  N: designs/s and the projected wall time of the whole job;
* peak RSS of a ``dpfexplore sweep`` child process (and its children) on a job of
  ``--rss-designs`` designs (the paper's space, all-inverted state only, no stiffness: cheap
  outputs, the same storage path), and on a tenth of it, to show memory does not grow with the
  sweep.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

from ._common import REPORTS, count, emit, fresh_process_timings, machine_info

#: The paper's model time per design (Table sim_time), s: the figure the job is measured against.
PAPER_SECONDS_PER_DESIGN = 0.66
JOBS = Path(__file__).resolve().parents[2] / "jobs"
COMPARED = ("tip_x", "tip_y", "curvature", "stiffness", "energy")


def register(subparsers) -> None:
    """Add ``bench sweep``."""
    parser = subparsers.add_parser(
        "sweep",
        help="sweep jobs end to end: paper job wall time, Dask overhead, designs/s, peak RSS",
        description=__doc__.split("\n\n", 1)[1],
    )
    parser.add_argument("--json", action="store_true", help="print the JSON record")
    parser.add_argument(
        "--save", action="store_true", help=f"also write the record to {REPORTS}/bench-sweep.json"
    )
    parser.add_argument("--jobs-dir", type=Path, default=JOBS, help="where the job files are")
    parser.add_argument(
        "--repeats", type=count(1), default=3, help="runs of the paper job (median)"
    )
    parser.add_argument(
        "--baseline-designs",
        type=count(1),
        default=30,
        help="designs per N solved one at a time for the baseline",
    )
    parser.add_argument(
        "--overnight-designs",
        type=count(1),
        default=100,
        help="designs per N of the overnight job's subsample",
    )
    parser.add_argument(
        "--rss-designs",
        type=count(0),
        default=1_000_000,
        help="designs of the peak-RSS run (0 skips it)",
    )
    parser.add_argument(
        "--workers",
        type=count(1),
        default=None,
        help="Dask worker processes (default: one per core)",
    )
    parser.add_argument("--skip-dask", action="store_true", help="do not run the Dask engine")
    parser.add_argument(
        "--no-compile",
        action="store_true",
        help="skip the compile-time measurement (two fresh processes)",
    )
    parser.set_defaults(handler=run)


class PeakRSS:
    """Largest resident set of a process plus its children, sampled every ``interval`` s."""

    def __init__(self, pid: int | None = None, interval: float = 0.02) -> None:
        import psutil

        self.process = psutil.Process(pid or os.getpid())
        self.interval = interval
        self.peak = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._poll, daemon=True)

    def _sample(self) -> int:
        import psutil

        total = 0
        try:
            for proc in [self.process, *self.process.children(recursive=True)]:
                try:
                    total += proc.memory_info().rss
                except psutil.Error:
                    continue
        except psutil.Error:
            return 0
        return total

    def _poll(self) -> None:
        while not self._stop.is_set():
            self.peak = max(self.peak, self._sample())
            self._stop.wait(self.interval)

    def __enter__(self) -> PeakRSS:
        self.peak = self._sample()
        self._thread.start()
        return self

    def __exit__(self, *exc) -> None:
        self._stop.set()
        self._thread.join()

    @property
    def mb(self) -> float:
        """Peak in MB (10^6 bytes)."""
        return self.peak / 1e6


def _compile_seconds() -> dict[str, float]:
    """Cold compile and warm cache-load times of every sweep kernel, each in a new process."""
    (cold,), (warm,) = fresh_process_timings(
        """
        from dpfexplore.sweep.warmup import compile_kernels
        print(compile_kernels())
        """
    )
    return {"compile_cold_s": cold, "cache_load_s": warm}


def _run_job(spec, out: Path, engine) -> tuple[object, float]:
    from ..sweep.driver import run_sweep

    with PeakRSS() as rss:
        summary = run_sweep(spec, out, engine=engine)
    return summary, rss.mb


def _max_difference(a, b) -> float:
    worst = 0.0
    for name in COMPARED:
        if name in a and name in b:
            x, y = a[name].to_numpy(float), b[name].to_numpy(float)
            same_nan = np.isnan(x) == np.isnan(y)
            if not same_nan.all():
                return float("inf")
            finite = ~np.isnan(x)
            if finite.any():
                worst = max(worst, float(np.max(np.abs(x[finite] - y[finite]))))
    return worst


def _paper_job(args, tmp: Path) -> dict:
    from ..sweep.engines import LocalEngine
    from ..sweep.job_file import load_job
    from ..sweep.storage.store import read_results

    spec = load_job(args.jobs_dir / "paper-design-space.toml")
    walls, chunk_phase, rss = [], [], []
    for i in range(args.repeats):
        summary, peak = _run_job(spec, tmp / f"local-{i}", LocalEngine())
        walls.append(summary.wall_s - summary.timings.get("compile_s", 0.0))
        chunk_phase.append(summary.timings["chunks_s"])
        rss.append(peak)
    frame = read_results(tmp / "local-0").sort_values(["design_id", "requested"])
    wall = statistics.median(walls)
    return {
        "spec": spec,
        "frame": frame,
        "designs": spec.n_designs,
        "rows": summary.rows,
        "statuses": summary.statuses,
        "wall_s": wall,
        "wall_runs_s": walls,
        "chunks_s": statistics.median(chunk_phase),
        "designs_per_s": spec.n_designs / wall,
        "peak_rss_mb": max(rss),
        "goal_wall_s": 2.0,
        "paper_model_s": spec.n_designs * PAPER_SECONDS_PER_DESIGN,
        "speedup_vs_paper_model": spec.n_designs * PAPER_SECONDS_PER_DESIGN / wall,
    }


def _one_at_a_time(spec, frame, designs_per_n: int) -> dict:
    """Baseline: the job's first designs of each N solved one per solver call."""
    import pandas as pd

    from ..solvers.statics import solve_batch
    from ..sweep.sampling import sample_designs

    rows, elapsed, count = [], 0.0, 0
    for n in spec.space.n_units:
        batch = sample_designs(spec, n, 0, designs_per_n)
        for i in range(len(batch)):
            one = batch.take(np.array([i]))
            start = time.perf_counter()
            out = solve_batch(
                one,
                spec.compute.states,
                stiffness=spec.compute.stiffness,
                min_eig=spec.compute.min_eig,
            )
            elapsed += time.perf_counter() - start
            count += 1
            rows.append(
                pd.DataFrame(
                    {"n_units": n, "sample": i, **{k: out[k] for k in COMPARED if k in out}}
                )
            )
    baseline = pd.concat(rows, ignore_index=True)
    ours = frame[frame["sample"] < designs_per_n].sort_values(["n_units", "sample"])
    per_design = elapsed / count
    return {
        "designs_timed": count,
        "seconds_per_design": per_design,
        "projected_job_s": per_design * spec.n_designs,
        "max_abs_difference": _max_difference(ours.reset_index(drop=True), baseline),
    }


def _dask_job(args, spec, frame, tmp: Path) -> dict:
    from ..sweep.engines import DaskEngine
    from ..sweep.storage.store import read_results

    engine = DaskEngine(n_workers=args.workers)
    summary, peak = _run_job(spec, tmp / "dask", engine)
    other = read_results(tmp / "dask").sort_values(["design_id", "requested"])
    timings = dict(summary.timings)
    wall = summary.wall_s - timings.get("compile_s", 0.0)
    return {
        "designs": spec.n_designs,
        "workers": len(engine.worker_info),
        "numba_threads_per_worker": sorted(
            {w["numba_threads"] for w in engine.worker_info.values()}
        ),
        "wall_s": wall,
        "chunks_s": timings["chunks_s"],
        "designs_per_s": spec.n_designs / wall,
        "peak_rss_mb": peak,
        "timings_s": timings,
        "max_abs_difference_vs_local": _max_difference(
            frame.reset_index(drop=True), other.reset_index(drop=True)
        ),
    }


def _overnight(args, tmp: Path) -> dict:
    from ..sweep.engines import LocalEngine
    from ..sweep.job_file import load_job

    full = load_job(args.jobs_dir / "overnight.toml")
    spec = dataclasses.replace(full, samples_per_n=args.overnight_designs, chunk_size=None)
    summary, peak = _run_job(spec, tmp / "overnight", LocalEngine())
    wall = summary.wall_s - summary.timings.get("compile_s", 0.0)
    rate = spec.n_designs / wall
    return {
        "designs": spec.n_designs,
        "rows": summary.rows,
        "statuses": summary.statuses,
        "wall_s": wall,
        "designs_per_s": rate,
        "rows_per_s": summary.rows / wall,
        "peak_rss_mb": peak,
        "overnight_designs": full.n_designs,
        "projected_overnight_h": full.n_designs / rate / 3600.0,
    }


RSS_JOB = """
[job]
name = "rss"
seed = 1
samples_per_n = {per_n}
[space]
n_units = [2, 3, 4, 5, 6, 7, 8, 9, 10, 11]
material = "cheetah-95a"
[space.variables]
H = {{min = 3.0, max = 5.0}}
U_sep = {{min = 1.0, max = 5.0}}
U_L = {{min = 5.5, max = 10.0}}
t = {{min = 0.5, max = 1.0}}
t_lim = {{min = 1.0, max = 2.0}}
[compute]
states = "all_inverted"
stiffness = false
"""


def _rss_run(designs: int, tmp: Path) -> dict:
    """Peak RSS of a ``dpfexplore sweep`` child process on a job of ``designs`` designs."""
    per_n = max(1, designs // 10)
    job = tmp / f"rss-{designs}.toml"
    job.write_text(RSS_JOB.format(per_n=per_n))
    command = [
        sys.executable,
        "-m",
        "dpfexplore",
        "sweep",
        str(job),
        "--out",
        str(tmp / f"rss-{designs}"),
    ]
    start = time.perf_counter()
    proc = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    with PeakRSS(proc.pid, interval=0.05) as rss:
        out, err = proc.communicate()
    wall = time.perf_counter() - start
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(command)} failed: {err.strip().splitlines()[-1:]}")
    return {
        "designs": per_n * 10,
        "command": " ".join(command),
        "job": "paper ranges, N = 2..11, all_inverted, no stiffness",
        "wall_s": wall,
        "peak_rss_mb": rss.mb,
        "summary": out.strip().splitlines(),
    }


def run(args: argparse.Namespace) -> int:
    """Handler of ``dpfexplore bench sweep``."""
    record: dict = {"machine": machine_info()}
    record.update(
        {"compile_cold_s": float("nan"), "cache_load_s": float("nan")}
        if args.no_compile
        else _compile_seconds()
    )
    from ..sweep.warmup import compile_kernels

    compile_kernels()  # this process: load the cache so no run below includes compilation
    with tempfile.TemporaryDirectory() as directory:
        tmp = Path(directory)
        paper = _paper_job(args, tmp)
        spec, frame = paper.pop("spec"), paper.pop("frame")
        paper["one_at_a_time"] = _one_at_a_time(spec, frame, args.baseline_designs)
        record["paper_job"] = paper
        engines = {
            "local": {k: paper[k] for k in ("designs", "wall_s", "designs_per_s", "peak_rss_mb")}
        }
        if not args.skip_dask:
            dask = _dask_job(args, spec, frame, tmp)
            dask["overhead_ratio_vs_local"] = dask["wall_s"] / paper["wall_s"]
            dask["chunks_ratio_vs_local"] = dask["chunks_s"] / paper["chunks_s"]
            engines["dask"] = dask
        record["engines"] = engines
        record["overnight_outputs"] = _overnight(args, tmp)
        if args.rss_designs:
            record["rss"] = {
                "small": _rss_run(max(10, args.rss_designs // 10), tmp),
                "large": _rss_run(args.rss_designs, tmp),
            }
    emit(
        record,
        as_json=args.json,
        text=_text(record),
        save=REPORTS / "bench-sweep.json" if args.save else None,
    )
    return 0


def _text(r: dict) -> str:
    m, p = r["machine"], r["paper_job"]
    base = p["one_at_a_time"]
    runs = ", ".join(f"{w:.2f}" for w in p["wall_runs_s"])
    lines = [
        "sweep benchmark (wall times exclude compilation; medians where repeated)",
        f"machine: {m['cpu']}, {m['cores']} cores, numba {m['numba']} "
        f"({m['threading_layer']}, {m['numba_threads']} threads)",
        f"compile: cold {r['compile_cold_s']:.1f} s, cache load {r['cache_load_s']:.2f} s",
        "",
        f"paper design-space job: {p['designs']} designs, {p['rows']} rows, "
        "end to end with Parquet",
        f"  local engine   {p['wall_s']:8.2f} s  {p['designs_per_s']:9.0f} designs/s  "
        f"(goal <= {p['goal_wall_s']:.0f} s; runs {runs})",
        f"  one at a time  {base['projected_job_s']:8.2f} s  projected from "
        f"{base['designs_timed']} designs ({1e3 * base['seconds_per_design']:.2f} ms each); "
        f"ratio {base['projected_job_s'] / p['wall_s']:.1f}x; "
        f"max |diff| {base['max_abs_difference']:.1e}",
        f"  paper's model  {p['paper_model_s']:8.0f} s  (0.66 s/design, quoted); ratio "
        f"{p['speedup_vs_paper_model']:.0f}x",
    ]
    if "dask" in r["engines"]:
        d = r["engines"]["dask"]
        lines.append(
            f"  dask engine    {d['wall_s']:8.2f} s  {d['designs_per_s']:9.0f} designs/s  "
            f"({d['workers']} workers x {d['numba_threads_per_worker']} threads)"
        )
        t = d["timings_s"]
        lines.append(
            f"    {d['overhead_ratio_vs_local']:.2f}x local in all; cluster start "
            f"{t.get('cluster_start_s', 0):.2f} s, worker warm-up {t.get('worker_warmup_s', 0):.2f}"
            f" s, chunks {d['chunks_s']:.2f} s ({d['chunks_ratio_vs_local']:.2f}x local's "
            f"{p['chunks_s']:.2f} s), close {t.get('cluster_close_s', 0):.2f} s; "
            f"max |diff| vs local {d['max_abs_difference_vs_local']:.1e}"
        )
    lines.append(
        "  peak RSS: "
        + ", ".join(f"{name} {e['peak_rss_mb']:.0f} MB" for name, e in r["engines"].items())
    )
    o = r["overnight_outputs"]
    lines += [
        "",
        "overnight job outputs (sequential states, stiffness, reset times), "
        f"{o['designs']} designs:",
        f"  {o['designs_per_s']:.0f} designs/s ({o['rows_per_s']:.0f} rows/s); whole job "
        f"({o['overnight_designs']} designs) projected {o['projected_overnight_h']:.1f} h; "
        f"statuses {o['statuses']}",
    ]
    if "rss" in r:
        for key in ("small", "large"):
            s = r["rss"][key]
            lines.append(
                f"peak RSS of `dpfexplore sweep` ({s['job']}), {s['designs']} designs: "
                f"{s['peak_rss_mb']:.0f} MB in {s['wall_s']:.0f} s"
            )
    return "\n".join(lines)
