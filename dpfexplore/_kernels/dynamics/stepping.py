"""The step driver every time integrator runs: caps, knots, early stops, rejections, step sizes.

An integrator is a method of taking one step (the stages of Rodas4, Dormand-Prince 5(4) or the
release's Rodas3) and a rule for the next step size; everything around the step is the same
for all of them, and is written once here. :func:`step_driver` builds an integrator's loop from
its parts, each a kernel taking the integrator's own workspace record ``work`` (a named tuple of
its arrays, model, controls and record):

``stop(work, t, capped)``
    An early stop before the next step: a status to return now, or -1 to go on. ``capped``
    says that the step cap is reached (the driver then returns ``STEP_LIMIT`` if ``stop``
    does not end the run first).
``attempt(work, t, step, retry)``
    Try one step of ``step`` s from ``t``: ``(ok, err)``, the error estimate scaled to the
    tolerance (``err <= 1`` passes) and ``ok`` False where the step failed (a singular
    matrix, a non-finite stage or error). ``retry``: the last attempt, from this same point,
    was rejected (a Rosenbrock method reuses its Jacobian).
``accept(work, t, step, err)``
    Record the accepted step (dense output, events) and move the state to its end.
``accepted_factor(err, step, h_acc, err_acc, last_rejected)``
    The next step over this accepted one; ``h_acc``, ``err_acc``: the previous accepted step
    and its error (``h_acc = 0``: none yet).
``rejected_factor(err)``
    The retry's step over this rejected one (``err > 1``).

The loop (:func:`step_driver`'s ``drive``): while ``t < t_end``, stop or cap; clip the step to
the next knot of the pressure profile (:func:`.events.clip_to_knot`: steps never cross a kink
of the load) and end with ``NOT_CONVERGED`` below ``CTRL_H_MIN``; attempt; a failed attempt is
rejected with the step divided by 4, an accepted one advances ``t`` (exactly onto the knot
when it lands there) and counts in ``STAT_STEPS``, a rejected one in ``STAT_REJECTED``.

Everything is compiled inline (``inline="always"``: Numba inlines the driver and the parts
into the integrator's own kernel), so an integrator runs the loop it would have written out,
with the same operations in the same order and no call between its parts.
"""

from __future__ import annotations

from ...model import status as st
from .._jit import kernel
from .events import (
    CTRL_H_MAX,
    CTRL_H_MIN,
    CTRL_MAX_STEPS,
    CTRL_STOP_WHEN_RESET,
    CTRL_TAU_END,
    STAT_REJECTED,
    STAT_STEPS,
    STAT_STOPPED_EARLY,
    clip_to_knot,
    settled_reset,
)

#: Step reduction after a failed attempt (singular matrix, non-finite stage or error).
FAILED_STEP_FACTOR = 0.25
#: ``stop``'s "go on".
GO_ON = -1


def step_driver(stop, attempt, accept, accepted_factor, rejected_factor):
    """The adaptive step loop of one integrator, from its parts (see the module docstring).

    Returns ``drive(work, t, t_end, step, ctrl, knot_t, stats)``, compiled inline into its
    caller: integrate from ``t`` to ``t_end`` (s) with the first step ``step`` (s), the solver
    controls ``ctrl`` (:mod:`.events`: largest and smallest step, step cap), the profile's knot
    times ``knot_t`` (s) and the counters ``stats`` (int64, :mod:`.events`); returns a status
    (``OK``, ``STEP_LIMIT``, ``NOT_CONVERGED`` or what ``stop`` returned).
    """

    @kernel(inline="always")
    def drive(work, t, t_end, step, ctrl, knot_t, stats):
        h_max = ctrl[CTRL_H_MAX]
        h_min = ctrl[CTRL_H_MIN]
        max_steps = int(ctrl[CTRL_MAX_STEPS])
        last_rejected = False
        h_acc = 0.0  # the last accepted step (s) and its error estimate; 0: none yet
        err_acc = 0.0
        while t < t_end:
            capped = stats[STAT_STEPS] + stats[STAT_REJECTED] >= max_steps
            status = stop(work, t, capped)
            if status != GO_ON:
                return status
            if capped:
                return st.STEP_LIMIT
            step, t_stop, lands = clip_to_knot(t, step, knot_t, t_end)
            if step < h_min:
                return st.NOT_CONVERGED
            ok, err = attempt(work, t, step, last_rejected)
            if not ok:
                stats[STAT_REJECTED] += 1
                step *= FAILED_STEP_FACTOR
                last_rejected = True
            elif err <= 1.0:
                accept(work, t, step, err)
                t = t_stop if lands else t + step
                stats[STAT_STEPS] += 1
                fac = accepted_factor(err, step, h_acc, err_acc, last_rejected)
                h_acc = step
                err_acc = err
                last_rejected = False
                step = min(step * fac, h_max)
            else:
                stats[STAT_REJECTED] += 1
                step *= rejected_factor(err)
                last_rejected = True
        return st.OK

    return drive


@kernel(inline="always")
def stop_when_reset(work, t, capped):
    """The integrators' early stop: past the profile, every inverted unit reset and settled.

    Only with ``CTRL_STOP_WHEN_RESET`` set and below the step cap; sets
    ``stats[STAT_STOPPED_EARLY]``. ``work`` needs the fields ``ctrl`` and ``record`` (a
    :class:`~.records.RunRecord`).
    """
    ctrl = work.ctrl
    record = work.record
    tau_end = ctrl[CTRL_TAU_END]
    if (
        not capped
        and ctrl[CTRL_STOP_WHEN_RESET] > 0.0
        and t >= tau_end
        and settled_reset(record.unit_rec, t, tau_end)
    ):
        record.stats[STAT_STOPPED_EARLY] = 1
        return st.OK
    return GO_ON
