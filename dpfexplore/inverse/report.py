"""What every scene kind's report shares: verified re-solves, result records, summary files.

Nothing the optimiser found is reported as it stands: every reported design is verified alone,
by :func:`dpfexplore.solvers.statics.find_state` (:func:`verify_state`; the statics scenes) or by
a full-model simulation over its whole horizon (the timing scenes, :data:`TIMING_VERIFIED_BY`),
and the values reported are those of that verification; the report says so in each result's
``"verification"``. A design outside the range the closed forms were fitted on (MODEL.md §3) is
flagged (``"fitted_range": false`` with a note).

Each kind's report (``dpfexplore.inverse.scenes.<kind>.report``) makes one result record per
result row: a frozen dataclass with units in its docstring that satisfies
:class:`~.scene_kind.SceneResult` (``reachable``, ``met``, ``to_dict()``: the ``--json`` row).
Each kind's writer fills the directory it is given with these files and its own (design TOMLs,
leg files, figures):

``summary.json``
    the scene, every result (the ``--json`` rows), evaluation counts (:func:`write_summary`)
``history.parquet``
    every evaluated design: parameters, purpose, objective parts, status (read with
    :func:`pandas.read_parquet`)

``dpfexplore design`` gives the writers a staging directory that replaces ``--out`` whole once
everything is written (:func:`dpfexplore.io.result_dirs.result_directory`, manifest
``.dpfexplore-result.json``).
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..lookup.files import write_design_file
from ..model.design import Design
from .evaluation import SceneEvaluator
from .spec import SceneSpec

__all__ = [
    "RESOLVED_ALONE",
    "SIMULATED_ALONE",
    "TIMING_VERIFIED_BY",
    "VERIFIED_BY",
    "StateCheck",
    "fitted_range_warning",
    "json_times",
    "text_number",
    "verify_state",
    "write_result_row",
    "write_summary",
]

#: How the statics scenes verify a reported design.
VERIFIED_BY = (
    "re-solved alone by find_state (exact model, default solver options); the "
    "reported values are this re-solve's"
)
#: How the timing scenes (pick-and-place, walker) verify a reported design's reset times.
TIMING_VERIFIED_BY = (
    "simulated alone to the horizon (no early stop) by the full model (rodas4) at "
    "atol = {atol:g} mm; the reported reset times and classes are this run's"
)
#: The same, as the text summary's last line says it (statics scenes).
RESOLVED_ALONE = "re-solved by find_state"
#: The same, as the text summary's last line says it (timing scenes).
SIMULATED_ALONE = "re-simulated alone in the full model"


def json_times(values) -> list:
    """Reset times for JSON: ``"inf"`` never reset, None never inverted or no contact."""
    out = []
    for v in values:
        v = float(v)
        out.append(None if math.isnan(v) else ("inf" if math.isinf(v) else round(v, 9)))
    return out


@dataclass(frozen=True)
class StateCheck:
    """A design's state re-solved alone by :func:`~dpfexplore.solvers.statics.find_state`.

    Attributes
    ----------
    stable : bool
    status : str
        The solve's status label.
    found : str
        The state found (bits).
    tip : (x, y)
        Tip, mm.
    stiffness, min_eig : float
        Tip stiffness and least Hessian eigenvalue, N/mm.
    nodes : ndarray
        The finger's nodes, mm (for figures).
    """

    stable: bool
    status: str
    found: str
    tip: tuple[float, float]
    stiffness: float
    min_eig: float
    nodes: NDArray


def verify_state(design: Design, state: str, evaluator: SceneEvaluator) -> StateCheck:
    """Re-solve ``state`` of ``design`` alone (counted as a verification)."""
    from ..solvers.statics import find_state

    result = find_state(design, state)
    evaluator.count("verifications")
    return StateCheck(
        stable=result.stable,
        status=result.status.label,
        found=result.found,
        tip=(float(result.tip[0]), float(result.tip[1])),
        stiffness=float(result.stiffness),
        min_eig=float(result.min_eig),
        nodes=result.nodes,
    )


# ----------------------------------------------------------------------------- files


#: Keys of a statics row that a design TOML's ``[result]`` table holds.
_RESULT_KEYS = (
    "state",
    "target",
    "tip",
    "objective",
    "stiffness",
    "apertures",
    "theta_B_deg",
    "base_L",
    "reachable",
    "fitted_range",
    "fitted_range_note",
)


def write_result_row(
    path: str | Path, row: Mapping[str, Any], *, title: str, constants=None
) -> Path:
    """Write a ``[design]`` table (read back by ``dpfexplore states``) and a ``[result]`` table.

    ``row`` is a statics result's ``--json`` row; ``constants``: the scene's set, named in the
    file when it is not the paper's. The file is read back before this returns
    (:func:`~dpfexplore.lookup.files.write_design_file`).
    """
    return write_design_file(
        path,
        row["design"],
        [title, "Written by dpfexplore design; [design] is read by dpfexplore states."],
        {key: row.get(key) for key in _RESULT_KEYS},
        constants=constants,
    )


def write_summary(
    spec: SceneSpec,
    rows: Sequence[Mapping[str, Any]],
    evaluator: SceneEvaluator,
    out: Path,
    *,
    wall_s: float,
    history=None,
) -> list[Path]:
    """Write ``summary.json`` and ``history.parquet`` in ``out``; returns their paths.

    The summary holds the scene, the result rows (each result's ``to_dict()``), the evaluations
    by kind and the wall time; the history every evaluated design (``history``:
    :meth:`SceneEvaluator.history`, if the caller has it).
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    summary = {
        "scene": spec.document,
        "kind": spec.kind,
        "name": spec.name,
        "constants": {"name": spec.constants.name, "fingerprint": spec.constants.fingerprint},
        "results": list(rows),
        "evaluations": dict(evaluator.counts),
        "wall_s": wall_s,
    }
    path = out / "summary.json"
    path.write_text(json.dumps(summary, indent=2, default=_json_default) + "\n")
    history_path = out / "history.parquet"
    (evaluator.history() if history is None else history).to_parquet(history_path, index=False)
    return [path, history_path]


def _json_default(value: Any) -> Any:
    if isinstance(value, (np.floating, np.integer)):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    raise TypeError(f"{type(value).__name__} is not JSON serialisable")


# ----------------------------------------------------------------------------- text


def text_number(value: Any, spec: str, missing: str = "nan") -> str:
    """A row's number in a text summary: ``missing`` for None, a string as it stands."""
    if value is None:
        return missing
    if isinstance(value, str):
        return value
    return format(value, spec)


def fitted_range_warning(row: Mapping[str, Any], indent: str = "      ") -> list[str]:
    """The summary line of a row whose design is outside the fitted range (none otherwise).

    ``indent`` is that of the lines about the row's design (under a table row: six spaces).
    """
    if row.get("fitted_range") is not False:
        return []
    return [
        f"{indent}warning: the design lies outside the closed forms' fitted range "
        f"({row['fitted_range_note']}); its spring constants are extrapolated"
    ]
