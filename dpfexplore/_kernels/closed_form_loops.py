"""Closed forms over many domes, two ways: the paper's compiled forms and a constants set.

Used by ``dpfexplore bench identify`` to put the cost of evaluating a set's constants (the
general path every kernel table takes, :func:`dpfexplore.model.closed_form.set_constants_form`)
side by side with the paper's forms compiled as plain arithmetic
(:mod:`dpfexplore.model.constants`), on the same domes, and to measure how far apart their
numbers are.
"""

from __future__ import annotations

from ..model.closed_form import power_tables, set_constants_form
from ..model.constants import alpha_form, kb_form, radius_form, reach_raw_form
from ._jit import kernel


@kernel
def paper_forms(H, t, r_b, E, U_sep, t_ch, out):
    """``k_b``, ``alpha`` and the raw reach of each dome by the paper's compiled forms.

    ``H``, ``t`` ... ``t_ch``: arrays of shape (n,) (mm, MPa); ``out``: shape (n, 3), filled.
    """
    for i in range(H.shape[0]):
        R = radius_form(H[i], r_b[i])
        out[i, 0] = kb_form(E[i], H[i], t[i], R)
        out[i, 1] = alpha_form(H[i], t[i], R)
        out[i, 2] = reach_raw_form(H[i], t[i], U_sep[i], t_ch[i])


@kernel
def set_forms(forms, H, t, r_b, E, U_sep, t_ch, out):
    """The same three numbers under a constants set (``forms``: its ``kernel_forms()``)."""
    powers = power_tables()
    for i in range(H.shape[0]):
        k_b, alpha, tip = set_constants_form(forms, E[i], H[i], t[i], r_b[i], powers)
        out[i, 0] = k_b
        out[i, 1] = alpha
        out[i, 2] = tip - H[i] - U_sep[i] - t_ch[i] / 2.0 - t[i] / 2.0
