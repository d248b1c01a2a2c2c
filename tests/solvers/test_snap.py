"""Snap pressures by quasi-static continuation (dpfexplore.solvers.snap.continuation).

Checked against: finite differences (the non-symmetric Jacobian), an independent 2-DOF model of a
single unit cell (its fold by a 1-D root find and a bounded maximisation, no continuation),
slow-ramp simulations of the full equations of motion (their crossing pressures converge to the
continuation's as the ramp slows), the eigenvalues of the linearised motion (every landing and
every branch point is stable) and perturbed simulations at constant pressure (every landing is
an attractor).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy.optimize import brentq, minimize_scalar

from dpfexplore import Design, DesignBatch, PressureProfile, simulate
from dpfexplore._kernels.snap import continuation as kcont
from dpfexplore.cli import main
from dpfexplore.model.constants import dome_force
from dpfexplore.model.status import Status
from dpfexplore.solvers.lattice import lattice_params, spring_constants
from dpfexplore.solvers.snap.continuation import (
    decay_rate,
    inversion_pressure,
    snap_pressures,
    snap_pressures_batch,
)

# Small random designs of the paper's box (seeded draws, rounded), and two with smooth crossings
# (low domes: a unit with alpha >= 1/9 has no barrier; pressure carries it over u = 3/4).
RANDOM = [
    dict(H=[3.7753, 3.6461], U_L=[6.1759, 9.1735], U_sep=[1.7589, 2.9575], t=0.795, t_lim=1.6051),
    dict(
        H=[4.107, 4.991, 4.5853],
        U_L=[8.2998, 9.9503, 6.4689],
        U_sep=[1.3204, 2.2251, 1.0879],
        t=0.5178,
        t_lim=1.5149,
    ),
    dict(H=[4.276, 4.3529], U_L=[6.1785, 7.4814], U_sep=[1.4791, 1.805], t=0.5484, t_lim=1.9678),
]
CROSSING = [
    dict(
        H=[2.0137, 2.8982, 3.1449],
        U_L=[6.5413, 5.7184, 7.2966],
        U_sep=[1.33, 1.4616, 1.4274],
        t=0.9768,
        t_lim=1.1193,
    ),
    dict(H=[2.7978, 2.0373], U_L=[9.2605, 7.3731], U_sep=[1.2461, 1.2225], t=0.8604, t_lim=1.0478),
]


def _residual(params, x, pressure):
    ws = kcont.workspace(params.n_units)
    kcont.residual(x, pressure, params.unit_params, params.h, ws, True)
    return ws[1].copy(), ws[2].copy(), ws[3].copy()


@pytest.fixture(scope="module")
def gripper_up(gripper):
    return snap_pressures(gripper, P_max=0.7)


def _slow_ramp(design, p_max, duration):
    """First upward crossing pressure of every unit under a linear ramp, and the final state."""
    run = simulate(
        design, PressureProfile([0.0, duration], [0.0, p_max]), t_end=duration, n_samples=0
    )
    assert run.status == Status.OK
    return run.snap_through * p_max / duration, run.final_state


# ---- the Jacobian ------------------------------------------------------------------------------


@pytest.mark.parametrize("which", ["gripper", "random"])
def test_jacobian_is_the_derivative_of_the_residual_and_not_symmetric(which, gripper):
    design = gripper if which == "gripper" else Design(**RANDOM[1])
    params = lattice_params(design)
    rng = np.random.default_rng(4)
    x = snap_pressures(design, P_max=0.2, release=False).final_x + 0.05 * rng.standard_normal(
        4 * design.n_units - 2
    )
    pressure = 0.3
    _, load, jac = _residual(params, x, pressure)
    step = 1e-6
    fd = np.empty_like(jac)
    for j in range(x.size):
        e = np.zeros_like(x)
        e[j] = step
        fd[:, j] = (
            _residual(params, x + e, pressure)[0] - _residual(params, x - e, pressure)[0]
        ) / (2 * step)
    scale = np.abs(jac).max()
    assert np.abs(fd - jac).max() < 1e-7 * scale
    # dR/dP = -f (the load at unit pressure), and the asymmetry is the follower load's
    up, down = (_residual(params, x, pressure + s)[0] for s in (1e-6, -1e-6))
    dp = (up - down) / 2e-6
    assert np.abs(dp + load).max() < 1e-7 * np.abs(load).max()
    asym = np.abs(jac - jac.T).max()
    assert asym == pytest.approx(pressure, rel=1e-12)  # faces give ±P/2 blocks: |K - Kᵀ| = P


@pytest.mark.parametrize("singular", [False, True])
def test_bordered_lu_solves_banded_systems_with_a_border_even_where_k_is_singular(singular):
    from dpfexplore._kernels.linalg.bordered_lu import bordered_factor, bordered_solve

    rng = np.random.default_rng(11)
    band = 7
    for n in (2, 10, 30, 46):
        k = np.zeros((n, n))
        for i in range(n):
            lo, hi = max(0, i - band), min(n, i + band + 1)
            k[i, lo:hi] = rng.standard_normal(hi - lo)
        k += (3.0 + n / 4) * np.eye(n)
        if singular:  # a fold: K singular, the bordered matrix regular
            k = k + k.T
            k -= np.linalg.eigvalsh(k)[n // 2] * np.eye(n)
        a = np.zeros((n + 1, n + 1))
        a[:n, :n] = k
        a[:n, n] = rng.standard_normal(n)
        a[n] = rng.standard_normal(n + 1)
        rhs = rng.standard_normal(n + 1)
        factors, piv, z = a.copy(), np.empty(n + 2, dtype=np.int64), rhs.copy()
        assert bordered_factor(factors, n + 1, piv, band) == 0
        bordered_solve(factors, n + 1, piv, z, band)
        assert np.abs(a @ z - rhs).max() < 1e-12 * np.abs(a).max() * np.abs(z).max()
        # the banded elimination is kept unless K's singular direction calls for the border row
        assert (piv[n + 1] < n + 1) == singular


# ---- a single unit cell against an independent model ------------------------------------------


def _unit_cell_model(design):
    """Energy and load of a one-unit finger written out independently (free node D_1 = (X, Y))."""
    c = spring_constants(design)
    kb, alpha, d = c.k_b[0], c.alpha[0], c.d[0]
    p, h, kpost, kt = c.p[0], c.h, c.k_post[0], c.k_t[0]
    d0, l0, l1 = np.array([0.0, 0.0]), np.array([0.0, h]), np.array([p, h])

    def energy(z):
        xbar = np.linalg.norm(z - d0) - p
        u = xbar / d
        dome = 0.5 * kb * xbar**2 * (1 + (1 - alpha) * (u * u - 2 * u))
        post = 0.5 * kpost * (np.linalg.norm(l1 - z) - h) ** 2
        a, b = l0 - l1, z - l1
        theta = math.atan2(abs(a[0] * b[1] - a[1] * b[0]), a @ b)
        return dome + post + 0.5 * kt * (theta - math.pi / 2) ** 2

    def grad(z, step=1e-6):
        return np.array(
            [
                (energy(z + e) - energy(z - e)) / (2 * step)
                for e in (np.array([step, 0.0]), np.array([0.0, step]))
            ]
        )

    def load(z):
        # each face: P·length along its normal, half to each end; on D_1 from the dome face
        # D_0 -> D_1 (normal away from the layer) and the post D_1 -> L_1 (toward the tip)
        cw = np.array([[0.0, 1.0], [-1.0, 0.0]])  # clockwise rotation
        return 0.5 * cw @ (z - d0) + 0.5 * cw @ (l1 - z)

    return energy, grad, load, p, d, c


def test_single_unit_fold_matches_an_independent_root_find():
    design = Design(H=[4.2], U_L=7.0, U_sep=1.5, t=0.8, t_lim=1.4)
    _, grad, load, p, d, c = _unit_cell_model(design)

    def pressure_at(x_pos):
        # equilibrium grad E = P f: for a dome length X, the Y where grad E is parallel to f
        def off(y):
            z = np.array([x_pos, y])
            g, f = grad(z), load(z)
            return g[0] * f[1] - g[1] * f[0]

        y = brentq(off, -0.5, 0.5, xtol=1e-14)
        z = np.array([x_pos, y])
        f = load(z)
        return grad(z) @ f / (f @ f)

    u_barrier = c.domes.u_barrier[0]
    best = minimize_scalar(
        lambda xp: -pressure_at(xp),
        bounds=(p, p + u_barrier * d),
        method="bounded",
        options={"xatol": 1e-10},
    )
    fold = -best.fun
    seq = snap_pressures(design, P_max=2 * fold)
    snaps = seq.snaps
    assert seq.status == Status.OK and len(snaps) == 1
    assert snaps[0].before == "0" and snaps[0].after == "1"
    assert snaps[0].pressure == pytest.approx(fold, rel=1e-7)
    # Closed form with a rigid post: D_1 swings about L_1 by phi; the dome's force-extension
    # curve F(x̄) and the torsion balance the load's moment, whose largest ratio is the fold:
    # P(phi) = (F(x̄) dx̄/dphi + k_t phi) / (h²/2 cos phi - p h/2 sin phi). The real post
    # (5 k_lim) gives a little: 3e-4 relative.
    h, kt = c.h, c.k_t[0]

    def rigid_post(phi):
        z = np.array([p + h * math.sin(phi), h - h * math.cos(phi)])
        length = np.hypot(*z)
        slope = (z[0] * math.cos(phi) + z[1] * math.sin(phi)) * h / length
        force = dome_force(length - p, c.k_b[0], c.alpha[0], d)
        return (force * slope + kt * phi) / (h * h / 2 * math.cos(phi) - p * h / 2 * math.sin(phi))

    rigid = minimize_scalar(
        lambda phi: -rigid_post(phi),
        bounds=(0.0, u_barrier * d / h),
        method="bounded",
        options={"xatol": 1e-12},
    )
    assert snaps[0].pressure == pytest.approx(-rigid.fun, rel=1e-3)
    assert abs(snaps[0].pressure + rigid.fun) > 1e-6  # ... but not to round-off: it is a model


# ---- the gripper -------------------------------------------------------------------------------


def test_gripper_units_invert_base_first_and_release_into_the_grasp_states(gripper_up):
    seq = gripper_up
    assert seq.status == Status.OK and not seq.fitted_range  # the tip dome has H = 2.5
    assert [e.kind for e in seq.events] == ["snap"] * 5
    assert [v.state for v in seq.visits] == ["00000", "00001", "10001", "11001", "11101", "11111"]
    # the metastable tip unit is inverted only under pressure: releases give MODEL.md §9's states
    assert [v.released for v in seq.visits] == [
        "00000",
        "00000",
        "10000",
        "11000",
        "11100",
        "11110",
    ]
    inv = seq.inversion_pressures()
    assert np.all(np.diff(inv[:4]) > 0.05)  # units 1-4 in order, windows > 50 kPa
    windows = seq.release_windows()
    assert list(windows) == ["00000", "10000", "11000", "11100", "11110"]
    assert windows["10000"] == [(inv[0], inv[1])]
    for visit, following in zip(seq.visits, seq.visits[1:], strict=False):
        assert visit.P_leave == following.P_enter
    for event in seq.events:
        assert event.decay_rate > 0.1  # every landing decays back (1/s)
    assert seq.visits[1].P_release_leave < seq.visits[1].P_enter  # hysteresis of the tip unit


def test_gripper_fold_pressures_are_the_slow_ramp_limit(gripper, gripper_up):
    inv = gripper_up.inversion_pressures()
    errors = []
    for duration in (200.0, 2000.0):
        pressures, final = _slow_ramp(gripper, 0.6, duration)
        assert final == "11111"
        assert list(np.argsort(pressures)) == [4, 0, 1, 2, 3]  # tip first, then base first
        errors.append(pressures - inv)
    slow, slower = errors
    assert np.all(slow > 0) and np.all(slower > 0)  # a real ramp lags behind the fold
    # the saddle-node's delay falls as rate^(2/3): 10x slower -> 4.6x smaller (4.1-5.0 here)
    assert np.all((slow / slower > 3.5) & (slow / slower < 6.5))
    assert np.abs(slower).max() < 1.5e-3


def test_gripper_snap_back_pressure_is_the_slow_release_limit(gripper):
    down = snap_pressures(gripper, direction="down", P_max=0.6)
    assert down.status == Status.OK
    # the tip dome (alpha > 1/9, threshold u = 3/4) passes its threshold smoothly, then its
    # branch folds 0.8 kPa lower and it snaps back to the flat side
    assert [(e.kind, e.before, e.after) for e in down.events] == [
        ("crossing", "11111", "11110"),
        ("snap", "11110", "11110"),
    ]
    assert 0.0 < down.events[0].pressure - down.events[1].pressure < 2e-3
    fold = down.events[0].pressure
    errors = []
    for duration in (200.0, 2000.0):
        up = PressureProfile([0.0, 30.0, 30.0 + duration], [0.0, 0.6, 0.0])
        run = simulate(gripper, up, t_end=30.0 + duration, n_samples=0)
        assert run.final_state == "11110"
        errors.append(fold - 0.6 * (1.0 - (run.snap_back[4] - 30.0) / duration))
    assert 0 < errors[1] < errors[0] / 3.5 and errors[1] < 1e-3


# ---- small random designs ---------------------------------------------------------------------


@pytest.mark.parametrize("spec", RANDOM + CROSSING)
def test_random_designs_agree_with_slow_ramps(spec):
    design = Design(**spec)
    seq = snap_pressures(design, P_max=0.8, release=False)
    assert seq.status == Status.OK  # (UNSTABLE if a landing's linearised motion did not decay)
    assert all(e.decay_rate > 0.0 for e in seq.snaps)
    inv = seq.inversion_pressures()
    pressures, final = _slow_ramp(design, 0.8, 2000.0)
    assert final == seq.visits[-1].state
    inverted = np.isfinite(inv)
    assert np.array_equal(inverted, np.isfinite(pressures))
    lag = pressures[inverted] - inv[inverted]
    assert np.all(lag > -1e-6) and np.all(lag < 1.5e-3)
    if spec in CROSSING:
        assert "crossing" in [e.kind for e in seq.events]


def test_crossings_change_the_label_without_moving_the_shape():
    seq = snap_pressures(Design(**CROSSING[0]), P_max=0.8, release=False)
    crossing = [e for e in seq.events if e.kind == "crossing"]
    assert crossing and all(np.array_equal(e.x_before, e.x_after) for e in crossing)
    params = lattice_params(seq.design)
    for e in crossing:
        (unit,) = e.inverted or e.reverted
        u = np.empty(seq.design.n_units)
        from dpfexplore._kernels.dynamics.events import margins

        margins(e.x_before, params.unit_params, u)
        assert abs(u[unit - 1]) < 1e-9  # exactly on the threshold


# ---- folds and landings -------------------------------------------------------------------------


def test_folds_are_singular_and_landings_are_stable_attractors(gripper, gripper_up):
    params = lattice_params(gripper)
    for event in gripper_up.snaps:
        res, _, jac = _residual(params, event.x_before, event.pressure)
        eig = np.linalg.eigvals(jac)
        assert np.abs(eig).min() < 1e-8 * np.abs(eig).max()  # a real eigenvalue at zero
        res, _, jac = _residual(params, event.x_after, event.pressure)
        assert np.abs(res).max() < 1e-8
        # linearly stable: every mode of the overdamped motion decays (K from finite differences)
        assert decay_rate(params, event.x_after, event.pressure, "rodas4-overdamped") > 0.1
        # and an attractor: perturbed, the full motion at that pressure comes back
        rng = np.random.default_rng(1)
        start = event.x_after + 0.05 * rng.standard_normal(event.x_after.size)
        run = simulate(
            gripper, PressureProfile([0.0], [event.pressure]), t_end=40.0, x0=start, n_samples=0
        )
        assert np.abs(run.final_x - event.x_after).max() < 1e-3


def test_every_branch_point_is_stable_no_flutter(gripper, gripper_up):
    """The continuation detects folds only; the branches between them have no Hopf point."""
    params = lattice_params(gripper)
    path = gripper_up.path
    last_of_segment = np.r_[path["segment"][1:] != path["segment"][:-1], True]
    rates = [
        decay_rate(params, x, p, "rodas4")
        for x, p, last in zip(_path_shapes(gripper_up), path["P"], last_of_segment, strict=True)
        if not last
    ]
    assert min(rates) > 0.0


def _path_shapes(seq):
    """Equilibria at the path's pressures, polished from the nearest recorded shapes."""
    from dpfexplore._kernels.reset.reduced import loaded_equilibrium

    params = lattice_params(seq.design)
    shapes = []
    x = seq.events[0].x_before.copy() if seq.events else seq.final_x.copy()
    segment_starts = {0: snap_pressures(seq.design, P_max=1e-9, release=False).final_x}
    for e, seg in zip(seq.snaps, range(1, len(seq.snaps) + 1), strict=True):
        segment_starts[seg] = e.x_after
    current = -1
    for p, seg in zip(seq.path["P"], seq.path["segment"], strict=True):
        if seg != current:
            x = segment_starts[int(seg)].copy()
            current = seg
        assert loaded_equilibrium(x, params.unit_params, params.h, p, 1e-10, 50, 0.2) == 0
        shapes.append(x.copy())
    return shapes


def test_landings_do_not_depend_on_the_kick_or_the_inertia(gripper, gripper_up):
    for kwargs in ({"kick": 0.01}, {"model": "rodas4-overdamped"}):
        other = snap_pressures(gripper, P_max=0.7, release=False, **kwargs)
        assert [(e.before, e.after) for e in other.events] == [
            (e.before, e.after) for e in gripper_up.events
        ]
        for a, b in zip(other.events, gripper_up.events, strict=True):
            assert a.pressure == pytest.approx(b.pressure, abs=1e-9)
            assert np.abs(a.x_after - b.x_after).max() < 1e-6


# A 7-unit finger of the paper's box whose all-inverted branch folds at 0.374 MPa with no resting
# place beyond: past the fold the follower load drives a slow relaxation oscillation.
CURLING = dict(
    H=[4.7886, 4.9092, 3.5478, 4.6549, 3.3948, 3.1537, 4.243],
    U_L=[7.5491, 9.78, 5.9609, 7.1977, 7.1207, 9.4887, 7.3205],
    U_sep=[4.5692, 1.7296, 1.1845, 1.9319, 1.0992, 1.5032, 3.1766],
    t=0.5078,
    t_lim=1.4805,
)


def test_a_fold_without_a_resting_place_is_reported_unsettled():
    design = Design(**CURLING)
    seq = snap_pressures(design, P_max=0.5)
    assert seq.status == Status.NOT_CONVERGED
    last = seq.events[-1]
    assert last.kind == "unsettled" and last.after == "" and last.before == "1111111"
    # the fold pressure, checked by time integration (not the continuation): 0.1 kPa below it
    # the finger comes to rest, 0.1 kPa above it it does not (about 0.374 MPa)
    for dp, settles in ((-1e-4, True), (1e-4, False)):
        run = simulate(
            design,
            PressureProfile([0.0], [last.pressure + dp]),
            t_end=3000.0,
            x0=last.x_before,
            n_samples=61,
        )
        motion = np.ptp(run.tip[30:], axis=0).max()  # over the second half
        assert (motion < 1e-6) if settles else (motion > 20.0), (dp, motion)
    assert seq.visits[-1].state == "1111111" and seq.visits[-1].P_leave == last.pressure
    assert all(v.released is not None for v in seq.visits)  # the states before it still release
    # the motion 1 kPa past the fold keeps going: excursions of tens of mm, again and again
    run = simulate(
        design,
        PressureProfile([0.0], [last.pressure + 1e-3]),
        t_end=3000.0,
        x0=last.x_before,
        n_samples=61,
    )
    tip = run.tip[30:]  # the second half
    assert np.ptp(tip[:, 0]) > 20.0 and np.ptp(tip[:, 1]) > 20.0


# ---- API -----------------------------------------------------------------------------------------


def test_cycle_goes_up_then_down(gripper):
    seq = snap_pressures(gripper, direction="cycle", P_max=0.6, release=False)
    assert seq.status == Status.OK
    assert [e.direction for e in seq.events] == ["up"] * 5 + ["down"] * 2
    assert [v.entered_by for v in seq.visits][-3:] == ["turn", "crossing", "snap"]
    assert len(np.unique(seq.path["segment"])) == 5 + 1 + 1 + 1  # snaps and the turn
    assert seq.visits[-1].state == "11110"


def test_start_state_and_its_checks(gripper):
    seq = snap_pressures(gripper, start_state="11000", P_max=0.7, release=False)
    assert seq.visits[0].state == "11000"
    assert [e.inverted for e in seq.events] == [(5,), (3,), (4,)]
    with pytest.raises(ValueError, match="start_state = '00001'"):
        snap_pressures(gripper, start_state="00001")  # the tip cannot stay inverted at P = 0
    with pytest.raises(ValueError, match="does not last up to P_start"):
        snap_pressures(gripper, start_state="11000", P_start=0.2)
    with pytest.raises(ValueError, match="P_min"):
        snap_pressures(gripper, P_min=1.0, P_max=0.5)
    with pytest.raises(ValueError, match="direction"):
        snap_pressures(gripper, direction="sideways")
    with pytest.raises(ValueError, match="model"):
        snap_pressures(gripper, model="radau")


def test_units_without_dome_contact_are_flagged():
    design = Design(H=[4.0, 3.2], U_L=7.0, U_sep=[1.5, 4.5], t=0.8, t_lim=1.4)
    assert list(spring_constants(design).no_contact) == [False, True]
    seq = snap_pressures(design, P_max=0.5, release=False)
    assert seq.no_contact == (False, True) and seq.to_dict()["no_contact"] == [False, True]


def test_inversion_pressure(gripper, gripper_up):
    assert inversion_pressure(gripper, 1, P_max=0.7) == gripper_up.events[1].pressure
    assert inversion_pressure(gripper, 4, P_max=0.5) == math.inf
    with pytest.raises(ValueError, match="unit"):
        inversion_pressure(gripper, 6)


def test_batch_matches_single_designs(gripper, gripper_up):
    designs = [gripper, Design(**RANDOM[0]), Design(**CROSSING[1]), Design(**CURLING)]
    batch = DesignBatch.from_designs([*designs, designs[1]])
    batch.t[-1] = -1.0  # an invalid row keeps its status and gets no events
    out = snap_pressures_batch(batch, P_max=0.7)
    for i, design in enumerate(designs):
        seq = gripper_up if i == 0 else snap_pressures(design, P_max=0.7)
        assert out["status"][i] == seq.status
        assert out["n_events"][i] == len(seq.events)
        for j, e in enumerate(seq.events):
            assert out["event_pressure"][i, j] == pytest.approx(e.pressure, abs=1e-12)
            assert out["event_after"][i, j] == (int(e.after, 2) if e.after else -1)
        released = [int(v.released, 2) for v in seq.visits]
        assert list(out["release_state"][i, : len(released)]) == released
        inv = out["inversion_pressure"][i, : design.n_units]
        assert np.array_equal(inv, seq.inversion_pressures())
        assert tuple(out["no_contact"][i, : design.n_units]) == seq.no_contact
    assert out["status"][-1] == Status.INVALID_INPUT and out["n_events"][-1] == 0
    assert np.isnan(out["inversion_pressure"][-1]).all()


# ---- CLI ---------------------------------------------------------------------------------------


def test_cli_json_and_plot(tmp_path, capsys):
    plot = tmp_path / "snap.png"
    code = main(["snap", "gripper", "--P-max", "0.6", "--json", "--plot", str(plot)])
    assert code == 0 and plot.stat().st_size > 10_000
    data = json.loads(capsys.readouterr().out)
    assert [e["after"] for e in data["events"]] == ["00001", "10001", "11001", "11101", "11111"]
    assert data["release_windows"]["11000"][0][0] == pytest.approx(data["events"][2]["pressure"])
    assert data["fitted_range"] is False
    assert main(["snap", "gripper", "--P-max", "0.2", "--no-release"]) == 0
    text = capsys.readouterr().out
    assert "10001" in text and "snap" in text


@pytest.mark.parametrize(
    "argv", [["nowhere.toml"], ["gripper", "--P-max", "-1"], ["gripper", "--start", "2"]]
)
def test_cli_bad_input_exits_2(argv, capsys):
    assert main(["snap", *argv]) == 2
    err = capsys.readouterr().err
    assert err.startswith("dpfexplore snap: error:") and err.count("\n") == 1


@pytest.mark.slow
def test_bench_snap_record(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    code = main(
        [
            "bench",
            "snap",
            "--json",
            "--units",
            "2",
            "--designs",
            "2",
            "--ramp-designs",
            "1",
            "--rounds",
            "1",
            "--no-compile",
            "--save",
        ]
    )
    assert code == 0
    record = json.loads(capsys.readouterr().out)
    assert record["gripper"]["median_ms"] > 0 and record["by_n_units"][0]["n_units"] == 2
    ramp = record["slow_ramp"]
    # the lag shrinks as the ramp slows, and every final state agrees
    assert ramp["max_lag_MPa"][0] > ramp["max_lag_MPa"][1] > ramp["max_lag_MPa"][2] > 0
    assert ramp["final_state_mismatches"] == [0, 0, 0]
    assert 0.5 < ramp["lag_exponent_median"] < 0.8
    assert (tmp_path / "results" / "reports" / "bench-snap.json").exists()
