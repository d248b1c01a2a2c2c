"""Snap pressures of the gripper finger.

The gripper example's equilibrium followed by pseudo-arclength continuation as the chamber
pressure rises slowly to 0.7 MPa (:func:`dpfexplore.snap_pressures`); each unit's extension
against pressure, with the snaps marked (:func:`dpfexplore.plotting.snap.plot_snap`).
"""

import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

from dpfexplore import load_design, snap_pressures
from dpfexplore.examples import example_path
from dpfexplore.plotting.snap import plot_snap

finger = load_design(example_path("gripper"))
sequence = snap_pressures(finger, P_max=0.7)
fig, ax = plt.subplots(figsize=(7, 4.5), layout="constrained")
plot_snap(sequence, ax=ax)
fig.savefig(sys.argv[1], dpi=110)
