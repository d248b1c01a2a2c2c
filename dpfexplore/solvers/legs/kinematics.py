"""Kinematic composition of a leg's sections into one 3D shape (MODEL.md §10).

A leg is a chain of independent planar lattices ("units within different planes and zones do
not interact"). Each section is simulated alone in its own MODEL.md §5 frame (dome line on
``y = 0``, limiting layer on ``y = h``, base at the origin); these functions place the sections'
nodes in the leg's frame at every instant. Node arrays have shape ``(m, 2N + 2, 2)`` (``m``
instants; node ``2k`` is ``D_k``, ``2k + 1`` is ``L_k``) and the results ``(m, 2N + 2, 3)``, mm.

Two compositions:

``"dpw"`` -- :func:`compose_dpw`
    The implementation's walker leg (``Dynamic_DPW``), exactly as MODEL.md §10 states it, for
    three sections. Section 1's nodes ``P`` have ``y`` negated; ``θ₁ = -atan2(v)`` with
    ``v = P[D_N] - P[L_{N-1}]``. Section 2's nodes become ``Q = R(θ₁) Q + (x, -y)`` of
    ``P[D_N]``, and ``θ₂ = atan2(w)`` with ``w = Q[L_1] - Q[D_0]``. Section 3's nodes
    ``(x, y, 0)`` are rotated by ``R_z(θ₁ + θ₂) R_x(90°)``, have ``z`` negated and are shifted by
    ``(Q[L_1], 0)``. MODEL.md's section 2 has one unit; for ``N₂`` units ``L_1`` and ``D_0``
    read ``L_{N₂}`` and ``D_{N₂-1}`` (the implementation's "last node" and "last node - 3"),
    which is the same for ``N₂ = 1``. The transform keeps the implementation's quirks on
    purpose (section 1 is drawn mirrored but section 2 hangs from the unmirrored ``D_N``;
    ``θ₁`` enters section 3's heading twice): it defines the implementation's tip path. Note a
    consequence: with one unit, section 2's ``L_1`` and ``D_0`` are clamped nodes, so section 2's
    own motion never reaches the tip.
``"chain"`` -- :func:`compose_chain`
    A rigid chain of any number of sections: section ``i + 1`` starts where section ``i``
    ends, its post 0 on section ``i``'s last post (``D_0`` on ``D_N``, the post's direction
    ``D_N -> L_N`` as its ``+y``), turned about its own length axis (``x``) by a mount angle.
    Mount 0 continues the plane; 90° bends the next section out of it.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

__all__ = ["COMPOSITIONS", "compose", "compose_chain", "compose_dpw", "tip_node"]

COMPOSITIONS = ("dpw", "chain")


def _n_units(nodes: NDArray) -> int:
    return (nodes.shape[1] - 2) // 2


def tip_node(n_units: int) -> int:
    """Index of the tip node ``L_N`` among ``2N + 2`` nodes."""
    return 2 * n_units + 1


def _rot2(angle: NDArray) -> NDArray:
    """Planar rotations, shape ``(m, 2, 2)``."""
    c, s = np.cos(angle), np.sin(angle)
    return np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], -2)


def _rot_z(angle: NDArray) -> NDArray:
    c, s = np.cos(angle), np.sin(angle)
    zero, one = np.zeros_like(c), np.ones_like(c)
    return np.stack(
        [np.stack([c, -s, zero], -1), np.stack([s, c, zero], -1), np.stack([zero, zero, one], -1)],
        -2,
    )


def _rot_x(degrees: float) -> NDArray:
    # Exact entries at multiples of 90° (MATLAB's cosd(90) is 0 exactly; cos(π/2) is not).
    quarter = {0.0: (1.0, 0.0), 90.0: (0.0, 1.0), 180.0: (-1.0, 0.0), 270.0: (0.0, -1.0)}
    c, s = quarter.get(
        float(degrees) % 360.0, (np.cos(np.radians(degrees)), np.sin(np.radians(degrees)))
    )
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def _embed(nodes: NDArray) -> NDArray:
    """Planar nodes ``(m, n, 2)`` as ``(x, y, 0)``."""
    return np.concatenate([nodes, np.zeros((*nodes.shape[:-1], 1))], axis=-1)


def _check(sections: Sequence[NDArray], count: int | None) -> list[NDArray]:
    arrays = [np.asarray(s, dtype=float) for s in sections]
    if count is not None and len(arrays) != count:
        raise ValueError(f"sections: the composition needs {count}, got {len(arrays)}")
    if not arrays:
        raise ValueError("sections: need at least one")
    m = arrays[0].shape[0]
    for i, a in enumerate(arrays):
        if a.ndim != 3 or a.shape[2] != 2 or a.shape[1] < 4 or a.shape[1] % 2:
            raise ValueError(f"sections[{i}]: need nodes of shape (m, 2N + 2, 2), got {a.shape}")
        if a.shape[0] != m:
            raise ValueError(f"sections[{i}]: {a.shape[0]} instants, section 1 has {m}")
    return arrays


def compose_dpw(sections: Sequence[NDArray]) -> list[NDArray]:
    """Place the three sections of the implementation's walker leg (MODEL.md §10).

    Parameters
    ----------
    sections : sequence of 3 ndarrays of shape (m, 2N_i + 2, 2), mm
        Each section's nodes in its own §5 frame.

    Returns
    -------
    list of 3 ndarrays of shape (m, 2N_i + 2, 3), mm
        The nodes in the leg's frame (sections 1 and 2 in the ``z = 0`` plane). The leg's tip
        is section 3's ``L_N``.
    """
    s1, s2, s3 = _check(sections, 3)
    n1, n2 = _n_units(s1), _n_units(s2)
    P = s1 * np.array([1.0, -1.0])
    v = P[:, 2 * n1] - P[:, 2 * n1 - 1]  # D_N - L_{N-1}
    theta1 = -np.arctan2(v[:, 1], v[:, 0])
    anchor = P[:, 2 * n1] * np.array([1.0, -1.0])  # (x, -y) of P[D_N]
    Q = np.einsum("mij,mnj->mni", _rot2(theta1), s2) + anchor[:, None, :]
    top = Q[:, tip_node(n2)]  # L_{N2}
    w = top - Q[:, 2 * n2 - 2]  # minus D_{N2-1}
    theta2 = np.arctan2(w[:, 1], w[:, 0])
    turn = np.einsum("mij,jk->mik", _rot_z(theta1 + theta2), _rot_x(90.0))
    S = np.einsum("mij,mnj->mni", turn, _embed(s3))
    S[..., 2] *= -1.0
    S[..., :2] += top[:, None, :]
    return [_embed(P), _embed(Q), S]


def compose_chain(sections: Sequence[NDArray], mounts_deg: Sequence[float]) -> list[NDArray]:
    """Place sections one after the other, each turned by its mount angle (module docstring).

    Parameters
    ----------
    sections : sequence of ndarrays of shape (m, 2N_i + 2, 2), mm
    mounts_deg : sequence of float, degrees
        Per section: rotation about its own length axis relative to the previous section's
        end (the first section's relative to the leg frame).

    Returns
    -------
    list of ndarrays of shape (m, 2N_i + 2, 3), mm
    """
    arrays = _check(sections, None)
    if len(mounts_deg) != len(arrays):
        raise ValueError(f"mounts_deg: {len(mounts_deg)} angles for {len(arrays)} sections")
    m = arrays[0].shape[0]
    rotation = np.broadcast_to(np.eye(3), (m, 3, 3))
    origin = np.zeros((m, 3))
    placed = []
    for nodes, mount in zip(arrays, mounts_deg, strict=True):
        rotation = rotation @ _rot_x(mount)
        placed.append(np.einsum("mij,mnj->mni", rotation, _embed(nodes)) + origin[:, None, :])
        n = _n_units(nodes)
        base, top = nodes[:, 2 * n], nodes[:, 2 * n + 1]  # the last post D_N -> L_N
        e_y = top - base
        e_y /= np.linalg.norm(e_y, axis=1, keepdims=True)
        frame = np.zeros((m, 3, 3))
        frame[:, 0, 0], frame[:, 1, 0] = e_y[:, 1], -e_y[:, 0]  # e_x: e_y turned by -90°
        frame[:, 0, 1], frame[:, 1, 1] = e_y[:, 0], e_y[:, 1]
        frame[:, 2, 2] = 1.0
        origin = origin + np.einsum("mij,mj->mi", rotation, _embed(base[:, None, :])[:, 0])
        rotation = rotation @ frame
    return placed


def compose(
    composition: str, sections: Sequence[NDArray], mounts_deg: Sequence[float] | None = None
) -> list[NDArray]:
    """Dispatch to :func:`compose_dpw` or :func:`compose_chain` by name."""
    if composition == "dpw":
        return compose_dpw(sections)
    if composition == "chain":
        return compose_chain(sections, [0.0] * len(sections) if mounts_deg is None else mounts_deg)
    raise ValueError(f"composition = {composition!r}: choose one of {COMPOSITIONS}")
