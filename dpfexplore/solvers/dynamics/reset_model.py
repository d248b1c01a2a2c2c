"""The fitted part of the fast reset-time model, and its safe file format.

A :class:`ResetModel` holds what
:func:`dpfexplore.solvers.dynamics.fast_reset.fast_reset_times_batch` needs besides the physics:
the scene it was trained for, its domain, the core's tolerance, the fitted correction and scale
(regression trees as arrays, :class:`TreeEnsemble`), the conformal quantile of the prediction
interval, the fallback thresholds and the training record. It is saved as JSON, never pickled:
loading one runs no code, so a model file from anywhere is safe to open (it can still be a bad
model; its ``info`` says how it was trained and tested).

The package ships one model (:data:`DEFAULT_MODEL_PATH`, the pick-and-place scene: 0.7 MPa,
``τ = (0, 1, 5, 5.1)`` s); ``dpfexplore reset-model fit`` trains others.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..._kernels.records import TreeArrays
from ..._kernels.reset.trees import tree_ensemble_predict
from ...io.files import atomic_write
from ...model.constants_set import DEFAULT, ConstantsSet
from ...model.version import MODEL_VERSION

__all__ = [
    "DEFAULT_MODEL_PATH",
    "FEATURES",
    "MODEL_FORMAT",
    "ResetModel",
    "TreeEnsemble",
    "load_reset_model",
]

#: File format tag and version of a saved model.
MODEL_FORMAT = "dpfexplore-reset-model"
FORMAT_VERSION = 1
#: The model shipped with the package.
DEFAULT_MODEL_PATH = Path(__file__).parent / "data" / "reset_model.json"

#: Inputs of the correction and scale trees, one row per unit whose core reset time is finite
#: (built by :func:`dpfexplore.solvers.dynamics.fast_reset.unit_features`).
FEATURES = (
    "log_T_core",  # log of the core's reset time (s, floored at 1 ms)
    "n_units",
    "unit_from_base",  # 0 = unit 1
    "unit_from_tip",  # 0 = unit N
    "alpha",  # the unit's dome energy ratio (MODEL.md §3)
    "H",  # mm
    "t",  # mm
    "t_lim",  # mm
    "U_L",  # mm
    "U_sep",  # mm
    "alpha_before",  # α of the unit toward the base (0: none)
    "alpha_after",  # α of the unit toward the tip (0: none)
    "u_load",  # dome extension x̄/d at the loaded equilibrium
    "load_margin",  # N, the unit's snap decision λ (negative: snapped)
    "crossings",  # threshold crossings during the release
    "log_event_step",  # log of the step (s) that held the reset crossing
    "event_error",  # that step's error estimate (1 = tolerance)
    "n_inverted",  # units inverted at the start of the release
    "n_reset_core",  # units the core resets
    "release_steps",
    "design_load_margin",  # N, smallest |λ| of the design's snap decisions
)


@dataclass(frozen=True)
class TreeEnsemble:
    """A sum of regression trees in flat arrays (see :mod:`dpfexplore._kernels.reset.trees`).

    Attributes
    ----------
    feature, left, right : ndarray of int64, shape (n_nodes,)
    threshold, value : ndarray of shape (n_nodes,)
    roots : ndarray of int64, shape (n_trees,)
    bias : float
    """

    feature: NDArray[np.int64]
    threshold: NDArray[np.float64]
    left: NDArray[np.int64]
    right: NDArray[np.int64]
    value: NDArray[np.float64]
    roots: NDArray[np.int64]
    bias: float

    def predict(self, x: NDArray) -> NDArray[np.float64]:
        """Sum over the trees for each row of ``x`` (shape ``(n_rows, n_features)``)."""
        x = np.ascontiguousarray(x, dtype=np.float64)
        out = np.empty(x.shape[0])
        trees = TreeArrays(
            self.feature, self.threshold, self.left, self.right, self.value, self.roots, self.bias
        )
        tree_ensemble_predict(x, trees, out)
        return out

    @classmethod
    def from_gradient_boosting(cls, estimator) -> TreeEnsemble:
        """Flatten a fitted ``sklearn.ensemble.GradientBoostingRegressor`` (single output).

        Uses only its public attributes: ``estimators_[i, 0].tree_`` (``feature``,
        ``threshold``, ``children_left``/``right``, ``value``), ``learning_rate`` and ``init_``
        (the initial estimate, a constant).
        """
        trees = [est[0].tree_ for est in estimator.estimators_]
        rate = float(estimator.learning_rate)
        feature, threshold, left, right, value, roots = [], [], [], [], [], []
        offset = 0
        for tree in trees:
            roots.append(offset)
            leaf = tree.children_left < 0
            feature.append(np.where(leaf, 0, tree.feature))
            threshold.append(np.where(leaf, 0.0, tree.threshold))
            left.append(np.where(leaf, -1, tree.children_left + offset))
            right.append(np.where(leaf, -1, tree.children_right + offset))
            value.append(np.where(leaf, rate * tree.value[:, 0, 0], 0.0))
            offset += tree.node_count
        bias = float(np.ravel(estimator.init_.predict(np.zeros((1, estimator.n_features_in_))))[0])
        return cls(
            np.concatenate(feature).astype(np.int64),
            np.concatenate(threshold),
            np.concatenate(left).astype(np.int64),
            np.concatenate(right).astype(np.int64),
            np.concatenate(value),
            np.array(roots, dtype=np.int64),
            bias,
        )

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready form."""
        return {
            "feature": self.feature.tolist(),
            "threshold": self.threshold.tolist(),
            "left": self.left.tolist(),
            "right": self.right.tolist(),
            "value": self.value.tolist(),
            "roots": self.roots.tolist(),
            "bias": self.bias,
        }

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> TreeEnsemble:
        """Inverse of :meth:`to_dict`; ``ValueError`` if the arrays do not form trees."""
        arrays = {
            key: np.asarray(data[key])
            for key in ("feature", "threshold", "left", "right", "value", "roots")
        }
        n = arrays["feature"].shape[0]
        if any(a.ndim != 1 or (a.shape[0] != n and key != "roots") for key, a in arrays.items()):
            raise ValueError("tree ensemble: arrays of unequal length")
        for key in ("left", "right"):
            a = arrays[key]
            if a.size and (a.min() < -1 or a.max() >= n):
                raise ValueError(f"tree ensemble: {key} points outside the {n} nodes")
        if arrays["roots"].size and (arrays["roots"].min() < 0 or arrays["roots"].max() >= n):
            raise ValueError("tree ensemble: a root outside the nodes")
        return cls(
            arrays["feature"].astype(np.int64),
            arrays["threshold"].astype(float),
            arrays["left"].astype(np.int64),
            arrays["right"].astype(np.int64),
            arrays["value"].astype(float),
            arrays["roots"].astype(np.int64),
            float(data["bias"]),
        )


@dataclass(frozen=True)
class ResetModel:
    """Everything the fast reset model needs besides the physics (module docstring).

    Attributes
    ----------
    P0 : float, MPa
    tau : tuple of 4 float, s
        The scene: a single pulse; other profiles are outside the model.
    horizon_max : float, s
        Longest horizon ``t_end - τ4`` the training covered.
    domain : dict
        ``name -> (low, high)`` for ``n_units``, ``H``, ``U_L``, ``U_sep``, ``t``, ``t_lim``, and
        ``name -> value`` for the fixed ``E``, ``nu``, ``r_b``, ``t_ch`` (under ``"fixed"``).
    atol : float, mm
        Position tolerance of the core's release integration.
    correction, scale : TreeEnsemble
        ``log(T_full / T_core)`` and the 90 % quantile of its remaining error, from
        :data:`FEATURES`.
    conformal_q : float
        Split-conformal factor: the interval's half-width in ``log T`` is ``conformal_q·scale``.
    coverage : float
        Nominal coverage of that interval (0.9).
    scale_floor : float
        Smallest ``scale`` used (log units).
    small_T : float, s
        Below this core reset time (monostable units) intervals are absolute: ``± abs_halfwidth``.
    abs_halfwidth : float, s
    margin_min : float, N
        A design whose closest snap decision ``|λ|`` is below this falls back.
    info : dict
        Training record: designs, seeds, reference tolerance, metrics, versions, date.
    constants : dict
        ``{"name", "fingerprint"}`` of the constants set the training designs ran on (the
        paper's for a model file that records none); the model answers for designs of
        that set only (:meth:`check_constants`).
    """

    P0: float
    tau: tuple[float, float, float, float]
    horizon_max: float
    domain: dict[str, Any]
    atol: float
    correction: TreeEnsemble
    scale: TreeEnsemble
    conformal_q: float
    coverage: float
    scale_floor: float
    small_T: float
    abs_halfwidth: float
    margin_min: float
    features: tuple[str, ...] = FEATURES
    info: dict[str, Any] = field(default_factory=dict)
    constants: dict[str, str] = field(default_factory=lambda: _paper_constants())

    def check_constants(self, constants: ConstantsSet) -> None:
        """Refuse designs of another constants set than the training's (naming both).

        Raises
        ------
        ValueError
        """
        if constants.fingerprint != self.constants["fingerprint"]:
            raise ValueError(
                f"the fast reset model was trained on designs of constants set "
                f"{self.constants['name']!r} ({self.constants['fingerprint'][:12]}), these run "
                f"on {constants.label}: use the full model, or refit it "
                "(dpfexplore reset-model fit) on that set"
            )

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready form (with the format tag and the physics version)."""
        return {
            "format": MODEL_FORMAT,
            "format_version": FORMAT_VERSION,
            "model_version": MODEL_VERSION,
            "scene": {"P0": self.P0, "tau": list(self.tau)},
            "horizon_max": self.horizon_max,
            "domain": self.domain,
            "atol": self.atol,
            "features": list(self.features),
            "correction": self.correction.to_dict(),
            "scale": self.scale.to_dict(),
            "conformal_q": self.conformal_q,
            "coverage": self.coverage,
            "scale_floor": self.scale_floor,
            "small_T": self.small_T,
            "abs_halfwidth": self.abs_halfwidth,
            "margin_min": self.margin_min,
            "info": self.info,
            "constants": dict(self.constants),
        }

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> ResetModel:
        """Inverse of :meth:`to_dict`; ``ValueError`` naming what does not fit."""
        if data.get("format") != MODEL_FORMAT:
            raise ValueError(f"format = {data.get('format')!r}: not a {MODEL_FORMAT} file")
        if data.get("format_version") != FORMAT_VERSION:
            raise ValueError(
                f"format_version = {data.get('format_version')!r}: this dpfexplore "
                f"reads version {FORMAT_VERSION}"
            )
        if data.get("model_version") != MODEL_VERSION:
            raise ValueError(
                f"model_version = {data.get('model_version')!r}: trained on another physics "
                f"than this dpfexplore's {MODEL_VERSION!r}; refit it (dpfexplore reset-model fit)"
            )
        if tuple(data.get("features", ())) != FEATURES:
            raise ValueError("features: the model's inputs differ from this dpfexplore's; refit it")
        tau = tuple(float(v) for v in data["scene"]["tau"])
        if len(tau) != 4:
            raise ValueError(f"scene.tau = {list(tau)!r}: need 4 times")
        numbers = {
            key: float(data[key])
            for key in (
                "horizon_max",
                "atol",
                "conformal_q",
                "coverage",
                "scale_floor",
                "small_T",
                "abs_halfwidth",
                "margin_min",
            )
        }
        for key, value in numbers.items():
            if not math.isfinite(value) or value < 0.0:
                raise ValueError(f"{key} = {value!r}: must be a finite number >= 0")
        return cls(
            P0=float(data["scene"]["P0"]),
            tau=tau,
            domain=dict(data["domain"]),
            correction=TreeEnsemble.from_dict(data["correction"]),
            scale=TreeEnsemble.from_dict(data["scale"]),
            info=dict(data.get("info", {})),
            constants=_recorded_constants(data.get("constants")),
            **numbers,
        )

    def save(self, path: str | Path) -> Path:
        """Write the model as JSON; returns the path."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        # atomically: a kill or a full disk mid-write leaves the previous model whole
        return atomic_write(path, json.dumps(self.to_dict(), indent=1) + "\n")


def _paper_constants() -> dict[str, str]:
    return {"name": DEFAULT.name, "fingerprint": DEFAULT.fingerprint}


def _recorded_constants(value: Any) -> dict[str, str]:
    """A model file's constants record; the paper's set when the file predates it."""
    if value is None:
        return _paper_constants()
    if not isinstance(value, dict) or not isinstance(value.get("fingerprint"), str):
        raise ValueError("constants: need {name, fingerprint}")
    return {"name": str(value.get("name", "?")), "fingerprint": value["fingerprint"]}


def load_reset_model(path: str | Path | None = None) -> ResetModel:
    """Read a model file (the packaged one by default); cached per resolved path.

    Raises
    ------
    ValueError
        The file is missing, not JSON, or not a model this version can use.
    """
    return _load(str(Path(path or DEFAULT_MODEL_PATH).resolve()))


@lru_cache(maxsize=8)
def _load(path: str) -> ResetModel:
    try:
        data = json.loads(Path(path).read_text())
    except FileNotFoundError:
        raise ValueError(f"model = {path!r}: no such file") from None
    except json.JSONDecodeError as exc:
        raise ValueError(f"model = {path!r}: not JSON ({exc.msg}, line {exc.lineno})") from None
    if not isinstance(data, dict):
        raise ValueError(f"model = {path!r}: not a {MODEL_FORMAT} file")
    try:
        return ResetModel.from_dict(data)
    except (KeyError, TypeError) as exc:
        raise ValueError(f"model = {path!r}: missing or malformed entry {exc}") from None
