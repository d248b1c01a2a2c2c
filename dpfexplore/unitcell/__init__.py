"""Unit-cell mechanics: one dome unit's curve from its geometry and material.

The data source of identification (MODEL.md §11): a geometrically exact, shear-rigid
axisymmetric shell model of a pinned spherical cap, loaded by apex displacement control through
inversion, every fold followed by continuation.

Modules
-------
geometry
    Inputs checked once, the reference meridian and the kernels' discretised geometry; the
    unit cell's plate around the cap (``Plate``, ``cell_plate``).
shell
    :func:`unit_cell_curve` and its record :class:`UnitCellRun` (``to_frame()`` is the table
    ``identify fit`` reads); :func:`apex_stiffness` for small deflections.
path
    Branch ids, zero-force states and the work ``∫ F dδ`` of a traced path.
checks
    Closed forms the model is validated against: the pinned plate, Reissner's shallow shell,
    Pogorelov's ridge exponent.
plotting
    Force and energy against apex travel by branch, deformed meridians.
sweep, sweep_chunks
    Many geometries (a grid or a Latin hypercube) on the sweep engines (worker processes or a
    Dask cluster) into the identification table; resumable. Its chunks: what one computes, its
    files committed with their checksums, their manifest, the merge.
contact
    The two-unit run: the dome inverted against its neighbour's wall (rigid or giving way).
reach
    The dome's inverted apex travel under each model of its surroundings: the plates, the
    two-unit runs (:mod:`dpfexplore.identification.causes` sets them beside the paper's).
solid_check, solid_mesh, solid_materials, solid_report, solid_rest
    The independent cross-check: the dome as a 2-D axisymmetric solid with scikit-fem (the
    ``crosscheck`` extra), its mesh, material laws, the comparison at matching apex travel
    (``scripts/unitcell_solid_check.py`` writes the record) and its inverted rest.
"""

from .path import ZeroForceState
from .shell import DEFAULT_ELEMENTS, UnitCellRun, apex_stiffness, unit_cell_curve

__all__ = ["DEFAULT_ELEMENTS", "UnitCellRun", "ZeroForceState", "apex_stiffness", "unit_cell_curve"]
