"""A leg: a chain of independently simulated sections composed into a 3D tip path (MODEL.md §10).

"Units within different planes and zones do not interact": each section is a finger of its own
(a :class:`~dpfexplore.model.design.Design`) driven by the pressure of its phase, simulated
alone with :func:`dpfexplore.solvers.dynamics.simulate.simulate` (MODEL.md §8), and the sections'
nodes are placed in the leg's frame at each instant by :mod:`dpfexplore.solvers.legs.kinematics`.

Only the phases that move a section are integrated
    A section starts flat, unloaded and at rest, which is an exact equilibrium while its
    pressure is 0: its trajectory is the rest state until its phase first raises the pressure
    (:meth:`PressureProfile.zero_until`, the knot before the first non-zero pressure). Its
    integration starts there (``simulate(..., t_start=...)``) and runs to the leg's ``t_end``,
    since after its phase a section keeps moving (its domes reset). A section whose phase never
    raises the pressure before ``t_end`` is not integrated at all. The samples before the start
    are the rest state, exactly what an integration from 0 would give up to its tolerance.

Leg files (TOML)
----------------
::

    [leg]
    name = "walker-leg"          # optional
    composition = "dpw"          # "dpw" (MODEL.md §10, three sections) or "chain"
    t_end = 5.0                  # s: every section is simulated on [0, t_end]
    n_samples = 501              # tip-path samples, evenly spaced on [0, t_end]
    method = "rodas4"            # optional, as `simulate`; atol = ... (mm) optional too

    [defaults]                   # design keys every section takes unless it sets them
    U_L = 6.5
    t = 1.0

    [phase.1]                    # a pulse: P0 (MPa) and tau = [τ1, τ2, τ3, τ4] (s), or
    P0 = 0.4                     # pulses = [[P0, τ1, τ2, τ3, τ4], ...] (a gait of cycles), or
    tau = [0.0, 0.1, 1.1, 1.2]   # profile = "t:P, t:P, ..." (piecewise linear)

    [[section]]                  # in chain order, base first
    name = "purple"
    phase = "1"
    mount_deg = 0.0              # "chain" only: turn about the section's length axis
    design = { H = [1.1, 1.1] }  # a [design] table as in design files (merged over defaults)

Reset times of a section are measured from the end of its own phase's profile. Every output
carries ``fitted_range``: False when any section leaves the box the closed forms were fitted
on (:meth:`dpfexplore.model.design.Design.in_fitted_range`), as the walker's low domes do.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..._kernels.lattice import unpack_nodes
from ...io.toml_fields import known_keys, read_toml
from ...model import status as st
from ...model.constants_set import ConstantsSet
from ...model.design import Design
from ...model.pressure import PressureProfile
from ..dynamics.simulate import DEFAULT_METHOD, SimulationResult, method_info, simulate
from ..lattice import lattice_params
from .kinematics import COMPOSITIONS, compose, tip_node

__all__ = ["Leg", "LegResult", "Section", "load_leg", "simulate_leg"]

_LEG_KEYS = {"name", "composition", "t_end", "n_samples", "method", "atol"}
_SECTION_KEYS = {"name", "phase", "mount_deg", "design"}
_PHASE_KEYS = {"P0", "tau", "pulses", "profile"}


@dataclass(frozen=True)
class Section:
    """One zone of a leg: a finger and the phase that drives it.

    Attributes
    ----------
    name : str
    design : Design
    phase : str
        Key of its pressure profile in :attr:`Leg.phases`.
    mount_deg : float, degrees
        Turn about its own length axis relative to the previous section (``"chain"`` only).
    """

    name: str
    design: Design
    phase: str
    mount_deg: float = 0.0


@dataclass(frozen=True)
class Leg:
    """A chain of sections, their phases and how they compose (module docstring).

    Attributes
    ----------
    sections : tuple of Section
        Base first.
    phases : mapping of str to PressureProfile
    t_end : float, s
    n_samples : int
    composition : str
        ``"dpw"`` or ``"chain"`` (:mod:`dpfexplore.solvers.legs.kinematics`).
    method : str
        Integrator of every section (:data:`dpfexplore.solvers.dynamics.simulate.METHODS`).
    atol : float or None, mm
    name : str
    """

    sections: tuple[Section, ...]
    phases: Mapping[str, PressureProfile]
    t_end: float
    n_samples: int = 501
    composition: str = "dpw"
    method: str = DEFAULT_METHOD
    atol: float | None = None
    name: str = field(default="", compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "sections", tuple(self.sections))
        object.__setattr__(self, "phases", dict(self.phases))
        if not self.sections:
            raise ValueError("section: a leg needs at least one section")
        if self.composition not in COMPOSITIONS:
            raise ValueError(f"composition = {self.composition!r}: choose one of {COMPOSITIONS}")
        if self.composition == "dpw" and len(self.sections) != 3:
            raise ValueError(
                f"composition = 'dpw': needs exactly 3 sections (MODEL.md §10), got "
                f"{len(self.sections)}"
            )
        t_end = self.t_end
        if (
            isinstance(t_end, bool)
            or not isinstance(t_end, (int, float))
            or not math.isfinite(t_end)
            or t_end <= 0
        ):
            raise ValueError(f"t_end = {t_end!r}: must be a time > 0 s")
        if (
            isinstance(self.n_samples, bool)
            or not isinstance(self.n_samples, int)
            or self.n_samples < 2
        ):
            raise ValueError(f"n_samples = {self.n_samples!r}: must be an integer >= 2")
        info = method_info(self.method)
        if info.model == "release" or info.integrator < 0:
            raise ValueError(
                f"method = {self.method!r}: a leg needs a Numba integrator that "
                "gives trajectories (rodas4, rodas4-overdamped, dopri5, ...)"
            )
        seen = set()
        for i, section in enumerate(self.sections):
            where = f"section[{i + 1}]"
            if not isinstance(section, Section):
                raise ValueError(f"{where}: must be a Section")
            if section.name in seen:
                raise ValueError(f"{where}.name = {section.name!r}: used twice")
            seen.add(section.name)
            if section.phase not in self.phases:
                raise ValueError(
                    f"{where}.phase = {section.phase!r}: no such phase; phases: "
                    f"{', '.join(sorted(self.phases)) or 'none'}"
                )
            profile = self.phases[section.phase]
            if profile.t_release > t_end:
                raise ValueError(
                    f"t_end = {t_end}: phase {section.phase!r} ends at {profile.t_release} s, "
                    "after it (reset times are measured from a phase's end)"
                )
            if section.mount_deg != 0.0 and self.composition != "chain":
                raise ValueError(
                    f"{where}.mount_deg = {section.mount_deg!r}: only for composition = 'chain'"
                )

    @classmethod
    def from_dict(cls, document: Mapping[str, Any], *, base: str | Path | None = None) -> Leg:
        """Build a leg from a parsed leg file (module docstring); ``ValueError`` names the key.

        A ``constants = "FILE"`` design key (in ``[defaults]`` or a section's design) is
        relative to ``base``, the leg file's folder.
        """
        known_keys(document, "top level", {"leg", "defaults", "phase", "section"})
        head = dict(document.get("leg", {}))
        known_keys(head, "[leg]", _LEG_KEYS)
        if "t_end" not in head:
            raise ValueError("leg.t_end: missing (s)")
        defaults = dict(document.get("defaults", {}))
        phases = {}
        for key, table in dict(document.get("phase", {})).items():
            phases[str(key)] = _phase(f"phase.{key}", table)
        tables = document.get("section", [])
        if not isinstance(tables, list) or not tables:
            raise ValueError("section: give the sections as [[section]] tables, base first")
        sections = []
        for i, table in enumerate(tables):
            where = f"section[{i + 1}]"
            if not isinstance(table, Mapping):
                raise ValueError(f"{where}: must be a table")
            known_keys(table, where, _SECTION_KEYS)
            for key in ("phase", "design"):
                if key not in table:
                    raise ValueError(f"{where}.{key}: missing")
            name = str(table.get("name", f"section-{i + 1}"))
            design_table = {**defaults, **dict(table["design"]), "name": name}
            try:
                design = Design.from_dict(design_table, base=base)
            except ValueError as exc:
                raise ValueError(f"{where}.design: {exc}") from None
            mount = table.get("mount_deg", 0.0)
            if (
                isinstance(mount, bool)
                or not isinstance(mount, (int, float))
                or not math.isfinite(mount)
            ):
                raise ValueError(f"{where}.mount_deg = {mount!r}: must be a number of degrees")
            sections.append(Section(name, design, str(table["phase"]), float(mount)))
        return cls(
            sections=tuple(sections),
            phases=phases,
            t_end=head["t_end"],
            n_samples=head.get("n_samples", 501),
            composition=head.get("composition", "dpw"),
            method=head.get("method", DEFAULT_METHOD),
            atol=head.get("atol"),
            name=str(head.get("name", "")),
        )

    def section(self, name: str) -> Section:
        """The section called ``name``."""
        for s in self.sections:
            if s.name == name:
                return s
        raise ValueError(
            f"section {name!r}: no such section; sections: "
            f"{', '.join(s.name for s in self.sections)}"
        )

    def with_design(self, name: str, **changes: Any) -> Leg:
        """Copy with design keys of section ``name`` changed (e.g. ``H=[2.5, 2.5]``)."""
        target = self.section(name)
        design = target.design.replace(**changes)
        sections = tuple(replace(s, design=design) if s.name == name else s for s in self.sections)
        return replace(self, sections=sections)

    def with_constants(self, constants: ConstantsSet) -> Leg:
        """Copy with every section's design under the constants set ``constants``."""
        sections = tuple(
            replace(s, design=s.design.replace(constants=constants)) for s in self.sections
        )
        return replace(self, sections=sections)

    def times(self) -> NDArray[np.float64]:
        """Sample times of the tip path, ``(n_samples,)``, s."""
        return np.linspace(0.0, float(self.t_end), self.n_samples)


def _phase(where: str, table: Any) -> PressureProfile:
    known_keys(table, where, _PHASE_KEYS)
    kinds = [k for k in ("tau", "pulses", "profile") if k in table]
    if len(kinds) != 1:
        raise ValueError(f"{where}: give exactly one of tau (with P0), pulses or profile")
    try:
        if kinds == ["tau"]:
            if "P0" not in table:
                raise ValueError(f"{where}.P0: missing (MPa)")
            tau = table["tau"]
            if not isinstance(tau, list) or len(tau) != 4:
                raise ValueError(f"{where}.tau = {tau!r}: need [tau1, tau2, tau3, tau4] (s)")
            return PressureProfile.pulse(table["P0"], tau)
        if "P0" in table:
            raise ValueError(f"{where}.P0: only with tau")
        if kinds == ["pulses"]:
            return PressureProfile.pulses(table["pulses"])
        return PressureProfile.parse(str(table["profile"]))
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{where}: {exc}") from None


def load_leg(path: str | Path) -> Leg:
    """Read a leg file (module docstring); a ``ValueError`` naming the key, then the file."""
    path = Path(path)
    document = read_toml(path, "leg")  # its errors start with the path
    try:
        leg = Leg.from_dict(document, base=path.parent)
    except ValueError as exc:
        if str(path) in str(exc):
            raise
        raise ValueError(f"{exc} (in {path})") from None
    return leg if leg.name else replace(leg, name=path.stem)


@dataclass(frozen=True)
class SectionRun:
    """One section of a simulated leg.

    Attributes
    ----------
    section : Section
    result : SimulationResult
        Its simulation on the leg's sample times (``result.t``).
    t_start : float, s
        Where its integration started (``t_end``: never integrated, its pressure stays 0).
    nodes : ndarray of shape (m, 2N + 2, 2), mm
        Its nodes in its own §5 frame at each sample.
    fitted_range : bool
    fitted_range_note : str or None
    """

    section: Section
    result: SimulationResult
    t_start: float
    nodes: NDArray[np.float64]
    fitted_range: bool
    fitted_range_note: str | None

    @property
    def integrated(self) -> bool:
        """Whether the section was integrated at all."""
        return self.result.stats.get("steps", 0) > 0

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary: the section's :meth:`SimulationResult.to_dict` plus leg keys."""
        out = {
            "name": self.section.name,
            "phase": self.section.phase,
            "n_units": self.section.design.n_units,
        }
        out.update(self.result.to_dict())
        out.update(
            {
                "integrated_from": self.t_start if self.integrated else None,
                "fitted_range": self.fitted_range,
                "fitted_range_note": self.fitted_range_note,
            }
        )
        return out


@dataclass(frozen=True)
class LegResult:
    """A simulated leg.

    Attributes
    ----------
    leg : Leg
    t : ndarray of shape (m,), s
    tip : ndarray of shape (m, 3), mm
        The leg's tip (last section's ``L_N``) in the leg frame.
    placed : list of ndarray of shape (m, 2N_i + 2, 3), mm
        Every section's nodes in the leg frame.
    sections : tuple of SectionRun
    fitted_range : bool
        Every section inside the fitted range of the closed forms.
    fitted_range_note : str or None
        The sections outside it and why.
    """

    leg: Leg
    t: NDArray[np.float64]
    tip: NDArray[np.float64]
    placed: list[NDArray[np.float64]]
    sections: tuple[SectionRun, ...]
    fitted_range: bool
    fitted_range_note: str | None

    @property
    def tip_path(self) -> NDArray[np.float64]:
        """Tip relative to its start, ``(m, 3)``, mm (MODEL.md §10's output)."""
        return self.tip - self.tip[0]

    @property
    def extent(self) -> NDArray[np.float64]:
        """Range of the tip path along x, y and z (max - min), ``(3,)``, mm.

        NaN samples (past the stop of a section that failed) are left out.
        """
        finite = self.tip[np.all(np.isfinite(self.tip), axis=1)]
        if finite.shape[0] == 0:
            return np.full(3, np.nan)
        return np.ptp(finite, axis=0)

    @property
    def stride(self) -> float:
        """Largest distance between two points of the tip path (its diameter), mm."""
        tip = self.tip[np.all(np.isfinite(self.tip), axis=1)]
        if tip.shape[0] < 2:
            return 0.0
        gaps = tip[:, None, :] - tip[None, :, :]
        return float(np.sqrt(np.max(np.einsum("ijk,ijk->ij", gaps, gaps))))

    @property
    def status(self) -> st.Status:
        """The first section status that is not OK, else OK."""
        for run in self.sections:
            if run.result.status != st.OK:
                return run.result.status
        return st.Status.OK

    def to_dict(self, *, digits: int = 6) -> dict[str, Any]:
        """JSON-ready summary: ``tip_path``, sections, ``fitted_range``, extent and stride.

        ``tip_path`` rows are ``[t, x, y, z]`` (s, mm relative to the start; None past the stop
        of a section that failed).
        """
        rows = [
            [None if not np.isfinite(v) else v for v in row]
            for row in np.round(np.column_stack([self.t, self.tip_path]), digits).tolist()
        ]
        return {
            "leg": self.leg.name,
            "composition": self.leg.composition,
            "status": self.status.label,
            "tip_path": rows,
            "tip_start": np.round(self.tip[0], digits).tolist(),
            "extent": np.round(self.extent, digits).tolist(),
            "stride": round(self.stride, digits),
            "sections": [run.to_dict() for run in self.sections],
            "fitted_range": self.fitted_range,
            "fitted_range_note": self.fitted_range_note,
            "evaluations": {
                "sections_integrated": sum(run.integrated for run in self.sections),
                "sections_at_rest": sum(not run.integrated for run in self.sections),
                "steps": sum(run.result.stats.get("steps", 0) for run in self.sections),
            },
        }


def section_nodes(result: SimulationResult) -> NDArray[np.float64]:
    """Node positions ``(m, 2N + 2, 2)`` (mm, §5 frame) of a simulation's samples."""
    params = lattice_params(result.design)
    n_units = params.n_units
    out = np.full((result.x.shape[0], 2 * n_units + 2, 2), np.nan)
    for j in range(result.x.shape[0]):
        if np.isfinite(result.x[j, 0]):
            unpack_nodes(result.x[j], params.unit_params, params.h, out[j])
    return out


def simulate_section(
    section: Section,
    profile: PressureProfile,
    *,
    t_end: float,
    n_samples: int,
    method: str = DEFAULT_METHOD,
    atol: float | None = None,
) -> tuple[SimulationResult, float]:
    """Simulate one section from rest, integrating only from its phase's start (module doc).

    Returns the result (samples on ``linspace(0, t_end, n_samples)``) and the start time.
    """
    t_start = min(max(profile.zero_until(), 0.0), float(t_end))
    result = simulate(
        section.design,
        profile,
        t_end=t_end,
        t_start=t_start,
        method=method,
        n_samples=n_samples,
        atol=atol,
    )
    return result, t_start


def simulate_leg(leg: Leg, *, method: str | None = None, atol: float | None = None) -> LegResult:
    """Simulate every section under its phase and compose the leg's tip path.

    Parameters
    ----------
    leg : Leg
    method, atol : optional
        Override the leg's integrator and tolerance (mm).

    Returns
    -------
    LegResult
    """
    method = leg.method if method is None else method
    atol = leg.atol if atol is None else atol
    runs = []
    for section in leg.sections:
        result, t_start = simulate_section(
            section,
            leg.phases[section.phase],
            t_end=leg.t_end,
            n_samples=leg.n_samples,
            method=method,
            atol=atol,
        )
        design = section.design
        runs.append(
            SectionRun(
                section,
                result,
                t_start,
                section_nodes(result),
                design.in_fitted_range,
                design.fitted_range_note,
            )
        )
    placed = compose(
        leg.composition, [run.nodes for run in runs], [s.mount_deg for s in leg.sections]
    )
    last = leg.sections[-1].design.n_units
    notes = [f"{run.section.name}: {run.fitted_range_note}" for run in runs if not run.fitted_range]
    return LegResult(
        leg=leg,
        t=leg.times(),
        tip=placed[-1][:, tip_node(last)].copy(),
        placed=placed,
        sections=tuple(runs),
        fitted_range=not notes,
        fitted_range_note="; ".join(notes) or None,
    )


def parse_assignment(text: str) -> tuple[str, str, Any]:
    """``"SECTION.KEY=VALUE"`` -> ``(section, key, value)``; VALUE a number or ``a,b,...``.

    Used by ``dpfexplore simulate-leg --set purple.H=2.5``; ``ValueError`` if malformed.
    """
    target, sep, value_text = text.partition("=")
    section, dot, key = target.strip().rpartition(".")
    if not sep or not dot or not section or not key:
        raise ValueError(f"--set {text!r}: write SECTION.KEY=VALUE, e.g. purple.H=2.5")
    try:
        values = [float(v) for v in value_text.split(",")]
    except ValueError:
        raise ValueError(
            f"--set {text!r}: VALUE must be a number or comma-separated numbers"
        ) from None
    return section, key.strip(), values[0] if len(values) == 1 else values


def apply_assignments(leg: Leg, assignments: Sequence[str]) -> Leg:
    """``leg`` with each ``SECTION.KEY=VALUE`` applied to that section's design."""
    for text in assignments:
        section, key, value = parse_assignment(text)
        if key not in {"H", "U_L", "U_sep", "t", "t_lim", "E", "nu", "r_b", "t_ch"}:
            raise ValueError(f"--set {text!r}: {key} is not a design key")
        if key == "H" and not isinstance(value, list):
            value = [value] * leg.section(section).design.n_units
        try:
            leg = leg.with_design(section, **{key: value})
        except ValueError as exc:  # the design's message names the key, not where it came from
            raise ValueError(f"--set {text!r}: section {section!r}: {exc}") from None
    return leg
