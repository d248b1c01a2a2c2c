"""Plots: ``plot_*(..., ax=None) -> Axes``; no file I/O and no ``plt.show()`` here.

Modules: :mod:`.statics` (finger shapes), :mod:`.dynamics` (time histories, reset-time maps),
:mod:`.space` (design-space maps of sweep results), :mod:`.leg` (tip paths of legs), :mod:`.snap`
(extensions and tip against pressure on a slow ramp), :mod:`.lookup` (the tip region a dataset
reaches, with a lookup's target and designs), :mod:`.compare` (two constants sets on whole fingers:
tips, tip stiffness and reset times, ``identify compare --plot``).
"""
