"""Figures of inverse design: targets met, objective against evaluations, fronts, regions.

Plain arrays and DataFrames in (the history written by ``dpfexplore design``), Axes out.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from ..model.gripper import gripper_frame
from .statics import plot_finger

__all__ = [
    "plot_front",
    "plot_gripper",
    "plot_objective_history",
    "plot_reachable_region",
    "plot_target_shapes",
]


def _axes(ax: Axes | None, size=(6, 5)) -> Axes:
    if ax is None:
        import matplotlib.pyplot as plt

        _, ax = plt.subplots(figsize=size, layout="constrained")
    return ax


def plot_target_shapes(
    nodes: Sequence[np.ndarray],
    targets: Sequence[Sequence[float]],
    reachable: Sequence[bool],
    ax: Axes | None = None,
) -> Axes:
    """Each target's finger in its targeted state, with the target (x: unreachable).

    Parameters
    ----------
    nodes : sequence of ndarray of shape (2N + 2, 2), mm
    targets : sequence of (x, y), mm
    reachable : sequence of bool
    """
    ax = _axes(ax, (7, 6))
    import matplotlib as mpl

    colors = mpl.colormaps["tab10"](np.arange(len(nodes)) % 10)
    for i, (xy, target, ok) in enumerate(zip(nodes, targets, reachable, strict=True)):
        plot_finger(xy, ax, color=colors[i], label=f"target {i + 1}")
        ax.plot(*target, "*" if ok else "x", color=colors[i], ms=12, mec="k")
    # beside the axes: the fingers fan out over the whole panel
    ax.legend(fontsize="small", loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0)
    ax.set_title("Designs in their targeted state (star: target met, x: unreachable)")
    return ax


def plot_objective_history(
    history,
    ax: Axes | None = None,
    *,
    labels: Mapping[int, str] | None = None,
    ylabel: str = "best objective so far (mm²)",
) -> Axes:
    """Best objective so far against exact evaluations, one line per target.

    Every evaluation is a marker, so a target met at its first evaluations is still drawn; a
    target without a finite objective is left out of the plot and of the legend.

    Parameters
    ----------
    history : pandas.DataFrame
        The scene's history (columns ``evaluation``, ``target``, ``objective``).
    labels : mapping of int to str, optional
        Legend label of each target index (default ``"target i"``, 1-based).
    ylabel : str
        What the objective is (mm² for the position scenes).
    """
    ax = _axes(ax)
    counts = []
    for target, part in history.groupby("target"):
        objective = part["objective"].to_numpy(dtype=float)
        best = np.minimum.accumulate(np.where(np.isfinite(objective), objective, np.inf))
        count = np.arange(1, len(best) + 1)
        keep = np.isfinite(best)
        if not keep.any():
            continue
        label = (labels or {}).get(int(target), f"target {int(target) + 1}")
        ax.plot(count[keep], np.maximum(best[keep], 1e-16), "-o", ms=3, lw=1.2, label=label)
        counts.append(int(count[keep][-1]))
    ax.set_yscale("log")
    if counts and max(counts) > 20:
        ax.set_xscale("log")
    else:  # a few evaluations: whole numbers on a linear axis read better than 2×10⁰
        from matplotlib.ticker import MaxNLocator

        ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    ax.set_xlabel("exact evaluations (designs solved)")
    ax.set_ylabel(ylabel)
    if counts:
        ax.legend(fontsize="small")
    ax.set_title("Objective against evaluations")
    return ax


def plot_front(
    points: Sequence[tuple[float, float | None, float | None]],
    *,
    reference: tuple[float, float] | None = None,
    title: str = "",
    ax: Axes | None = None,
) -> Axes:
    """Stiffness against tip tolerance (the two-objective scenes' answer).

    Parameters
    ----------
    points : sequence of (tolerance, distance, stiffness)
        mm, mm, N/mm of each rung of the front.
    reference : (distance, stiffness), optional
        A design to compare with (e.g. the paper's, evaluated in this model).
    """
    ax = _axes(ax)
    tol = np.array([p[0] for p in points], dtype=float)
    dist = np.array([np.nan if p[1] is None else p[1] for p in points], dtype=float)
    stiff = np.array([np.nan if p[2] is None else p[2] for p in points], dtype=float)
    ax.step(tol, stiff, where="post", label="front: stiffest within the tolerance")
    ax.plot(np.maximum(dist, 1e-7), stiff, "o", ms=4, label="designs (their distance)")
    if reference is not None and reference[0] is not None and reference[1] is not None:
        ax.plot(max(reference[0], 1e-7), reference[1], "s", color="C3", label="reference")
    ax.set_xscale("log")
    ax.set_xlabel("tip distance to the target (mm)")
    ax.set_ylabel("tip stiffness (N/mm)")
    ax.legend(fontsize="small")
    ax.set_title(title or "Stiffness against tip tolerance")
    return ax


def plot_reachable_region(
    history, target: Sequence[float], nearest: Sequence[float], ax: Axes | None = None
) -> Axes:
    """Tips of every evaluated design per N (the sampled reachable region) with the target.

    Parameters
    ----------
    history : pandas.DataFrame
        History rows of one target (columns ``n_units``, ``tip_x``, ``tip_y``, ``status``).
    target, nearest : (x, y), mm
    """
    ax = _axes(ax, (7, 6))
    ok = history[history["status"] == 0]
    for n, part in ok.groupby("n_units"):
        ax.plot(part["tip_x"], part["tip_y"], ".", ms=2, alpha=0.5, label=f"N = {int(n)}")
    ax.plot(*target, "x", color="k", ms=12, mew=2, label="target")
    ax.plot(*nearest, "o", mfc="none", mec="r", ms=10, label="nearest tip found")
    ax.set_aspect("equal")
    ax.set_xlabel("tip x (mm)")
    ax.set_ylabel("tip y (mm)")
    ax.legend(fontsize="small", markerscale=3)
    ax.set_title("Reachable region sampled per N")
    return ax


def plot_gripper(
    nodes: Sequence[np.ndarray],
    h: float,
    theta_deg: float,
    base_l: float,
    targets: Sequence[float],
    apertures: Sequence[float],
    *,
    states: Sequence[str] = (),
    fig: Figure | None = None,
) -> Figure:
    """The two mirrored fingers of the gripper in each targeted state, with the object.

    Parameters
    ----------
    nodes : sequence of ndarray of shape (2N + 2, 2), mm
        Finger nodes (model frame) per targeted state.
    h, theta_deg, base_l : float
        Segment height (mm), base angle (degrees) and base length (mm) (MODEL.md §7).
    targets, apertures : sequence of float, mm
    """
    from matplotlib.patches import Circle

    n = len(nodes)
    if fig is None:
        fig = Figure(figsize=(3.0 * n + 0.6, 4.2), layout="constrained")
    # one scale for every panel: the states differ by how far the fingers close
    axes = fig.subplots(1, n, squeeze=False, sharex=True, sharey=True)[0]
    extents = []
    for ax, xy, target, aperture, label in zip(
        axes, nodes, targets, apertures, list(states) or [""] * n, strict=False
    ):
        finger = gripper_frame(xy, h, theta_deg)
        mirrored = finger.copy()
        mirrored[:, 1] = 2.0 * base_l - finger[:, 1]
        plot_finger(finger, ax, color="C0")
        plot_finger(mirrored, ax, color="C0")
        centre = (float(np.mean(finger[-1:, 0])), base_l)
        ax.add_patch(Circle(centre, target / 2.0, fill=False, ls="--", color="C3"))
        extents += [finger, mirrored]
        extents.append(np.array(centre) + target / 2.0 * np.array([[-1, -1], [1, 1]]))
        ax.set_title(f"{label}: {aperture:.2f} mm\n(target {target:g})", fontsize="small")
    every = np.vstack(extents)
    low, high = every.min(axis=0), every.max(axis=0)
    pad = 0.05 * float(np.max(high - low))
    axes[0].set_xlim(low[0] - pad, high[0] + pad)
    axes[0].set_ylim(low[1] - pad, high[1] + pad)
    for ax in axes[1:]:
        ax.set_ylabel("")
        ax.tick_params(labelleft=False)
    fig.suptitle("Gripper in its targeted states (dashed: object)")
    return fig
