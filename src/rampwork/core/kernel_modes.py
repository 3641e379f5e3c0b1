"""The lane kernel's bookkeeping: loading a lane, its modes, finishing it.

A trajectory is loaded into a lane (``_load_lane``), runs in modes of
constant direction and contact side (``_set_mode``: its constants; ``_rebase``:
a new mode's time and curvature integral), and is finished into its
output column (``_finish_lane``), with the paper's lift-off criterion looked
for per mode where asked (``_paper_scan``).

Templates: their globals (``kernel_globals.py``) are bound per variant by
``kernel.build_kernel``.
"""

from __future__ import annotations

import math

import numpy as np

from . import status as st
from .jit import aligned_zeros, fma
from .physics import (acceleration, departure_direction, drag_rate, normal_term,
                      specific_energy)
from .layout import *  # noqa: F403 - the lane layout
from .kernel_globals import *  # noqa: F403 - the templates' globals, bound per variant


def _current_time(lanes, i, h):
    """t = time at mode start + (steps since) * h: no accumulated rounding.
    (Adaptive methods keep the current time itself.)"""
    if ADAPTIVE:
        return lanes[T * LANES + i]
    return lanes[T * LANES + i] + (lanes[STEPS * LANES + i] - lanes[SM * LANES + i]) * h


def _mode_curvature(lanes, i, x, shared):
    """The curvature integral of lane i's mode so far, from its start XM to x:
    the integral of f'' d v dt = d df' is d (f'(x) - f'(XM)), exactly, as d
    is constant within a mode (fixed steps: the one place where it is formed;
    the adaptive pairs integrate it, as part of their error norm)."""
    d = lanes[D * LANES + i]
    if d == 0.0:  # no mode yet (a lane being loaded): XM is not set
        return 0.0
    p0 = lanes[P0 * LANES + i]
    p1 = lanes[P1 * LANES + i]
    p2 = lanes[P2 * LANES + i]
    p3 = lanes[P3 * LANES + i]
    fp_end, _ = ramp_slope_curvature(x, p0, p1, p2, p3, shared)
    fp_start, _ = ramp_slope_curvature(lanes[XM * LANES + i], p0, p1, p2, p3, shared)
    return d * (fp_end - fp_start)


def _rebase(lanes, i, t_now, settings, shared):
    """Start a new mode (after an event) at time t_now and the lane's current x:
    bank the path travelled (and, with fixed steps, the mode's curvature
    integral), reset the time base and the step limit."""
    x = lanes[X * LANES + i]
    if not ADAPTIVE and not CONSTANT_CURVATURE:
        lanes[K * LANES + i] += mode_curvature(lanes, i, x, shared)
    lanes[S * LANES + i] += lanes[D * LANES + i] * (x - lanes[XM * LANES + i])
    lanes[XM * LANES + i] = x
    lanes[T * LANES + i] = t_now
    if ADAPTIVE:
        return
    lanes[SM * LANES + i] = lanes[STEPS * LANES + i]
    remaining = math.floor((settings[SET_TMAX] - t_now) / settings[SET_DT])
    lanes[LIMIT * LANES + i] = lanes[STEPS * LANES + i] + max(remaining, 0.0)


def _refresh_slope(lanes, i, shared):
    """Evaluate f', f'' at lane i's x, store them in the lane and return them."""
    fp, fpp = ramp_slope_curvature(lanes[X * LANES + i], lanes[P0 * LANES + i],
                                   lanes[P1 * LANES + i], lanes[P2 * LANES + i],
                                   lanes[P3 * LANES + i], shared)
    lanes[FP * LANES + i] = fp
    lanes[FPP * LANES + i] = fpp
    return fp, fpp


def _finish_lane(lanes, i, status, x_lift, outputs, shared):
    """Write lane i's trajectory to the outputs; the lane becomes empty."""
    j = np.int64(lanes[TRAJ * LANES + i])
    x = lanes[X * LANES + i]
    v = lanes[V * LANES + i]
    x_paper = np.nan
    if PAPER_CRITERION:
        paper_scan(lanes, i, x, shared)
        x_paper = lanes[XP * LANES + i]
        if status == st.LIFTED_OFF and math.isnan(x_paper):
            x_paper = x_lift  # n = 0 there: y'' = -g, so eq. (26) holds too
    p0 = lanes[P0 * LANES + i]
    p1 = lanes[P1 * LANES + i]
    p2 = lanes[P2 * LANES + i]
    p3 = lanes[P3 * LANES + i]
    fp, fpp = ramp_slope_curvature(x, p0, p1, p2, p3, shared)
    f = ramp_height(x, p0, p1, p2, p3, shared)
    energy_end = specific_energy(f, fp, v, lanes[G * LANES + i])
    if not energy_end <= lanes[ELIM * LANES + i]:
        status = st.DIVERGED  # whatever event ended it, the energy says the step was too large
    path = lanes[S * LANES + i] + lanes[D * LANES + i] * (x - lanes[XM * LANES + i])
    outputs[OUT_STATUS, j] = status
    outputs[OUT_T, j] = lanes[T * LANES + i]
    outputs[OUT_X, j] = x
    outputs[OUT_V, j] = v
    outputs[OUT_WORK, j] = lanes[W * LANES + i]
    outputs[OUT_ENERGY_LOSS, j] = lanes[E0 * LANES + i] - energy_end
    outputs[OUT_PATH, j] = path
    # mean f'' over the path; its limit f''(x0) where nothing was travelled
    if CONSTANT_CURVATURE:  # the mean of a constant
        outputs[OUT_CONVEXITY, j] = lanes[FPP0 * LANES + i]
    else:
        curvature = lanes[K * LANES + i]
        if not ADAPTIVE:  # the last mode's, not yet banked (_mode_curvature)
            curvature += mode_curvature(lanes, i, x, shared)
        outputs[OUT_CONVEXITY, j] = curvature / path if path > 0.0 else lanes[FPP0 * LANES + i]
    outputs[OUT_NREV, j] = lanes[NREV * LANES + i]
    outputs[OUT_XLIFT, j] = x_lift
    outputs[OUT_XLIFT_PAPER, j] = x_paper
    outputs[OUT_STEPS, j] = lanes[STEPS * LANES + i]
    outputs[OUT_NREJ, j] = lanes[NREJ * LANES + i]
    outputs[OUT_WORK_ERROR, j] = lanes[EEST * LANES + i]
    outputs[OUT_DRAG_WORK, j] = lanes[WD * LANES + i]
    outputs[OUT_PROJECTED, j] = lanes[EPROJ * LANES + i]
    make_empty(lanes, i)


def _new_lanes():
    """A block of LANES empty lanes and its tile scratch (nothing cached),
    starting on a cache line (``jit.aligned_zeros``)."""
    lanes = aligned_zeros(N_LANE_FIELDS * LANES + N_SCRATCH)
    for i in range(LANES):
        make_empty(lanes, i)
    lanes[N_LANE_FIELDS * LANES:] = np.nan
    return lanes


def _make_empty(lanes, i):
    """Mark lane i empty: D = 0 fails d * v1 > 0, so it never steps."""
    lanes[TRAJ * LANES + i] = -1.0
    lanes[D * LANES + i] = 0.0
    lanes[X * LANES + i] = 0.0
    lanes[V * LANES + i] = 0.0
    lanes[H * LANES + i] = 0.0
    lanes[PENDING * LANES + i] = 0.0


def _set_mode(lanes, i, direction, settings):
    """Direction of motion and signed friction coefficient of the coming mode."""
    lanes[D * LANES + i] = direction
    lanes[Q * LANES + i] = direction * lanes[MUK * LANES + i] * lanes[SN * LANES + i]
    if not ADAPTIVE:  # the vector loop's forms of D and Q (see layout)
        lanes[DSIGN * LANES + i] = -0.0 if direction < 0.0 else 0.0
        lanes[QH * LANES + i] = settings[SET_DT] * lanes[Q * LANES + i]
        lanes[AHEAD * LANES + i] = settings[SET_XHI] if direction > 0.0 else settings[SET_XLO]
    if ADAPTIVE:  # the first stage of the coming step (f', f'' are current)
        n = normal_term(lanes[V * LANES + i], lanes[FPP * LANES + i], lanes[G * LANES + i])
        lanes[A1 * LANES + i] = acceleration(n, lanes[FP * LANES + i], lanes[Q * LANES + i])
        if DRAG:  # as steppers._with_drag
            v = lanes[V * LANES + i]
            kd = drag_rate(v, lanes[FP * LANES + i], lanes[DRAG_B * LANES + i],
                           lanes[DRAG_C * LANES + i], direction, DRAG_LINEAR, DRAG_QUADRATIC)
            lanes[A1 * LANES + i] = fma(-kd, v, lanes[A1 * LANES + i])


def _load_lane(lanes, i, j, inputs, settings, outputs, shared):
    """Start trajectory j in lane i.  Returns True if it is running, False if
    it finished at t = 0 (stuck, exited or lifted off at the start)."""
    x = inputs[IN_X0, j]
    v = inputs[IN_V0, j]
    g = inputs[IN_G, j]
    p0 = inputs[IN_P0, j]
    p1 = inputs[IN_P1, j]
    p2 = inputs[IN_P2, j]
    p3 = inputs[IN_P3, j]
    x_lo = settings[SET_XLO]
    x_hi = settings[SET_XHI]
    fp, fpp = ramp_slope_curvature(x, p0, p1, p2, p3, shared)
    f = ramp_height(x, p0, p1, p2, p3, shared)
    lanes[TRAJ * LANES + i] = j
    lanes[X * LANES + i] = x
    lanes[V * LANES + i] = v
    lanes[FP * LANES + i] = fp
    lanes[FPP * LANES + i] = fpp
    lanes[FPP0 * LANES + i] = fpp
    lanes[G * LANES + i] = g
    lanes[P0 * LANES + i] = p0
    lanes[P1 * LANES + i] = p1
    lanes[P2 * LANES + i] = p2
    lanes[P3 * LANES + i] = p3
    lanes[MUK * LANES + i] = inputs[IN_MUK, j]
    lanes[MUS * LANES + i] = inputs[IN_MUS, j]
    lanes[DRAG_B * LANES + i] = inputs[IN_DRAG_B, j] if DRAG_LINEAR else 0.0
    lanes[DRAG_C * LANES + i] = inputs[IN_DRAG_C, j] if DRAG_QUADRATIC else 0.0
    lanes[WD * LANES + i] = 0.0
    lanes[W * LANES + i] = 0.0
    lanes[S * LANES + i] = 0.0
    lanes[K * LANES + i] = 0.0
    lanes[STEPS * LANES + i] = 0.0
    lanes[NREV * LANES + i] = 0.0
    lanes[CASCADE * LANES + i] = 0.0
    lanes[NREJ * LANES + i] = 0.0
    lanes[EEST * LANES + i] = 0.0
    lanes[EPROJ * LANES + i] = 0.0
    lanes[PENDING * LANES + i] = 0.0
    lanes[FRESH * LANES + i] = 0.0
    lanes[D * LANES + i] = 0.0
    if PAPER_CRITERION:
        lanes[XP * LANES + i] = np.nan
        lanes[PXM * LANES + i] = x
    rebase(lanes, i, 0.0, settings, shared)
    lanes[E0 * LANES + i] = specific_energy(f, fp, v, g)
    # divergence bound: the speed can never exceed what the energy allows
    scratch = N_LANE_FIELDS * LANES
    if not (lanes[scratch + RANGE_P0] == p0 and lanes[scratch + RANGE_P1] == p1
            and lanes[scratch + RANGE_P2] == p2 and lanes[scratch + RANGE_P3] == p3):
        f_low = math.inf
        f_high = -math.inf
        spacing = (x_hi - x_lo) / (N_RANGE_SAMPLES - 1)
        for k in range(N_RANGE_SAMPLES):
            fs = ramp_height(x_lo + spacing * k, p0, p1, p2, p3, shared)
            f_low = min(f_low, fs)
            f_high = max(f_high, fs)
        lanes[scratch + RANGE_P0] = p0
        lanes[scratch + RANGE_P1] = p1
        lanes[scratch + RANGE_P2] = p2
        lanes[scratch + RANGE_P3] = p3
        lanes[scratch + RANGE_FMIN] = f_low
        lanes[scratch + RANGE_FMAX] = f_high
    f_min = min(f, lanes[scratch + RANGE_FMIN])
    f_max = max(f, lanes[scratch + RANGE_FMAX])
    energy_scale = 0.5 * v * v * (1.0 + fp * fp) + g * (f_max - f_min)
    lanes[VLIM2 * LANES + i] = SPEED_BOUND_FACTOR ** 2 * 2.0 * energy_scale + 1e-12
    lanes[ELIM * LANES + i] = lanes[E0 * LANES + i] + ENERGY_RISE_FACTOR * energy_scale + 1e-12

    n = normal_term(v, fpp, g)
    lanes[SN * LANES + i] = 1.0 if (ONE_SIDED or n >= 0.0) else -1.0
    if v == 0.0:
        direction = departure_direction(fp, inputs[IN_MUS, j], inputs[IN_MUK, j], g)
        if direction == 0.0:
            finish_lane(lanes, i, st.STUCK, np.nan, outputs, shared)
            return False
    else:
        direction = 1.0 if v > 0.0 else -1.0
    if ONE_SIDED and n <= 0.0:
        finish_lane(lanes, i, st.LIFTED_OFF, x, outputs, shared)
        return False
    if (x >= x_hi and direction > 0.0) or (x <= x_lo and direction < 0.0):
        finish_lane(lanes, i, st.EXITED, np.nan, outputs, shared)
        return False
    set_mode(lanes, i, direction, settings)
    if ADAPTIVE:
        start_adaptive(lanes, i, settings, shared)
    return True


#: samples of f' per mode where the paper's criterion is looked for (then
#: bisected to rounding); a sign change narrower than a sample can be missed
PAPER_SAMPLES = 64


def _paper_holds(lanes, i, x, shared):
    """Whether the paper's lift-off criterion (eq. 26, y'' <= -g) holds at x
    in lane i's mode.  y'' + g = n (1 - q f') / (1 + f'^2) with q = d mu_k s_n,
    and n keeps its sign s_n within a mode: so it holds where
    s_n (1 - q f'(x)) <= 0, a condition on x alone."""
    fp, _ = ramp_slope_curvature(x, lanes[P0 * LANES + i], lanes[P1 * LANES + i],
                                 lanes[P2 * LANES + i], lanes[P3 * LANES + i], shared)
    return lanes[SN * LANES + i] * (1.0 - lanes[Q * LANES + i] * fp) <= 0.0


def _paper_scan(lanes, i, x_end, shared):
    """A diagnostic beside the contact-force criterion (docs/physics.md §1.3): the first
    x of the mode's path from PXM to ``x_end`` where eq. (26) holds, into XP
    unless it held before.  Because the condition depends on x alone within
    a mode, it is found by sampling f' along the path and bisecting on x, to
    rounding, without touching the integration.  It differs from the
    contact-force lift-off where d mu_k f' > 1 (sliding up a steep slope)."""
    x_start = lanes[PXM * LANES + i]
    lanes[PXM * LANES + i] = x_end
    if not math.isnan(lanes[XP * LANES + i]) or lanes[D * LANES + i] == 0.0:
        return
    previous = x_start
    for k in range(PAPER_SAMPLES + 1):
        x = x_end if k == PAPER_SAMPLES else x_start + (x_end - x_start) * (k / PAPER_SAMPLES)
        if _paper_holds(lanes, i, x, shared):
            if k > 0:
                # bisect [previous (does not hold), x (holds)] down to adjacent floats
                outside = previous
                for _ in range(1100):
                    middle = 0.5 * (outside + x)
                    if middle == outside or middle == x:
                        break
                    if _paper_holds(lanes, i, middle, shared):
                        x = middle
                    else:
                        outside = middle
            lanes[XP * LANES + i] = x
            return
        previous = x


def _fill_lane(lanes, i, next_j, stop, inputs, settings, outputs, shared):
    """Load trajectories into lane i until one runs; returns the next index."""
    while next_j < stop:
        j = next_j
        next_j += 1
        if load_lane(lanes, i, j, inputs, settings, outputs, shared):
            break
    return next_j


def _no_adaptive_start(lanes, i, settings, shared):
    """Fixed-step methods have no step-control state."""
