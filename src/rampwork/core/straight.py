"""Closed-form motion on a straight ramp (f'' = 0 everywhere): no stepping.

With f'' = 0 the normal term n = g is constant and positive (no lift-off, no
contact switch), so within a mode of direction d the acceleration
a = -g (f' + d mu_k) / (1 + f'^2) is constant: v is linear and x a parabola in
t.  A trajectory is at most a few such segments (a start, say uphill; a stop
where the rest rule decides; a slide back down), each ended exactly by the
earliest of its stop, its exit and t_max.  Results are exact to rounding and
cost a few dozen operations per trajectory, whatever t_max is.

The functions are templates like the lane kernels: ``ramp_height``,
``ramp_slope_curvature`` and ``PAPER_CRITERION`` are bound per scene by
:func:`build_closed_form`.  The outputs are the rows of ``layout`` that the
lane kernels write (per unit mass); ``steps`` is 0 (nothing was stepped).
"""

from __future__ import annotations

import math

import numpy as np

from . import status as st
from .jit import jit, specialise
from .threads import TiledKernel
from .layout import (OUT_DRAG_WORK, IN_G, IN_MUK, IN_MUS, IN_P0, IN_P1, IN_P2, IN_P3, IN_V0, IN_X0,
                     N_OUTPUTS, OUT_CONVEXITY, OUT_ENERGY_LOSS, OUT_NREJ, OUT_NREV, OUT_PATH,
                     OUT_STATUS, OUT_STEPS, OUT_T, OUT_V, OUT_WORK, OUT_WORK_ERROR, OUT_X,
                     OUT_XLIFT, OUT_XLIFT_PAPER, OUT_PROJECTED, SET_TMAX, SET_XHI, SET_XLO)
from .physics import acceleration, departure_direction, specific_energy

# bound per scene by build_closed_form
ramp_height = ramp_slope_curvature = None
PAPER_CRITERION = False  # record where the paper's eq. (26) would report lift-off
solve_trajectory = None

#: recorded samples per segment (evenly spaced in time) when tracing
SEGMENT_SAMPLES = 32
# how a segment ends
ENDS_EXIT, ENDS_STOP, ENDS_TIMEOUT = range(3)
#: more segments than a straight ramp allows (start, stop, slide back): a guard
MAX_SEGMENTS = 8


@jit
def _time_to_reach(x, v, a, target):
    """Smallest t > 0 with x + v t + a t^2 / 2 = target, for motion towards
    target (v, if not zero, has the sign of target - x); inf if never.
    The form 2 D / (v + sign(D) sqrt(v^2 + 2 a D)) has no cancellation."""
    distance = target - x
    discriminant = v * v + 2.0 * a * distance
    if not discriminant >= 0.0:
        return math.inf  # it stops first
    denominator = v + math.copysign(math.sqrt(discriminant), distance)
    if denominator == 0.0:
        return math.inf
    return 2.0 * distance / denominator


def _solve_trajectory(j, inputs, settings, outputs, shared, trace):
    """Trajectory j in closed form into ``outputs[:, j]``; samples into
    ``trace`` (4, max_samples) as far as it has room.  Returns the samples
    written."""
    x = inputs[IN_X0, j]
    v = inputs[IN_V0, j]
    g = inputs[IN_G, j]
    mu_k = inputs[IN_MUK, j]
    mu_s = inputs[IN_MUS, j]
    p0 = inputs[IN_P0, j]
    p1 = inputs[IN_P1, j]
    p2 = inputs[IN_P2, j]
    p3 = inputs[IN_P3, j]
    x_lo = settings[SET_XLO]
    x_hi = settings[SET_XHI]
    t_max = settings[SET_TMAX]
    slope, _ = ramp_slope_curvature(x, p0, p1, p2, p3, shared)  # the same everywhere
    energy_start = specific_energy(ramp_height(x, p0, p1, p2, p3, shared), slope, v, g)
    t = 0.0
    work = 0.0
    path = 0.0
    reversals = 0.0
    x_paper = np.nan
    previous = 0.0  # the last segment's direction
    max_samples = trace.shape[1]
    count = 0
    if max_samples > 0:
        trace[0, 0] = t
        trace[1, 0] = x
        trace[2, 0] = v
        trace[3, 0] = work
        count = 1
    status = st.DIVERGED  # unless a segment ends it (MAX_SEGMENTS is a guard)
    for _ in range(MAX_SEGMENTS):
        if v == 0.0:  # the rest rule (docs/physics.md §1.4)
            direction = departure_direction(slope, mu_s, mu_k, g)
            if direction == 0.0:
                status = st.STUCK
                break
            if previous != 0.0 and direction != previous:
                reversals += 1.0
        else:
            direction = 1.0 if v > 0.0 else -1.0
        if (x >= x_hi and direction > 0.0) or (x <= x_lo and direction < 0.0):
            status = st.EXITED
            break
        q = direction * mu_k
        # eq. (26), y'' <= -g, is n (1 - q f') <= 0 with n = g > 0 here
        if PAPER_CRITERION and math.isnan(x_paper) and q * slope >= 1.0:
            x_paper = x
        a = acceleration(g, slope, q)
        t_stop = -v / a if direction * a < 0.0 else math.inf  # it decelerates
        t_exit = _time_to_reach(x, v, a, x_hi if direction > 0.0 else x_lo)
        t_left = t_max - t
        # ties go to the event, as in the lane kernels: exit, then stop, then t_max
        if t_exit <= t_stop and t_exit <= t_left:
            ending = ENDS_EXIT
            duration = t_exit
            x_new = x_hi if direction > 0.0 else x_lo
            v_new = a * duration + v
        elif t_stop <= t_left:
            ending = ENDS_STOP
            duration = t_stop
            x_new = x + 0.5 * v * duration  # where v reaches 0: x - v^2 / (2 a)
            x_new = min(max(x_new, x_lo), x_hi)  # rounding past an end it just reaches
            v_new = 0.0
        else:
            ending = ENDS_TIMEOUT
            duration = t_left
            x_new = x + duration * (v + 0.5 * a * duration)
            v_new = a * duration + v
        t_new = t_max if ending == ENDS_TIMEOUT else t + duration
        if max_samples > 0:
            for k in range(1, SEGMENT_SAMPLES + 1):
                if count >= max_samples:
                    break
                last = k == SEGMENT_SAMPLES
                tau = duration * k / SEGMENT_SAMPLES
                x_k = x_new if last else x + tau * (v + 0.5 * a * tau)
                trace[0, count] = t_new if last else t + tau
                trace[1, count] = x_k
                trace[2, count] = v_new if last else a * tau + v
                trace[3, count] = work + q * g * (x_k - x)
                count += 1
        # friction work q n dx = mu_k g |dx| >= 0; path d dx = |dx|
        work += q * g * (x_new - x)
        path += direction * (x_new - x)
        t = t_new
        x = x_new
        v = v_new
        previous = direction
        if ending == ENDS_EXIT:
            status = st.EXITED
            break
        if ending == ENDS_TIMEOUT:
            status = st.TIMEOUT
            break
    slope_end, _ = ramp_slope_curvature(x, p0, p1, p2, p3, shared)
    energy_end = specific_energy(ramp_height(x, p0, p1, p2, p3, shared), slope_end, v, g)
    if not (math.isfinite(x) and math.isfinite(v) and math.isfinite(work)
            and math.isfinite(energy_end)):
        status = st.DIVERGED  # overflow of absurd inputs: flagged, never a silent NaN
    outputs[OUT_STATUS, j] = status
    outputs[OUT_T, j] = t
    outputs[OUT_X, j] = x
    outputs[OUT_V, j] = v
    outputs[OUT_WORK, j] = work
    outputs[OUT_ENERGY_LOSS, j] = energy_start - energy_end
    outputs[OUT_PATH, j] = path
    outputs[OUT_CONVEXITY, j] = 0.0
    outputs[OUT_NREV, j] = reversals
    outputs[OUT_XLIFT, j] = np.nan  # n = g > 0: it never lifts off
    outputs[OUT_XLIFT_PAPER, j] = x_paper
    outputs[OUT_STEPS, j] = 0.0
    outputs[OUT_NREJ, j] = 0.0
    outputs[OUT_WORK_ERROR, j] = 0.0
    outputs[OUT_PROJECTED, j] = 0.0
    outputs[OUT_DRAG_WORK, j] = 0.0  # no drag: with drag a straight ramp is stepped
    return count


def _run_tiles(first_tile, stop_tile, tile_size, inputs, settings, outputs, shared):
    """Tiles first_tile .. stop_tile - 1 of the trajectories (see
    ``threads.TiledKernel``)."""
    n = inputs.shape[1]
    no_trace = np.empty((4, 0))
    for tile in range(first_tile, stop_tile):
        for j in range(tile * tile_size, min(n, (tile + 1) * tile_size)):
            solve_trajectory(j, inputs, settings, outputs, shared, no_trace)


def _trace_one(j, inputs, settings, shared, every, trace):
    """Record trajectory j: its start, SEGMENT_SAMPLES points per segment
    (evenly in time; ``every`` does not apply) and its end."""
    outputs = np.zeros((N_OUTPUTS, inputs.shape[1]))
    return solve_trajectory(j, inputs, settings, outputs, shared, trace)


def build_closed_form(variant, ramp_height_fn, ramp_slope_curvature_fn, *, cache: bool = True):
    """Compile (or load) the closed-form kernels of a straight-ramp variant
    (``KernelVariant`` with method ``closed_form``); the same
    ``(run_batch, trace_one)`` signatures as ``kernel.build_kernel``."""
    name = variant.name
    constants = {**variant.constants(), "ramp_height": ramp_height_fn,
                 "ramp_slope_curvature": ramp_slope_curvature_fn}
    constants["solve_trajectory"] = specialise(
        _solve_trajectory, f"solve_trajectory_{name}", constants, cache=cache)
    run_batch = TiledKernel(specialise(_run_tiles, f"run_tiles_{name}", constants, cache=cache))
    trace_one = specialise(_trace_one, f"trace_one_{name}", constants, cache=cache)
    return run_batch, trace_one
