"""Training the fitted part of the fast reset-time model, with active learning.

``dpfexplore reset-model fit`` calls :func:`fit_reset_model`. The physics core
(:func:`.fast_reset.fast_reset_core`) is fixed; what is fitted, on designs simulated by the full
model (``rodas4`` at ``atol = 1e-7`` mm, 1000x tighter than its default):

* the **correction**: gradient-boosted trees (depth 3, Huber loss, so the rare units whose core
  time is qualitatively off do not pull the rest) on :data:`.fast_reset_model.FEATURES`,
  target ``log(T_full / T_core)`` per unit whose core time is at least ``small_T``;
* the **scale**: trees with the quantile loss at 0.9 on the corrected error, fitted on
  out-of-fold residuals (two folds by design), so the scale sees errors the correction did not
  fit;
* the **conformal factor** ``q``: on a separate calibration sample drawn from the target
  distribution (not the actively chosen designs, so the guarantee holds for that distribution),
  the ``⌈0.9 (n + 1)⌉``-th smallest of ``|log(T_full / T)| / scale``; a unit whose class differs
  (the full model resets it, the model does not, or the other way) scores infinity;
* ``margin_min``: 1.5 times the largest snap-decision margin at which the core's snap pattern
  disagreed with the full model in the training designs (at least ``MARGIN_FLOOR``);
* ``abs_halfwidth`` of monostable units: the conformal quantile of their absolute error.

**Active learning**: after an initial uniform sample, each round draws a pool of candidate
designs, runs only the core on them (cheap), scores each by the largest predicted scale of its
units (the model's own estimate of where it errs most: near the bistable boundary, where reset
times grow without bound, and around snap cascades), simulates the top-scoring ones with the full
model, adds them and refits. The calibration sample is never chosen this way.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..model.design import DEFAULTS, DesignBatch
from ..model.domain import MAX_UNITS
from ..model.pressure import PressureProfile
from ..model.version import package_versions
from ..solvers.dynamics.fast_reset import fast_reset_core, raced_release, unit_features
from ..solvers.dynamics.reset_model import FEATURES, ResetModel, TreeEnsemble, provenance_now
from ..solvers.dynamics.simulate import reset_times_batch

__all__ = ["DEFAULT_DOMAIN", "TrainingOptions", "fit_reset_model", "training_designs"]

logger = logging.getLogger(__name__)

#: The design domain of the packaged model: the ``bench dynamics`` distribution (2-6 units,
#: heights 3-5 mm with one or two low domes of 2.6-3.2 mm) with a little room in ``t`` and
#: ``U_sep``.
DEFAULT_DOMAIN = {
    "n_units": (2, 6),
    "H": (2.6, 5.0),
    "U_L": (5.5, 10.0),
    "U_sep": (1.0, 2.5),
    "t": (0.7, 1.0),
    "t_lim": (1.0, 2.0),
    "fixed": {name: DEFAULTS[name] for name in ("E", "nu", "r_b", "t_ch")},
}
#: Range of the low domes the sampler puts in each design (mm), and their count (1-2).
LOW_DOMES = (2.6, 3.2)
#: Share of designs whose ``U_L`` and ``U_sep`` vary from unit to unit.
PER_UNIT_SHARE = 0.25
#: Tolerance (mm) of the full-model runs that label the training designs.
REFERENCE_ATOL = 1e-7
#: Units with a core reset time below this (s) get an absolute interval (monostable units).
SMALL_T = 0.04
#: Floor of ``margin_min`` (N).
MARGIN_FLOOR = 0.01
#: Smallest scale (log units) the interval uses.
SCALE_FLOOR = 1e-4


@dataclass(frozen=True)
class TrainingOptions:
    """Sizes and settings of a training run (``dpfexplore reset-model fit`` options).

    Attributes
    ----------
    P0 : float, MPa
    tau : tuple of 4 float, s
    horizon : float, s
        ``t_end - τ4`` of the labelling runs (the longest horizon the model serves).
    initial, per_round, rounds : int
        Uniform designs first, then actively chosen designs per round, number of rounds.
    pool : int
        Candidates scored per round.
    calibration : int
        Uniform designs for the conformal calibration.
    atol : float, mm
        The core's release tolerance.
    seed : int
    """

    P0: float = 0.7
    tau: tuple[float, float, float, float] = (0.0, 1.0, 5.0, 5.1)
    horizon: float = 15.0
    initial: int = 3000
    per_round: int = 1000
    rounds: int = 2
    pool: int = 8000
    calibration: int = 2000
    atol: float = 3e-3
    seed: int = 2025


def training_designs(n: int, seed: int, domain: dict | None = None) -> DesignBatch:
    """``n`` valid random designs of the domain, each with one or two low domes.

    Heights uniform in ``[max(3, H_low), H_high]`` with one or two of them redrawn in
    :data:`LOW_DOMES` (the metastable candidates); ``U_L``, ``U_sep`` one value per design, or
    one per unit for :data:`PER_UNIT_SHARE` of the designs; ``t``, ``t_lim`` uniform.
    """
    domain = domain or DEFAULT_DOMAIN
    rng = np.random.default_rng(seed)
    kept: list[DesignBatch] = []
    count = 0
    while count < n:
        m = max(16, 2 * (n - count))
        lo_n, hi_n = domain["n_units"]
        n_units = rng.integers(lo_n, hi_n + 1, m)
        H = np.full((m, MAX_UNITS), np.nan)
        U_L = H.copy()
        U_sep = H.copy()
        active = np.arange(MAX_UNITS)[None, :] < n_units[:, None]
        h_low, h_high = domain["H"]
        H_all = rng.uniform(max(3.0, h_low), h_high, (m, MAX_UNITS))
        per_unit = rng.random(m) < PER_UNIT_SHARE
        for name, target in (("U_L", U_L), ("U_sep", U_sep)):
            low, high = domain[name]
            shared = rng.uniform(low, high, (m, 1))
            own = rng.uniform(low, high, (m, MAX_UNITS))
            target[:] = np.where(per_unit[:, None], own, shared)
        for i in range(m):
            low = rng.choice(n_units[i], size=min(n_units[i], rng.integers(1, 3)), replace=False)
            H_all[i, low] = rng.uniform(max(LOW_DOMES[0], h_low), LOW_DOMES[1], low.size)
        H[active] = H_all[active]
        U_L[~active] = np.nan
        U_sep[~active] = np.nan
        batch = DesignBatch(
            n_units=n_units,
            H=H,
            U_L=U_L,
            U_sep=U_sep,
            t=rng.uniform(*domain["t"], m),
            t_lim=rng.uniform(*domain["t_lim"], m),
            **domain["fixed"],
        )
        batch = batch.take(np.flatnonzero(batch.status() == 0)[: n - count])
        kept.append(batch)
        count += len(batch)
    return DesignBatch.concatenate(kept)


@dataclass
class _Labelled:
    """Designs with their core outputs and the full model's."""

    batch: DesignBatch
    core: dict
    ref: dict

    def extend(self, other: _Labelled) -> _Labelled:
        cat = {k: np.concatenate([self.core[k], other.core[k]]) for k in self.core}
        ref = {k: np.concatenate([self.ref[k], other.ref[k]]) for k in self.ref}
        return _Labelled(DesignBatch.concatenate([self.batch, other.batch]), cat, ref)


def _label(
    batch: DesignBatch,
    profile: PressureProfile,
    t_end: float,
    atol: float,
    core: dict | None = None,
) -> _Labelled:
    if core is None:
        core = fast_reset_core(batch, profile, t_end=t_end, atol=atol)
    start = time.perf_counter()
    ref = reset_times_batch(batch, profile, t_end=t_end, atol=REFERENCE_ATOL)
    logger.info(
        "labelled %d designs with the full model in %.1f s", len(batch), time.perf_counter() - start
    )
    return _Labelled(batch, core, ref)


def _units(data: _Labelled, small_t: float) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """Features, target ``log(T_ref/T_core)``, design index and the unit mask of the slow units.

    Rows: units of designs whose core and full model both ran (and whose release was no race,
    :func:`.fast_reset.raced_release`), with a core time >= ``small_t``
    and a finite reference time (units whose class the core gets wrong are left to the scale
    and the conformal factor).
    """
    core_t = data.core["reset_time"]
    ref_t = data.ref["reset_time"]
    ok = (data.core["status"] == 0) & (data.ref["status"] == 0) & ~raced_release(data.core)
    with np.errstate(invalid="ignore"):
        mask = (
            ok[:, None]
            & np.isfinite(core_t)
            & (core_t >= small_t)
            & np.isfinite(ref_t)
            & (ref_t > 0.0)
        )
    x = unit_features(data.batch, data.core, mask)
    y = np.log(ref_t[mask] / core_t[mask])
    return x, y, np.nonzero(mask)[0], mask


def _gbr(**kwargs):
    from sklearn.ensemble import GradientBoostingRegressor

    base = {
        "n_estimators": 400,
        "max_depth": 3,
        "learning_rate": 0.05,
        "subsample": 0.8,
        "min_samples_leaf": 20,
        "n_iter_no_change": 20,
        "validation_fraction": 0.15,
        "random_state": 0,
    }
    return GradientBoostingRegressor(**{**base, **kwargs})


def _fit_trees(x: NDArray, y: NDArray, groups: NDArray, seed: int):
    """Correction on all rows; scale on two-fold out-of-fold residuals (folds by design)."""
    correction = _gbr(loss="huber", alpha=0.9).fit(x, y)
    rng = np.random.default_rng(seed)
    designs = np.unique(groups)
    fold_of = dict(zip(designs, rng.integers(0, 2, designs.size), strict=True))
    fold = np.array([fold_of[g] for g in groups])
    residual = np.empty_like(y)
    for f in (0, 1):
        part = _gbr(loss="huber", alpha=0.9).fit(x[fold != f], y[fold != f])
        residual[fold == f] = np.abs(y[fold == f] - part.predict(x[fold == f]))
    scale = _gbr(loss="quantile", alpha=0.9).fit(x, residual)
    return TreeEnsemble.from_gradient_boosting(correction), TreeEnsemble.from_gradient_boosting(
        scale
    )


def _margin_min(data: _Labelled) -> float:
    """1.5x the largest snap margin where the core's snapped units differ from the full model's."""
    ok = (data.core["status"] == 0) & (data.ref["status"] == 0)
    core_inv = ~np.isnan(data.core["reset_time"])
    ref_inv = ~np.isnan(data.ref["reset_time"])
    wrong = ok & (core_inv != ref_inv).any(axis=1)
    margins = data.core["design_diag"][wrong, 2]
    worst = float(np.nanmax(margins)) if margins.size else 0.0
    return max(MARGIN_FLOOR, 1.5 * worst)


def _conformal(model: ResetModel, data: _Labelled, horizon: float) -> tuple[float, float, dict]:
    """Conformal factor, monostable half-width and calibration facts on ``data``."""
    core_t = data.core["reset_time"]
    ref_t = data.ref["reset_time"]
    run = (
        (data.core["status"] == 0)
        & (data.ref["status"] == 0)
        & (data.core["design_diag"][:, 2] >= model.margin_min)
        & ~raced_release(data.core)
    )
    with np.errstate(invalid="ignore"):
        slow = run[:, None] & np.isfinite(core_t) & (core_t >= model.small_T)
        quick = run[:, None] & np.isfinite(core_t) & (core_t < model.small_T)
    x = unit_features(data.batch, data.core, slow)
    predicted = core_t[slow] * np.exp(model.correction.predict(x))
    scale = np.maximum(model.scale.predict(x), model.scale_floor)
    with np.errstate(invalid="ignore", divide="ignore"):
        score = np.abs(np.log(ref_t[slow] / predicted)) / scale
    score = np.where(np.isfinite(ref_t[slow]) & (ref_t[slow] > 0.0), score, np.inf)
    # units the core keeps inverted but the full model resets: not covered
    missed = run[:, None] & np.isinf(core_t) & np.isfinite(ref_t) & (ref_t >= model.small_T)
    score = np.concatenate([score, np.full(int(missed.sum()), np.inf)])
    q = _conformal_quantile(score, model.coverage)
    quick_err = np.abs(ref_t[quick] - core_t[quick])
    quick_err = np.where(np.isfinite(quick_err), quick_err, np.inf)
    abs_half = _conformal_quantile(quick_err, model.coverage) if quick_err.size else 0.01
    facts = {
        "calibration_units": int(score.size),
        "calibration_quick_units": int(quick_err.size),
        "calibration_designs": int(run.sum()),
    }
    return q, abs_half, facts


def _conformal_quantile(score: NDArray, level: float) -> float:
    n = score.size
    k = min(n, math.ceil(level * (n + 1)))
    return float(np.sort(score)[k - 1]) if n else math.inf


def _score_pool(model: ResetModel, batch: DesignBatch, core: dict) -> NDArray:
    """Per design: the largest predicted scale of its slow units (0 where none)."""
    with np.errstate(invalid="ignore"):
        slow = (
            (core["status"] == 0)[:, None]
            & np.isfinite(core["reset_time"])
            & (core["reset_time"] >= model.small_T)
        )
    score = np.zeros(len(batch))
    if slow.any():
        s = model.scale.predict(unit_features(batch, core, slow))
        np.maximum.at(score, np.nonzero(slow)[0], s)
    # a design whose snap decision is close to its margin is as uncertain
    margin = core["design_diag"][:, 2]
    score = np.where(margin < 3.0 * model.margin_min, np.maximum(score, 1.0), score)
    return score


def fit_reset_model(
    options: TrainingOptions = TrainingOptions(),
    domain: dict | None = None,
    *,
    progress: Callable[[str], None] | None = None,
) -> tuple[ResetModel, dict]:
    """Train the fitted part (module docstring); returns the model and a training record.

    ``progress`` receives one line per stage (labelling, each round, calibration): the training
    takes minutes and would otherwise be silent.
    """
    say = progress or (lambda text: logger.info("%s", text))
    domain = domain or DEFAULT_DOMAIN
    profile = PressureProfile.pulse(options.P0, options.tau)
    t_end = options.tau[3] + options.horizon
    start = time.perf_counter()
    seeds = np.random.SeedSequence(options.seed).spawn(options.rounds + 3)
    say(f"labelling {options.initial} uniform designs with the full model")
    data = _label(
        training_designs(options.initial, _int(seeds[0]), domain), profile, t_end, options.atol
    )
    rounds = []
    model = None
    for r in range(options.rounds + 1):
        x, y, groups, _ = _units(data, SMALL_T)
        correction, scale = _fit_trees(x, y, groups, options.seed + r)
        model = ResetModel(
            P0=options.P0,
            tau=tuple(options.tau),
            horizon_max=options.horizon,
            domain=domain,
            atol=options.atol,
            correction=correction,
            scale=scale,
            conformal_q=1.0,
            coverage=0.9,
            scale_floor=SCALE_FLOOR,
            small_T=SMALL_T,
            abs_halfwidth=0.01,
            margin_min=_margin_min(data),
        )
        rounds.append(
            {
                "round": r,
                "designs": len(data.batch),
                "units": int(y.size),
                "margin_min": model.margin_min,
            }
        )
        say(
            f"round {r} of {options.rounds}: correction fitted on {len(data.batch)} designs "
            f"({y.size} units), {time.perf_counter() - start:.0f} s so far"
        )
        if r == options.rounds:
            break
        say(f"round {r + 1}: scoring {options.pool} candidates, labelling {options.per_round}")
        pool = training_designs(options.pool, _int(seeds[r + 3]), domain)
        pool_core = fast_reset_core(pool, profile, t_end=t_end, atol=options.atol)
        chosen = np.argsort(-_score_pool(model, pool, pool_core), kind="stable")[
            : options.per_round
        ]
        pool_core = {k: v[chosen] for k, v in pool_core.items()}
        data = data.extend(_label(pool.take(chosen), profile, t_end, options.atol, pool_core))
        rounds[-1]["chosen_mean_score"] = float(
            np.mean(_score_pool(model, pool.take(chosen), pool_core))
        )
    say(f"calibrating the intervals on {options.calibration} uniform designs")
    calibration = _label(
        training_designs(options.calibration, _int(seeds[1]), domain), profile, t_end, options.atol
    )
    q, abs_half, facts = _conformal(model, calibration, options.horizon)
    importance = _importance(model, data)
    ablation = _ablation(model, data, calibration)
    info = {
        "trained": time.strftime("%Y-%m-%d %H:%M:%S %Z"),
        "seconds": round(time.perf_counter() - start, 1),
        "options": {k: getattr(options, k) for k in options.__dataclass_fields__},
        "reference_atol_mm": REFERENCE_ATOL,
        "rounds": rounds,
        "calibration": facts,
        "feature_importance": importance,
        "ablation": ablation,
        "versions": package_versions(),
    }
    model = ResetModel(
        **{
            **{k: getattr(model, k) for k in model.__dataclass_fields__},
            "conformal_q": q,
            "abs_halfwidth": abs_half,
            "info": info,
            "provenance": provenance_now(
                "trained by active learning on designs simulated by the full model "
                "(dpfexplore.surrogates.reset_training.fit_reset_model; options in info.options)"
            ),
        }
    )
    record = {
        "training_designs": len(data.batch),
        "calibration_designs": len(calibration.batch),
        **info,
    }
    return model, record


def _importance(model: ResetModel, data: _Labelled) -> dict[str, float]:
    """Mean absolute change of the correction when one feature is permuted (log units)."""
    x, _, _, _ = _units(data, model.small_T)
    base = model.correction.predict(x)
    rng = np.random.default_rng(0)
    out = {}
    for j, name in enumerate(FEATURES):
        shuffled = x.copy()
        shuffled[:, j] = rng.permutation(shuffled[:, j])
        out[name] = float(np.mean(np.abs(model.correction.predict(shuffled) - base)))
    return dict(sorted(out.items(), key=lambda item: -item[1]))


#: Features a fit without the release dynamics can use: the design and the static loading.
STATIC_FEATURES = tuple(
    name
    for name in FEATURES
    if name
    not in (
        "log_T_core",
        "crossings",
        "log_event_step",
        "event_error",
        "n_reset_core",
        "release_steps",
    )
)


def _ablation(model: ResetModel, data: _Labelled, calibration: _Labelled) -> dict:
    """Relative errors of the core alone, corrected, and of a fit without the release.

    On the calibration designs' metastable units; the last is a fit of ``log T`` on the static
    features only (the design and the static loading, no release dynamics: what a surrogate
    without the physics of the release gets, trained on the same designs).
    """

    def units(d: _Labelled):
        core_t = d.core["reset_time"]
        ref_t = d.ref["reset_time"]
        with np.errstate(invalid="ignore"):
            mask = (
                ((d.core["status"] == 0) & (d.ref["status"] == 0))[:, None]
                & np.isfinite(core_t)
                & np.isfinite(ref_t)
                & (ref_t >= 0.05)
                & (core_t >= model.small_T)
            )
        return unit_features(d.batch, d.core, mask), ref_t[mask], core_t[mask]

    def stats(rel):
        return {
            "median": float(np.median(rel)),
            "p95": float(np.quantile(rel, 0.95)),
            "max": float(rel.max()),
            "units": int(rel.size),
        }

    x_train, t_train, _ = units(data)
    x_test, t_test, core_test = units(calibration)
    if not (t_train.size and t_test.size):
        return {}
    static = [FEATURES.index(name) for name in STATIC_FEATURES]
    fit = _gbr(n_estimators=1500, max_depth=5, loss="huber", alpha=0.9).fit(
        x_train[:, static], np.log(t_train)
    )
    corrected = core_test * np.exp(model.correction.predict(x_test))
    return {
        "static_features": list(STATIC_FEATURES),
        "static_fit": stats(np.abs(np.exp(fit.predict(x_test[:, static])) / t_test - 1.0)),
        "core_alone": stats(np.abs(core_test / t_test - 1.0)),
        "core_corrected": stats(np.abs(corrected / t_test - 1.0)),
    }


def _int(seed_sequence: np.random.SeedSequence) -> int:
    return int(seed_sequence.generate_state(1)[0])
