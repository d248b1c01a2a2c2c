"""``python -m dpfexplore``: the same as the ``dpfexplore`` console script."""

from dpfexplore.cli import run

run()
