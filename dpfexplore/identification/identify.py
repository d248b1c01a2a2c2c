"""From unit-cell curves to a constants set: per-curve fits, then closed forms (MODEL.md §11).

:func:`identify` fits the spring law to every curve (``method="states"``, the default: the law
holds the curve's inverted rest and balances its initial slope against its barrier,
:mod:`.states`; ``method="features"``: the law matched to the curve's initial slope, inverted
rest and its energy, :mod:`.features`; ``method="least_squares"``: robust least squares over
the curve, :mod:`.spring_fit`), refuses to build a set
from flagged fits unless ``allow_flagged``, checks that ``alpha`` does not depend on ``E`` across
the curves of one geometry (a linear-elastic unit's ``alpha`` and shape cannot), selects the
closed forms (:mod:`.closed_forms`) and returns the set with its domain (the data's ranges) and
provenance (method settings, the data's SHA-256, package versions).
"""

from __future__ import annotations

import dataclasses
import hashlib
import math
from collections import defaultdict
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..model.constants_set import DEFAULT, ConstantsSet, ConstantsSetError, data_hull
from ..model.quantities import SET_FORMS, unscaled
from .closed_forms import Selection, select_closed_form
from .curves import CurveError, UnitCellCurve
from .spring_fit import CurveFit, fit_curve

__all__ = ["DEFAULT_METHOD", "METHODS", "Identification", "data_sha256", "identify"]

#: Per-curve fit methods: the law by the unit's states (the default, :mod:`.states`), by
#: features (:mod:`.features`), or robust least squares over the curve (:mod:`.spring_fit`).
METHODS = ("states", "features", "least_squares")
#: The default: the recipe that reproduces the paper's per-dome constants best over its box
#: (``docs/guide/unitcell.md``, "Against the paper's closed forms").
DEFAULT_METHOD = "states"
_METHOD_TEXT = {
    "states": "per-curve spring law by the unit's states (inverted rest matched; initial slope "
    "and barrier balanced by least squares)",
    "features": "per-curve spring law matched to features (initial slope, inverted rest, its "
    "energy)",
    "least_squares": "per-curve robust spring-law fits",
}


@dataclass(frozen=True)
class Identification:
    """A constants set and everything that went into it.

    Attributes
    ----------
    constants : ConstantsSet
    fits : list of CurveFit
        One per curve, flagged ones included.
    selections : dict
        Target name -> :class:`~.closed_forms.Selection`.
    alpha_spread_over_E : float
        Largest relative spread of the fitted ``alpha`` among curves of one geometry at several
        ``E`` (0 for a linear-elastic unit up to the fits' noise).
    """

    constants: ConstantsSet
    fits: list[CurveFit]
    selections: dict[str, Selection]
    alpha_spread_over_E: float = 0.0
    notes: list[str] = field(default_factory=list)


def data_sha256(curves: Sequence[UnitCellCurve]) -> str:
    """SHA-256 of everything the fits read of ``curves``, in their order.

    A curve read from a table contributes its name and the hash of its rows
    (:attr:`~.curves.UnitCellCurve.rows_sha256`: every column a fit reads, every row); a curve
    made in Python, every one of its fields (arrays by their float64 bytes).
    """
    digest = hashlib.sha256()
    for c in curves:
        name = c.curve.encode("utf-8", "surrogatepass")
        digest.update(len(name).to_bytes(8, "little") + name)
        if c.rows_sha256 is not None:
            digest.update(b"rows" + bytes.fromhex(c.rows_sha256))
            continue
        for item in dataclasses.fields(c):
            value = getattr(c, item.name)
            digest.update(item.name.encode() + b"=")
            if value is None or isinstance(value, (bool, str)):
                digest.update(repr(value).encode())
            else:  # numbers, arrays and tuples of pairs (a path's zero-force states)
                digest.update(np.ascontiguousarray(value, dtype="<f8").tobytes())
                digest.update(repr(np.shape(value)).encode())
    return digest.hexdigest()


def _versions() -> dict[str, str]:
    from importlib.metadata import version

    return {name: version(name) for name in ("numpy", "scipy", "scikit-learn")}


def _targets(
    used: Sequence[tuple[UnitCellCurve, CurveFit]],
    H: NDArray,
    t: NDArray,
    R: NDArray,
    E: NDArray,
) -> tuple[dict[str, NDArray], list[str]]:
    """Per-curve values of each closed form of a set, and notes on the forms left out.

    One target per row of :data:`~dpfexplore.model.quantities.SET_FORMS`: the row's quantity
    from each curve's fit or from the curve itself (its ``source``), with the quantity's scale
    removed exactly (``k_hat = k_b R / (E t²)``, ``tip_ratio = tip_dis / H``). A form whose
    quantity some curve lacks is left out (the default set's form is kept), with a note.
    """
    targets, notes = {}, []
    for form in SET_FORMS:
        values = [getattr(f if form.source == "fit" else c, form.quantity) for c, f in used]
        if any(v is None for v in values):
            notes.append(
                f"{form.name}: no {form.quantity} for every curve; the default set's closed form "
                "is kept"
            )
            continue
        targets[form.name] = unscaled(form.scale, np.array(values), H, t, R, E)
    return targets, notes


#: What a refusal of flagged fits suggests, by method: the method that fits such curves first,
#: leaving the flagged ones out (``allow_flagged``) last.
_FLAGGED_HINT = {
    "states": "allow_flagged (--allow-flagged) leaves them out",
    "features": "the law by the unit's states (method 'states', the default) fits a monostable "
    "dome's curve too; allow_flagged (--allow-flagged) leaves them out",
    "least_squares": "a quartic fitted to the path cannot follow a folded shell path: the law "
    "by the unit's states (method 'states', the default) fits it; allow_flagged "
    "(--allow-flagged) leaves them out",
}


def identify(
    curves: Sequence[UnitCellCurve],
    *,
    name: str,
    degree: int = 3,
    selector: str = "rfecv",
    n_splits: int = 5,
    max_relative_rms: float = 0.05,
    allow_flagged: bool = False,
    seed: int = 0,
    method: str = DEFAULT_METHOD,
) -> Identification:
    """Identify a constants set from unit-cell curves (module docstring).

    Raises
    ------
    CurveError
        When a curve's fit is flagged and ``allow_flagged`` is False (naming the curve and why),
        or there are too few geometries to cross-validate.
    ConstantsSetError
        When the selected closed forms are unphysical inside the data's own domain.
    """
    if method not in METHODS:
        raise ValueError(f"method={method!r}: must be one of {', '.join(METHODS)}")
    if not (isinstance(max_relative_rms, (int, float)) and math.isfinite(max_relative_rms)):
        raise ValueError(f"max_relative_rms = {max_relative_rms!r}: need a finite number > 0")
    if not max_relative_rms > 0.0:
        raise ValueError(f"max_relative_rms = {max_relative_rms!r}: need a finite number > 0")
    if isinstance(degree, bool) or not isinstance(degree, int) or not 1 <= degree <= 5:
        raise ValueError(f"degree = {degree!r}: need a whole number from 1 to 5")
    if isinstance(n_splits, bool) or not isinstance(n_splits, int) or n_splits < 2:
        raise ValueError(f"n_splits = {n_splits!r}: need a whole number >= 2")
    if method == "states":
        from .states import fit_states

        # the law claims the states, not the path: its relative RMS is reported, not a flag
        fits = [fit_states(c) for c in curves]
    elif method == "features":
        from .features import fit_features

        fits = [fit_features(c) for c in curves]
    else:
        fits = [fit_curve(c, max_relative_rms=max_relative_rms) for c in curves]
    flagged = [(c, f) for c, f in zip(curves, fits, strict=True) if not f.ok]
    if flagged and not allow_flagged:
        curve, fit = flagged[0]
        raise CurveError(
            f"{len(flagged)} of {len(fits)} curve fits cannot be trusted, e.g. curve "
            f"{curve.curve!r}: {fit.flags[0]}; {_FLAGGED_HINT[method]}"
        )
    used = [(c, f) for c, f in zip(curves, fits, strict=True) if f.ok]
    groups = np.array(["|".join(map(str, c.geometry)) for c, _ in used])
    if len(np.unique(groups)) < n_splits:
        raise CurveError(
            f"{len(np.unique(groups))} geometries (H, t, r_b) with trusted fits; need at least "
            f"{n_splits} to cross-validate by geometry"
        )
    H = np.array([c.H for c, _ in used])
    t = np.array([c.t for c, _ in used])
    r_b = np.array([c.r_b for c, _ in used])
    E = np.array([c.E for c, _ in used])
    R = (H**2 + r_b**2) / (2 * H)
    pi1, pi3 = t / H, H / R
    targets, notes = _targets(used, H, t, R, E)
    alpha = np.array([f.alpha for _, f in used])
    by_geometry: dict[str, list[float]] = defaultdict(list)
    for g, a in zip(groups, alpha, strict=True):
        by_geometry[g].append(a)
    spreads = [np.ptp(v) / np.mean(v) for v in by_geometry.values() if len(v) > 1]
    spread = float(max(spreads)) if spreads else 0.0
    selections = {
        target: select_closed_form(
            pi1, pi3, y, groups, degree=degree, selector=selector, n_splits=n_splits, seed=seed
        )
        for target, y in targets.items()
    }
    domain = {
        "H_over_rb": (float((H / r_b).min()), float((H / r_b).max())),
        "t_over_rb": (float((t / r_b).min()), float((t / r_b).max())),
        "E": (float(E.min()), float(E.max())),
        "nu": (float(min(c.nu for c, _ in used)), float(max(c.nu for c, _ in used))),
    }
    provenance: dict[str, Any] = {
        "method": _METHOD_TEXT[method]
        + "; closed forms by grouped RFECV with ridge, one-standard-error rule, OLS refit "
        "(dpfexplore.identification)",
        "settings": {
            **({"fit": method} if method != "least_squares" else {}),
            "degree": degree,
            "selector": selector,
            "n_splits": n_splits,
            "max_relative_rms": max_relative_rms,
            "seed": seed,
        },
        "curves": len(curves),
        "curves_used": len(used),
        "geometries": len(np.unique(groups)),
        "data_sha256": data_sha256(curves),
        "alpha_spread_over_E": spread,
        "versions": _versions(),
        "notes": notes,
    }
    constants = ConstantsSet(
        name=name,
        **{
            form.name: selections[form.name].form
            if form.name in selections
            else getattr(DEFAULT, form.name)
            for form in SET_FORMS
        },
        domain=domain,
        provenance=provenance,
        hull=data_hull(H / r_b, t / r_b),
    )
    try:
        constants.check()
    except ConstantsSetError as exc:
        raise ConstantsSetError(f"identified set refused: {exc}") from None
    return Identification(constants, fits, selections, spread, notes)
