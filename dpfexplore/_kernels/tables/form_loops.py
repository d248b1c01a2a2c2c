"""Closed forms over many domes, two ways: the paper's compiled forms and a constants set.

Used by ``dpfexplore bench identify`` to put the cost of evaluating a set's constants (the
general path every kernel table takes, :func:`.set_forms.set_constants_block`) side by side with
the paper's forms compiled as plain arithmetic (:mod:`dpfexplore.model.constants`, compiled by
:mod:`.model_forms`), on the same domes, and to measure how far apart their
numbers are: per dome (:func:`set_forms` against :func:`paper_forms`) and in the whole build of
a batch's kernel tables (:func:`.tables.design_tables.design_tables` against :func:`paper_tables`,
the same build with the compiled paper forms in place of the set).
"""

from __future__ import annotations

import numpy as np

from ...model.closed_form import FORM_ALPHA, FORM_K_HAT, FORM_TIP_RATIO, N_FORMS
from ...model.constants import TIP_PER_HEIGHT, TIP_PER_THICKNESS
from .._jit import kernel
from .design_tables import batch_block_size, fill_designs, gather_domes
from .model_forms import alpha_form, kb_form, radius_form, reach_raw_form
from .set_forms import DOME_BLOCK, dome_block, set_constants_block, set_terms


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
    terms = set_terms(forms, False)
    block = dome_block(terms, DOME_BLOCK)
    for first in range(0, H.shape[0], DOME_BLOCK):
        count = min(DOME_BLOCK, H.shape[0] - first)
        for d in range(count):
            block.H[d] = H[first + d]
            block.t[d] = t[first + d]
            block.r_b[d] = r_b[first + d]
            block.E[d] = E[first + d]
        set_constants_block(terms, block, count)
        for d in range(count):
            i = first + d
            out[i, 0] = block.values[FORM_K_HAT, d]
            out[i, 1] = block.values[FORM_ALPHA, d]
            tip = block.values[FORM_TIP_RATIO, d]
            out[i, 2] = tip - H[i] - U_sep[i] - t_ch[i] / 2.0 - t[i] / 2.0


@kernel
def paper_tables(designs, forms, out):
    """:func:`.design_tables.design_tables` with the paper's compiled forms in place of the set's.

    The same blocks, rows and status checks; ``k_b``, ``alpha`` and ``tip_dis`` of each dome
    from :func:`~dpfexplore.model.constants.kb_form` and :func:`alpha_form` (``forms`` only
    sizes the block). Without derivative tables. A form of the set's table that the paper does
    not have (:data:`~dpfexplore.model.quantities.SET_FORMS` beyond these three) is NaN here.
    """
    block = dome_block(set_terms(forms, False), batch_block_size(designs))
    first = np.int64(0)  # not the literal 0: one compiled signature of the block functions
    while first < designs.n_units.shape[0]:
        end, count = gather_domes(designs, first, block)
        for d in range(count):
            H = block.H[d]
            t = block.t[d]
            R = radius_form(H, block.r_b[d])
            block.values[FORM_K_HAT, d] = kb_form(block.E[d], H, t, R)
            block.values[FORM_ALPHA, d] = alpha_form(H, t, R)
            block.values[FORM_TIP_RATIO, d] = TIP_PER_THICKNESS * t + TIP_PER_HEIGHT * H
        for f in range(N_FORMS):
            if f != FORM_K_HAT and f != FORM_ALPHA and f != FORM_TIP_RATIO:
                block.values[f, :count] = np.nan
        fill_designs(designs, first, end, block, out)
        first = end
