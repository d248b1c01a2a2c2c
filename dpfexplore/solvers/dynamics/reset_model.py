"""The fitted part of the fast reset-time model, and its checked file format.

A :class:`ResetModel` holds what
:func:`dpfexplore.solvers.dynamics.fast_reset.fast_reset_times_batch` needs besides the physics:
the scene it was trained for, its domain, the core's tolerance, the fitted correction and scale
(regression trees as arrays, :class:`~.tree_ensemble.TreeEnsemble`), the conformal quantile of
the prediction interval, the fallback thresholds, the training record and its provenance.

File format (JSON, never pickled: loading one runs no code), version :data:`FORMAT_VERSION`:
``format``, ``format_version``, ``model_version``, ``provenance`` (``created``, ``by`` and how),
``scene``, ``horizon_max``, ``domain``, ``atol``, ``features``, ``correction`` and ``scale``
(each with its arrays, ``n_features`` and the ``range`` its outputs lie in), the interval and
fallback numbers, ``info``, ``constants``, and ``sha256``: the SHA-256 of the canonical JSON of
everything else (sorted keys, no spaces, :func:`canonical_sha256`).

:func:`load_reset_model` reads at most :data:`MAX_MODEL_BYTES` of a regular file and checks the
whole of it before anything runs: the header, every number finite and within its meaning
(coverage in (0, 1), tolerances positive, the domain's ranges ordered and inside the physical
limits), the trees well formed (:mod:`.tree_ensemble`: indices in range, no cycle, every node
reached once, their outputs within the recorded range, itself within ±:data:`LOG_LIMIT`), and
last the checksum. Anything else is one ``ValueError`` line naming the file. A file of format
version 1 (no checksum, no provenance) is refused with the command that upgrades it
(:func:`upgrade_reset_model`, ``dpfexplore reset-model upgrade``), which checks the same and
keeps every number, so results stay bit for bit.

The package ships one model (:data:`DEFAULT_MODEL_PATH`, the pick-and-place scene: 0.7 MPa,
``τ = (0, 1, 5, 5.1)`` s); ``dpfexplore reset-model fit`` trains others.
"""

from __future__ import annotations

import hashlib
import json
import os
import time
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import Any

from ...io.files import SIZE_LIMITS, BoundedReadError, atomic_write, read_json_bounded
from ...model.constants_set import DEFAULT, ConstantsSet
from ...model.formatting import json_text
from ...model.limits import MAX_UNITS
from ...model.pressure import PressureProfile
from ...model.version import MODEL_VERSION
from .tree_ensemble import TreeEnsemble, TreeError, finite_number

__all__ = [
    "DEFAULT_MODEL_PATH",
    "FEATURES",
    "FORMAT_VERSION",
    "LOG_LIMIT",
    "MAX_MODEL_BYTES",
    "MODEL_FORMAT",
    "ResetModel",
    "TreeEnsemble",
    "canonical_sha256",
    "load_reset_model",
    "provenance_now",
    "upgrade_reset_model",
]

#: File format tag and version of a saved model (2: checksum, provenance, recorded ranges).
MODEL_FORMAT = "dpfexplore-reset-model"
FORMAT_VERSION = 2
#: The model shipped with the package.
DEFAULT_MODEL_PATH = Path(__file__).parent / "data" / "reset_model.json"
#: Largest model file read, bytes (the reason in :data:`dpfexplore.io.files.SIZE_LIMITS`).
MAX_MODEL_BYTES = SIZE_LIMITS["reset model"].bytes
#: Bound of the trees' recorded output ranges, log units: the correction is ``log(T_full /
#: T_core)`` and the scale the size of its error; ``e^20`` (5e8) is beyond any reset time ratio
#: the core can be off by.
LOG_LIMIT = 20.0
#: Ranged keys of a model's domain; ``fixed`` holds the material and plate values.
DOMAIN_RANGES = ("n_units", "H", "U_L", "U_sep", "t", "t_lim")
DOMAIN_FIXED = ("E", "nu", "r_b", "t_ch")

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
        ``{"name", "fingerprint"}`` of the constants set the training designs ran on; the model
        answers for designs of that set only (:meth:`check_constants`).
    provenance : dict of str to str
        ``created`` (UTC time), ``by`` (the program and its version) and how the model was made.

    Raises
    ------
    ValueError
        On construction, naming the first value outside its meaning (module docstring).
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
    provenance: dict[str, str] = field(default_factory=lambda: provenance_now("built in Python"))

    def __post_init__(self) -> None:
        _check_model(self)

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
        """JSON-ready form: the format tag, the physics version and the checksum ``sha256``."""
        body = {
            "format": MODEL_FORMAT,
            "format_version": FORMAT_VERSION,
            "model_version": MODEL_VERSION,
            "provenance": dict(self.provenance),
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
            "info": json.loads(json_text(self.info, indent=None)),
            "constants": dict(self.constants),
        }
        return {**body, "sha256": canonical_sha256(body)}

    @classmethod
    def from_dict(cls, data: Any) -> ResetModel:
        """Inverse of :meth:`to_dict`; ``ValueError`` naming what does not fit.

        Everything is checked (module docstring), the checksum last.
        """
        _check_header(data)
        model = _model_from(data, provenance=_provenance_of(data.get("provenance")))
        body = {k: v for k, v in data.items() if k != "sha256"}
        recorded = data.get("sha256")
        if not isinstance(recorded, str):
            raise ValueError("sha256: missing (the checksum of everything else)")
        if canonical_sha256(body) != recorded:
            raise ValueError(
                "sha256 differs from the contents (the file was changed or damaged after it "
                "was written): refit it (dpfexplore reset-model fit)"
            )
        return model

    def save(self, path: str | Path) -> Path:
        """Write the model as JSON and read it back checked; returns the path."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        # atomically: a kill or a full disk mid-write leaves the previous model whole
        atomic_write(path, json.dumps(self.to_dict(), indent=1, allow_nan=False) + "\n")
        load_reset_model(path)
        return path


def canonical_sha256(data: Any) -> str:
    """SHA-256 of ``data`` as canonical JSON (sorted keys, no spaces, ASCII, no NaN)."""
    text = json.dumps(
        data, sort_keys=True, separators=(",", ":"), ensure_ascii=True, allow_nan=False
    )
    return hashlib.sha256(text.encode()).hexdigest()


def provenance_now(how: str) -> dict[str, str]:
    """A model's provenance made now: ``created`` (UTC), ``by`` (dpfexplore's version), ``how``."""
    from importlib.metadata import version

    return {
        "created": time.strftime("%Y-%m-%d %H:%M:%S UTC", time.gmtime()),
        "by": f"dpfexplore {version('dpfexplore')}",
        "how": how,
    }


def _provenance_of(value: Any) -> dict[str, str]:
    if not isinstance(value, dict) or not all(
        isinstance(value.get(k), str) and value.get(k) for k in ("created", "by")
    ):
        raise ValueError("provenance: need a table with the strings created and by")
    if not all(isinstance(v, str) for v in value.values()):
        raise ValueError("provenance: every entry must be a string")
    return dict(value)


def _paper_constants() -> dict[str, str]:
    return {"name": DEFAULT.name, "fingerprint": DEFAULT.fingerprint}


def _recorded_constants(value: Any) -> dict[str, str]:
    """A model file's constants record; the paper's set when the file predates it."""
    if value is None:
        return _paper_constants()
    if not isinstance(value, dict) or not isinstance(value.get("fingerprint"), str):
        raise ValueError("constants: need {name, fingerprint}")
    return {"name": str(value.get("name", "?")), "fingerprint": value["fingerprint"]}


def _check_header(data: Any, version: int = FORMAT_VERSION) -> None:
    if not isinstance(data, dict):
        raise ValueError(f"not a {MODEL_FORMAT} file (not a JSON object)")
    if data.get("format") != MODEL_FORMAT:
        raise ValueError(f"format = {data.get('format')!r}: not a {MODEL_FORMAT} file")
    found = data.get("format_version")
    if found == 1 and version == FORMAT_VERSION:
        raise ValueError(
            "format_version = 1: a model of an earlier dpfexplore, without checksum or "
            "provenance; 'dpfexplore reset-model upgrade FILE --out NEW.json' checks it and "
            "writes it in this format (same numbers), or refit it (dpfexplore reset-model fit)"
        )
    if found != version:
        raise ValueError(f"format_version = {found!r}: this dpfexplore reads version {version}")
    if data.get("model_version") != MODEL_VERSION:
        raise ValueError(
            f"model_version = {data.get('model_version')!r}: trained on another physics "
            f"than this dpfexplore's {MODEL_VERSION!r}; refit it (dpfexplore reset-model fit)"
        )
    if data.get("features") != list(FEATURES):
        raise ValueError("features: the model's inputs differ from this dpfexplore's; refit it")


_NUMBERS = (
    "horizon_max",
    "atol",
    "conformal_q",
    "coverage",
    "scale_floor",
    "small_T",
    "abs_halfwidth",
    "margin_min",
)


def _model_from(data: dict[str, Any], *, provenance: dict[str, str]) -> ResetModel:
    """The model of a file's entries (format version 1 or 2: trees without recorded ranges in 1)."""
    scene = data.get("scene")
    if not isinstance(scene, dict) or not isinstance(scene.get("tau"), list):
        raise ValueError("scene: need a table with P0 and tau")
    trees = {}
    for key in ("correction", "scale"):
        entry = data.get(key)
        if isinstance(entry, dict) and data.get("format_version") == 1:
            ensemble = _v1_ensemble(entry)
            entry = {**entry, "n_features": len(FEATURES), "range": list(ensemble.output_range)}
        try:
            trees[key] = TreeEnsemble.from_dict(entry, limit=LOG_LIMIT)
        except TreeError as exc:
            raise ValueError(f"{key}: {exc}") from None
        if trees[key].n_features != len(FEATURES):
            raise ValueError(f"{key}.n_features = {trees[key].n_features}: need {len(FEATURES)}")
    info = data.get("info", {})
    if not isinstance(info, dict):
        raise ValueError("info: need a table")
    if not isinstance(data.get("domain"), dict):
        raise ValueError("domain: need a table")
    return ResetModel(
        P0=finite_number(scene.get("P0"), "scene.P0"),
        tau=tuple(finite_number(v, f"scene.tau[{i}]") for i, v in enumerate(scene["tau"])),
        domain=data["domain"],
        correction=trees["correction"],
        scale=trees["scale"],
        info=info,
        constants=_recorded_constants(data.get("constants")),
        provenance=provenance,
        **{key: finite_number(data.get(key), key) for key in _NUMBERS},
    )


def _v1_ensemble(entry: dict[str, Any]) -> TreeEnsemble:
    """A format-1 ensemble (no ``n_features``, no ``range``), checked as any."""
    try:
        return TreeEnsemble.from_dict(
            {**entry, "n_features": len(FEATURES), "range": [-LOG_LIMIT, LOG_LIMIT]},
            limit=LOG_LIMIT,
        )
    except TreeError as exc:
        raise ValueError(f"trees: {exc}") from None


def _check_model(model: ResetModel) -> None:
    """Every value of a model within its meaning (module docstring); ``ValueError`` naming it."""
    for key in ("correction", "scale"):
        if not isinstance(getattr(model, key), TreeEnsemble):
            raise ValueError(f"{key}: need a TreeEnsemble")
    if tuple(model.features) != FEATURES:
        raise ValueError("features: the model's inputs differ from this dpfexplore's; refit it")
    numbers = {key: getattr(model, key) for key in ("P0", *_NUMBERS)}
    for key, value in numbers.items():
        finite_number(value, key)
    try:
        PressureProfile.pulse(model.P0, model.tau)
    except (ValueError, TypeError) as exc:
        raise ValueError(f"scene: {exc}") from None
    for key in ("horizon_max", "atol", "scale_floor"):
        if not numbers[key] > 0.0:
            raise ValueError(f"{key} = {numbers[key]!r}: need a number > 0")
    for key in ("conformal_q", "small_T", "abs_halfwidth", "margin_min"):
        if not numbers[key] >= 0.0:
            raise ValueError(f"{key} = {numbers[key]!r}: need a number >= 0")
    if not 0.0 < numbers["coverage"] < 1.0:
        raise ValueError(f"coverage = {numbers['coverage']!r}: need a fraction in (0, 1)")
    _check_domain(model.domain)
    if not isinstance(model.info, dict):
        raise ValueError("info: need a table")
    if not isinstance(model.constants, dict) or not all(
        isinstance(model.constants.get(k), str) for k in ("name", "fingerprint")
    ):
        raise ValueError("constants: need {name, fingerprint}")
    _provenance_of(model.provenance)


def _check_domain(domain: Any) -> None:
    if not isinstance(domain, dict) or set(domain) != {*DOMAIN_RANGES, "fixed"}:
        raise ValueError(f"domain: need the ranges {', '.join(DOMAIN_RANGES)} and fixed")
    for key in DOMAIN_RANGES:
        pair = domain[key]
        if not isinstance(pair, (list, tuple)) or len(pair) != 2:
            raise ValueError(f"domain.{key} = {pair!r}: need [low, high]")
        low, high = (finite_number(v, f"domain.{key}") for v in pair)
        if key == "n_units":
            if not (float(low).is_integer() and float(high).is_integer()):
                raise ValueError(f"domain.n_units = {list(pair)}: need whole numbers of units")
            if not 1 <= low <= high <= MAX_UNITS:
                raise ValueError(
                    f"domain.n_units = {list(pair)}: need 1 <= low <= high <= {MAX_UNITS}"
                )
        elif not 0.0 < low <= high <= 1e3:
            raise ValueError(f"domain.{key} = {list(pair)}: need 0 < low <= high <= 1000 mm")
    fixed = domain["fixed"]
    if not isinstance(fixed, dict) or set(fixed) != set(DOMAIN_FIXED):
        raise ValueError(f"domain.fixed: need {', '.join(DOMAIN_FIXED)}")
    for key in DOMAIN_FIXED:
        value = finite_number(fixed[key], f"domain.fixed.{key}")
        if not (0.0 < value < 0.5 if key == "nu" else 0.0 < value <= 1e6):
            raise ValueError(f"domain.fixed.{key} = {value!r}: outside its physical range")


def upgrade_reset_model(path: str | Path) -> ResetModel:
    """The model of a format-1 file (no checksum, no provenance), checked as a current one.

    Every number is kept (results bit for bit); the provenance records when it was trained
    (``info.trained``) and that it was upgraded. Save it with :meth:`ResetModel.save`.

    Raises
    ------
    ValueError
        One line naming the file, as :func:`load_reset_model`.
    """
    path = Path(path)
    data = _read(path, strict=False)  # format 1 wrote infinite reset times into info as Infinity
    try:
        _check_header(data, version=1)
        info = data.get("info") if isinstance(data.get("info"), dict) else {}
        versions = info.get("versions") if isinstance(info.get("versions"), dict) else {}
        made = provenance_now(
            "trained by active learning (info.options, info.rounds); upgraded from format "
            "version 1 (dpfexplore reset-model upgrade), every number kept"
        )
        provenance = {
            "created": str(info.get("trained") or "unknown"),
            "by": f"dpfexplore {versions.get('dpfexplore', '?')} (reset-model fit)",
            "how": made["how"],
            "upgraded": f"{made['created']} by {made['by']}",
        }
        return _model_from(data, provenance=provenance)
    except ValueError as exc:
        raise ValueError(f"reset model {path}: {exc}") from None


def load_reset_model(path: str | Path | None = None) -> ResetModel:
    """Read and check a model file (the packaged one by default); cached per file version.

    Raises
    ------
    ValueError
        One line naming the file: missing, not a regular file, too large, not JSON, or not a
        model this version can use (module docstring).
    """
    path = Path(path or DEFAULT_MODEL_PATH)
    try:
        facts = os.stat(path)
    except FileNotFoundError:
        raise ValueError(f"reset model {path}: no such file") from None
    except OSError as exc:
        raise ValueError(f"reset model {path}: {exc.strerror or exc}") from None
    return _load(str(path), facts.st_mtime_ns, facts.st_size, facts.st_ino)


def _read(path: Path, *, strict: bool = True) -> Any:
    try:
        return read_json_bounded(path, MAX_MODEL_BYTES, strict=strict)
    except BoundedReadError as exc:
        raise ValueError(f"reset model {exc}") from None
    except FileNotFoundError:
        raise ValueError(f"reset model {path}: no such file") from None
    except OSError as exc:
        raise ValueError(f"reset model {path}: {exc.strerror or exc}") from None
    except ValueError as exc:
        raise ValueError(f"reset model {path}: {exc}") from None


@lru_cache(maxsize=8)
def _load(path: str, mtime_ns: int, size: int, inode: int) -> ResetModel:
    data = _read(Path(path))
    try:
        return ResetModel.from_dict(data)
    except ValueError as exc:
        raise ValueError(f"reset model {path}: {exc}") from None
