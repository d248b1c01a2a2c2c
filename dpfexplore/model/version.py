"""Versions recorded with every stored result.

:data:`MODEL_VERSION` names the physics that produced a dataset: MODEL.md's lattice model as
implemented by the kernels and solvers of this package. Bump it with every deliberate change to
the model or to what its outputs mean (a constant, a boundary condition, a solver tolerance that
moves stored values, a new meaning of a status code). A sweep directory records it, and
``dpfexplore sweep --resume`` refuses to append rows of one model version to a dataset written by
another, because the two halves would silently disagree.

The package version (``importlib.metadata.version("dpfexplore")``) is recorded too, but only for
provenance: a release that leaves the model alone does not invalidate stored results.
"""

from __future__ import annotations

import importlib.metadata
import platform

#: Version of the physical model and of the meaning of its outputs (see the module docstring).
#: 2: designs outside the physical domain (:mod:`dpfexplore.model.domain`: a dome taller than
#: its base radius or its unit) are rejected with status ``outside_domain`` instead of solved,
#: every dataset has the ``fitted_range`` column, and units whose reach is clamped are classed
#: ``no_contact`` (code 3) with NaN snap and reset times.
MODEL_VERSION = "dpf-lattice-2"

#: Distributions whose versions are stored with a dataset (provenance only).
_RECORDED_DISTRIBUTIONS = (
    "dpfexplore",
    "numpy",
    "numba",
    "scipy",
    "pyarrow",
    "pandas",
    "dask",
    "distributed",
)


def package_versions() -> dict[str, str]:
    """Versions of Python, dpfexplore and the libraries that shape stored results."""
    versions = {"python": platform.python_version()}
    for name in _RECORDED_DISTRIBUTIONS:
        try:
            versions[name] = importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            versions[name] = "not installed"
    return versions
