"""``dpfexplore grasp GRIPPER --object D[:MASS]`` and ``dpfexplore sort GRIPPER OBJECTS.csv``.

``grasp``: the gripper closed on one disk in each grasp state (contact, grip force, sensor
against its threshold, payload, whether the state holds), with the tip unit's reset time beside
the lift. ``sort``: the paper's size-and-weight loop on every object of a CSV file, with the
confusion table when the file gives true classes, and the sorting map (``--plot``).
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from .. import EXIT_FAILURE, EXIT_OK, UsageError
from ..support.inputs import add_constants_option, design_of
from ..support.output import (
    FIGURE_SUFFIXES,
    announce_compilation,
    error_line,
    json_text,
    output_path,
    save_figure,
)

UNITS_HELP = (
    "Units: diameters and depths in mm, masses in kg (payloads printed in g), forces in N, "
    "times in s, mu dimensionless. States are inversion vectors, unit 1 (the base) first."
)
GRIPPER_HELP = "design file (TOML, [design] table) or a packaged example's name ('gripper')"


def _common(parser) -> None:
    parser.add_argument("design", metavar="GRIPPER", help=GRIPPER_HELP)
    parser.add_argument(
        "--mu", type=float, default=0.5, help="Coulomb friction at the contacts (default 0.5)"
    )
    parser.add_argument(
        "--depth",
        type=float,
        help="disk centre's depth along the axis, mm (default: the mean "
        "fingertip depth of the grasp states)",
    )
    parser.add_argument(
        "--threshold",
        type=float,
        help="sensor threshold, N (default: 1.1 x the largest free-state reading)",
    )
    parser.add_argument(
        "--lift-s",
        type=float,
        dest="lift_s",
        help="the lift's duration, s: the tip unit is used only if it resets later",
    )
    parser.add_argument(
        "--base",
        nargs=2,
        type=float,
        metavar=("BASE_L", "THETA_DEG"),
        help="the gripper's base: length (mm) and angle (deg); default: the file's [result] "
        "(as `design` writes a gripper), else the paper's gripper base",
    )
    parser.add_argument("--json", action="store_true", help="print JSON instead of a table")
    add_constants_option(parser)


def register(subparsers) -> None:
    """Add the ``grasp`` and ``sort`` subcommands."""
    parser = subparsers.add_parser(
        "grasp",
        help="close the gripper on a disk: contact, grip force, sensor, payload per state",
        description="Close the gripper (two mirrored fingers) on a rigid disk in each grasp "
        "state; print per state contact, grip force, the contact sensor's reading against its "
        "threshold, the payload and whether the state holds. " + UNITS_HELP,
    )
    _common(parser)
    parser.add_argument(
        "--object", required=True, metavar="D[:MASS]", help="disk diameter (mm) and mass (kg)"
    )
    parser.add_argument("--plot", metavar="FILE.png", help="draw both fingers around the disk")
    parser.set_defaults(handler=run_grasp)
    parser = subparsers.add_parser(
        "sort",
        help="sort objects by size and weight with the paper's one-sensor loop",
        description="Run the paper's classification loop on each object of a CSV file "
        "(columns name, diameter, mass[, class]): size class from the first state whose sensor "
        "passes its threshold, weight class light / heavy (held with the tip unit inverted) / "
        "not_held. With a class column: the confusion table and accuracy. " + UNITS_HELP,
    )
    _common(parser)
    parser.add_argument("objects", metavar="OBJECTS.csv", help="CSV: name, diameter, mass[, class]")
    parser.add_argument("--plot", metavar="FILE.png", help="draw the sorting map with the objects")
    parser.set_defaults(handler=run_sort)


def _object(text: str) -> tuple[float, float]:
    diameter, _, mass = text.partition(":")
    try:
        return float(diameter), float(mass) if mass else 0.0
    except ValueError:
        raise UsageError(f"--object {text!r}: give D[:MASS], diameter in mm, mass in kg") from None


def _check_options(args) -> None:
    """Refuse a negative or non-finite mu, lift, threshold or depth (one line, before work)."""
    for name, value, low in (
        ("--mu", args.mu, 0.0),
        ("--lift-s", args.lift_s, 0.0),
        ("--threshold", args.threshold, None),
        ("--depth", args.depth, None),
    ):
        if value is None:
            continue
        if not math.isfinite(value) or (low is not None and value < low):
            raise UsageError(f"{name} {value:g}: must be a finite number >= 0")
        if name == "--threshold" and value <= 0:
            raise UsageError(f"{name} {value:g}: must be > 0 (N)")


def gripper_base(args) -> tuple[float, float, str]:
    """The gripper's base (``base_L`` mm, ``theta_B_deg`` degrees) and where it comes from.

    ``--base`` first; else the ``[result]`` table of a design file (``design`` writes the base it
    chose there); else the paper's gripper base.

    Raises
    ------
    UsageError
        ``--base`` or ``[result]`` values that are not finite numbers, a ``[result]`` with only
        one of the two keys.
    """
    from ...io.toml_fields import read_toml
    from ...model.gripper import PAPER_GRIPPER_BASE

    if args.base is not None:
        base_L, theta = args.base
        source = "--base"
    else:
        path = Path(args.design)
        result = read_toml(path, "design").get("result", {}) if path.is_file() else {}
        keys = [k for k in ("base_L", "theta_B_deg") if k in result]
        if not keys:
            return (*PAPER_GRIPPER_BASE, "the paper's gripper")
        if len(keys) == 1:
            raise UsageError(
                f"{path}: [result] has {keys[0]} but not the other of base_L, theta_B_deg"
            )
        base_L, theta = result["base_L"], result["theta_B_deg"]
        source = f"{path.name} [result]"
    for name, value in (("base_L", base_L), ("theta_B_deg", theta)):
        if (
            isinstance(value, bool)
            or not isinstance(value, (int, float))
            or not math.isfinite(value)
        ):
            raise UsageError(f"{source}: {name} = {value!r}: must be a finite number")
    if base_L <= 0:
        raise UsageError(f"{source}: base_L = {base_L!r}: must be > 0 (mm)")
    return float(base_L), float(theta), source


def _gripper(args, groups=("states", "grasp")):
    from ...grasping import gripper_of

    try:
        design = design_of(args)
        base_L, theta, source = gripper_base(args)
    except (OSError, ValueError) as exc:
        raise UsageError(str(exc)) from None
    announce_compilation(args.command, list(groups))
    base = {"base_L_mm": base_L, "theta_B_deg": theta, "base_from": source}
    return gripper_of(design, base_L=base_L, theta_B_deg=theta), base


def _base_line(base: dict) -> str:
    return (
        f"gripper base: base_L {base['base_L_mm']:g} mm, theta_B {base['theta_B_deg']:g} deg "
        f"({base['base_from']})"
    )


def run_grasp(args: argparse.Namespace) -> int:
    """Handler of ``dpfexplore grasp``."""
    from ...grasping.grasp import check_object, grasp

    diameter, mass = _object(args.object)
    _check_options(args)
    try:
        check_object(diameter, mass, args.mu, None)
    except ValueError as exc:
        raise UsageError(f"--object {args.object}: {exc}") from None
    plot = output_path(args.plot, "--plot", suffixes=FIGURE_SUFFIXES) if args.plot else None
    gripper, base = _gripper(args, ("states", "grasp", "reset"))
    try:
        check_object(diameter, mass, args.mu, gripper.open_aperture)
    except ValueError as exc:
        raise UsageError(f"--object {args.object}: {exc}") from None
    report = grasp(
        gripper,
        diameter,
        mass,
        mu=args.mu,
        depth=args.depth,
        threshold=args.threshold,
        lift_s=args.lift_s,
        reset=True,
    )
    document = report.to_dict()
    document["gripper"] = args.design
    document.update(base)
    for row, s in zip(document["states"], report.states, strict=True):
        row["carries"] = bool(s.holds and s.payload_kg >= mass)
    tip_lasts = args.lift_s is None or (report.tip_reset_s or 0.0) >= args.lift_s
    document["tip_lasts"] = tip_lasts
    if args.json:
        sys.stdout.write(json_text(document))
        print()
    else:
        print(_base_line(base))
        _print_grasp(report, document, mass, tip_lasts)
    if plot is not None:
        _plot_grasp(report, plot)
    failed = [s.state for s in report.states + report.tip_states if s.status != "ok"]
    if failed:
        error_line(f"dpfexplore grasp: not solved: {', '.join(failed)}; their outputs are nan")
    return EXIT_FAILURE if failed else EXIT_OK


def _tip_line(reset: float | None, lift: float | None, lasts: bool) -> str:
    reset_text = "does not reset" if reset is None or math.isinf(reset) else f"{reset:.3g} s"
    line = f"tip unit (inverted by its pulse): resets after {reset_text}"
    if lift is None:
        return line + "; lift duration not given (--lift-s): not checked"
    verdict = "usable for the lift" if lasts else "resets before the lift ends: not used"
    return line + f"; lift {lift:g} s: {verdict}"


def _print_grasp(report, document, mass: float, tip_lasts: bool) -> None:
    g = report.gripper
    print(
        f"disk {report.diameter_mm:g} mm, {mass:g} kg at depth {report.depth_mm:.2f} mm; "
        f"mu {report.mu:g}; sensor threshold {report.threshold_N:.4g} N (unit 1's dome force); "
        f"open aperture {g.open_aperture:.2f} mm"
    )
    print(
        f"{'state':<8}{'aperture':>9}{'contact':>9}{'grip':>9}{'sensor':>9}{'decides':>9}"
        f"{'payload':>9}{'+tip':>9}{'holds':>7}{'carries':>9}"
    )
    print(f"{'':<8}{'mm':>9}{'':>9}{'N':>9}{'N':>9}{'':>9}{'g':>9}{'g':>9}{'':>7}{'':>9}")
    yes = {True: "yes", False: "no"}
    for s, tip, row in zip(report.states, report.tip_states, document["states"], strict=True):
        print(
            f"{s.state:<8}{row['aperture_mm']:>9.2f}{yes[s.contact]:>9}{s.grip_force_N:>9.4f}"
            f"{s.sensor_N:>9.4f}{yes[s.detects]:>9}{1e3 * s.payload_kg:>9.2f}"
            f"{1e3 * tip.payload_kg:>9.2f}{yes[s.holds]:>7}{yes[row['carries']]:>9}"
        )
    print(f"size class: {report.size_state or 'none'} (the first state that decides)")
    print(_tip_line(report.tip_reset_s, report.lift_s, tip_lasts))


def _plot_grasp(report, path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from ...plotting.grasp import plot_grasp

    n = len(report.states)
    fig, axes = plt.subplots(1, n, figsize=(3.6 * n, 4), squeeze=False)
    for ax, s in zip(axes[0], report.states, strict=True):
        plot_grasp(
            s.nodes_mm,
            s.forces_N,
            s.points_mm,
            s.normals,
            base_l=report.gripper.base_L,
            depth=report.depth_mm,
            diameter=report.diameter_mm,
            title=f"{s.state}: grip {s.grip_force_N:.3g} N" + ("" if s.holds else " (lost)"),
            ax=ax,
        )
    # one scale for every panel: the union of their limits (each holds its legend's band)
    for get, put in (("get_xlim", "set_xlim"), ("get_ylim", "set_ylim")):
        limits = np.array([getattr(ax, get)() for ax in axes[0]])
        for ax in axes[0]:
            getattr(ax, put)(limits[:, 0].min(), limits[:, 1].max())
    fig.tight_layout()
    save_figure(fig, path, dpi=150, bbox_inches="tight")
    plt.close(fig)


def run_sort(args: argparse.Namespace) -> int:
    """Handler of ``dpfexplore sort``."""
    import numpy as np

    from ...grasping.sort import WEIGHT_CLASSES, read_objects, report_map, sort_objects

    _check_options(args)
    try:
        objects = read_objects(args.objects)
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    plot = output_path(args.plot, "--plot", suffixes=FIGURE_SUFFIXES) if args.plot else None
    gripper, base = _gripper(args, ("states", "grasp", "grasp sort", "reset"))
    try:
        report = sort_objects(
            gripper,
            objects,
            mu=args.mu,
            lift_s=args.lift_s,
            depth=args.depth,
            threshold=args.threshold,
        )
    except ValueError as exc:
        raise UsageError(f"{args.objects}: {exc}") from None
    if args.json:
        document = {"gripper": args.design, **base, **report.to_dict()}
        sys.stdout.write(json_text(document))
        print()
    else:
        print(_base_line(base))
        _print_sort(report)
    if plot is not None:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        from ...plotting.grasp import plot_sorting_map

        diameters, masses, size, weight = report_map(
            report, float(np.min(objects.diameters)), float(np.max(objects.masses))
        )
        ax = plot_sorting_map(
            diameters,
            masses,
            size,
            weight,
            states=gripper.states,
            weight_classes=WEIGHT_CLASSES,
            objects=(objects.diameters, objects.masses),
        )
        save_figure(ax.figure, plot, dpi=150, bbox_inches="tight")
        plt.close(ax.figure)
    failed = [o.name for o in report.objects if o.status != "ok"]
    if failed:
        error_line(f"dpfexplore sort: not solved: {', '.join(failed[:8])}: no class")
    return EXIT_FAILURE if failed else EXIT_OK


def _print_sort(report) -> None:
    print(
        f"mu {report.mu:g}; disk depth {report.depth_mm:.2f} mm; sensor threshold "
        f"{report.threshold_N:.4g} N"
    )
    width = max(4, *(len(o.name) for o in report.objects))
    print(
        f"{'name':<{width}}{'diameter':>10}{'mass':>8}{'size':>8}{'weight':>10}"
        f"{'sensor':>9}{'payload':>9}{'+tip':>9}{'margin':>9}  true"
    )
    print(f"{'':<{width}}{'mm':>10}{'g':>8}{'':>8}{'':>10}{'N':>9}{'g':>9}{'g':>9}{'g':>9}")
    for o in report.objects:
        print(
            f"{o.name:<{width}}{o.diameter_mm:>10.2f}{1e3 * o.mass_kg:>8.1f}"
            f"{o.size_state or 'none':>8}{o.weight_class:>10}{o.sensor_N:>9.4f}"
            f"{1e3 * o.payload_kg:>9.2f}{1e3 * o.payload_tip_kg:>9.2f}"
            f"{1e3 * o.payload_margin_kg:>9.2f}  {o.true_class or ''}"
        )
    print(_tip_line(report.tip_reset_s, report.lift_s, report.tip_lasts))
    if report.confusion is not None:
        outcomes = sorted({k for row in report.confusion.values() for k in row})
        print("confusion (rows: true class; columns: outcome)")
        first = max(len(t) for t in report.confusion)
        print(f"{'':<{first}}" + "".join(f"{c:>18}" for c in outcomes))
        for true, row in report.confusion.items():
            print(f"{true:<{first}}" + "".join(f"{row.get(c, 0):>18}" for c in outcomes))
        print(f"accuracy {report.accuracy:.3f}")
