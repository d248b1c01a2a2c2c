"""Stable states of the gripper finger.

The shipped gripper example (``dpfexplore.examples.example_path("gripper")``), solved in its
sequential states (units inverted base first) with :func:`dpfexplore.enumerate_states`; every
state that exists is drawn with :func:`dpfexplore.plotting.statics.plot_states`.
"""

import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

from dpfexplore import enumerate_states, load_design
from dpfexplore.examples import example_path
from dpfexplore.plotting.statics import plot_states

finger = load_design(example_path("gripper"))
states = [result for result in enumerate_states(finger, "sequential") if result.found]
fig, ax = plt.subplots(figsize=(6, 5), layout="constrained")
plot_states(states, ax=ax)
ax.set_title(f"gripper: {len(states)} sequential states")
fig.savefig(sys.argv[1], dpi=110)
