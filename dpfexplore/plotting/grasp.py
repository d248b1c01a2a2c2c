"""The gripper closed on a disk (contact forces as arrows), and the sorting map.

Frames: the gripper's (MODEL.md §7): ``x`` the depth along the axis from the base (mm), ``y``
across it; the second finger is the first mirrored about ``y = base_L``.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from matplotlib.axes import Axes
from numpy.typing import NDArray

__all__ = ["plot_grasp", "plot_sorting_map"]


#: Height of one legend row of the sorting map, as a fraction of the map's mass range.
_SORT_LEGEND_ROW = 0.11

#: Height of the band above the drawing that holds the legend (fraction of the drawing's height):
#: three entries at the small font in a panel a few inches tall.
_LEGEND_BAND = 0.4


def _outline(nodes: NDArray) -> NDArray:
    """The finger's outline: the post side (even nodes), back along the limiting layer (odd)."""
    return np.vstack([nodes[0::2], nodes[1::2][::-1], nodes[:1]])


def plot_grasp(
    nodes: NDArray,
    forces: NDArray,
    points: NDArray,
    normals: NDArray,
    *,
    base_l: float,
    depth: float,
    diameter: float,
    title: str = "",
    ax: Axes | None = None,
) -> Axes:
    """Both fingers around the disk, each contact's force on the disk as an arrow.

    Parameters
    ----------
    nodes : ndarray of shape (2N + 2, 2), mm
        One finger's nodes at equilibrium (gripper frame).
    forces : ndarray of shape (N,), N
        Normal force of each limiting-layer segment on the disk (0: no contact).
    points, normals : ndarray of shape (N, 2)
        Contact points (mm, gripper frame) and unit normals toward the disk's centre.
    base_l, depth, diameter : float, mm
        The mirror line ``y = base_l``, the disk centre's depth and its diameter.
    title : str
    ax : Axes, optional

    Returns
    -------
    Axes
        With two finger lines, one disk patch and one arrow (``FancyArrow``) per contact of
        either finger; arrows' lengths scale with force (the largest is half the radius).
    """
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D
    from matplotlib.patches import Circle, FancyArrow

    if ax is None:
        _, ax = plt.subplots(figsize=(4.5, 4.5))
    finger = _outline(np.asarray(nodes, dtype=float))
    mirrored = finger.copy()
    mirrored[:, 1] = 2.0 * base_l - finger[:, 1]
    ax.plot(finger[:, 0], finger[:, 1], "-", color="C0", lw=1.4, label="fingers")
    ax.plot(mirrored[:, 0], mirrored[:, 1], "-", color="C0", lw=1.4)
    radius = 0.5 * diameter
    ax.add_patch(Circle((depth, base_l), radius, fill=True, alpha=0.25, color="C7", label="disk"))
    forces = np.nan_to_num(np.asarray(forces, dtype=float))
    biggest = float(forces.max()) if forces.size else 0.0
    touching = np.flatnonzero(forces > 0.0)
    for k in touching:
        length = 0.5 * radius * forces[k] / biggest
        for sign in (1.0, -1.0):
            px, py = points[k, 0], points[k, 1]
            nx, ny = normals[k, 0], normals[k, 1]
            if sign < 0:
                py, ny = 2.0 * base_l - py, -ny
            ax.add_patch(
                FancyArrow(
                    px,
                    py,
                    length * nx,
                    length * ny,
                    width=0.02 * radius,
                    head_width=0.08 * radius,
                    length_includes_head=True,
                    color="C3",
                )
            )
    handles = [
        Line2D([], [], color="C0", lw=1.4, label="fingers"),
        Circle((0, 0), 1, alpha=0.25, color="C7", label=f"disk {diameter:g} mm"),
    ]
    if touching.size:
        handles.append(
            Line2D([], [], color="C3", lw=2, label=f"contact force\n(largest {biggest:.3g} N)")
        )
    ax.legend(handles=handles, loc="upper left", fontsize="small")
    ax.set_aspect("equal")
    ax.autoscale_view()
    # a band above the fingers and the disk, where the legend stands clear of them
    low, high = ax.get_ylim()
    ax.set_ylim(low, high + _LEGEND_BAND * (high - low))
    ax.set_xlabel("depth along the axis (mm)")
    ax.set_ylabel("across the axis (mm)")
    if title:
        ax.set_title(title, fontsize="small")
    return ax


def plot_sorting_map(
    diameters: NDArray,
    masses: NDArray,
    size: NDArray,
    weight: NDArray,
    *,
    states: Sequence[str],
    weight_classes: Sequence[str],
    objects: tuple[NDArray, NDArray] | None = None,
    ax: Axes | None = None,
) -> Axes:
    """The loop's class over (diameter, mass), its boundaries, and the objects on it.

    Parameters
    ----------
    diameters : ndarray of shape (n_d,), mm
    masses : ndarray of shape (n_m,), kg
    size, weight : ndarray of int, shape (n_m, n_d)
        Deciding state's index (-1: none) and weight-class code at each grid point.
    states, weight_classes : sequence of str
        Names of the size states and weight classes.
    objects : (diameters, masses), optional
        Objects to mark (mm, kg).
    ax : Axes, optional

    Returns
    -------
    Axes
        Colours: one per (size, weight) class; solid black lines where the size class changes,
        dashed where the weight class does; the objects as black crosses.
    """
    import matplotlib.pyplot as plt
    from matplotlib.colors import ListedColormap
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    if ax is None:
        _, ax = plt.subplots(figsize=(7, 4.5))
    n_w = len(weight_classes)
    code = (np.asarray(size) + 1) * n_w + np.asarray(weight)
    n_codes = (len(states) + 1) * n_w
    palette = plt.get_cmap("tab20", n_codes)
    grams = 1e3 * np.asarray(masses, dtype=float)
    ax.pcolormesh(
        diameters,
        grams,
        code,
        cmap=ListedColormap([palette(i) for i in range(n_codes)]),
        vmin=-0.5,
        vmax=n_codes - 0.5,
        shading="nearest",
    )
    if np.unique(size).size > 1:
        ax.contour(diameters, grams, size, levels=np.arange(-0.5, len(states)), colors="k")
    if np.unique(weight).size > 1:
        ax.contour(
            diameters, grams, weight, levels=np.arange(0.5, n_w - 1), colors="k", linestyles="--"
        )
    handles = []
    for c in np.unique(code):
        s, w = divmod(int(c), n_w)
        name = states[s - 1] if s > 0 else "none"
        handles.append(Patch(color=palette(int(c)), label=f"{name}/{weight_classes[w]}"))
    if objects is not None:
        ax.plot(objects[0], 1e3 * np.asarray(objects[1]), "kx", ms=6)
        handles.append(Line2D([], [], color="k", marker="x", ls="", label="objects"))
    # the legend stands in a band above the map, clear of its boundaries and objects
    # as many columns as the axes' width holds (an x-small entry: about 0.055 in per character
    # of its label plus 0.5 in for its key and padding)
    width_in = ax.get_position().width * ax.figure.get_figwidth()
    entry_in = 0.5 + 0.055 * max(len(h.get_label()) for h in handles)
    ncols = max(1, min(4, len(handles), int(width_in // entry_in)))
    rows = -(-len(handles) // ncols)
    cell = float(grams[1] - grams[0]) if grams.size > 1 else 1.0  # the map's cells are centred
    low, top = float(grams[0]) - 0.5 * cell, float(grams[-1]) + 0.5 * cell
    height = top - low
    ax.set_ylim(low, top + _SORT_LEGEND_ROW * rows * height + 0.04 * height)
    ax.legend(handles=handles, loc="upper center", ncols=ncols, fontsize="x-small", framealpha=0.9)
    ax.set_xlabel("object diameter (mm)")
    ax.set_ylabel("object mass (g)")
    ax.set_title("Sorting map: size state / weight class", fontsize="small")
    return ax
