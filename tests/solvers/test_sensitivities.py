"""Design sensitivities: closed-form derivatives, kernel pieces and the implicit-function result.

Every derivative is checked against central differences: of the NumPy closed forms (5-point
stencil), of the lattice's gradient, energy and ``rᵀHr`` at a fixed shape, and of the solver
itself (the state re-solved at ``θ ± ε`` and ``θ ± ε/2``, Richardson-extrapolated, so that the
difference's own error is ~1e-10 of the derivative's scale and a 1e-6 tolerance tests ours).
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import assume, example, given, settings
from hypothesis import strategies as hs
from model_helpers import FINGER, height_for_alpha, other_set

from dpfexplore import Design, DesignBatch, SolverOptions, Status, find_state, solve_batch
from dpfexplore._kernels import layout as lay
from dpfexplore._kernels.lattice import HESSIAN, assemble, lattice_hessian
from dpfexplore._kernels.records import (
    DesignDerivatives,
    Lattice,
    SensitivityRows,
    TangentParameter,
)
from dpfexplore._kernels.sensitivity.states import (
    N_SENS,
    design_sensitivities,
    tangent,
    third_derivative_contraction,
    workspace,
)
from dpfexplore._kernels.statics.states import geometric_guess
from dpfexplore._kernels.tables.design_tables import DP_T, DP_TLIM, N_DPARAM
from dpfexplore.model.constants import (
    DERIVATIVE_PARAMETERS,
    constant_derivatives,
    dome_extrema,
    inversion_threshold,
)
from dpfexplore.model.constants_set import DEFAULT
from dpfexplore.model.domain import MAX_UNITS
from dpfexplore.model.validation import status_code
from dpfexplore.solvers import statics
from dpfexplore.solvers.lattice import (
    _unit_constants,
    batch_constants,
    design_kernel_tables,
    kernel_tables,
    spring_constants,
)
from dpfexplore.solvers.sensitivities import COLUMNS, OUTPUTS, batch_columns, parameter_names

TIGHT = SolverOptions(xtol=1e-11)
#: Largest difference from the Richardson-extrapolated solver differences, relative to the
#: output's largest derivative over all parameters.
REL = 1e-6


# --- closed forms -----------------------------------------------------------------------------


def constants_at(values: dict) -> dict:
    c = _unit_constants(
        values["H"],
        values["U_L"],
        values["U_sep"],
        values["t"],
        values["t_lim"],
        values["E"],
        values["nu"],
        values["r_b"],
        values["t_ch"],
        DEFAULT,
        domes=False,
    )
    return {
        name: np.asarray(c[name], float)
        for name in ("R", "k_b", "alpha", "d", "k_lim", "k_post", "k_t", "p", "h")
    }


@pytest.mark.parametrize("seed", [0, 1])
def test_constant_derivatives_equal_central_differences(seed):
    rng = np.random.default_rng(seed)
    n = 400
    values = {
        "H": rng.uniform(2.6, 5.5, n),
        "U_L": rng.uniform(5.0, 10.5, n),
        "U_sep": rng.uniform(0.8, 5.2, n),  # up to 5.2: some reaches are clamped
        "t": rng.uniform(0.45, 1.1, n),
        "t_lim": rng.uniform(0.9, 2.1, n),
        "E": rng.uniform(5.0, 40.0, n),
        "nu": 0.35,
        "r_b": 5.0,
        "t_ch": 1.0,
    }
    analytic = constant_derivatives(
        *(values[k] for k in ("H", "U_L", "U_sep", "t", "t_lim", "E", "nu", "r_b", "t_ch"))
    )
    clamped = constants_at(values)["d"] == 0.01
    assert 0 < clamped.sum() < n
    for param in DERIVATIVE_PARAMETERS:
        step = 1e-3
        stencil = {}
        for m in (-2, -1, 1, 2):
            shifted = dict(values)
            shifted[param] = values[param] + m * step
            stencil[m] = constants_at(shifted)
        for name, table in analytic.items():
            fd = (
                stencil[-2][name] - 8 * stencil[-1][name] + 8 * stencil[1][name] - stencil[2][name]
            ) / (12 * step)
            # skip the few points whose stencil crosses the d clamp (a kink)
            keep = np.ones(n, bool)
            if name == "d":
                keep = np.all([stencil[m]["d"] == 0.01 for m in stencil], axis=0) | np.all(
                    [stencil[m]["d"] != 0.01 for m in stencil], axis=0
                )
            # round-off of the stencil: ~1e-16 of the constant over the step
            scale = np.abs(fd).max() + np.abs(stencil[1][name]).max()
            np.testing.assert_allclose(
                table[param][keep],
                fd[keep],
                rtol=1e-8,
                atol=1e-9 * scale,
                err_msg=f"d{name}/d{param}",
            )
    # on the clamped branch d is a constant
    for param in DERIVATIVE_PARAMETERS:
        assert np.all(analytic["d"][param][clamped] == 0.0)


def test_kernel_derivative_table_equals_the_numpy_one():
    """The kernels chain through the constants set's own derivatives; for the paper's set they
    equal the paper's compiled forms' derivatives (model.constants) to rounding."""
    rng = np.random.default_rng(3)
    batch = random_batch(rng, 50, bad=False)
    tables = kernel_tables(batch, derivatives=True)
    c = constant_derivatives(
        batch.H,
        batch.U_L,
        batch.U_sep,
        *(getattr(batch, k)[:, None] for k in ("t", "t_lim", "E", "nu", "r_b", "t_ch")),
    )
    active = np.arange(MAX_UNITS)[None, :] < batch.n_units[:, None]
    rows = {
        "p": lay.COL_P,
        "k_b": lay.COL_KB,
        "alpha": lay.COL_ALPHA,
        "d": lay.COL_D,
        "k_lim": lay.COL_KLIM,
        "k_post": lay.COL_KPOST,
        "k_t": lay.COL_KT,
        "h": 7,
    }
    for name, row in rows.items():
        for j, param in enumerate(DERIVATIVE_PARAMETERS):
            got = tables.derivatives[..., row, j]
            want = c[name][param][active]
            scale = np.abs(want).max()
            np.testing.assert_allclose(got[active], want, rtol=1e-12, atol=1e-13 * scale)
            assert np.all(np.isnan(got[~active]))


# --- kernel tables: the compiled validation and packing ----------------------------------------


def random_batch(rng, n: int, *, bad: bool) -> DesignBatch:
    """Designs of mixed N around the paper's box; with ``bad``, some invalid entries."""
    N = rng.integers(1, MAX_UNITS + 1, n)
    H = np.full((n, MAX_UNITS), np.nan)
    U_L = H.copy()
    U_sep = H.copy()
    for i in range(n):
        H[i, : N[i]] = rng.uniform(2.0, 5.5, N[i])
        U_L[i, : N[i]] = rng.uniform(5.0, 10.0, N[i])
        U_sep[i, : N[i]] = rng.uniform(0.5, 5.0, N[i])
    shared = {
        "t": rng.uniform(0.4, 1.2, n),
        "t_lim": rng.uniform(1.0, 2.0, n),
        "E": rng.uniform(5, 40, n),
        "nu": np.full(n, 0.35),
        "r_b": np.full(n, 5.0),
        "t_ch": np.full(n, 1.0),
    }
    if bad:
        rows = rng.choice(n, n // 3, replace=False)
        for i in rows:
            what = rng.integers(0, 6)
            if what == 0:
                N[i] = rng.choice([0, 13, -1])
            elif what == 1:
                H[i, rng.integers(0, max(N[i], 1))] = rng.choice([np.nan, -1.0, 0.0, np.inf])
            elif what == 2:
                U_sep[i, rng.integers(0, max(N[i], 1))] = rng.choice([np.nan, 0.0])
            elif what == 3:
                shared[str(rng.choice(["t", "t_lim", "E", "r_b", "t_ch"]))][i] = rng.choice(
                    [np.nan, -0.5, 0.0, np.inf]
                )
            elif what == 4:
                shared["nu"][i] = rng.choice([0.5, -0.1, np.nan])
            else:
                H[i, : max(N[i], 1)] = 0.6  # very shallow domes: the closed forms are nonsense
    return DesignBatch(n_units=N, H=H, U_L=U_L, U_sep=U_sep, **shared)


def numpy_tables(batch: DesignBatch):
    """The kernel tables by the NumPy closed forms (how pack_batch built them before)."""
    c = batch_constants(batch, domes=False)
    u_barrier, u_second = dome_extrema(c["alpha"])
    columns = {
        lay.COL_P: c["p"],
        lay.COL_KB: c["k_b"],
        lay.COL_ALPHA: c["alpha"],
        lay.COL_D: c["d"],
        lay.COL_KLIM: c["k_lim"],
        lay.COL_KPOST: c["k_post"],
        lay.COL_KT: c["k_t"],
        lay.COL_U_LO: -np.inf,
        lay.COL_U_HI: np.inf,
        lay.COL_PEN: 0.0,
        lay.COL_U_INV: inversion_threshold(u_barrier),
        lay.COL_U_HELD: np.where(np.isnan(u_second), 1.0, u_second),
    }
    active = np.arange(MAX_UNITS)[None, :] < np.clip(batch.n_units, 0, MAX_UNITS)[:, None]
    table = np.stack(
        [np.broadcast_to(columns[j], active.shape) for j in range(lay.N_COLS)], axis=-1
    )
    return np.where(active[..., None], table, np.nan), c["h"][:, 0], active & c["no_contact"]


@settings(max_examples=25, deadline=None)
@given(seed=hs.integers(0, 2**32 - 1))
def test_compiled_tables_and_status_equal_the_numpy_model_exactly(seed):
    batch = random_batch(np.random.default_rng(seed), 40, bad=True)
    tables = kernel_tables(batch)
    table, h, no_contact = numpy_tables(batch)
    np.testing.assert_array_equal(tables.status, batch.status())
    # the same rules run as Python, as Design does
    shared = [getattr(batch, k) for k in ("t", "t_lim", "E", "nu", "r_b", "t_ch")]
    python = [
        status_code(
            int(batch.n_units[i]),
            batch.H[i],
            batch.U_L[i],
            batch.U_sep[i],
            tuple(float(v[i]) for v in shared),
            batch.constants,
        )
        for i in range(len(batch))
    ]
    np.testing.assert_array_equal(python, tables.status)
    valid = tables.status == Status.OK
    # bit for bit, wherever the design is valid (invalid rows are never read)
    np.testing.assert_array_equal(tables.unit_params[valid], table[valid])
    np.testing.assert_array_equal(tables.h[valid], h[valid])
    np.testing.assert_array_equal(tables.no_contact[valid], no_contact[valid])


# --- kernel pieces at a fixed shape ---------------------------------------------------------


def stable_design_and_shape(n_units: int, seed: int):
    rng = np.random.default_rng(seed)
    design = Design(
        H=list(rng.uniform(3.0, 5.0, n_units)),
        U_L=list(rng.uniform(5.5, 10.0, n_units)),
        U_sep=list(rng.uniform(1.0, 5.0, n_units)),
        t=rng.uniform(0.5, 1.0),
        t_lim=rng.uniform(1.0, 2.0),
    )
    state = int(rng.integers(0, 2**n_units))
    result = find_state(design, state)
    assert result.status in (Status.OK, Status.COLLAPSED)
    return design, result.x, rng


def phi(x, up, h, r):
    """``rᵀ H(x) r`` by the lattice's own Hessian."""
    hess = np.empty((x.size, x.size))
    lattice_hessian(x, up, h, np.empty(x.size), hess)
    return r @ hess @ r


@pytest.mark.parametrize(("n_units", "seed"), [(1, 0), (2, 1), (3, 2), (5, 3), (8, 4)])
def test_third_derivative_contraction_equals_central_differences(n_units, seed):
    design, x, rng = stable_design_and_shape(n_units, seed)
    tables = design_kernel_tables(design)
    up, h = tables.unit_params[0, :n_units], float(tables.h[0])
    # away from the minimum too: every spring stretched, torsions bent
    x = x + rng.normal(0.0, 0.05, x.size)
    r = rng.normal(size=x.size)
    ws = workspace()
    assemble(x, up, h, ws[0], ws[1], ws[2], HESSIAN, ws[8])
    w = np.empty(x.size)
    third_derivative_contraction(ws[0], up, h, r, w)
    step = 1e-5
    fd = np.empty(x.size)
    for i in range(x.size):
        e = np.zeros(x.size)
        e[i] = step
        fd[i] = (
            -phi(x + 2 * e, up, h, r)
            + 8 * phi(x + e, up, h, r)
            - 8 * phi(x - e, up, h, r)
            + phi(x - 2 * e, up, h, r)
        ) / (12 * step)
    np.testing.assert_allclose(w, fd, rtol=1e-7, atol=1e-7 * np.abs(fd).max())


def perturbed(design: Design, name: str, delta: float) -> Design:
    """``design`` with parameter ``name`` (``"H_3"``, ``"t"``, ...) moved by ``delta``."""
    values = design.to_dict()
    if name in ("t", "t_lim", "E"):
        return design.replace(**{name: values[name] + delta})
    kind, _, unit = name.rpartition("_")
    column = list(values[kind])
    column[int(unit) - 1] += delta
    return design.replace(**{kind: column})


def kind_and_unit(name: str, n_units: int) -> tuple[int, int]:
    names = parameter_names(n_units)
    j = names.index(name)
    if j < 3 * n_units:
        return j // n_units, j % n_units + 1
    return DP_T + (j - 3 * n_units), -1


@pytest.mark.parametrize(("n_units", "seed"), [(1, 5), (2, 6), (4, 7), (6, 8)])
def test_tangent_assembly_equals_differences_at_a_fixed_shape(n_units, seed):
    """∂g/∂θ, ∂E/∂θ and ∂(rᵀHr)/∂θ at fixed free coordinates, clamp motion included; and the
    assembly restricted to the units a per-unit parameter touches equals the full one."""
    design, x, rng = stable_design_and_shape(n_units, seed)
    x = x + rng.normal(0.0, 0.02, x.size)
    r = rng.normal(size=x.size)
    tables = design_kernel_tables(design, derivatives=True)
    up, h = tables.unit_params[0, :n_units], float(tables.h[0])
    dtab = tables.derivatives[0, :n_units]
    ws = workspace()
    assemble(x, up, h, ws[0], ws[1], ws[2], HESSIAN, ws[8])

    def energy_gradient_phi(d: Design):
        t = design_kernel_tables(d)
        up_d, h_d = t.unit_params[0, :n_units], float(t.h[0])
        grad = np.empty(x.size)
        hess = np.empty((x.size, x.size))
        e = lattice_hessian(x, up_d, h_d, grad, hess)
        return np.array([e, r @ hess @ r, *grad])

    for name in parameter_names(n_units)[:-1]:  # E is closed form
        kind, unit = kind_and_unit(name, n_units)
        dg = np.empty(x.size)
        d_energy, d_phi = tangent(
            ws[0], Lattice(up, h), dtab, TangentParameter(kind, unit, 1, n_units), r, dg
        )
        # small: a dome of tiny reach (unit 1 of seed 7, d = 0.015 mm) is very nonlinear in d
        step = 1e-5
        at = {m: energy_gradient_phi(perturbed(design, name, m * step)) for m in (-2, -1, 1, 2)}
        fd = (at[-2] - 8 * at[-1] + 8 * at[1] - at[2]) / (12 * step)
        ours = np.array([d_energy, d_phi, *dg])
        np.testing.assert_allclose(ours, fd, rtol=1e-7, atol=1e-8 * np.abs(fd).max(), err_msg=name)
        if unit > 0:
            touches_l1 = unit == 1 and kind != 0
            hi = min(unit + 1, n_units) if touches_l1 else unit
            dg_local = np.empty(x.size)
            parameter = TangentParameter(kind, unit, unit, hi)
            local = tangent(ws[0], Lattice(up, h), dtab, parameter, r, dg_local)
            np.testing.assert_allclose(local, (d_energy, d_phi), rtol=1e-13, atol=1e-15)
            np.testing.assert_allclose(dg_local, dg, rtol=1e-13, atol=1e-15)


def test_no_sensitivities_where_the_hessian_is_not_positive_definite():
    design = Design(H=[4.5, 4.0, 4.8], U_L=7.0, U_sep=1.5, t=0.8, t_lim=1.2)
    tables = design_kernel_tables(design, derivatives=True)
    up, h = tables.unit_params[0, :3], float(tables.h[0])
    x = np.empty(10)
    geometric_guess(up, h, 0b111, 0.5, x)  # every dome half way up: past its stiffest point
    hess = np.empty((10, 10))
    lattice_hessian(x, up, h, np.empty(10), hess)
    assert np.linalg.eigvalsh(hess)[0] < 0
    sens = np.zeros((N_SENS, 12))
    dx = np.zeros((10, 12))
    ok = design_sensitivities(
        x,
        Lattice(up, h),
        DesignDerivatives(tables.derivatives[0, :3], 26.0),
        3,
        SensitivityRows(sens, dx),
        workspace(),
    )
    assert not ok
    assert np.all(np.isnan(sens)) and np.all(np.isnan(dx))


# --- against the solver ---------------------------------------------------------------------


def solver_outputs(design: Design, state: str) -> np.ndarray:
    r = find_state(design, state, options=TIGHT)
    assert r.found == state, f"the state changed under the step: {r.found} != {state}"
    stiffness = 0.0 if design.n_units == 1 else r.stiffness  # inf: the tip is clamped
    return np.array([r.tip[0], r.tip[1], r.bend_angle, r.curvature, r.energy, stiffness, *r.x])


def solver_differences(design: Design, state: str, step: float = 1e-4) -> np.ndarray:
    """Richardson-extrapolated central differences of the solver, shape (6 + 4N - 2, P).

    The step is small for the sake of units of tiny reach (``d = 0.01`` mm where clamped), whose
    energy is very nonlinear; the solver's ~1e-14 precision keeps the round-off near 1e-9.
    """
    columns = []
    for name in parameter_names(design.n_units):
        h = step * (design.E if name == "E" else 1.0)
        d1, d2 = (
            (
                solver_outputs(perturbed(design, name, e), state)
                - solver_outputs(perturbed(design, name, -e), state)
            )
            / (2 * e)
            for e in (h, h / 2)
        )
        columns.append((4 * d2 - d1) / 3)
    return np.array(columns).T


def check_against_solver(design: Design, state: str, step: float = 1e-4):
    result = find_state(design, state, options=TIGHT, sensitivities=True)
    assert result.status in (Status.OK, Status.COLLAPSED)
    s = result.sensitivities
    assert s.state == result.found
    assert s.parameters == parameter_names(design.n_units)
    ours = np.vstack([np.stack([s.of(name) for name in OUTPUTS]), s.x])
    fd = solver_differences(design, result.found, step)
    n_out = len(OUTPUTS)
    if design.n_units == 1:  # the tip is clamped: stiffness inf, derivatives NaN
        assert np.isinf(result.stiffness) and np.all(np.isnan(s.stiffness))
        ours[5] = fd[5] = 0.0
    for i, label in enumerate([*OUTPUTS, *(f"x[{j}]" for j in range(s.x.shape[0]))]):
        scale = np.abs(ours[i if i < n_out else slice(n_out, None)]).max()
        err = np.abs(ours[i] - fd[i])
        # floor: outputs that do not move at all (a straight finger's bend) differ by round-off
        assert err.max() <= REL * scale + 1e-10, (label, err.max(), scale)
    return result


def random_design(rng, n_units: int) -> Design:
    return Design(
        H=list(rng.uniform(3.0, 5.0, n_units)),
        U_L=list(rng.uniform(5.5, 10.0, n_units)),
        U_sep=list(rng.uniform(1.0, 5.0, n_units)),
        t=rng.uniform(0.5, 1.0),
        t_lim=rng.uniform(1.0, 2.0),
        E=rng.choice([12.0, 26.0]),
    )


#: Steps of the solver's differences per distance to the nearest fold (:func:`fold_reach`): the
#: Richardson-extrapolated difference errs by about ``(step / distance)⁴`` of the derivative,
#: and the distance is an estimate (an eigenvalue can fall faster than linearly in λ²). Over
#: 800 random designs, 50 steps per distance kept every difference within 0.8 of the tolerance;
#: 100 leaves a factor 16 on that term. Far from folds the step stays 1e-4.
STEPS_PER_REACH = 100
#: Smallest step (parameter units; E relative): the solver's outputs carry round-off of about
#: 1e-11 of their size, which a difference divides by the step; near a fold the derivatives it
#: is compared with grow, so 2e-6 still keeps that round-off below the 1e-6 tolerance.
MIN_STEP = 2e-6


def hessian_eigenvalues(design: Design, state: str) -> tuple[np.ndarray, str]:
    """Eigenvalues (N/mm) of the lattice's Hessian at the state, and the state found."""
    r = find_state(design, state, options=TIGHT)
    tables = design_kernel_tables(design)
    hess = np.empty((r.x.size, r.x.size))
    n = design.n_units
    lattice_hessian(r.x, tables.unit_params[0, :n], float(tables.h[0]), np.empty(r.x.size), hess)
    return np.linalg.eigvalsh(hess), r.found


def fold_reach(design: Design, state: str, probe: float = 1e-6) -> float:
    """Distance, in any one parameter, to the nearest fold of the state's branch (estimate).

    At a fold (a saddle-node) an eigenvalue λ of the Hessian reaches zero with λ² linear in
    the parameter, so each eigenvalue's ``λ² / |dλ²/dθ|`` estimates the distance to the fold
    it leads to. Every eigenvalue counts, not only the smallest: a stiffer mode can fall to
    zero first (``n_units=5, seed=3589128611``: smallest λ = 7e-3 N/mm, another mode's fold
    9e-4 mm away in t). Parameter units as :func:`solver_differences` steps them (E relative).
    """
    lam, _ = hessian_eigenvalues(design, state)
    reach = np.inf
    for name in parameter_names(design.n_units):
        h = probe * (design.E if name == "E" else 1.0)
        up, up_state = hessian_eigenvalues(perturbed(design, name, h), state)
        down, down_state = hessian_eigenvalues(perturbed(design, name, -h), state)
        if up_state != state or down_state != state:
            return 0.0
        slope = np.abs(up**2 - down**2) / (2 * probe)
        with np.errstate(divide="ignore"):
            reach = min(reach, float(np.min(lam**2 / slope)))
    return reach


@settings(max_examples=12, deadline=None)
@given(n_units=hs.integers(2, 8), seed=hs.integers(0, 2**32 - 1))
# found by random draws: soft modes whose folds lie within 1e-4 steps' reach
@example(n_units=6, seed=7701)  # smallest λ 1.5e-3 N/mm, fold 2.4e-4 away: step 2.4e-6
@example(n_units=5, seed=3589128611)  # smallest λ 7e-3, another mode's fold 8.7e-4 away
@example(n_units=5, seed=3386275496)  # smallest λ 7.5e-3, another mode's fold 1.4e-3 away
def test_sensitivities_equal_solver_differences_on_random_designs(n_units, seed):
    rng = np.random.default_rng(seed)
    design = random_design(rng, n_units)
    result = find_state(design, int(rng.integers(0, 2**n_units)))
    assume(result.status in (Status.OK, Status.COLLAPSED) and result.min_eig > 1e-3)
    # The differences are exact only as far as the branch is smooth, up to the nearest fold:
    # the step is a fraction of that distance, and a fold too near for the smallest step
    # that round-off allows is beyond the differences' reach.
    reach = fold_reach(design, result.found)
    assume(reach >= STEPS_PER_REACH * MIN_STEP)
    check_against_solver(design, result.found, step=min(1e-4, reach / STEPS_PER_REACH))


def test_near_the_saddle_node_alpha_one_ninth():
    """A unit at α = 1/9 + 1e-4 (its derivative table at the isolated dome's fold). Inverted it
    collapses in this finger (and in every finger we tried: the layer pushes it back), so the
    state far from a fold is the one with that unit flat."""
    H = height_for_alpha(1 / 9 + 1e-4, t=0.83)
    design = Design(H=[4.0, 4.5, H, 4.5], U_L=6.5, U_sep=1.2, t=0.83, t_lim=1.1)
    assert abs(spring_constants(design).alpha[2] - 1 / 9) < 2e-4
    result = check_against_solver(design, "1101")
    assert result.status == Status.OK


def test_clamped_reach_no_contact():
    design = Design(H=[4.5, 3.0, 4.8], U_L=7.0, U_sep=[1.5, 4.0, 1.5], t=0.5, t_lim=1.5)
    result = check_against_solver(design, "111")
    np.testing.assert_array_equal(result.sensitivities.no_contact, [False, True, False])


def test_one_unit_finger_has_a_clamped_tip():
    design = Design(H=[4.2], U_L=7.0, U_sep=2.0, t=0.8, t_lim=1.4)
    result = check_against_solver(design, "1")
    s = result.sensitivities
    # L_1 = (p_1, h): dp_1/dU_L = dp_1/dU_sep = 1, dh/dt = dh/dt_lim = 1
    np.testing.assert_array_equal(s.tip, [[0, 1, 1, 0, 0, 0], [0, 0, 0, 1, 1, 0]])
    np.testing.assert_array_equal(s.bend_angle, 0.0)


def test_twelve_units():
    design = Design(H=list(np.linspace(4.9, 3.6, 12)), U_L=6.0, U_sep=1.2, t=0.75, t_lim=1.3)
    check_against_solver(design, "1" * 12)


def test_E_scales_energy_and_stiffness_and_leaves_shapes_alone(pickplace):
    a = find_state(pickplace, "111100", sensitivities=True).sensitivities
    doubled = pickplace.replace(E=2 * pickplace.E)
    r2 = find_state(doubled, "111100", sensitivities=True)
    b = r2.sensitivities
    np.testing.assert_allclose(b.x, a.x, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(b.tip, a.tip, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(b.energy[:-1], 2 * a.energy[:-1], rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(b.stiffness[:-1], 2 * a.stiffness[:-1], rtol=1e-8, atol=1e-12)
    E = a.wrt("E")
    assert E["tip_x"] == E["tip_y"] == E["bend_angle"] == E["curvature"] == 0.0
    assert b.wrt("E")["energy"] == pytest.approx(r2.energy / doubled.E, rel=1e-15)
    assert b.wrt("E")["stiffness"] == pytest.approx(r2.stiffness / doubled.E, rel=1e-15)
    np.testing.assert_array_equal(a.x[:, -1], 0.0)


# --- batch against single design; fast paths against the batch path -----------------------------


def mixed_batch() -> DesignBatch:
    rng = np.random.default_rng(11)
    designs = [random_design(rng, n) for n in (1, 2, 3, 5, 5, 8, 12)]
    batch = DesignBatch.from_designs(designs)
    bad = DesignBatch.from_designs(designs[:1])
    bad = DesignBatch(**{**{k: getattr(bad, k) for k in bad.ARRAY_FIELDS}, "t": -1.0})
    merged = {k: np.concatenate([getattr(batch, k), getattr(bad, k)]) for k in batch.ARRAY_FIELDS}
    return DesignBatch(**merged)


@pytest.mark.parametrize("with_sensitivities", [False, True])
def test_serial_and_parallel_batches_are_identical(monkeypatch, with_sensitivities):
    batch = mixed_batch()
    runs = []
    for limit in (10**9, 0):
        monkeypatch.setattr(statics, "SERIAL_MAX_ROWS", limit)
        runs.append(solve_batch(batch, "sequential", shapes=True, sensitivities=with_sensitivities))
    serial, parallel = runs
    assert serial.keys() == parallel.keys()
    for name in serial:
        np.testing.assert_array_equal(serial[name], parallel[name], err_msg=name)


def test_batch_sensitivities_equal_the_single_design_path_exactly():
    batch = mixed_batch()
    columns = solve_batch(batch, "sequential", shapes=True, sensitivities=True)
    n_params = 3 * MAX_UNITS + 3
    for name in COLUMNS:
        assert columns[name].shape == (columns["status"].size, n_params)
    for r, i in enumerate(columns["design_index"]):
        status = columns["status"][r]
        if status not in (Status.OK, Status.COLLAPSED):
            assert all(np.isnan(columns[name][r]).all() for name in COLUMNS)
            continue
        design = batch.design(int(i))
        n = design.n_units
        one = find_state(design, int(columns["requested"][r]), sensitivities=True)
        assert one.found == format(columns["found"][r], f"0{n}b")
        np.testing.assert_array_equal(one.x, columns["x"][r, : 4 * n - 2])
        np.testing.assert_array_equal(one.tip, [columns["tip_x"][r], columns["tip_y"][r]])
        assert one.stiffness == columns["stiffness"][r] or n == 1
        cols = batch_columns(n)
        outside = np.setdiff1d(np.arange(n_params), cols)
        for name, output in zip(COLUMNS, OUTPUTS, strict=True):
            np.testing.assert_array_equal(columns[name][r, cols], one.sensitivities.of(output))
            assert np.isnan(columns[name][r, outside]).all()


def test_find_state_fast_path_equals_solve_batch(gripper):
    for state in range(2**gripper.n_units):
        one = find_state(gripper, state)
        batch = solve_batch(DesignBatch.from_designs([gripper]), [state], shapes=True)
        np.testing.assert_array_equal(one.x, batch["x"][0, : one.x.size])
        for name in ("energy", "bend_angle", "curvature", "min_eig", "stiffness", "grad_norm"):
            assert getattr(one, name) == batch[name][0]
        assert one.status == batch["status"][0] and one.n_iter == batch["n_iter"][0]


def test_a_collapsed_row_describes_the_state_it_collapsed_to():
    design = Design(
        H=[4.0, 4.5, height_for_alpha(1 / 9 + 1e-4), 4.5], U_L=6.5, U_sep=1.2, t=0.83, t_lim=1.1
    )
    collapsed = find_state(design, "1111", sensitivities=True)
    assert collapsed.status == Status.COLLAPSED and collapsed.found == "1101"
    direct = find_state(design, "1101", sensitivities=True)
    assert collapsed.sensitivities.state == "1101"
    for name in OUTPUTS:
        a, b = collapsed.sensitivities.of(name), direct.sensitivities.of(name)
        np.testing.assert_allclose(a, b, rtol=1e-7, atol=1e-9 * np.abs(b).max())


def test_sensitivities_helpers(gripper):
    s = find_state(gripper, "11110", sensitivities=True).sensitivities
    assert s.defined and s.tip.shape == (2, 18) and s.x.shape == (18, 18)
    table = s.as_dict()
    assert set(table) == set(OUTPUTS) and table["tip_y"]["H_2"] == s.tip[1, 1]
    assert s.wrt("t_lim")["stiffness"] == s.stiffness[16]
    with pytest.raises(ValueError, match="parameter = 'H_9'"):
        s.wrt("H_9")
    with pytest.raises(ValueError, match="output = 'tip'"):
        s.of("tip")
    assert find_state(gripper, "11110").sensitivities is None
    assert N_DPARAM == 5 and DP_TLIM == DP_T + 1


def test_design_sensitivities_under_another_set_equal_solver_differences():
    """Issue 20: sensitivities chain through the set's own derivatives, exactly."""
    design = Design(**FINGER, constants=other_set())
    result = check_against_solver(design, "010")
    assert result.status == Status.OK
