"""Helpers of the sweep tests: small job specs and an evaluator that does not need the solver.

:class:`UnitConstantsEvaluator` is a real (cheap) evaluation: one row per unit of each design
with the unit's spring constants from :func:`dpfexplore.solvers.lattice.pack_batch` - a variable
number of rows per design, like the solver's design-state rows, and one row with its status for an
invalid design. Tests of the store and the engines use it so that they exercise the machinery
rather than the solver.
"""

from __future__ import annotations

import copy
import sys
import time

import cloudpickle
import numpy as np
import psutil
import pyarrow as pa

from dpfexplore._kernels import layout as lay
from dpfexplore.model import status as st
from dpfexplore.solvers.lattice import pack_batch
from dpfexplore.sweep.job_file import parse_job
from dpfexplore.sweep.storage.store import STATUS_TYPE, column

# Dask workers cannot import this module from the tests directory; ship it by value.
cloudpickle.register_pickle_by_value(sys.modules[__name__])

PAPER_VARIABLES = {
    "H": {"min": 3.0, "max": 5.0},
    "U_sep": {"min": 1.0, "max": 5.0},
    "U_L": {"min": 5.5, "max": 10.0},
    "t": {"min": 0.5, "max": 1.0},
    "t_lim": {"min": 1.0, "max": 2.0},
}


def job_dict(**changes) -> dict:
    """A small valid job as a TOML-shaped dict; ``changes`` maps dotted keys to new values."""
    data = {
        "job": {"name": "test-job", "seed": 7, "samples_per_n": 60, "sampler": "lhs"},
        "space": {
            "n_units": [2, 3],
            "material": "cheetah-95a",
            "variables": copy.deepcopy(PAPER_VARIABLES),
            "constraints": {"heights": "free", "equal_U_sep": False, "equal_U_L": False},
        },
        "compute": {"states": "all_inverted", "stiffness": True, "min_eig": False},
    }
    for dotted, value in changes.items():
        *parents, last = dotted.split(".")
        table = data
        for part in parents:
            table = table.setdefault(part, {})
        if value is DELETE:
            table.pop(last, None)
        else:
            table[last] = value
    return data


DELETE = object()


def make_job(**changes):
    """:func:`job_dict` validated into a JobSpec."""
    return parse_job(job_dict(**changes))


def toml_text(data: dict) -> str:
    """Minimal TOML writer for the job dicts above (tables of scalars, lists, inline tables)."""

    def value(v):
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, str):
            return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
        if isinstance(v, list):
            return "[" + ", ".join(value(x) for x in v) + "]"
        if isinstance(v, dict):
            return "{" + ", ".join(f"{k} = {value(x)}" for k, x in v.items()) + "}"
        return repr(v)

    lines = []

    def table(name, content):
        scalars = {k: v for k, v in content.items() if not (isinstance(v, dict) and _is_table(k))}
        lines.append(f"[{name}]")
        lines.extend(f"{k} = {value(v)}" for k, v in scalars.items())
        for k, v in content.items():
            if isinstance(v, dict) and _is_table(k):
                table(f"{name}.{k}", v)

    for name, content in data.items():
        table(name, content)
    return "\n".join(lines) + "\n"


def _is_table(key: str) -> bool:
    return key in {"variables", "constraints", "reset_times"}


class UnitConstantsEvaluator:
    """One row per unit: ``unit``, ``k_b`` (N/mm), ``alpha``, ``d`` (mm), with a status.

    Parameters
    ----------
    delay : float
        Seconds to sleep per chunk (to hold a chunk "in flight" in fault tests).
    """

    def __init__(self, delay: float = 0.0) -> None:
        self.delay = delay

    def warm_up(self) -> float:
        return 0.0

    def fields(self, max_units: int) -> list[pa.Field]:
        return [
            column("unit", pa.int8(), "1", "unit number (-1: invalid design)"),
            column("k_b", pa.float64(), "N/mm", "dome stiffness"),
            column("alpha", pa.float64(), "1", "dome energy ratio"),
            column("d", pa.float64(), "mm", "dome reach"),
            column("status", pa.int8(), "1", "design status code"),
            column("status_label", STATUS_TYPE, "1", "design status"),
        ]

    def __call__(self, batch):
        if self.delay:
            time.sleep(self.delay)
        table, _, n_units = pack_batch(batch)
        status = batch.status()
        valid = status == st.OK
        per_design = np.where(valid, n_units, 1)
        design_index = np.repeat(np.arange(len(batch)), per_design)
        parts = [
            np.arange(1, n + 1) if ok else np.array([-1])
            for n, ok in zip(n_units, valid, strict=True)
        ]
        unit = np.concatenate(parts) if parts else np.empty(0, dtype=np.int64)
        slot = np.where(unit > 0, unit - 1, 0)
        values = table[design_index, slot]
        bad = unit < 0
        pick = lambda col: np.where(bad, np.nan, values[:, col])  # noqa: E731
        return {
            "design_index": design_index,
            "unit": unit.astype(np.int8),
            "k_b": pick(lay.COL_KB),
            "alpha": pick(lay.COL_ALPHA),
            "d": pick(lay.COL_D),
            "status": status[design_index],
            "status_label": status[design_index],
        }


class CrashingEvaluator(UnitConstantsEvaluator):
    """Aborts the process that evaluates a chunk of designs of ``n_units`` units."""

    def __init__(self, n_units: int) -> None:
        super().__init__()
        self.n_units = n_units

    def __call__(self, batch):
        import os

        if batch.n_units[0] == self.n_units:
            os.abort()
        return super().__call__(batch)


def spawned_workers(parent: psutil.Process | None = None) -> list[psutil.Process]:
    """Live spawned worker processes: this process's children, or all of ``parent``'s descendants.

    Zombies (an earlier test's) are not counted.
    """
    children = psutil.Process().children() if parent is None else parent.children(recursive=True)
    found = []
    for child in children:
        try:
            if "spawn_main" in " ".join(child.cmdline()):
                found.append(child)
        except (psutil.ZombieProcess, psutil.NoSuchProcess, psutil.AccessDenied):
            continue
    return found
