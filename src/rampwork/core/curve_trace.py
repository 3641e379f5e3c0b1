"""Recorded trajectories of the curve kernel (``[record]``, docs/physics.md §5.2).

A trace replays one trajectory alone, in lane 0, through the scalar pass
(``curve_kernel._iterate``): the same steps, events and floating-point
operations as the batch, whose vector loop gives the scalar kernel's bits
(tests/test_curve_lanes.py).  It samples the state at the start, every
``every`` accepted steps and after every event step; its last sample is the
trajectory's outputs as ``curve_lanes._finish_lane`` writes them, so a trace
ends exactly where the batch says.

The functions are templates: ``start_lane``, ``iterate``, ``finish_lane``,
``curve_point``, ``sample`` (:func:`_sample`) and ``DRAG`` are bound per scene by
``curve_lanes.build_curve_kernel``, so a trace runs the batch's own kernel.
"""

from __future__ import annotations

import numpy as np

from . import status as st
from .curve_kernel import (BRANCH, COSNOW, DRAGW, G, I_M, INROW, KAPNOW, LANES, N_FIELDS, O_P,
                           O_T, O_U, O_W, O_WD, O_X, O_Y, OUTPUTS, P, S0, S1, S2, STATUS, STEPS,
                           T, U, WORK, field)
from .curve_steppers import normal_along_n

# bound per scene by curve_lanes.build_curve_kernel
start_lane = iterate = finish_lane = curve_point = sample = None
DRAG = False

#: rows of a trace, in order: time, position parameter, speed along the
#: curve, the point, friction work, the normal force on the block's side
#: and drag work (the last three in J and N: times the mass)
TRACE_ROWS = ("t", "s", "u", "X", "Y", "W_friction", "nu", "W_drag")
(R_T, R_P, R_U, R_X, R_Y, R_W, R_NU, R_WD) = range(len(TRACE_ROWS))
N_OUTPUTS = len(OUTPUTS)


def _sample(lanes, shared, side, m, trace, k):
    """Lane 0's state into column k of ``trace``."""
    p = field(lanes, P, 0)
    u = field(lanes, U, 0)
    x, y = curve_point(p, field(lanes, S0, 0), field(lanes, S1, 0), field(lanes, S2, 0),
                       field(lanes, BRANCH, 0), shared)
    trace[R_T, k] = field(lanes, T, 0)
    trace[R_P, k] = p
    trace[R_U, k] = u
    trace[R_X, k] = x
    trace[R_Y, k] = y
    trace[R_W, k] = m * field(lanes, WORK, 0)
    trace[R_NU, k] = m * (side * normal_along_n(u, field(lanes, COSNOW, 0),
                                                field(lanes, KAPNOW, 0), field(lanes, G, 0)))
    trace[R_WD, k] = m * field(lanes, DRAGW, 0) if DRAG else 0.0


def _trace_one(j, inputs, shared, h, t_max, side, rtol, atol, every, trace):
    """Run column j of ``inputs`` alone and record it into ``trace``
    (``TRACE_ROWS`` x max_samples); returns the number of samples.  Past
    ``max_samples - 1`` samples only the end is written (in the last one)."""
    lanes = np.zeros(N_FIELDS * LANES)
    out = np.zeros((N_OUTPUTS, inputs.shape[1]))
    status = np.zeros(inputs.shape[1], dtype=np.int8)
    m = inputs[I_M, j]
    max_samples = trace.shape[1]
    start_lane(lanes, 0, inputs, j, shared, h, side)
    sample(lanes, shared, side, m, trace, 0)
    count = 1
    while field(lanes, STATUS, 0) == st.NOT_RUN:
        before = field(lanes, STEPS, 0)
        iterate(lanes, 0, shared, t_max, side, rtol, atol)
        steps = field(lanes, STEPS, 0)
        if field(lanes, STATUS, 0) != st.NOT_RUN or not steps > before:
            continue  # the end (sampled below) or a rejected attempt
        event = field(lanes, INROW, 0) != 0.0
        if count < max_samples - 1 and (event or np.int64(steps) % every == 0):
            sample(lanes, shared, side, m, trace, count)
            count += 1
    # the end, from the outputs the batch writes (bit for bit)
    sample(lanes, shared, side, m, trace, count)
    finish_lane(lanes, 0, inputs, shared, out, status)
    trace[R_T, count] = out[O_T, j]
    trace[R_P, count] = out[O_P, j]
    trace[R_U, count] = out[O_U, j]
    trace[R_X, count] = out[O_X, j]
    trace[R_Y, count] = out[O_Y, j]
    trace[R_W, count] = out[O_W, j]
    trace[R_WD, count] = out[O_WD, j] if DRAG else 0.0
    return count + 1
