"""Printing materials: the presets a design or scene names instead of ``E`` and ``nu``.

Apart from :mod:`dpfexplore.model.design` (which loads Numba) so that help screens can list them
cheaply.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["MATERIALS", "Material", "material"]


@dataclass(frozen=True)
class Material:
    """A printing material.

    Attributes
    ----------
    name : str
        Trade name.
    E : float, MPa
        Young's modulus.
    nu : float
        Poisson ratio.
    """

    name: str
    E: float
    nu: float = 0.35


#: Material presets (MODEL.md §2): Cheetah 95A at the implementation's modulus, NinjaFlex 85A at
#: the manufacturer's.
MATERIALS: dict[str, Material] = {
    "cheetah-95a": Material("Cheetah 95A", 26.0),
    "ninjaflex-85a": Material("NinjaFlex 85A", 12.0),
}


def material(key: str) -> Material:
    """Look up a material preset by key (``"cheetah-95a"`` or ``"ninjaflex-85a"``)."""
    try:
        return MATERIALS[key.lower()]
    except KeyError:
        raise ValueError(
            f"material = {key!r}: unknown material; choose one of {', '.join(sorted(MATERIALS))}"
        ) from None
