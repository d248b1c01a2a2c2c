"""Identification: from unit-cell mechanics to spring constants (the paper's RFE step).

Modules
-------
curves
    The input table of unit-cell curves (CSV or Parquet), read and checked; folded paths.
spring_fit
    The dome spring law fitted to one curve: linear start, robust refinement, flags.
features
    The spring law matched to a folded curve's features (initial slope, far state, barrier).
states
    The spring law by the unit's states: the inverted rest held, the initial slope and the
    barrier balanced (``identify``'s default).
closed_forms
    Closed forms in ``π1 = t/H``, ``π3 = H/R`` selected by grouped RFECV with ridge (and a lasso
    alternative scored on held-out geometries).
identify
    Curves to a :class:`~dpfexplore.model.constants_set.ConstantsSet`.
synthetic
    Curves drawn from a constants set, with noise: data with a known answer.
report
    Saving, reading and printing an identification; two sets side by side on units.
compare
    Two sets side by side on whole fingers: states, tips, stiffness, reset times.
compare_paper
    The shell's spring constants (``identify``'s fits) beside the paper's closed forms over its
    box, and a constants set from a ``unitcell sweep`` (how ``shell-extended`` was identified).
causes
    Each cause of the unit-cell route's miss measured over the paper's box: fit recipes, the
    reach (plates, two-unit runs), the edge.
"""
