"""Synthetic unit-cell curves drawn from a constants set: data with a known answer.

Each curve follows the spring law of MODEL.md §4 with the set's ``k_b`` and ``alpha`` at its
``(H, t, r_b, E)``; the law's reach for a unit cell is taken as ``tip_dis − H`` (the apex travel
past the flat position, where the inverted dome rests against the next unit). Gaussian noise of
``noise`` times each curve's RMS energy (and RMS force) is added, and ``tip_dis`` is given per
curve, as a two-unit contact run would.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd

from ..model.constants_set import DEFAULT, ConstantsSet
from .spring_fit import spring_energy, spring_force

__all__ = ["synthetic_curves"]


def synthetic_curves(
    H: Sequence[float],
    t: Sequence[float],
    r_b: Sequence[float],
    E: Sequence[float],
    *,
    constants: ConstantsSet = DEFAULT,
    nu: float = 0.35,
    noise: float = 0.01,
    points: int = 200,
    cover: float = 1.3,
    seed: int = 0,
) -> pd.DataFrame:
    """A table of curves (:mod:`.curves` format) on the grid ``H × t × r_b × E``.

    Parameters
    ----------
    H, t, r_b : sequence of float, mm
    E : sequence of float, MPa
    noise : float
        Standard deviation of the added noise, relative to each curve's RMS energy and force.
    points : int
        Points per curve, evenly spaced from 0 to ``cover`` times the law's reach.
    """
    rng = np.random.default_rng(seed)
    frames = []
    for h in H:
        for thickness in t:
            for radius in r_b:
                for modulus in E:
                    values = constants.evaluate(h, thickness, radius, modulus)
                    k_b, alpha = float(values["k_b"]), float(values["alpha"])
                    tip = float(values["tip_dis"])
                    d = tip - h
                    x = np.linspace(0.0, cover * d, points)
                    energy = spring_energy(x, k_b, alpha, d)
                    force = spring_force(x, k_b, alpha, d)
                    energy = energy + noise * np.sqrt(np.mean(energy**2)) * rng.standard_normal(
                        points
                    )
                    force = force + noise * np.sqrt(np.mean(force**2)) * rng.standard_normal(points)
                    frames.append(
                        pd.DataFrame(
                            {
                                "curve": f"H{h:g}-t{thickness:g}-rb{radius:g}-E{modulus:g}",
                                "H": h,
                                "t": thickness,
                                "r_b": radius,
                                "E": modulus,
                                "nu": nu,
                                "displacement": x,
                                "energy": energy,
                                "force": force,
                                "tip_dis": tip,
                            }
                        )
                    )
    return pd.concat(frames, ignore_index=True)
