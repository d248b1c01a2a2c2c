"""Saving and loading fitted surrogates, with the fingerprint of the data they were fitted on.

Layout of a saved surrogate (``results/surrogates/NAME/``)::

    surrogate.json     format, SURROGATE_VERSION, MODEL_VERSION, library versions, the training
                       dataset's path and fingerprint, outputs, kinds, SHA-256 of models.skops
    models.skops       the fitted estimators (skops format)
    report.json        held-out errors, classifier accuracy, speed table, goals, verdict
    speed_error.csv    the speed-versus-error table
    speed_error.png    its plot

Format: the estimators are stored with skops (``skops.io``), not pickle. Loading a pickle runs
whatever code the file names; skops rebuilds objects only of the types the loader trusts, and
:func:`load_surrogates` trusts exactly :data:`TRUSTED_TYPES` (the scikit-learn and dpfexplore
classes a surrogate is made of) and refuses a file that names any other type. The file's
SHA-256, kept in ``surrogate.json``, catches a damaged file.

A checksum proves integrity, not identity: ``models.skops`` swapped for another surrogate's, with
the checksum updated, would pass it. So both files carry the surrogate's **identity**
(:func:`identity`): the output names, the training data's fingerprint, and for every estimator
what it says of itself (class, kind, output names and count, the input features per number of
units, the constants set). Before anything predicts, the identity recorded in ``models.skops``
and the one computed from the estimators it holds must both equal ``surrogate.json``'s, whose
own must agree with its outputs and dataset fingerprint.

Loading refuses, with one line naming the file and what differs: another
:data:`SURROGATE_VERSION` or file format, another physical model
(:data:`dpfexplore.model.version.MODEL_VERSION`), another scikit-learn minor version (its
estimators' internals change between them), a changed or damaged model file, another identity,
and, when a dataset is given, a dataset whose fingerprint differs from the training one. The
JSON files are read only as regular files of at most :data:`MAX_JSON_BYTES`, the models file
only as a regular file of at most :data:`MAX_MODELS_BYTES`.
"""

from __future__ import annotations

import hashlib
import json
import math
import zipfile
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import pandas as pd

from ..io.commits import StoreError
from ..io.files import SIZE_LIMITS, BoundedReadError, file_sha256, read_bounded, read_json_bounded
from ..model.constants_set import DEFAULT, ConstantsSet
from ..model.version import MODEL_VERSION, package_versions
from .data import dataset_fingerprint
from .fit import SurrogateSet

__all__ = [
    "FORMAT",
    "SURROGATE_VERSION",
    "TRUSTED_TYPES",
    "SurrogateLoadError",
    "identity",
    "json_safe",
    "load_surrogates",
    "read_report",
    "save_surrogates",
]

FORMAT = "dpfexplore-surrogate/1"
#: Version of the surrogates' features and estimators; bump when a saved one would mean
#: something else (another feature set, scaling or target) or could not be loaded (surrogate-2:
#: the estimators' classes moved to dpfexplore.surrogates, and skops stores class paths;
#: surrogate-3: every estimator holds its constants set, and the flat ones' dome features come
#: from it; surrogate-4: both files carry the surrogate's identity).
SURROGATE_VERSION = "surrogate-4"
#: Largest ``surrogate.json`` or ``report.json`` read, bytes (reasons in
#: :data:`dpfexplore.io.files.SIZE_LIMITS`).
MAX_JSON_BYTES = SIZE_LIMITS["surrogate metadata"].bytes
#: Largest ``models.skops`` read, bytes.
MAX_MODELS_BYTES = SIZE_LIMITS["surrogate models"].bytes
META, MODELS, REPORT = "surrogate.json", "models.skops", "report.json"
SPEED_CSV, SPEED_PNG = "speed_error.csv", "speed_error.png"

#: Types a saved surrogate may contain beyond those skops trusts by default.
TRUSTED_TYPES = (
    "dpfexplore.surrogates.flat.DesignSurrogate",
    "dpfexplore.surrogates.flat.StatusClassifier",
    "dpfexplore.surrogates.chain.ChainSurrogate",
    "dpfexplore.surrogates.chain.ChainStatusClassifier",
    "sklearn.ensemble._hist_gradient_boosting.predictor.TreePredictor",
    "sklearn.ensemble._hist_gradient_boosting.binning._BinMapper",
    "sklearn._loss.loss.HalfSquaredError",
    "sklearn._loss.loss.HalfBinomialLoss",
    "sklearn._loss.link.IdentityLink",
    "sklearn._loss.link.LogitLink",
    "sklearn._loss.link.Interval",
    "sklearn.gaussian_process.kernels.ConstantKernel",
    "sklearn.gaussian_process.kernels.Product",
    "sklearn.gaussian_process.kernels.RBF",
    "sklearn.gaussian_process.kernels.Sum",
    "sklearn.gaussian_process.kernels.WhiteKernel",
    "sklearn.gaussian_process.kernels.Hyperparameter",
    "sklearn.metrics._dist_metrics.EuclideanDistance64",
    "sklearn.neighbors._kd_tree.KDTree",
    "sklearn.neural_network._stochastic_optimizers.AdamOptimizer",
    "sklearn.neural_network._stochastic_optimizers.SGDOptimizer",
)


class SurrogateLoadError(ValueError):
    """A saved surrogate that cannot be used: missing, damaged, or made for other data/code."""


def _library_versions() -> dict[str, str]:
    import sklearn
    import skops

    return {**package_versions(), "scikit-learn": sklearn.__version__, "skops": skops.__version__}


def _minor(version: str) -> str:
    return ".".join(version.split(".")[:2])


def json_safe(value: Any) -> Any:
    """Replace NaN and infinities (not JSON) by None, recursively."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {str(k): json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_safe(v) for v in value]
    if hasattr(value, "item"):  # NumPy scalars
        return json_safe(value.item())
    return value


def save_surrogates(
    surrogates: SurrogateSet,
    path: str | Path,
    *,
    force: bool = False,
    figures: Mapping[str, Any] | None = None,
) -> Path:
    """Write a fitted :class:`SurrogateSet` as the result directory ``path``.

    ``figures`` maps file names (``speed_error.png``) to matplotlib figures drawn by the caller
    (:func:`dpfexplore.surrogates.report.report_figures`): the store writes, it does not draw.
    Written complete or not at all (:func:`~dpfexplore.io.result_dirs.result_directory`):
    a kill or a full disk mid-save leaves the previous surrogate whole; a directory that holds
    another result is replaced only with ``force``.

    Returns
    -------
    Path
        The directory.
    """
    from ..io.result_dirs import result_directory

    final = Path(path)
    description = {"outputs": list(surrogates.outputs), "best": surrogates.best}
    with result_directory(final, kind="surrogate", force=force, description=description) as path:
        _write_surrogate(surrogates, path)
        for name, figure in (figures or {}).items():
            figure.savefig(path / name, dpi=130)
    return final


def _write_surrogate(surrogates: SurrogateSet, path: Path) -> None:
    import skops.io as sio

    record = identity(surrogates)
    payload = {
        "regressors": surrogates.regressors,
        "classifier": surrogates.classifier,
        "classifiers": surrogates.classifiers,
        "identity": record,
    }
    data = sio.dumps(payload)
    untrusted = sorted(set(sio.get_untrusted_types(data=data)) - set(TRUSTED_TYPES))
    if untrusted:  # would be refused on load: fail now rather than write it
        raise ValueError(f"surrogate holds types not in TRUSTED_TYPES: {', '.join(untrusted)}")
    (path / MODELS).write_bytes(data)
    report = surrogates.report
    meta = {
        "format": FORMAT,
        "surrogate_version": SURROGATE_VERSION,
        "model_version": MODEL_VERSION,
        "versions": _library_versions(),
        "dataset": {
            "path": report.get("dataset", {}).get("path"),
            "fingerprint": surrogates.fingerprint,
        },
        "outputs": list(surrogates.outputs),
        "units": surrogates.units,
        "kinds": list(surrogates.regressors),
        "best": surrogates.best,
        "classifier": surrogates.classifier.kind,
        "classifiers": list(surrogates.classifiers),
        "per_n": surrogates.classifier.per_n,
        "models_sha256": file_sha256(path / MODELS),
        "identity": record,
    }
    (path / META).write_text(json.dumps(json_safe(meta), indent=1) + "\n")
    (path / REPORT).write_text(json.dumps(json_safe(report), indent=1) + "\n")
    if report.get("speed"):
        pd.DataFrame(report["speed"]).to_csv(path / SPEED_CSV, index=False)


#: Keys of a dataset fingerprint that say which data a surrogate was trained on.
_DATA_KEYS = ("job_fingerprint", "chunks_sha256", "model_version", "constants")


def identity(surrogates: SurrogateSet) -> dict[str, Any]:
    """What a fitted surrogate predicts, from what, trained on which data (JSON types only).

    Returns
    -------
    dict
        ``outputs`` (names, in order), ``dataset`` (the training data's fingerprint:
        ``job_fingerprint``, ``chunks_sha256``, ``model_version``, ``constants``) and
        ``estimators``: for each regressor (``regressor:KIND``) and status classifier
        (``classifier:KIND``) :func:`estimator_facts`.
    """
    estimators = {
        **{f"regressor:{k}": estimator_facts(m) for k, m in surrogates.regressors.items()},
        **{f"classifier:{k}": estimator_facts(m) for k, m in surrogates.classifiers.items()},
    }
    return {
        "outputs": [str(o) for o in surrogates.outputs],
        "dataset": {k: json_safe(surrogates.fingerprint.get(k)) for k in _DATA_KEYS},
        "estimators": estimators,
    }


def estimator_facts(estimator: Any) -> dict[str, Any]:
    """What one fitted estimator says of itself: class, kind, outputs, inputs, constants set.

    Read from its fitted attributes only (``outputs_`` or ``outputs``, ``n_outputs_``,
    ``n_units_``, ``feature_names_`` per N, an inner model's, ``constants``), so a models file
    of another surrogate says so whatever record it carries.
    """
    outputs = getattr(estimator, "outputs_", None)
    if outputs is None and hasattr(estimator, "inner_model_"):  # the chain names its outputs
        outputs = getattr(estimator, "outputs", None)
    features = getattr(estimator, "feature_names_", None)
    inner = getattr(estimator, "inner_model_", None)
    constants = getattr(estimator, "constants", None)
    return json_safe(
        {
            "class": f"{type(estimator).__module__}.{type(estimator).__qualname__}",
            "kind": str(getattr(estimator, "kind", "")),
            "outputs": None if outputs is None else [str(o) for o in outputs],
            "n_outputs": getattr(estimator, "n_outputs_", None),
            "n_units": [int(n) for n in getattr(estimator, "n_units_", ())],
            "features": None
            if not isinstance(features, dict)
            else {str(n): [str(c) for c in names] for n, names in features.items()},
            "inner": None if inner is None else estimator_facts(inner),
            "constants": (constants or {}).get("fingerprint", DEFAULT.fingerprint)
            if isinstance(constants, dict) or constants is None
            else "?",
        }
    )


def _first_difference(found: Any, wanted: Any, where: str = "") -> str:
    """The path of the first entry where two identity records differ, and both values."""
    if isinstance(found, dict) and isinstance(wanted, dict):
        for key in [*wanted, *(k for k in found if k not in wanted)]:
            if found.get(key, "<none>") != wanted.get(key, "<none>"):
                return _first_difference(
                    found.get(key, "<none>"), wanted.get(key, "<none>"), f"{where}.{key}"
                )
    shown = [json.dumps(v, default=repr)[:80] for v in (found, wanted)]
    return f"{where.lstrip('.') or 'identity'} {shown[0]} where {META} says {shown[1]}"


def _check_identity(path: Path, meta: dict[str, Any], payload: Any) -> None:
    """Refuse a models file whose estimators are not what ``surrogate.json`` describes."""
    models = path / MODELS
    wanted = meta.get("identity")
    if not isinstance(wanted, dict):
        raise SurrogateLoadError(f"{path / META}: no identity record; refit it")
    if wanted.get("outputs") != meta["outputs"]:
        raise SurrogateLoadError(f"{path / META}: identity.outputs differ from outputs")
    data = {k: json_safe(meta["dataset"]["fingerprint"].get(k)) for k in _DATA_KEYS}
    if wanted.get("dataset") != data:
        raise SurrogateLoadError(f"{path / META}: identity.dataset differs from dataset")
    keys = ("regressors", "classifier", "classifiers", "identity")
    if not isinstance(payload, dict) or any(k not in payload for k in keys):
        raise SurrogateLoadError(f"{models}: not the estimators of a saved surrogate")
    regressors, classifiers = payload["regressors"], payload["classifiers"]
    if not (isinstance(regressors, dict) and isinstance(classifiers, dict)):
        raise SurrogateLoadError(f"{models}: not the estimators of a saved surrogate")
    if not _same(payload["identity"], wanted):
        difference = _first_difference(payload["identity"], wanted)
        raise SurrogateLoadError(f"{models}: another surrogate's models (recorded {difference})")
    try:
        found = {
            "outputs": wanted["outputs"],
            "dataset": wanted["dataset"],
            "estimators": {
                **{f"regressor:{k}": estimator_facts(m) for k, m in regressors.items()},
                **{f"classifier:{k}": estimator_facts(m) for k, m in classifiers.items()},
            },
        }
        chosen = estimator_facts(payload["classifier"])
    except (TypeError, ValueError, AttributeError) as exc:  # attributes of the wrong kind
        raise SurrogateLoadError(
            f"{models}: estimators without their fitted facts ({exc})"
        ) from None
    if not _same(found, wanted):
        difference = _first_difference(found, wanted)
        raise SurrogateLoadError(f"{models}: another surrogate's models ({difference})")
    for kind, said in found["estimators"].items():
        if not kind.startswith("regressor:"):
            continue
        if (said["outputs"] or meta["outputs"]) != meta["outputs"] or said["n_outputs"] != len(
            meta["outputs"]
        ):
            raise SurrogateLoadError(
                f"{models}: {kind} predicts {said['outputs'] or said['n_outputs']}, "
                f"{META} says {meta['outputs']}"
            )
    if sorted(map(str, regressors)) != sorted(map(str, meta["kinds"])):
        raise SurrogateLoadError(
            f"{models}: regressors {sorted(map(str, regressors))}, {META} says {meta['kinds']}"
        )
    if not _same(chosen, wanted["estimators"].get(f"classifier:{meta['classifier']}")):
        raise SurrogateLoadError(f"{models}: the status classifier is not {meta['classifier']}")


def _same(first: Any, second: Any) -> bool:
    """Whether two identity records are equal (as canonical JSON: arrays never compared)."""
    try:
        return json.dumps(first, sort_keys=True, default=repr) == json.dumps(
            second, sort_keys=True, default=repr
        )
    except (TypeError, ValueError, RecursionError):  # keys of mixed types, a cycle
        return False


#: Keys of ``surrogate.json`` and the JSON type each must have.
_META_TYPES: dict[str, type | tuple[type, ...]] = {
    "format": str,
    "surrogate_version": str,
    "model_version": str,
    "versions": dict,
    "dataset": dict,
    "outputs": list,
    "units": dict,
    "kinds": list,
    "best": str,
    "classifier": str,
    "models_sha256": str,
}


def _read_meta(path: Path) -> dict[str, Any]:
    from ..io.result_dirs import ResultError, read_result_marker, verify_result_dir

    if not path.is_dir():
        raise SurrogateLoadError(f"{path}: no saved surrogate (not a directory)")
    if read_result_marker(path) is not None:  # saved as a result directory: check every file
        try:
            verify_result_dir(path)
        except ResultError as exc:
            raise SurrogateLoadError(str(exc)) from None
    try:
        meta = read_json_bounded(path / META, MAX_JSON_BYTES)
    except FileNotFoundError:
        raise SurrogateLoadError(f"{path}: no saved surrogate (no {META})") from None
    except BoundedReadError as exc:
        raise SurrogateLoadError(str(exc)) from None
    except (ValueError, OSError) as exc:
        raise SurrogateLoadError(f"{path / META}: unreadable ({exc})") from None
    if not isinstance(meta, dict):
        raise SurrogateLoadError(f"{path / META}: not a surrogate description (a JSON object)")
    if meta.get("format") != FORMAT:
        raise SurrogateLoadError(
            f"{path}: format {meta.get('format')!r}, this dpfexplore reads {FORMAT!r}"
        )
    for key, kind in _META_TYPES.items():
        if not isinstance(meta.get(key), kind):
            raise SurrogateLoadError(
                f"{path / META}: {key} is missing or not a {getattr(kind, '__name__', kind)}"
            )
    if not all(isinstance(o, str) for o in meta["outputs"]) or not meta["outputs"]:
        raise SurrogateLoadError(f"{path / META}: outputs must be a list of column names")
    if not isinstance(meta["dataset"].get("fingerprint"), dict):
        raise SurrogateLoadError(f"{path / META}: dataset.fingerprint is missing")
    return meta


def read_report(path: str | Path) -> dict[str, Any]:
    """The saved report of a surrogate directory (no estimator is loaded)."""
    path = Path(path)
    _read_meta(path)
    try:
        report = read_json_bounded(path / REPORT, MAX_JSON_BYTES)
    except BoundedReadError as exc:
        raise SurrogateLoadError(str(exc)) from None
    except (ValueError, OSError) as exc:
        raise SurrogateLoadError(f"{path / REPORT}: unreadable ({exc})") from None
    if not isinstance(report, dict):
        raise SurrogateLoadError(f"{path / REPORT}: not a report (a JSON object)")
    return report


def check_compatible(
    meta: dict[str, Any],
    *,
    dataset: str | Path | None = None,
    constants: ConstantsSet | None = None,
) -> None:
    """Raise :class:`SurrogateLoadError` if a saved surrogate's metadata does not fit this code.

    Parameters
    ----------
    meta : dict
        Contents of ``surrogate.json``.
    dataset : path, optional
        A sweep dataset that must be the one the surrogate was fitted on.
    constants : ConstantsSet, optional
        The constants set the caller's designs run on: it must be the one of the surrogate's
        training data (recorded in its dataset fingerprint; the paper's for surrogates saved
        before sets were recorded).
    """
    if meta.get("surrogate_version") != SURROGATE_VERSION:
        raise SurrogateLoadError(
            f"surrogate version {meta.get('surrogate_version')!r}, this dpfexplore reads "
            f"{SURROGATE_VERSION!r}: refit it"
        )
    if meta.get("model_version") != MODEL_VERSION:
        raise SurrogateLoadError(
            f"fitted on model version {meta.get('model_version')!r}, this dpfexplore computes "
            f"{MODEL_VERSION!r}: refit it on a dataset of this model"
        )
    import sklearn

    saved = meta.get("versions", {}).get("scikit-learn", "?")
    if _minor(saved) != _minor(sklearn.__version__):
        raise SurrogateLoadError(
            f"saved with scikit-learn {saved}, this is {sklearn.__version__}: refit it"
        )
    if constants is not None:
        recorded = surrogate_constants(meta)
        if recorded["fingerprint"] != constants.fingerprint:
            raise SurrogateLoadError(
                f"fitted on rows of constants set {recorded['name']!r} "
                f"({recorded['fingerprint'][:12]}), not {constants.label}: refit it on a "
                "dataset of that set"
            )
    if dataset is not None:
        try:
            actual = dataset_fingerprint(dataset)
        except (StoreError, OSError, ValueError) as exc:  # not a sweep directory, unreadable
            raise SurrogateLoadError(f"dataset {dataset}: {exc}") from None
        wanted = meta.get("dataset", {}).get("fingerprint", {})
        for key in ("job_fingerprint", "model_version", "chunks_sha256"):
            # (job_fingerprint covers the dataset's constants set)
            if actual.get(key) != wanted.get(key):
                raise SurrogateLoadError(
                    f"dataset {dataset} is not the one this surrogate was fitted on "
                    f"({key} {str(actual.get(key))[:16]} != {str(wanted.get(key))[:16]})"
                )


def surrogate_constants(meta: dict[str, Any]) -> dict[str, str]:
    """``{"name", "fingerprint"}`` of the constants set a saved surrogate was fitted under."""
    recorded = meta.get("dataset", {}).get("fingerprint", {}).get("constants")
    if not isinstance(recorded, dict) or not isinstance(recorded.get("fingerprint"), str):
        return {"name": DEFAULT.name, "fingerprint": DEFAULT.fingerprint}
    return {"name": str(recorded.get("name", "?")), "fingerprint": recorded["fingerprint"]}


def load_surrogates(
    path: str | Path,
    *,
    dataset: str | Path | None = None,
    constants: ConstantsSet | None = None,
) -> SurrogateSet:
    """Load a saved surrogate directory.

    Parameters
    ----------
    path : path
        Directory written by :func:`save_surrogates`.
    dataset : path, optional
        Sweep dataset to check the surrogate against (its fingerprint must match).
    constants : ConstantsSet, optional
        The constants set the designs to predict run on; refused unless it is the one the
        surrogate was fitted under.

    Raises
    ------
    SurrogateLoadError
        One line naming the problem (see the module docstring).
    """
    import skops.io as sio

    path = Path(path)
    meta = _read_meta(path)
    check_compatible(meta, dataset=dataset, constants=constants)
    models = path / MODELS
    if not models.exists():
        raise SurrogateLoadError(f"{path}: no {MODELS}")
    try:
        data = read_bounded(models, MAX_MODELS_BYTES)
    except BoundedReadError as exc:
        raise SurrogateLoadError(str(exc)) from None
    except OSError as exc:
        raise SurrogateLoadError(f"{models}: unreadable ({exc.strerror or exc})") from None
    if hashlib.sha256(data).hexdigest() != meta.get("models_sha256"):
        raise SurrogateLoadError(f"{models}: checksum differs from {META} (changed or damaged)")
    try:
        untrusted = sorted(set(sio.get_untrusted_types(data=data)) - set(TRUSTED_TYPES))
        if untrusted:
            raise SurrogateLoadError(
                f"{models}: holds types this loader does not trust: {', '.join(untrusted)}"
            )
        payload = sio.loads(data, trusted=list(TRUSTED_TYPES))
    except (ValueError, KeyError, TypeError, AttributeError, zipfile.BadZipFile) as exc:
        # what skops, zipfile and json raise for bytes that are not a skops file
        if isinstance(exc, SurrogateLoadError):
            raise
        message = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise SurrogateLoadError(f"{models}: not a readable skops file ({message[:120]})") from None
    _check_identity(path, meta, payload)
    report = read_report(path)
    return SurrogateSet(
        outputs=tuple(meta["outputs"]),
        units=dict(meta.get("units", {})),
        regressors=payload["regressors"],
        classifier=payload["classifier"],
        best=meta["best"],
        report=report,
        fingerprint=meta["dataset"]["fingerprint"],
        classifiers=payload.get("classifiers") or {meta["classifier"]: payload["classifier"]},
    )
