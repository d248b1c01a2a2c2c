"""Plots: ``plot_*(..., ax=None) -> Axes``; no file I/O and no ``plt.show()`` here.

The package imports only :mod:`dpfexplore.model` and :mod:`dpfexplore.solvers`, so that every
stage above it draws its figures here: inverse design (:mod:`dpfexplore.plotting.design`:
targets met, objective against evaluations, fronts, regions; :mod:`dpfexplore.plotting.timing`:
the pick-and-place reset map and front, walker gait timing) and surrogates
(:mod:`dpfexplore.plotting.surrogates`: speed against error, beside the exact model).

Modules: :mod:`.statics` (finger shapes), :mod:`.dynamics` (time histories, reset-time maps),
:mod:`.space` (design-space maps of sweep results), :mod:`.leg` (tip paths of legs), :mod:`.snap`
(extensions and tip against pressure on a slow ramp), :mod:`.lookup` (the tip region a dataset
reaches, with a lookup's target and designs), :mod:`.compare` (two constants sets on whole fingers:
tips, tip stiffness and reset times, ``identify compare --plot``), :mod:`.validation` (printed
fingers under constants sets, the measured tips marked, ``validate --plot``).
"""
