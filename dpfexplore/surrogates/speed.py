"""Time per prediction on one core, and the exact model as a predictor of sweep rows.

The speed table of :func:`~.fit.fit_surrogates` and ``dpfexplore bench surrogate``: every
predictor (a surrogate, a classifier, the exact model) is called through the public API (a
DataFrame of rows in, arrays out) with Numba and BLAS/OpenMP limited to one thread; batched
(all rows in one call, time per row) and single (one row per call), medians of repeats.
"""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from ..model.constants_set import DEFAULT, ConstantsSet
from ..solvers.statics import solve_batch
from .data import designs_from_rows

__all__ = ["TIMED_BATCH", "TIMED_SINGLE", "exact_predict", "one_thread", "time_per_row"]

#: Largest number of held-out rows timed in one batched call, and rows timed one at a time.
TIMED_BATCH = 5000
TIMED_SINGLE = 60


@contextmanager
def one_thread() -> Iterator[None]:
    """Limit Numba and BLAS/OpenMP (scikit-learn) to one thread inside the block."""
    import numba
    from threadpoolctl import threadpool_limits

    previous = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        with threadpool_limits(limits=1):
            yield
    finally:
        numba.set_num_threads(previous)


def _median_seconds(func: Callable[[], object], repeats: int) -> float:
    samples = []
    for _ in range(repeats):
        start = time.perf_counter()
        func()
        samples.append(time.perf_counter() - start)
    return statistics.median(samples)


def time_per_row(
    predict: Callable[[pd.DataFrame], object],
    frame: pd.DataFrame,
    *,
    repeats: int = 3,
    single_rows: int = TIMED_SINGLE,
) -> tuple[float, float]:
    """Microseconds per row of ``predict``: batched (one call on ``frame``) and single.

    Returns
    -------
    batched_us, single_us : float
        Median over ``repeats`` calls on the whole frame, divided by its rows; median over
        ``single_rows`` rows of one call each (after one warm-up call).
    """
    predict(frame.iloc[:1])
    batched = _median_seconds(lambda: predict(frame), repeats) / len(frame) * 1e6
    rows = [frame.iloc[[i]] for i in range(min(single_rows, len(frame)))]
    single = []
    for row in rows:
        start = time.perf_counter()
        predict(row)
        single.append(time.perf_counter() - start)
    return batched, statistics.median(single) * 1e6


def exact_predict(
    outputs: Sequence[str], constants: ConstantsSet = DEFAULT
) -> Callable[[pd.DataFrame], dict[str, NDArray]]:
    """The exact model as a predictor of sweep rows (their requested states) under ``constants``."""
    stiffness, min_eig = "stiffness" in outputs, "min_eig" in outputs

    def predict(rows: pd.DataFrame) -> dict[str, NDArray]:
        return solve_batch(
            designs_from_rows(rows, constants),
            rows["requested"].to_numpy(dtype=np.int64),
            stiffness=stiffness,
            min_eig=min_eig,
        )

    return predict
