"""Checks of a constants set: its file's fields, and its claims proven over its domain.

Modules
-------
fields
    The set file read within bounds as strict JSON; every field's type and magnitude checked
    before any is used.
claims
    What a set claims about its domain: magnitudes within a physical set's, a hull consistent
    with its ranges, and each closed form within its physical bounds over the whole domain;
    the hull of the data a set is fitted on (``data_hull``).
bounds
    Proven bounds of closed forms over a domain of ``(H/r_b, t/r_b)``: Bernstein enclosures,
    subdivided where inconclusive.

:class:`~dpfexplore.model.constants_set.ConstantsSet` and
:func:`~dpfexplore.model.constants_set.load_constants_set` run them; nothing here imports them.
"""
