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
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from .._kernels import layout as lay
from .._kernels.tables import design_tables as ktables
from ..model.constants import (
    POST_STIFFNESS_FACTOR,
    DomeAnalysis,
    analyse_domes,
    dome_radius,
    limiting_layer_stiffness,
    segment_height,
    torsion_stiffness,
)
from ..model.constants_set import ConstantsSet
from ..model.design import Design, DesignBatch
from ..model.domain import MAX_UNITS

__all__ = [
    "KernelTables",
    "LatticeParams",
    "SpringConstants",
    "batch_constants",
    "design_kernel_tables",
    "free_node_names",
    "kernel_tables",
    "lattice_params",
    "pack_batch",
    "segment_height",
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


def _unit_constants(
    H, U_L, U_sep, t, t_lim, E, nu, r_b, t_ch, constants: ConstantsSet, *, domes: bool = True
) -> dict:
    """Closed forms of MODEL.md §3, broadcasting (per-unit arrays against shared scalars).

    ``k_b``, ``alpha`` and the reach from the constants set; ``domes=False`` skips the
    isolated-dome analysis (energies, forces, regime names), which the kernel tables do not
    need and which takes half the time of a batch.
    """
    R = dome_radius(H, r_b)
    springs = constants.springs(H, t, r_b, E, U_sep, t_ch)
    k_b, alpha, d, no_contact = (springs[k] for k in ("k_b", "alpha", "d", "no_contact"))
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
    """Evaluate the closed forms of MODEL.md §3 for one design (under its constants set)."""
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
        design.constants,
    )
    c["h"] = float(c["h"])
    return SpringConstants(**c)


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


def lattice_params(design: Design) -> LatticeParams:
    """Per-unit kernel table and segment height of one design."""
    tables = design_kernel_tables(design)
    return LatticeParams(tables.unit_params[0, : design.n_units].copy(), float(tables.h[0]))


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
            batch.constants,
            domes=domes,
        )


class KernelTables(NamedTuple):
    """What the state kernels read about a batch of designs (:func:`kernel_tables`).

    Attributes
    ----------
    status : ndarray of int8, shape (n,)
        Status code per design (those of :meth:`DesignBatch.status`).
    unit_params : ndarray of shape (n, MAX_UNITS, N_COLS)
        Per-unit tables (:mod:`dpfexplore._kernels.layout`); NaN past a design's ``N``.
    h : ndarray of shape (n,), mm
        Segment heights.
    n_units : ndarray of int64, shape (n,)
    E : ndarray of shape (n,), MPa
        Young's moduli (every stiffness is proportional to ``E``).
    no_contact : ndarray of bool, shape (n, MAX_UNITS)
        Units whose reach ``d`` is clamped.
    derivatives : ndarray of shape (n, MAX_UNITS, N_DCONST, N_DPARAM) or (0, 0, 0, 0)
        Derivatives of the constants in the design parameters
        (:mod:`dpfexplore._kernels.tables.design_tables`), when asked for.
    """

    status: NDArray
    unit_params: NDArray
    h: NDArray
    n_units: NDArray
    E: NDArray
    no_contact: NDArray
    derivatives: NDArray


def _tables(n_units, H, U_L, U_sep, shared, forms, derivatives: bool) -> KernelTables:
    n = n_units.shape[0]
    status = np.empty(n, dtype=np.int8)
    table = np.empty((n, MAX_UNITS, lay.N_COLS))
    h = np.empty(n)
    no_contact = np.empty((n, MAX_UNITS), dtype=np.bool_)
    dtab = (
        np.empty((n, MAX_UNITS, ktables.N_DCONST, ktables.N_DPARAM))
        if derivatives
        else ktables.empty_derivative_table()
    )
    # DesignArrays and TableOutputs as plain tuples (dpfexplore._kernels, "Records at the
    # entry points")
    ktables.design_tables(
        (n_units, H, U_L, U_sep, *shared), forms, (status, table, h, no_contact, dtab)
    )
    return KernelTables(status, table, h, n_units, shared[2], no_contact, dtab)


def kernel_tables(batch: DesignBatch, *, derivatives: bool = False) -> KernelTables:
    """Status codes and kernel tables of a batch in one compiled pass (``_kernels.tables``).

    The numbers equal those of the NumPy closed forms (:func:`batch_constants`) bit for bit, and
    the codes those of :meth:`DesignBatch.status`.
    """
    shared = (batch.t, batch.t_lim, batch.E, batch.nu, batch.r_b, batch.t_ch)
    forms = batch.constants.kernel_forms()
    return _tables(batch.n_units, batch.H, batch.U_L, batch.U_sep, shared, forms, derivatives)


def design_kernel_tables(design: Design, *, derivatives: bool = False) -> KernelTables:
    """:func:`kernel_tables` of one (already validated) design, without building a batch."""
    n = design.n_units
    per_unit = np.full((3, 1, MAX_UNITS), np.nan)
    per_unit[:, 0, :n] = (design.H, design.U_L, design.U_sep)
    shared = np.array(
        [[design.t], [design.t_lim], [design.E], [design.nu], [design.r_b], [design.t_ch]]
    )
    n_units = np.array([n], dtype=np.int64)
    forms = design.constants.kernel_forms()
    return _tables(n_units, *per_unit, tuple(shared), forms, derivatives)


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
    tables = kernel_tables(batch)
    return tables.unit_params, tables.h, batch.n_units.copy()


def free_node_names(n_units: int) -> list[str]:
    """Names of the free nodes in kernel order: ``["D1", "D2", "L2", ..., "DN", "LN"]``."""
    names = ["D1"]
    for k in range(2, n_units + 1):
        names += [f"D{k}", f"L{k}"]
    return names
