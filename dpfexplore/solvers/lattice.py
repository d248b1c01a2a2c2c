"""From a design to the arrays the kernels read (MODEL.md §3 and §5).

:func:`spring_constants` gives every constant of a design with its units, for people;
:func:`lattice_params` and :func:`pack_batch` lay the same numbers out for the kernels
(see :mod:`dpfexplore._kernels.layout`).

Decisions the model leaves open
-------------------------------
* Post ``k`` (between unit ``k`` and unit ``k + 1``; post ``N`` is the tip wall) takes the post
  stiffness of unit ``k``. The reference designs have equal ``U_L`` in every unit, so they cannot
  tell; this choice makes post ``k`` close the chamber of unit ``k``. Post 0 joins two clamped
  nodes and stores no energy.
* Both torsional springs at ``L_k`` use ``k_t`` of unit ``k`` (MODEL.md §5), in the energy, the
  gradient and the Hessian alike.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .._kernels import layout as lay
from ..model.constants import (
    POST_STIFFNESS_FACTOR,
    UNIT_CELL_PER_BASE_RADIUS,
    DomeAnalysis,
    analyse_domes,
    dome_alpha,
    dome_extrema,
    dome_radius,
    dome_reach,
    dome_stiffness,
    inversion_threshold,
    limiting_layer_stiffness,
    torsion_stiffness,
)
from ..model.design import Design, DesignBatch
from ..model.domain import MAX_UNITS

__all__ = [
    "LatticeParams",
    "SpringConstants",
    "batch_constants",
    "free_node_names",
    "lattice_params",
    "pack_batch",
    "spring_constants",
]


@dataclass(frozen=True)
class SpringConstants:
    """All constants of one design, one entry per unit (MODEL.md §3).

    Attributes
    ----------
    R : ndarray, mm
        Dome radius of curvature.
    k_b : ndarray, N/mm
        Dome stiffness.
    alpha : ndarray
        Dome energy ratio.
    d : ndarray, mm
        Dome reach (0.01 where clamped).
    no_contact : ndarray of bool
        The closed form for ``d`` was not positive: the dome cannot bend the finger.
    k_lim : ndarray, N/mm
        Limiting-layer stiffness.
    k_post : ndarray, N/mm
        Post stiffness (5 ``k_lim``).
    k_t : ndarray, N·mm/rad
        Torsional stiffness at the unit's limiting-layer node.
    p : ndarray, mm
        Segment length ``U_L + t_ch + U_sep``.
    h : float, mm
        Segment height ``UC/2 + t_lim + t``.
    domes : DomeAnalysis
        Regime, barrier, second minimum and peak force of each isolated dome.
    """

    R: NDArray
    k_b: NDArray
    alpha: NDArray
    d: NDArray
    no_contact: NDArray
    k_lim: NDArray
    k_post: NDArray
    k_t: NDArray
    p: NDArray
    h: float
    domes: DomeAnalysis


def _unit_constants(H, U_L, U_sep, t, t_lim, E, nu, r_b, t_ch, *, domes: bool = True) -> dict:
    """Closed forms of MODEL.md §3, broadcasting (per-unit arrays against shared scalars).

    ``domes=False`` skips the isolated-dome analysis (energies, forces, regime names), which
    the kernel tables do not need and which takes half the time of a batch.
    """
    R = dome_radius(H, r_b)
    k_b = dome_stiffness(E, H, t, R)
    alpha = dome_alpha(H, t, R)
    d, no_contact = dome_reach(H, t, U_sep, t_ch)
    k_lim = limiting_layer_stiffness(E, t_lim, r_b, U_L, t, t_ch)
    return {
        "R": R,
        "k_b": k_b,
        "alpha": alpha,
        "d": d,
        "no_contact": no_contact,
        "k_lim": k_lim,
        "k_post": POST_STIFFNESS_FACTOR * k_lim,
        "k_t": torsion_stiffness(E, t_lim, nu, r_b, U_sep, t, t_ch),
        "p": U_L + t_ch + U_sep,
        "h": segment_height(r_b, t_lim, t),
        "domes": analyse_domes(k_b, alpha, d) if domes else None,
    }


def spring_constants(design: Design) -> SpringConstants:
    """Evaluate the closed forms of MODEL.md §3 for one design."""
    c = _unit_constants(
        np.asarray(design.H),
        np.asarray(design.U_L),
        np.asarray(design.U_sep),
        design.t,
        design.t_lim,
        design.E,
        design.nu,
        design.r_b,
        design.t_ch,
    )
    c["h"] = float(c["h"])
    return SpringConstants(**c)


def segment_height(r_b, t_lim, t):
    """Segment height ``h = UC/2 + t_lim + t`` (mm), the post rest length."""
    return UNIT_CELL_PER_BASE_RADIUS * np.asarray(r_b) / 2.0 + np.asarray(t_lim) + np.asarray(t)


@dataclass(frozen=True)
class LatticeParams:
    """Kernel inputs of one design.

    Attributes
    ----------
    unit_params : ndarray of shape (N, N_COLS)
        Per-unit table (columns in :mod:`dpfexplore._kernels.layout`), penalty switched off.
    h : float, mm
        Segment height.
    """

    unit_params: NDArray
    h: float

    @property
    def n_units(self) -> int:
        """Number of units."""
        return self.unit_params.shape[0]

    def scaled(self, column: int, factor: float) -> LatticeParams:
        """Copy with one column multiplied (e.g. posts 100x stiffer, for stress tests)."""
        table = self.unit_params.copy()
        table[:, column] *= factor
        return LatticeParams(table, self.h)


def _kernel_table(c: dict, active: NDArray) -> NDArray:
    """The per-unit kernel table (columns of :mod:`dpfexplore._kernels.layout`).

    Built in one stack of the columns; NaN where not ``active``.
    """
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
    shape = active.shape
    table = np.stack([np.broadcast_to(columns[j], shape) for j in range(lay.N_COLS)], axis=-1)
    return np.where(active[..., None], table, np.nan)


def lattice_params(design: Design) -> LatticeParams:
    """Per-unit kernel table and segment height of one design."""
    table, h, _ = pack_batch(DesignBatch.from_designs([design]))
    return LatticeParams(table[0, : design.n_units].copy(), float(h[0]))


def batch_constants(batch: DesignBatch, *, domes: bool = True) -> dict:
    """The constants of :class:`SpringConstants` for a whole batch, as ``(n, MAX_UNITS)`` arrays.

    Padding and invalid designs give NaN or meaningless entries: check
    :meth:`DesignBatch.status` before using a row. ``domes=False`` leaves ``"domes"`` None.
    """
    with np.errstate(all="ignore"):
        return _unit_constants(
            batch.H,
            batch.U_L,
            batch.U_sep,
            *(getattr(batch, name)[:, None] for name in ("t", "t_lim", "E", "nu", "r_b", "t_ch")),
            domes=domes,
        )


def pack_batch(batch: DesignBatch) -> tuple[NDArray, NDArray, NDArray]:
    """Kernel inputs of a batch.

    Returns
    -------
    unit_params : ndarray of shape (n, MAX_UNITS, N_COLS)
        Rows past a design's ``N`` hold NaN; kernels read only the first ``n_units[i]`` rows,
        and only of designs whose status is ``OK``.
    h : ndarray of shape (n,), mm
    n_units : ndarray of int64, shape (n,)
    """
    active = np.arange(MAX_UNITS)[None, :] < np.clip(batch.n_units, 0, MAX_UNITS)[:, None]
    c = batch_constants(batch, domes=False)
    table = _kernel_table(c, active)
    return table, np.ascontiguousarray(c["h"][:, 0]), batch.n_units.copy()


def free_node_names(n_units: int) -> list[str]:
    """Names of the free nodes in kernel order: ``["D1", "D2", "L2", ..., "DN", "LN"]``."""
    names = ["D1"]
    for k in range(2, n_units + 1):
        names += [f"D{k}", f"L{k}"]
    return names
