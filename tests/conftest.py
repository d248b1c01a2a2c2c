"""Shared fixtures: the reference designs and the reference data of the seed implementation."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from dpfexplore.model.design import Design

REFERENCE = Path(__file__).parent / "data" / "reference"

GRIPPER = dict(
    H=[3.8187, 4.1549, 4.5246, 4.8239, 2.5], U_L=8.5773, U_sep=1.8232, t=0.8326, t_lim=1.056, E=26.0
)
PICKPLACE = dict(H=[4.0, 4.5, 5.0, 5.0, 3.0, 3.0], U_L=6.0, U_sep=1.0, t=0.83, t_lim=1.0, E=26.0)


@pytest.fixture(scope="session")
def reference_dir() -> Path:
    return REFERENCE


@pytest.fixture(scope="session")
def gripper() -> Design:
    return Design(**GRIPPER)


@pytest.fixture(scope="session")
def pickplace() -> Design:
    return Design(**PICKPLACE)


def read_reference(name: str) -> pd.DataFrame:
    return pd.read_csv(REFERENCE / name)


def design_from_row(row) -> Design:
    """Design of a reference CSV row (columns H as space-separated string, U_L, U_sep, ...)."""
    return Design(
        H=[float(v) for v in str(row.H).split()],
        U_L=float(row.U_L),
        U_sep=float(row.U_sep),
        t=float(row.t),
        t_lim=float(row.t_lim),
        E=float(row.E),
    )


def free_coordinates(group: pd.DataFrame) -> np.ndarray:
    """Free coordinates (kernel order) of one reference sample (rows in D1, D2, L2, ... order)."""
    return np.ravel(np.column_stack([group.x.to_numpy(), group.y.to_numpy()]))
