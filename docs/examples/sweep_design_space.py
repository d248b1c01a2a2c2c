"""Design space of a small sweep.

A job of 60 Latin-hypercube designs per N (2-5 units, the paper's box, all units inverted, with
tip stiffness) is written to a temporary folder, run with :func:`dpfexplore.run_sweep`, read back
with :func:`dpfexplore.read_results` and drawn with
:func:`dpfexplore.plotting.space.plot_design_space`: the tips per N, the curvature and the
stiffness of the states that exist.
"""

import sys
import tempfile
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

from dpfexplore import load_job, read_results, run_sweep
from dpfexplore.plotting.space import plot_design_space

JOB = """
[job]
name = "gallery"
seed = 1
samples_per_n = 60

[space]
n_units = [2, 3, 4, 5]
material = "cheetah-95a"

[space.variables]
H = {min = 3.0, max = 5.0}
U_sep = {min = 1.0, max = 5.0}
U_L = {min = 5.5, max = 10.0}
t = {min = 0.5, max = 1.0}
t_lim = {min = 1.0, max = 2.0}

[compute]
states = "all_inverted"
stiffness = true
"""

with tempfile.TemporaryDirectory() as tmp:
    job = Path(tmp) / "gallery.toml"
    job.write_text(JOB)
    run_sweep(load_job(job), Path(tmp) / "gallery")
    frame = read_results(Path(tmp) / "gallery")

axes = plot_design_space(frame)
axes[0].figure.savefig(sys.argv[1], dpi=90)
plt.close("all")
