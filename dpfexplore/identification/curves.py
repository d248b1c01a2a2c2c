"""Unit-cell curves: the input table of identification, read and checked before any fit.

One row per point of a dome unit's apex-displacement-controlled run (MODEL.md §11):

========================= ====== ===========================================================
column                    unit   meaning
========================= ====== ===========================================================
``curve``                 --     curve id (text or integer)
``H``, ``t``, ``r_b``     mm     dome height, thickness, base radius (constant per curve)
``E``                     MPa    Young's modulus (constant per curve)
``nu``                    --     Poisson ratio (constant per curve)
``displacement``          mm     apex travel toward inversion, ``>= 0``
``energy``                N·mm   strain energy (``energy`` and/or ``force``)
``force``                 N      apex reaction, ``d energy / d displacement``
``branch`` (optional)     --     branch id of a folded path (see below)
``tip_dis`` (optional)    mm     the inverted apex travel the lattice's reach is built from
                                 (one value per curve: the paper's two-unit contact runs; the
                                 shell's inverted rest, or a monostable dome's ghost)
========================= ====== ===========================================================

A dome under apex displacement control can fold back before it inverts and jump to an inverted
branch: its trace is then several branches, not one curve. With a ``branch`` column the fit uses
the **lower energy envelope** of the branches (at each displacement, the lowest energy any branch
reaches there; forces are then not used, since the envelope's slope jumps where branches cross).
Without it, the points of a curve must be in increasing displacement.

:func:`read_curves` reads only a regular file of at most :data:`MAX_TABLE_BYTES` (a directory,
FIFO or device is refused before anything is read; a Parquet file's row count is checked before
it is decoded) and refuses, in one line naming the file and the curve: missing columns,
non-finite values, duplicate rows, parameters that change within a curve, unsorted or too-short
curves.

Each curve carries the SHA-256 of its rows (:attr:`UnitCellCurve.rows_sha256`): every column
listed above, every row, in the table's order, which is all a fit reads of the table;
identification's ``data_sha256`` is built from them.
"""

from __future__ import annotations

import hashlib
import io
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from ..io.files import SIZE_LIMITS

__all__ = [
    "COLUMNS",
    "MAX_TABLE_BYTES",
    "MAX_TABLE_ROWS",
    "MIN_POINTS",
    "CurveError",
    "UnitCellCurve",
    "curves_from_frame",
    "read_curves",
    "read_table",
    "rows_sha256",
]

#: Fewest points a curve needs (three polynomial coefficients, and enough to judge the fit).
MIN_POINTS = 12
#: Points of the grid on which a folded curve's lower envelope is taken.
ENVELOPE_POINTS = 200

_PARAMETERS = ("H", "t", "r_b", "E", "nu")
#: The columns a fit reads (module docstring), in the order their hash takes them.
COLUMNS = ("curve", *_PARAMETERS, "displacement", "energy", "force", "branch", "tip_dis")
#: Largest curve table read, bytes (the reason in :data:`dpfexplore.io.files.SIZE_LIMITS`).
MAX_TABLE_BYTES = SIZE_LIMITS["curve table"].bytes
#: Most rows of a table (checked in a Parquet file's footer before its columns are decoded).
MAX_TABLE_ROWS = 20_000_000


class CurveError(ValueError):
    """A unit-cell table that cannot be identified from (one line naming the curve)."""


@dataclass(frozen=True)
class UnitCellCurve:
    """One unit-cell run, ready to fit.

    Attributes
    ----------
    curve : str
    H, t, r_b : float, mm
    E : float, MPa
    nu : float
    displacement : ndarray, mm
    energy, force : ndarray or None
        N·mm and N at each displacement (``force`` None for a folded curve's envelope).
    tip_dis : float or None, mm
    folded : bool
        True when the curve was the envelope of several branches.
    rows_sha256 : str or None
        SHA-256 of the curve's rows in its table (:func:`rows_sha256`); None for a curve made
        in Python.
    """

    curve: str
    H: float
    t: float
    r_b: float
    E: float
    nu: float
    displacement: NDArray
    energy: NDArray | None
    force: NDArray | None
    tip_dis: float | None = None
    folded: bool = False
    rows_sha256: str | None = None

    @property
    def R(self) -> float:
        """Dome radius of curvature, mm (MODEL.md §2)."""
        return (self.H**2 + self.r_b**2) / (2.0 * self.H)

    @property
    def geometry(self) -> tuple[float, float, float]:
        """``(H, t, r_b)``: the group a curve belongs to (several ``E`` share one geometry)."""
        return (round(self.H, 9), round(self.t, 9), round(self.r_b, 9))


def read_curves(path: str | Path) -> list[UnitCellCurve]:
    """Read a CSV or Parquet table of unit-cell curves (module docstring) and check it.

    Raises
    ------
    CurveError
        One line naming the file and, where it applies, the curve.
    """
    return _read_checked(Path(path))[1]


def read_curve_table(path: str | Path) -> pd.DataFrame:
    """The table of a curve file, read and checked as :func:`read_curves` does.

    For readers that keep more of each curve than :class:`UnitCellCurve` (its path, its states).
    """
    return _read_checked(Path(path))[0]


def _read_checked(path: Path) -> tuple[pd.DataFrame, list[UnitCellCurve]]:
    frame = read_table(path)
    try:
        return frame, curves_from_frame(frame)
    except CurveError as exc:
        raise CurveError(f"{path}: {exc}") from None


def read_table(path: str | Path) -> pd.DataFrame:
    """A CSV or Parquet table as it is, read bounded (module docstring), not yet checked.

    Raises
    ------
    CurveError
        One line naming the file: another suffix, not a regular file, too large, unreadable.
    """
    from ..io.files import BoundedReadError, read_bounded

    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in (".parquet", ".csv"):
        raise CurveError(f"{path}: give a .csv or .parquet table of unit-cell curves")
    try:
        raw = read_bounded(path, MAX_TABLE_BYTES)
    except BoundedReadError as exc:
        raise CurveError(str(exc)) from None
    except FileNotFoundError:
        raise CurveError(f"{path}: no such file") from None
    except OSError as exc:
        raise CurveError(f"{path}: cannot read ({exc.strerror or exc})") from None
    try:
        frame = _parquet(path, raw) if suffix == ".parquet" else pd.read_csv(io.BytesIO(raw))
    except (OSError, ValueError, pd.errors.ParserError) as exc:
        if isinstance(exc, CurveError):
            raise
        message = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise CurveError(f"{path}: cannot read ({message})") from None
    return frame


def _parquet(path: Path, raw: bytes) -> pd.DataFrame:
    """A Parquet table from its bytes, its row count checked before its columns are decoded."""
    import pyarrow.parquet as pq

    rows = pq.ParquetFile(io.BytesIO(raw)).metadata.num_rows
    if rows > MAX_TABLE_ROWS:
        raise CurveError(f"{path}: {rows} rows, more than the limit of {MAX_TABLE_ROWS}")
    return pd.read_parquet(io.BytesIO(raw))


def rows_sha256(rows: pd.DataFrame) -> str:
    """SHA-256 of the columns of :data:`COLUMNS` in ``rows``: each its name and every value.

    Numbers as little-endian float64 (what the fits read; ``curve`` and ``branch`` as text).
    """
    digest = hashlib.sha256()
    for column in COLUMNS:
        if column not in rows:
            continue
        digest.update(column.encode() + b"\0")
        if column in ("curve", "branch"):
            for value in rows[column].astype(str):
                encoded = value.encode("utf-8", "surrogatepass")
                digest.update(len(encoded).to_bytes(8, "little") + encoded)
        else:
            values = pd.to_numeric(rows[column], errors="coerce").to_numpy(dtype="<f8")
            digest.update(np.ascontiguousarray(values).tobytes())
    return digest.hexdigest()


def curves_from_frame(frame: pd.DataFrame) -> list[UnitCellCurve]:
    """The curves of a table (module docstring), checked."""
    required = ("curve", *_PARAMETERS, "displacement")
    missing = [c for c in required if c not in frame.columns]
    if missing:
        raise CurveError(f"missing column(s) {', '.join(missing)}; need {', '.join(required)}")
    if "energy" not in frame.columns and "force" not in frame.columns:
        raise CurveError("need an energy (N·mm) or a force (N) column, or both")
    if frame.empty:
        raise CurveError("the table has no rows")
    repeated = frame.duplicated(subset=[c for c in COLUMNS if c in frame.columns])
    if repeated.any():
        row = int(np.flatnonzero(repeated.to_numpy())[0])
        raise CurveError(
            f"row {row} (curve {str(frame['curve'].iloc[row])!r}) repeats an earlier row: "
            "duplicate rows are refused (they would weigh twice in a fit)"
        )
    curves = []
    for key, rows in frame.groupby("curve", sort=False):
        curves.append(_curve(str(key), rows))
    return curves


def _curve(name: str, rows: pd.DataFrame) -> UnitCellCurve:
    numeric = [c for c in (*_PARAMETERS, "displacement", "energy", "force", "tip_dis") if c in rows]
    for column in numeric:
        values = pd.to_numeric(rows[column], errors="coerce").to_numpy(dtype=float)
        if not np.all(np.isfinite(values)):
            raise CurveError(f"curve {name!r}: {column} has missing or non-finite values")
    parameters = {}
    for column in (*_PARAMETERS, *(("tip_dis",) if "tip_dis" in rows else ())):
        values = rows[column].to_numpy(dtype=float)
        if np.ptp(values) > 1e-12 * max(1.0, abs(values[0])):
            raise CurveError(f"curve {name!r}: {column} changes within the curve")
        parameters[column] = float(values[0])
    for column in ("H", "t", "r_b", "E"):
        if parameters[column] <= 0.0:
            raise CurveError(f"curve {name!r}: {column} = {parameters[column]}: must be > 0")
    if not 0.0 <= parameters["nu"] < 0.5:
        raise CurveError(f"curve {name!r}: nu = {parameters['nu']}: must be in [0, 0.5)")
    if len(rows) < MIN_POINTS:
        raise CurveError(f"curve {name!r}: {len(rows)} points, need at least {MIN_POINTS}")
    x = rows["displacement"].to_numpy(dtype=float)
    energy = rows["energy"].to_numpy(dtype=float) if "energy" in rows else None
    force = rows["force"].to_numpy(dtype=float) if "force" in rows else None
    folded = "branch" in rows and rows["branch"].nunique() > 1
    if folded:
        if energy is None:
            raise CurveError(f"curve {name!r}: a folded curve (branch column) needs energy")
        x, energy = _lower_envelope(name, x, energy, rows["branch"].to_numpy())
        force = None
    elif np.any(np.diff(x) <= 0.0):
        raise CurveError(
            f"curve {name!r}: displacement not increasing (a folded path needs a branch column)"
        )
    if x[0] < 0.0:
        raise CurveError(f"curve {name!r}: displacement {x[0]} < 0")
    return UnitCellCurve(
        curve=name,
        H=parameters["H"],
        t=parameters["t"],
        r_b=parameters["r_b"],
        E=parameters["E"],
        nu=parameters["nu"],
        displacement=x,
        energy=energy,
        force=force,
        tip_dis=parameters.get("tip_dis"),
        folded=bool(folded),
        rows_sha256=rows_sha256(rows),
    )


def _lower_envelope(
    name: str, x: NDArray, energy: NDArray, branch: NDArray
) -> tuple[NDArray, NDArray]:
    """At each displacement of a grid, the lowest energy any branch reaches there."""
    grid = np.linspace(x.min(), x.max(), ENVELOPE_POINTS)
    envelope = np.full(grid.shape, np.inf)
    for key in pd.unique(branch):
        on = branch == key
        bx, be = x[on], energy[on]
        order = np.argsort(bx, kind="stable")
        bx, be = bx[order], be[order]
        if bx.size < 2:
            continue
        covered = (grid >= bx[0]) & (grid <= bx[-1])
        envelope[covered] = np.minimum(envelope[covered], np.interp(grid[covered], bx, be))
    keep = np.isfinite(envelope)
    if keep.sum() < MIN_POINTS:
        raise CurveError(f"curve {name!r}: its branches cover too little of the displacement")
    return grid[keep], envelope[keep]
