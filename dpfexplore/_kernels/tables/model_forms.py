"""The model's closed forms and validation rules, compiled inline into the kernels.

:mod:`dpfexplore.model` writes each closed form of MODEL.md §3 (``R``, ``k_b``, ``α``, the reach,
``k_lim``, ``k_t``, the segment height, and their derivatives in the design parameters), the
physical domain and the validation rules of one design once, as plain Python arithmetic that its
NumPy code runs on arrays; it imports no Numba. Each of those modules lists the functions it
offers for compilation in ``COMPILED_INLINE``. This module registers them with Numba
(:func:`~.._jit.jitable`: the same function objects, compiled inline into every kernel that
calls them) and names the ones kernels call. Kernels import them from here, never from
:mod:`dpfexplore.model`: importing this module is what makes them compilable.

One source for both: NumPy on arrays and the kernels on scalars form the same products in the
same order, so the kernel tables and the NumPy constants agree bit for bit.
"""

from __future__ import annotations

from ...model import constants, domain, validation
from .._jit import jitable

for _function in (
    *constants.COMPILED_INLINE,
    *domain.COMPILED_INLINE,
    *validation.COMPILED_INLINE,
):
    jitable(_function)

radius_form = constants.radius_form
kb_form = constants.kb_form
alpha_form = constants.alpha_form
reach_raw_form = constants.reach_raw_form
k_lim_form = constants.k_lim_form
k_t_form = constants.k_t_form
segment_height_form = constants.segment_height_form
constant_derivatives_form = constants.constant_derivatives_form
geometry_status = validation.geometry_status
constants_status = validation.constants_status
