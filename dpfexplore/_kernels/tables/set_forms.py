"""A constants set's closed forms evaluated in kernels, a block of domes at a time.

The kernels that build the lattice tables (:mod:`.design_tables`) read a constants set
(:mod:`dpfexplore.model.constants_set`) as a record of two arrays, its terms' powers and
coefficients (:meth:`~dpfexplore.model.constants_set.ConstantsSet.kernel_forms`), flatten it once
per batch (:func:`set_terms`) and evaluate it a block of domes at a time
(:func:`set_constants_block`): power tables per dome, then each term across the block. The
NumPy evaluation of a :class:`~dpfexplore.model.closed_form.ClosedForm` forms the same products
in the same order (powers by repeated multiplication; terms summed from zero in the form's
order), so the two agree bit for bit. Working across a block lets the compiler vectorise over
domes (``dpfexplore bench identify`` puts the cost beside the paper's forms compiled as plain
arithmetic).

These functions are :func:`~.._jit.jitable`: compiled inline into the kernels that call them.
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np

from ...model.closed_form import MAX_POWER, N_FORMS
from ...model.quantities import SCALE_HEIGHT, SCALE_STIFFNESS, SET_FORMS
from .._jit import jitable

#: How each form gives its quantity (``SCALE_*`` of :mod:`dpfexplore.model.quantities`), by
#: row ``FORM_*``.
FORM_SCALES = tuple(form.scale for form in SET_FORMS)

#: Row of the power ``π^0`` in a power table; a table holds the powers
#: ``-(MAX_POWER + 1) .. MAX_POWER + 1`` (the partials of a term in ``π^-MAX_POWER`` reach one
#: lower, and ``1 / π^k`` needs ``π^k``).
POWER_OFFSET = MAX_POWER + 1
POWER_TABLE_SIZE = 2 * MAX_POWER + 3
#: Rows of :attr:`DomeBlock.partials`: each form's quantity differentiated in ``H`` (row
#: ``2 FORM_*``) and in ``t`` (row ``2 FORM_* + 1``): ``∂k_b/∂H, ∂k_b/∂t, ∂α/∂H, ...`` (units of
#: the quantity per mm).
N_SET_PARTIALS = 2 * N_FORMS
#: Most domes a kernel evaluates together (at least ``MAX_UNITS``: one design's units share a
#: block). Larger blocks cost fewer passes of the gather, term and fill loops; on the benchmark
#: machine 384 built the tables about 15 % faster than 96, and 768 no faster than 384.
DOME_BLOCK = 384

#: A constants set's closed forms as one list of terms (:func:`set_terms`): per term its
#: ``coefficients`` and the rows ``index1``, ``index3`` (int64) of its powers of ``π1`` and
#: ``π3`` in a power table; ``ends`` (int64): where each form's terms end; ``range1``,
#: ``range3`` (int64, ``(2,)``): the lowest and highest powers of ``π1`` and ``π3`` in use.
FormTerms = namedtuple(
    "FormTerms", ["coefficients", "index1", "index3", "ends", "range1", "range3"]
)

#: A block of domes (:func:`dome_block`): their ``H``, ``t``, ``r_b`` (mm) and ``E`` (MPa), each
#: ``(DOME_BLOCK,)``, filled by the caller; the radii ``R`` (mm) and the power tables ``P1``,
#: ``P3`` ``(POWER_TABLE_SIZE, DOME_BLOCK)`` as scratch; and what :func:`set_constants_block`
#: writes: ``values`` ``(n_forms, DOME_BLOCK)`` (rows ``FORM_*`` end as the forms' quantities:
#: ``k_b`` (N/mm), ``alpha``, ``tip_dis`` (mm)) and ``partials`` ``(N_SET_PARTIALS, DOME_BLOCK)``.
DomeBlock = namedtuple("DomeBlock", ["H", "t", "r_b", "E", "R", "P1", "P3", "values", "partials"])


@jitable
def _used_terms(powers, coefficients, f):
    """Terms of form ``f`` up to its last one that is not padding (``0 · π1⁰ · π3⁰``)."""
    used = 0
    for j in range(coefficients.shape[1]):
        if coefficients[f, j] != 0.0 or powers[f, j, 0] != 0 or powers[f, j, 1] != 0:
            used = j + 1
    return used


@jitable
def set_terms(forms, partials):
    """The terms a kernel evaluates for a set: :meth:`ConstantsSet.kernel_forms` flattened.

    The closed forms, and with ``partials`` (bool) their derivatives in ``π1`` and ``π3``
    as closed forms of their own (``c p · π1^(p-1) π3^q`` per term with ``p != 0``, as
    :meth:`ClosedForm.partials` forms them). Trailing padding is dropped: a term ``0 · 1 · 1``
    adds ``+0`` to a sum that starts at ``+0``, which changes no sum. Built once per batch.
    """
    powers, coefficients = forms
    n_forms = 3 * N_FORMS if partials else N_FORMS
    used = np.zeros(N_FORMS, dtype=np.int64)
    size = 0
    for f in range(N_FORMS):
        used[f] = _used_terms(powers, coefficients, f)
        size += 3 * used[f]
    c = np.empty(size)
    index1 = np.empty(size, dtype=np.int64)
    index3 = np.empty(size, dtype=np.int64)
    ends = np.empty(n_forms, dtype=np.int64)
    range1 = np.zeros(2, dtype=np.int64)
    range3 = np.zeros(2, dtype=np.int64)
    s = 0
    for form in range(n_forms):
        f = form % N_FORMS
        along = form // N_FORMS  # 0: the form, 1: its derivative in π1, 2: in π3
        for j in range(used[f]):
            coefficient = coefficients[f, j]
            p = powers[f, j, 0]
            q = powers[f, j, 1]
            if along == 1:
                if p == 0:
                    continue
                coefficient = coefficient * p
                p = p - 1
            elif along == 2:
                if q == 0:
                    continue
                coefficient = coefficient * q
                q = q - 1
            c[s] = coefficient
            index1[s] = p + POWER_OFFSET
            index3[s] = q + POWER_OFFSET
            range1[0] = min(range1[0], p)
            range1[1] = max(range1[1], p)
            range3[0] = min(range3[0], q)
            range3[1] = max(range3[1], q)
            s += 1
        ends[form] = s
    return FormTerms(c[:s], index1[:s], index3[:s], ends, range1, range3)


@jitable
def dome_block(terms, size):
    """A :data:`DomeBlock` of ``size`` domes for ``terms`` (allocated once per batch).

    ``size``: at most :data:`DOME_BLOCK`; what a batch needs (:func:`block_size`), so a single
    design allocates a block of its own size.
    """
    return DomeBlock(
        np.empty(size),
        np.empty(size),
        np.empty(size),
        np.empty(size),
        np.empty(size),
        np.empty((POWER_TABLE_SIZE, size)),
        np.empty((POWER_TABLE_SIZE, size)),
        np.empty((terms.ends.shape[0], size)),
        np.empty((N_SET_PARTIALS, size)),
    )


@jitable
def block_size(n_domes, least):
    """The block for ``n_domes`` domes: ``n_domes`` up to :data:`DOME_BLOCK`, at least ``least``."""
    return min(DOME_BLOCK, max(n_domes, least))


@jitable
def _power_rows(P, power_range, n):
    """Fill rows ``π^lo .. π^hi`` of table ``P`` whose row ``π^1`` holds ``π`` (domes ``< n``).

    ``π^k`` by repeated multiplication and ``π^-k = 1 / π^k``, as :class:`_Powers` forms them:
    each entry is the number the NumPy path forms.
    """
    lo = power_range[0]
    hi = power_range[1]
    x = P[POWER_OFFSET + 1]
    ones = P[POWER_OFFSET]
    for d in range(n):
        ones[d] = 1.0
    previous = x
    for k in range(2, max(hi, -lo) + 1):
        row = P[POWER_OFFSET + k]
        for d in range(n):
            row[d] = previous[d] * x[d]
        previous = row
    for k in range(1, -lo + 1):
        row = P[POWER_OFFSET - k]
        positive = P[POWER_OFFSET + k]
        for d in range(n):
            row[d] = 1.0 / positive[d]


@jitable
def _evaluate_block(terms, block, n):
    """Every form of ``terms`` at the first ``n`` domes of ``block`` into ``block.values``.

    Term by term across the domes: the loops over domes do the same operations in the same
    order for every dome, so the compiler vectorises them without changing a result.
    """
    coefficients, index1, index3, ends, range1, range3 = terms
    H, t, r_b = block.H, block.t, block.r_b
    R, P1, P3, values = block.R, block.P1, block.P3, block.values
    pi1 = P1[POWER_OFFSET + 1]
    pi3 = P3[POWER_OFFSET + 1]
    for d in range(n):
        Hd = H[d]
        Rd = (Hd * Hd + r_b[d] * r_b[d]) / (2.0 * Hd)
        R[d] = Rd
        pi1[d] = t[d] / Hd
        pi3[d] = Hd / Rd
    _power_rows(P1, range1, n)
    _power_rows(P3, range3, n)
    start = 0
    for f in range(ends.shape[0]):
        total = values[f]
        for d in range(n):
            total[d] = 0.0
        j = start
        # Four terms per pass over the block: a quarter of the loads and stores of the running
        # sums; each dome still adds its terms one at a time in the form's order.
        while j + 4 <= ends[f]:
            c0, c1, c2, c3 = (
                coefficients[j],
                coefficients[j + 1],
                coefficients[j + 2],
                coefficients[j + 3],
            )
            a0, a1, a2, a3 = P1[index1[j]], P1[index1[j + 1]], P1[index1[j + 2]], P1[index1[j + 3]]
            b0, b1, b2, b3 = P3[index3[j]], P3[index3[j + 1]], P3[index3[j + 2]], P3[index3[j + 3]]
            for d in range(n):
                s = total[d] + c0 * a0[d] * b0[d]
                s = s + c1 * a1[d] * b1[d]
                s = s + c2 * a2[d] * b2[d]
                total[d] = s + c3 * a3[d] * b3[d]
            j += 4
        while j < ends[f]:
            c = coefficients[j]
            a = P1[index1[j]]
            b = P3[index3[j]]
            for d in range(n):
                total[d] = total[d] + c * a[d] * b[d]
            j += 1
        start = ends[f]


@jitable
def set_constants_block(terms, block, n):
    """The forms' quantities (and their partials) of the first ``n`` domes of a block.

    ``terms``: :func:`set_terms` of the set; ``block``: a :data:`DomeBlock` whose ``H``, ``t``,
    ``r_b``, ``E`` hold the domes. Writes ``block.values`` rows ``FORM_*`` as each form's
    quantity, scaled as its row of :data:`~dpfexplore.model.quantities.SET_FORMS` says:
    ``k_b = E t²/R · k̂`` (N/mm), ``alpha`` and ``tip_dis = H · tip/H`` (mm), the arithmetic of
    :meth:`ConstantsSet.evaluate` (:func:`~dpfexplore.model.quantities.scaled`), bit for bit.
    When ``terms`` holds the partials, also ``block.partials``: the chain rule through
    ``π1 = t/H``, ``π3 = H/R`` and ``R = (H² + r_b²)/(2H)`` (MODEL.md §2-§3), exact for any set.
    """
    _evaluate_block(terms, block, n)
    H, t, r_b, E, R, values = block.H, block.t, block.r_b, block.E, block.R, block.values
    if terms.ends.shape[0] > N_FORMS:
        dk = block.partials
        for d in range(n):
            Hd = H[d]
            td = t[d]
            Rd = R[d]
            dR_dH = 0.5 - r_b[d] * r_b[d] / (2.0 * Hd * Hd)
            dpi1_dH = -td / (Hd * Hd)
            dpi1_dt = 1.0 / Hd
            dpi3_dH = (Rd - Hd * dR_dH) / (Rd * Rd)
            for f in range(N_FORMS):
                v = values[f, d]
                v1 = values[N_FORMS + f, d]
                v3 = values[2 * N_FORMS + f, d]
                scale = FORM_SCALES[f]
                if scale == SCALE_STIFFNESS:
                    s = E[d] * (td * td) / Rd
                    dk[2 * f, d] = s * (v1 * dpi1_dH + v3 * dpi3_dH) - s * v * dR_dH / Rd
                    dk[2 * f + 1, d] = 2.0 * E[d] * td / Rd * v + s * v1 * dpi1_dt
                elif scale == SCALE_HEIGHT:
                    dk[2 * f, d] = v + Hd * (v1 * dpi1_dH + v3 * dpi3_dH)
                    dk[2 * f + 1, d] = Hd * v1 * dpi1_dt
                else:
                    dk[2 * f, d] = v1 * dpi1_dH + v3 * dpi3_dH
                    dk[2 * f + 1, d] = v1 * dpi1_dt
    for f in range(N_FORMS):
        scale = FORM_SCALES[f]
        row = values[f]
        if scale == SCALE_STIFFNESS:
            for d in range(n):
                row[d] = E[d] * (t[d] * t[d]) / R[d] * row[d]
        elif scale == SCALE_HEIGHT:
            for d in range(n):
                row[d] = H[d] * row[d]
