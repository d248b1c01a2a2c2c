"""Benchmarks: our kernels and a baseline, side by side in one process.

Each module registers a ``dpfexplore bench NAME`` subcommand. Times are medians over repeats
(these machines are shared and noisy); every speed figure comes with its error against a trusted
reference, and compile time is reported apart from run time.
"""
