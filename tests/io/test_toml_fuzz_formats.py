"""Mutated job, leg and measurement files: refused in one line naming the file, or read.

The same mutations as ``test_toml_fuzz.py`` (a span deleted, replaced or duplicated, hostile
text inserted, the file cut short) applied to a small valid file of each of the other TOML
formats a user writes by hand, read through the format's loader. The loader must refuse in one
``ValueError`` line naming the file, or read it; a mutation that leaves the document as it was
(a comment, blank space) must give the unmutated answer. Nothing else may escape.
"""

from __future__ import annotations

from hypothesis import example, given, settings
from test_toml_fuzz import mutated, refused_or_read

from dpfexplore.measurements.fingers import read_measurements
from dpfexplore.solvers.legs.leg import load_leg
from dpfexplore.sweep.job_file import load_job

JOB = """[job]
name = "fuzz"
seed = 0
samples_per_n = 40
sampler = "lhs"
chunk_size = 16

[space]
n_units = [2, 3]
material = "cheetah-95a"

[space.variables]
H = {min = 3.0, max = 5.0}
U_sep = {min = 1.0, max = 5.0}
U_L = {min = 5.5, max = 10.0}
t = {min = 0.5, max = 1.0}
t_lim = {min = 1.0, max = 2.0}

[space.constraints]
heights = "free"

[compute]
states = "sequential"
stiffness = true
"""

LEG = """[leg]
composition = "dpw"
t_end = 5.0
n_samples = 51

[defaults]
U_L = 6.5
U_sep = 1.0
t = 1.0
t_lim = 1.0
E = 26.0

[phase.1]
P0 = 0.4
tau = [0.0, 0.1, 1.1, 1.2]

[phase.2]
P0 = 0.4
tau = [1.1, 1.2, 2.2, 2.3]

[[section]]
name = "purple"
phase = "1"
design = { H = [1.1, 1.1] }

[[section]]
name = "green"
phase = "2"
design = { H = [2.0] }

[[section]]
name = "action"
phase = "2"
design = { H = [1.6, 4.5, 4.5, 4.5] }
"""

MEASUREMENTS = """format = "dpfexplore-measurements/1"
title = "fuzz"
source = "a test"

[[finger]]
name = "one"
material = "ninjaflex-85a"
H = [4.5, 4.7, 4.8, 5.0]
U_sep = 2.0
U_L = 9.9
t = 0.6
t_lim = 1.5
state = "1111"
tip = [42.9, 37.7]

[finger.provenance]
design = "a table"
material = "a sentence"
state = "a sentence"
tip = "a table"
"""


@settings(max_examples=60)
@given(text=mutated(JOB))
@example(text=JOB.replace("samples_per_n = 40", "samples_per_n = " + "9" * 400))
@example(text=JOB + "# a comment\n")
def test_a_mutated_job_file_is_refused_in_one_line_or_read(tmp_path_factory, text):
    refused_or_read(tmp_path_factory, text, JOB, "job.toml", load_job)


@settings(max_examples=60)
@given(text=mutated(LEG))
@example(text=LEG.replace("P0 = 0.4", "P0 = 1e400"))
@example(text=LEG + "\n# a comment\n")
def test_a_mutated_leg_file_is_refused_in_one_line_or_read(tmp_path_factory, text):
    refused_or_read(tmp_path_factory, text, LEG, "leg.toml", load_leg)


@settings(max_examples=60)
@given(text=mutated(MEASUREMENTS))
@example(text=MEASUREMENTS.replace("tip = [42.9, 37.7]", "tip = [nan, 37.7]"))
@example(text=MEASUREMENTS + "\n# a comment\n")
def test_a_mutated_measurement_file_is_refused_in_one_line_or_read(tmp_path_factory, text):
    # the file's SHA-256 covers its bytes (a comment included): the fingers must be the same
    refused_or_read(
        tmp_path_factory,
        text,
        MEASUREMENTS,
        "fingers.toml",
        read_measurements,
        key=lambda read: (read.fingers, read.title, read.source),
    )
