"""Simulated scenes against the reference run, SciPy's Radau, closed forms and invariants."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import PICKPLACE, read_reference
from scipy.optimize import brentq, curve_fit

from dpfexplore._kernels.dynamics.batch import rest_state
from dpfexplore._kernels.dynamics.motion import ETA_INTERNAL, ETA_ISO, node_mass
from dpfexplore._kernels.lattice import lattice_energy, unpack_nodes
from dpfexplore._kernels.layout import COL_KT
from dpfexplore.model import status as st
from dpfexplore.model.constants import ALPHA_BISTABLE, dome_alpha, dome_radius
from dpfexplore.model.design import Design
from dpfexplore.solvers.dynamics.scipy_baseline import simulate_scipy
from dpfexplore.solvers.dynamics.simulate import PressureProfile, simulate
from dpfexplore.solvers.lattice import lattice_params, spring_constants

PULSE = PressureProfile.pulse(0.7, (0.0, 1.0, 5.0, 5.1))
SHORT_PULSE = PressureProfile.pulse(0.7, (0.0, 0.1, 0.3, 0.35))
#: Two units, the tip one metastable: the smallest finger with a reset.
SMALL = Design(H=[4.0, 3.0], U_L=6.0, U_sep=1.0, t=0.83, t_lim=1.0, name="small")


@pytest.fixture(scope="module")
def pickplace_run():
    return simulate(Design(**PICKPLACE), PULSE, t_end=15.0, atol=1e-6)


def test_pickplace_reproduces_reference_run(pickplace_run):
    """reference/pickplace_dynamics.csv: tip path, extensions, snap-through times, resets."""
    ref = read_reference("pickplace_dynamics.csv")
    run = pickplace_run
    assert run.status == st.OK
    np.testing.assert_allclose(run.t, ref.t, atol=1e-12)
    # The reference is Radau at rtol 1e-4: agreement to ~1e-5 mm is the two solvers agreeing.
    assert np.abs(run.tip - ref[["tip_x", "tip_y"]].to_numpy()).max() < 1e-3
    ext = ref[[f"ext{k}" for k in range(1, 7)]].to_numpy()
    assert np.abs(run.extensions - ext).max() < 1e-4
    # README: snap-through at 0.388, 0.675, 0.919, 1.214, 0.641, 1.109 s (3 decimals)
    np.testing.assert_allclose(
        run.snap_through, [0.388, 0.675, 0.919, 1.214, 0.641, 1.109], atol=6e-4
    )
    assert run.final_state == "111100"
    assert run.unit_class == ("bistable",) * 4 + ("metastable",) * 2
    assert np.all(np.isinf(run.reset_time[:4]))
    # the reference's own crossings of u = 3/4 after the release, by linear interpolation
    for k in (4, 5):
        after = ref.t.to_numpy() > 5.1
        u = ext[after, k] - 0.75
        i = int(np.flatnonzero(u < 0)[0])
        t_ref = np.interp(0.0, [u[i], u[i - 1]], [ref.t[after].iloc[i], ref.t[after].iloc[i - 1]])
        assert run.snap_back[k] == pytest.approx(t_ref, abs=0.01)
    assert run.events.shape == (8, 3)
    assert np.all(np.diff(run.events[:, 0]) >= 0)


def test_reset_time_converges_and_agrees_with_radau():
    """Refinement changes the reset times by < 0.1 %; tight Radau agrees within 0.5 %."""
    design = Design(**PICKPLACE)
    resets = []
    for atol in (1e-4, 1e-5, 1e-6):
        run = simulate(design, PULSE, t_end=15.0, atol=atol, n_samples=0, stop_when_reset=True)
        resets.append(run.reset_time[4:])
    resets = np.array(resets)
    changes = np.abs(np.diff(resets, axis=0)) / resets[1:]
    assert np.all(changes <= 1e-3)
    assert changes[1].max() < changes[0].max()  # and the change shrinks
    radau = simulate_scipy(design, PULSE, t_end=15.0, rtol=1e-6, atol=1e-9, n_samples=0)
    assert radau.final_state == "111100"
    np.testing.assert_allclose(resets[-1], radau.reset_time[4:], rtol=5e-3)
    np.testing.assert_allclose(resets[-1], radau.reset_time[4:], rtol=1e-5)  # what we see
    # the default tolerance (the batch's) stays within 0.1 % of Radau too
    default = simulate(design, PULSE, t_end=15.0, n_samples=0)
    np.testing.assert_allclose(default.reset_time[4:], radau.reset_time[4:], rtol=1e-3)


@pytest.mark.parametrize("method", ["rodas4-overdamped", "dopri5", "dopri5-overdamped"])
def test_other_methods_agree_with_rodas4(method):
    """Explicit and overdamped integrations give the same events (short scene, small finger)."""
    ref = simulate(SMALL, SHORT_PULSE, t_end=1.0, atol=1e-7, n_samples=0)
    run = simulate(SMALL, SHORT_PULSE, t_end=1.0, method=method, atol=1e-6, n_samples=0)
    assert run.status == st.OK and run.final_state == ref.final_state == "10"
    if "overdamped" in method:
        # dropping inertia shifts events by ~3e-5 s (the masses lag the load by ~m/η)
        np.testing.assert_allclose(run.snap_through, ref.snap_through, rtol=0, atol=1e-4)
        np.testing.assert_allclose(run.reset_time[1], ref.reset_time[1], rtol=2e-3)
    else:
        np.testing.assert_allclose(run.snap_through, ref.snap_through, rtol=1e-5)
        np.testing.assert_allclose(run.reset_time[1], ref.reset_time[1], rtol=1e-4)


def test_static_equilibrium_is_a_fixed_point():
    from dpfexplore.solvers.statics import find_state

    design = Design(**PICKPLACE)
    state = find_state(design, "111100")
    assert state.stable
    zero = PressureProfile((0.0,), (0.0,))
    for method in ("rodas4", "rodas4-overdamped"):
        run = simulate(
            design,
            zero,
            t_end=2.0,
            method=method,
            x0=state.x,
            v0=np.zeros_like(state.x),
            atol=1e-8,
            n_samples=21,
        )
        assert run.status == st.OK and run.events.shape[0] == 0
        assert np.abs(run.x - state.x).max() < 1e-8
        assert np.abs(run.final_v).max() < 1e-7


def test_pulse_ends_in_the_state_the_static_solver_predicts(pickplace_run):
    """Ten seconds after the release the finger sits on the static minimum of its final state."""
    from dpfexplore.solvers.statics import find_state

    design = Design(**PICKPLACE)
    state = find_state(design, pickplace_run.final_state)
    assert state.stable and state.found == "111100"
    # the slowest mode decays at 1.2 /s: after 9.9 s the residual is ~1e-5 of the motion
    assert np.abs(pickplace_run.final_x - state.x).max() < 1e-3
    np.testing.assert_allclose(pickplace_run.tip[-1], state.tip, atol=1e-3)


def test_slowest_relaxation_of_the_pick_and_place_finger():
    """The slow mode behind the documented limits of reduced models and the hold-time effect.

    Linearised overdamped dynamics at the 111100 state: rates are the generalised eigenvalues
    of the Hessian against the damping matrix. The slowest, ~1.2 /s, is a global bending of
    the finger resisted by the torsion springs and damped by the isotropic drag.
    """
    from scipy.linalg import eigh

    from dpfexplore._kernels.dynamics.motion import damping_matrix
    from dpfexplore._kernels.lattice import lattice_hessian
    from dpfexplore.solvers.statics import find_state

    design = Design(**PICKPLACE)
    state = find_state(design, "111100")
    params = lattice_params(design)
    n = state.x.size
    hess = np.empty((n, n))
    lattice_hessian(state.x, params.unit_params, params.h, np.empty(n), hess)
    pos = np.empty((14, 2))
    unpack_nodes(state.x, params.unit_params, params.h, pos)
    cmat = np.empty((n, n))
    damping_matrix(pos, params.unit_params, params.h, ETA_INTERNAL, ETA_ISO, np.empty(n), cmat)
    rates = eigh(hess, cmat, eigvals_only=True)
    # the reference integration relaxes at that rate once the units 5-6 have reset (from 7.8 s,
    # at zero pressure, toward this state): three equally spaced tip samples of its tail give it
    ref = read_reference("pickplace_dynamics.csv")
    a, b, c = np.interp([10.0, 12.5, 15.0], ref.t, ref.tip_x)  # sample times of the 601
    observed = -np.log((c - b) / (b - a)) / 2.5  # 1.234 /s
    assert rates[0] == pytest.approx(observed, rel=0.01)
    assert rates[1] > 4 * rates[0]


def _energy(params, x, v, n_units):
    return lattice_energy(x, params.unit_params, params.h) + 0.5 * node_mass(n_units) * v @ v


def _perturbed(design, seed=1, spread=0.05):
    params = lattice_params(design)
    n = 4 * design.n_units - 2
    y = np.empty(2 * n)
    rest_state(params.unit_params, params.h, y)
    return params, y[:n] + np.random.default_rng(seed).normal(0, spread, n)


@pytest.mark.parametrize("method", ["dopri5", "rodas4"])
def test_undamped_unloaded_lattice_conserves_energy(method):
    """η = η_iso = 0, P = 0: total energy constant over ~300 periods of the fastest mode.

    Neither integrator is symplectic, so the energy error is the accumulated local error: it
    must be small (< 1e-4 relative at atol = 1e-9 mm) and shrink with the tolerance, which a
    dissipative or unstable scheme cannot do.
    """
    design = Design(H=[4.0, 3.5, 3.0], U_L=6.0, U_sep=1.0, t=0.83, t_lim=1.0)
    params, x0 = _perturbed(design)
    zero = PressureProfile((0.0,), (0.0,))
    drift = {}
    for atol in (1e-7, 1e-9):
        x, v = x0.copy(), np.zeros_like(x0)
        e0 = _energy(params, x, v, 3)
        worst = 0.0
        for _ in range(20):  # 0.1 s; fastest period ~0.3 ms, slowest ~40 ms
            run = simulate(
                design,
                zero,
                t_end=0.005,
                method=method,
                x0=x,
                v0=v,
                eta=0.0,
                eta_iso=0.0,
                atol=atol,
                n_samples=0,
            )
            assert run.status == st.OK
            x, v = run.final_x, run.final_v
            worst = max(worst, abs(_energy(params, x, v, 3) - e0) / e0)
        drift[atol] = worst
    assert drift[1e-9] < 1e-4
    assert drift[1e-9] < drift[1e-7] / 10


def test_damped_unloaded_lattice_never_gains_energy():
    """With the paper's damping and no load the total energy decreases monotonically."""
    design = Design(H=[4.0, 3.5, 3.0], U_L=6.0, U_sep=1.0, t=0.83, t_lim=1.0)
    params, x = _perturbed(design, spread=0.3)
    v = np.zeros_like(x)
    zero = PressureProfile((0.0,), (0.0,))
    energies = [_energy(params, x, v, 3)]
    for _ in range(100):
        run = simulate(design, zero, t_end=0.002, x0=x, v0=v, atol=1e-9, n_samples=0)
        x, v = run.final_x, run.final_v
        energies.append(_energy(params, x, v, 3))
    energies = np.array(energies)
    assert energies[-1] < 1e-3 * energies[0]
    assert np.all(np.diff(energies) <= 1e-12 * energies[0])


def _boundary_unit(eps, t=0.8):
    """One unit with ``α = 1/9 + ε`` and no torsional restraint: the isolated dome (MODEL.md §4).

    In a finger the limiting layer's torsion adds ``k_t/h²`` (~1.6 % of ``k_b``) to the dome's
    restoring stiffness and moves the bistable boundary; with the torsion switched off the only
    other spring at ``D_1`` is the post, perpendicular to the dome, so the dome's own ``α``
    decides. ``H`` is solved for ``α`` by ``brentq``.
    """
    H = brentq(
        lambda H: dome_alpha(H, t, dome_radius(H, 5.0)) - (ALPHA_BISTABLE + eps),
        2.5,
        3.5,
        xtol=1e-14,
        rtol=1e-15,
    )
    design = Design(H=[H], U_L=6.0, U_sep=1.0, t=t, t_lim=1.0)
    return design, lattice_params(design).scaled(COL_KT, 0.0)


def test_reset_time_diverges_like_inverse_square_root_near_bistable_boundary():
    """``T ~ A ε^(-1/2)``; the saddle-node passage gives ``A`` in closed form.

    For ``c ẋ = -f(x)`` near the double root at ``u = 3/4``, ``f ≈ a + b (x - x*)²`` with
    ``a = 27 k_b d ε/32`` and ``b = 4 k_b/(3 d)``, so the passage takes ``π c/√(ab)`` and the
    threshold ``u = 3/4`` is crossed half-way: ``T ≈ π c / (2 k_b √(9ε/8))`` with the dome's
    damping ``c = η + η_iso`` (the perpendicular post adds none at rest length).
    """
    release = PressureProfile.pulse(0.7, (0.0, 0.2, 0.4, 0.5))
    eps = np.array([1e-2, 3e-3, 1e-3, 3e-4, 1e-4])
    resets = []
    for e in eps:
        design, lattice = _boundary_unit(e)
        horizon = 0.5 + 10.0 / math.sqrt(e) * 0.01
        run = simulate(
            design,
            release,
            t_end=horizon,
            lattice=lattice,
            atol=1e-5,
            n_samples=0,
            stop_when_reset=True,
        )
        assert run.status == st.OK and run.stats["steps"] < 500  # never hangs
        assert run.unit_class[0] == "metastable"
        resets.append(run.reset_time[0])
    resets = np.array(resets)
    assert np.all(np.diff(resets) > 0)
    (_amplitude, _offset, exponent), _ = curve_fit(
        lambda log_e, a, b, p: a * np.exp(p * log_e) + b, np.log(eps), resets, p0=(0.01, 0, -0.5)
    )
    assert exponent == pytest.approx(-0.5, abs=0.03)
    k_b = spring_constants(_boundary_unit(1e-4)[0]).k_b[0]
    closed_form = math.pi * (ETA_INTERNAL + ETA_ISO) / (2 * k_b * math.sqrt(9 / 8 * 1e-4))
    assert resets[-1] == pytest.approx(closed_form, rel=0.08)
    # and just on the other side the unit is bistable: it never resets
    design, lattice = _boundary_unit(-1e-3)
    run = simulate(design, release, t_end=5.0, lattice=lattice, n_samples=0)
    assert run.status == st.OK and run.reset_time[0] == math.inf
    assert run.unit_class == ("bistable",) and run.final_state == "1"


def test_step_cap_stops_the_run_with_a_status():
    run = simulate(Design(**PICKPLACE), PULSE, t_end=15.0, max_steps=50, n_samples=0)
    assert run.status == st.STEP_LIMIT
    # units still inverted when the run stopped have no reset time to report
    inverted = np.array([b == "1" for b in run.final_state])
    assert np.all(np.isnan(run.reset_time[inverted]))


def test_scipy_baseline_has_an_evaluation_cap():
    run = simulate_scipy(SMALL, SHORT_PULSE, t_end=1.0, max_nfev=200, n_samples=0)
    assert run.status == st.STEP_LIMIT


def test_two_pulses_log_every_crossing():
    """A metastable unit snaps through and back twice; reset time counts from the last knot."""
    profile = PressureProfile.pulses([(0.7, 0.0, 0.1, 0.3, 0.35), (0.7, 1.0, 1.1, 1.3, 1.35)])
    run = simulate(SMALL, profile, t_end=2.0, atol=1e-6)
    tip_unit = run.events[run.events[:, 1] == 2]
    np.testing.assert_array_equal(tip_unit[:, 2], [1, -1, 1, -1])
    assert run.snap_through[1] == tip_unit[0, 0] and run.snap_back[1] == tip_unit[3, 0]
    assert run.reset_time[1] == pytest.approx(tip_unit[3, 0] - 1.35)
    assert 0.3 < tip_unit[1, 0] < 1.0  # reset between the pulses


def test_simulate_rejects_bad_input():
    with pytest.raises(ValueError, match="t_end"):
        simulate(SMALL, PULSE, t_end=2.0)
    with pytest.raises(ValueError, match="method"):
        simulate(SMALL, PULSE, t_end=10.0, method="euler")
    with pytest.raises(ValueError, match="x0"):
        simulate(SMALL, PULSE, t_end=10.0, x0=np.zeros(3))
    with pytest.raises(ValueError, match="atol"):
        simulate(SMALL, PULSE, t_end=10.0, atol=-1.0)


def test_tip_and_extensions_follow_the_samples(pickplace_run):
    params = lattice_params(Design(**PICKPLACE))
    pos = np.empty((14, 2))
    unpack_nodes(pickplace_run.x[300], params.unit_params, params.h, pos)
    np.testing.assert_array_equal(pickplace_run.tip[300], pos[13])
    assert pickplace_run.pressure[40] == pytest.approx(0.7)  # t = 1.0 s


def test_damping_constants_are_the_papers():
    assert (ETA_INTERNAL, ETA_ISO) == (0.05, 0.01)
    assert node_mass(5) == pytest.approx(7e-6 / 12)
