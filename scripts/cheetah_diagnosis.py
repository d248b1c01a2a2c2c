"""Why ``shell-extended`` loses the all-inverted state of five Cheetah 95A fingers: the record.

Every printed finger of the paper (``dpfexplore/data/measurements/paper.toml``) is solved by
the exact model (:func:`~dpfexplore.solvers.statics.find_state`) under the paper's set, under
``shell-extended`` and under the six sets between them that take some of the three closed forms
(``k_hat``, ``alpha``, ``tip_ratio``) from one and the rest from the other. Beside that, per
unit:

* the dome's constants under both sets (``k_b``, ``α``, ``tip_dis``, ``d``), its distance from
  the bistable edge ``1/9 − α`` and the law's barrier seen from the inverted rest;
* the frame's stiffness against the dome's extension, ``K_f``: the lattice without domes, at
  rest (its Hessian from the package's kernel), seen at the dome's two nodes. It holds only
  posts, limiting layer and torsion springs, so it is the same under every constants set;
* the dome's *holding capacity* ``k_b (1 − 9α) / 8``: a dome of the law (MODEL.md §4) pushing
  against a linear spring ``K`` has an inverted equilibrium iff ``K <= k_b (1 − 9α) / 8``
  (``(1 − α)(3u − 2u²) = 1 + K/k_b`` has a root iff its left side's maximum, ``9 (1 − α)/8``
  at ``u = 3/4``, reaches ``1 + K/k_b``); the reach ``d`` drops out;
* the hold number ``Q = K_f / capacity``: ``Q < 1`` says the unit stays inverted. Its
  classification is checked against the exact model's found state, unit by unit, under all
  eight sets.

Then the shell's own per-dome constants (the states law on the pinned cap, the packaged set's
recipe) at each snapping unit's dome, at ``ν`` = 0.35 and at the ends of the set's ``ν`` range,
and the failing fingers at NinjaFlex's ``E``. Writes ``results/reports/cheetah-diagnosis.json``
(read back) and prints its summary::

    .venv/bin/python scripts/cheetah_diagnosis.py   # about 1 min of CPU once compiled
"""

from __future__ import annotations

import argparse
import dataclasses
import itertools
import json
import sys
import time
from collections.abc import Sequence
from importlib.metadata import version
from pathlib import Path

import numpy as np

from dpfexplore._kernels import layout as lay
from dpfexplore._kernels.lattice import lattice_hessian, pack_free, rest_nodes
from dpfexplore.identification.causes import box_set
from dpfexplore.io.files import atomic_write, read_json_bounded
from dpfexplore.measurements import validate
from dpfexplore.measurements.fingers import packaged_measurements, read_measurements
from dpfexplore.model.constants_set import DEFAULT, ConstantsSet, find_constants_set
from dpfexplore.solvers.lattice import lattice_params
from dpfexplore.solvers.statics import find_state

#: The closed forms a set holds, in the order the swaps name them.
FORMS = ("k_hat", "alpha", "tip_ratio")
#: The causes' record: the shell's per-dome constants over the paper's box at ν = 0.35.
CAUSES = Path("results/reports/unitcell-causes.json")
#: The shell's ν range of the packaged set's data, and the lattice's ν.
NU = (0.30, 0.35, 0.49)


def hybrid(paper: ConstantsSet, shell: ConstantsSet, from_shell: Sequence[str]) -> ConstantsSet:
    """The paper's set with the forms ``from_shell`` taken from ``shell`` (paper's domain)."""
    forms = {f: getattr(shell if f in from_shell else paper, f) for f in FORMS}
    name = "paper" if not from_shell else "paper+shell:" + ",".join(from_shell)
    return dataclasses.replace(paper, name=name, validation=None, **forms)


def frame_stiffness(design) -> np.ndarray:
    """``K_f`` of each unit (N/mm): the dome-less lattice at rest, at the dome's two nodes.

    The Hessian of the lattice with every ``k_b`` set to zero (posts, limiting layer and
    torsion springs only: independent of the constants set), at the undeformed geometry;
    ``K_f = 1 / (gᵀ H⁻¹ g)`` with ``g`` the gradient of the dome's length.
    """
    params = lattice_params(design)
    up = params.unit_params.copy()
    up[:, lay.COL_KB] = 0.0
    n = up.shape[0]
    pos = np.empty((2 * n + 2, 2))
    rest_nodes(up, params.h, pos)
    x = np.empty(4 * n - 2)
    pack_free(pos, n, x)
    grad, hess = np.empty(4 * n - 2), np.empty((4 * n - 2, 4 * n - 2))
    lattice_hessian(x, up, params.h, grad, hess)
    out = np.empty(n)
    for k in range(1, n + 1):
        g = np.zeros(4 * n - 2)
        for node, sign in ((2 * k - 2, -1.0), (2 * k, 1.0)):  # D_{k-1}, D_k along the dome line
            free = 0 if node == 2 else node - 3 if node >= 4 else -1
            if free >= 0:
                g[2 * free] = sign
        out[k - 1] = 1.0 / float(g @ np.linalg.solve(hess, g))
    return out


def dome_springs(constants: ConstantsSet, design) -> dict:
    """``k_b``, ``alpha``, ``d`` of every unit of ``design`` under ``constants``."""
    H, U_sep = np.asarray(design.H), np.asarray(design.U_sep)
    return constants.springs(H, design.t, design.r_b, design.E, U_sep, design.t_ch)


def dome_law(k_b, alpha, d) -> dict:
    """Capacity, edge distance and the law's barrier seen from the inverted rest (MODEL.md §4)."""
    k_b, alpha, d = (np.asarray(v, dtype=float) for v in (k_b, alpha, d))
    root = np.sqrt(np.clip((1 - 9 * alpha) / (1 - alpha), 0, None))
    u_b, u_m = (3 - root) / 4, (3 + root) / 4

    def energy(u):
        return 0.5 * k_b * (u * d) ** 2 * (1 + (1 - alpha) * (u * u - 2 * u))

    return {
        "capacity": k_b * (1 - 9 * alpha) / 8,
        "edge": 1 / 9 - alpha,
        "u_barrier": u_b,
        "barrier_from_inverted": energy(u_b) - energy(u_m),
    }


def unit_records(finger, sets: dict[str, ConstantsSet], found: dict[str, str]) -> list[dict]:
    """Per unit of one finger: its dome under both sets, the frame, the hold number."""
    design = finger.design
    k_f = frame_stiffness(design.replace(constants=sets["paper"]))
    params = lattice_params(design.replace(constants=sets["paper"]))
    torsion = params.unit_params[:, lay.COL_KT] / params.h**2  # k_t / h², N/mm
    rows = []
    for k in range(design.n_units):
        H = float(design.H[k])
        row = {
            "unit": k + 1,
            "H": H,
            "t": design.t,
            "H_over_rb": H / design.r_b,
            "t_over_rb": design.t / design.r_b,
            "K_f": float(k_f[k]),
            "k_t_over_h2": float(torsion[k]),
        }
        for name, cs in sets.items():
            springs = cs.springs(H, design.t, design.r_b, design.E, design.U_sep[k], design.t_ch)
            tip = float(cs.evaluate(H, design.t, design.r_b, design.E)["tip_dis"])
            law = dome_law(springs["k_b"], springs["alpha"], springs["d"])
            row[name] = {
                "k_b": float(springs["k_b"]),
                "alpha": float(springs["alpha"]),
                "tip_dis": tip,
                "d": float(springs["d"]),
                **{key: float(v) for key, v in law.items()},
                "Q": float(k_f[k] / law["capacity"]),
                "in_domain": bool(cs.in_domain(H, design.t, design.r_b, design.E, design.nu)),
                "held": found[name][k] == finger.state[k],
            }
        rows.append(row)
    return rows


def swaps(fingers, paper, shell) -> tuple[dict, dict]:
    """The found state of every finger under the eight mixtures, and the criterion's agreement."""
    table, agree, total = {}, 0, 0
    disagreements = []
    k_f = {f.name: frame_stiffness(f.design.replace(constants=paper)) for f in fingers}
    for r in range(len(FORMS) + 1):
        for subset in itertools.combinations(FORMS, r):
            cs = hybrid(paper, shell, subset)
            key = "+".join(subset) or "none"
            table[key] = {}
            for f in fingers:
                design = f.design.replace(constants=cs)
                result = find_state(design, f.state)
                table[key][f.name] = result.found
                springs = dome_springs(cs, design)
                q = (
                    k_f[f.name]
                    / dome_law(springs["k_b"], springs["alpha"], springs["d"])["capacity"]
                )
                for k, bit in enumerate(result.found):
                    total += 1
                    predicted = "1" if q[k] < 1 else "0"
                    if predicted == bit:
                        agree += 1
                    else:
                        disagreements.append(f"{key}: {f.name} unit {k + 1} Q = {q[k]:.3f}")
    return table, {"units": total, "agree": agree, "disagreements": disagreements}


def shell_domes(domes: Sequence[tuple[float, float]], shell: ConstantsSet) -> list[dict]:
    """The shell's own states-law constants at each dome (pinned cap, E = 26), per ν."""
    from dpfexplore.identification.states import fit_states, states_curves_from_frame
    from dpfexplore.unitcell.shell import unit_cell_curve

    out = []
    for H, t in domes:
        entry = {"H": H, "t": t}
        for nu in NU:
            run = unit_cell_curve(H, t, nu=nu)
            (curve,) = states_curves_from_frame(run.to_frame())
            fit = fit_states(curve)
            law = dome_law(fit.k_b, fit.alpha, fit.d)
            entry[f"nu={nu}"] = {
                "k_b": fit.k_b,
                "alpha": fit.alpha,
                "capacity": float(law["capacity"]),
                "tip_kind": run.tip_kind,
            }
        values = shell.evaluate(H, t, 5.0, 26.0)
        entry["set"] = {
            "k_b": float(values["k_b"]),
            "alpha": float(values["alpha"]),
            "capacity": float(dome_law(values["k_b"], values["alpha"], 1.0)["capacity"]),
        }
        out.append(entry)
    return out


def _jsonable(value):
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not np.isfinite(value):
        return None
    return value


def main(argv: Sequence[str] | None = None) -> int:
    """Compute the record, write it (JSON), read it back, print its summary."""
    parser = argparse.ArgumentParser(
        prog="scripts/cheetah_diagnosis.py", description=__doc__.split("\n\n")[0]
    )
    parser.add_argument("--json", type=Path, default=Path("results/reports/cheetah-diagnosis.json"))
    args = parser.parse_args(argv)
    start = time.process_time()
    paper, shell = DEFAULT, find_constants_set("shell-extended")
    fingers = read_measurements(packaged_measurements()[0]).fingers
    sets = {"paper": paper, "shell-extended": shell}

    check = validate(constants=[paper, shell])
    summaries = [
        {
            "set": s.constants,
            "material": s.material,
            "held": s.held,
            "fingers": s.fingers,
            "mean_distance": s.mean_distance,
        }
        for s in check.summaries
    ]
    found = {(r.constants, r.finger): r.found for r in check.fingers}  # validate's states
    table, criterion = swaps(fingers, paper, shell)
    per_finger = {}
    for f in fingers:
        states = {name: found[(name, f.name)] for name in sets}
        per_finger[f.name] = {
            "material": f.material_label,
            "state": f.state,
            "found": states,
            "t_lim": f.design.t_lim,
            "U_sep": f.design.U_sep[0],
            "U_L": f.design.U_L[0],
            "E": f.design.E,
            "units": unit_records(f, sets, states),
        }
    # E cancels: the failing fingers printed in NinjaFlex's E settle in the same states
    at_12 = {
        f.name: find_state(f.design.replace(constants=shell, E=12.0), f.state).found
        for f in fingers
        if f.material_label.startswith("Cheetah")
    }
    snapping = sorted(
        {
            (u["H"], u["t"])
            for rec in per_finger.values()
            for u in rec["units"]
            if not u["shell-extended"]["held"]
        }
    )
    # the shell's per-dome states law at the lattice's ν = 0.35 over the paper's box (the causes
    # record's grid, unitcell-causes.json), the cells' reach: the set of the causes' study
    causes = read_json_bounded(CAUSES, "record")
    box = box_set(causes["units"], "states-nu0.35-box", "cap pinned: states", "square pinned")
    box_check = validate(constants=[paper, box])
    box_q = {}
    for f in fingers:
        design = f.design.replace(constants=box)
        springs = dome_springs(box, design)
        law = dome_law(springs["k_b"], springs["alpha"], springs["d"])
        box_q[f.name] = [float(q) for q in frame_stiffness(design) / law["capacity"]]
    box_record = {
        "recipe": "states law of the pinned cap at nu = 0.35 on the paper's 7 x 6 box grid, "
        "the cells' reach (dpfexplore.identification.causes.box_set)",
        "found": {r.finger: r.found for r in box_check.of_set(box.name)},
        "Q": box_q,
        "validate": [
            {"material": s.material, "held": s.held, "mean_distance": s.mean_distance}
            for s in box_check.summaries
            if s.constants == box.name
        ],
    }
    record = {
        "what": "why shell-extended loses the all-inverted state of Cheetah 95A fingers: form "
        "swaps, per-unit constants, frame stiffness, hold numbers (scripts/cheetah_diagnosis.py)",
        "command": f"python scripts/cheetah_diagnosis.py --json {args.json}",
        "versions": {name: version(name) for name in ("dpfexplore", "numpy", "scipy")},
        "validate": summaries,
        "swaps": table,
        "criterion": criterion,
        "fingers": per_finger,
        "shell_at_E_12": at_12,
        "shell_domes": shell_domes(snapping, shell),
        "box_set_nu_0.35": box_record,
    }
    record["cpu_s"] = time.process_time() - start
    args.json.parent.mkdir(parents=True, exist_ok=True)
    text = json.dumps(_jsonable(record), indent=1) + "\n"
    atomic_write(args.json, text)
    back = read_json_bounded(args.json, "record")
    if back != json.loads(text):
        raise RuntimeError(f"{args.json}: read back differs from what was written")
    print(
        json.dumps(_jsonable({k: record[k] for k in ("validate", "swaps", "criterion")}), indent=1)
    )
    print(f"wrote {args.json} ({record['cpu_s']:.0f} s of CPU)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
