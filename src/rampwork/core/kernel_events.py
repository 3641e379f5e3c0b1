"""The lane kernel's scalar event path: one lane's event, located and applied.

A lane whose block of steps was not clean is resolved here: the values whose
sign change is an event (exit at either end, contact, reversal) are
evaluated along a trial step from its start, the earliest root is located
inside the step by root finding on the step size, to rounding (in closed
form where x and v are linear in the step size, ``LINEAR_EVENTS``), and the
lane moves there and takes the event (a new mode, or its end).

Templates: their globals (``kernel_globals.py``) are bound per variant by
``kernel.build_kernel``.
"""

from __future__ import annotations

import math

import numpy as np

from . import status as st
from .jit import fma
from .physics import acceleration, departure_direction, drag_rate, normal_term
from .layout import *  # noqa: F403 - the lane layout
from .kernel_globals import *  # noqa: F403 - the templates' globals, bound per variant


def _trial_step(lanes, i, h, shared):
    """One step of size h from lane i's state, not committed:
    ``(x, v, friction_work, curvature_integral, drag_work)`` as the stepper
    returns them."""
    q = lanes[Q * LANES + i]
    return step(
        lanes[X * LANES + i], lanes[V * LANES + i], lanes[FP * LANES + i], lanes[FPP * LANES + i],
        q, h * q, lanes[D * LANES + i], h, lanes[G * LANES + i],
        lanes[P0 * LANES + i], lanes[P1 * LANES + i], lanes[P2 * LANES + i], lanes[P3 * LANES + i],
        shared, lanes[DRAG_B * LANES + i], lanes[DRAG_C * LANES + i])


def _apply_step(lanes, i, h, shared):
    """One step of size h from lane i's state, committed (events only)."""
    x1, v1, dw, dk, dwd = trial_step(lanes, i, h, shared)
    lanes[X * LANES + i] = x1
    lanes[V * LANES + i] = v1
    lanes[W * LANES + i] += dw
    if DRAG:
        lanes[WD * LANES + i] += dwd
    lanes[STEPS * LANES + i] += 1.0


def _event_values(lanes, i, h, settings, shared):
    """One trial step h from lane i's state and every event function after it:
    ``(bounded, exit_lo, exit_hi, contact, reversal)``, each function > 0
    before its event and <= 0 once it has happened.  ``bounded`` is False where
    the state stops being finite, passes the speed bound, or the step's
    friction work comes out negative (within a mode its integrand is
    mu |n| |v| >= 0: a step so long that its stages leave the mode's signs)."""
    x1, v1, dw, dk, dwd = trial_step(lanes, i, h, shared)
    fp1, fpp1 = ramp_slope_curvature(x1, lanes[P0 * LANES + i], lanes[P1 * LANES + i],
                                     lanes[P2 * LANES + i], lanes[P3 * LANES + i], shared)
    bounded = (math.isfinite(x1) and math.isfinite(v1) and math.isfinite(fp1)
               and math.isfinite(fpp1) and math.isfinite(dw) and math.isfinite(dk)
               and v1 * v1 <= lanes[VLIM2 * LANES + i] and dw >= 0.0)
    if DRAG:  # drag's work as friction's: finite and >= 0 within a mode
        bounded = bounded and math.isfinite(dwd) and dwd >= 0.0
    contact = (lanes[SN * LANES + i] * normal_term(v1, fpp1, lanes[G * LANES + i])
               if CHECK_CONTACT else 1.0)
    d = lanes[D * LANES + i]
    exit_lo = x1 - settings[SET_XLO]
    exit_hi = settings[SET_XHI] - x1
    # still on the end it started from, moving inward (explicit Euler's first
    # step from rest does not move x): not an exit
    if exit_lo == 0.0 and d > 0.0:
        exit_lo = 1.0
    if exit_hi == 0.0 and d < 0.0:
        exit_hi = 1.0
    return bounded, exit_lo, exit_hi, contact, d * v1


def _event_value(kind, lanes, i, h, settings, shared):
    """Event function ``kind`` after a trial step h (EV_DIVERGED: +1 while the
    state is bounded, -1 after; it is located by bisection)."""
    bounded, exit_lo, exit_hi, contact, reversal = event_values(lanes, i, h, settings, shared)
    if kind == EV_REVERSAL:
        return reversal
    if kind == EV_EXIT_HI:
        return exit_hi
    if kind == EV_EXIT_LO:
        return exit_lo
    if kind == EV_CONTACT:
        return contact
    return 1.0 if bounded else -1.0


def _start_value(kind, lanes, i, settings):
    """Event function at step size 0 (the step start), without a trial step."""
    if kind == EV_REVERSAL:
        return lanes[D * LANES + i] * lanes[V * LANES + i]
    if kind == EV_EXIT_HI:
        return settings[SET_XHI] - lanes[X * LANES + i]
    if kind == EV_EXIT_LO:
        return lanes[X * LANES + i] - settings[SET_XLO]
    if kind == EV_CONTACT:
        n = normal_term(lanes[V * LANES + i], lanes[FPP * LANES + i], lanes[G * LANES + i])
        return lanes[SN * LANES + i] * n
    return 1.0


def _locate_event(kind, lanes, i, h_end, value_end, settings, shared):
    """Smallest step size in (0, h_end] at which event ``kind`` has happened.

    Illinois (modified regula falsi) on the step size: each evaluation is one
    step of the scene's own method from the step start, so the event is found
    to the method's accuracy and the root to rounding.  Returns the bracket end
    on the event side, so the event condition holds exactly where it is applied.
    """
    a = 0.0
    fa = start_value(kind, lanes, i, settings)
    if not fa > 0.0:
        return 0.0
    b = h_end
    fb = value_end
    # a residual this small is rounding: the root is found (a linear event
    # function, as in Euler's steps, is hit in one or two iterations)
    tolerance = 1e-15 * (abs(fa) + abs(fb)) if math.isfinite(fb) else 0.0
    side = 0
    for _ in range(200):
        if kind == EV_DIVERGED or not math.isfinite(fb):
            c = 0.5 * (a + b)
        else:
            c = (a * fb - b * fa) / (fb - fa)
            if not (a < c < b):
                c = 0.5 * (a + b)
        if not (a < c < b):
            break  # the bracket is down to adjacent floats
        fc = event_value(kind, lanes, i, c, settings, shared)
        if fc > 0.0:
            a = c
            fa = fc
            if side == 1:
                fb *= 0.5
            side = 1
        else:
            b = c
            fb = fc
            if side == -1:
                fa *= 0.5
            side = -1
            if fc >= -tolerance:
                break
        if b - a <= 4.0e-16 * h_end:
            break
    return b


def _resolve_lane(lanes, i, settings, outputs, shared):
    """Handle the step of lane i that raised an event.  Returns True if the
    trajectory goes on (new mode), False if it finished."""
    h = settings[SET_DT]
    t_now = current_time(lanes, i, h)
    lanes[CASCADE * LANES + i] += 1.0
    if lanes[CASCADE * LANES + i] > MAX_EVENT_CASCADE:
        rebase(lanes, i, t_now, settings, shared)
        finish_lane(lanes, i, st.DIVERGED, np.nan, outputs, shared)
        return False
    if not CARRY_SLOPE:
        refresh_slope(lanes, i, shared)  # the vector loop did not store f', f''
    # 1. the largest usable step: where the state stays finite and bounded
    h_end = h
    bounded, exit_lo, exit_hi, contact, reversal = event_values(lanes, i, h, settings, shared)
    if LINEAR_EVENTS and bounded and contact > 0.0:  # the whole step is usable
        return resolve_linear(lanes, i, t_now, exit_lo, exit_hi, reversal, settings, outputs, shared)
    if not bounded:
        # Most often an event came first: a step that stops early, whose later
        # stages run on past the stop with the mode's signs, ends with
        # friction work < 0.  The earliest event that shows at the step's
        # end, located on [0, h], is a usable end if the state is bounded
        # there; only otherwise is the bound itself bisected (to rounding:
        # about 50 trial steps).
        h_end = locate_earliest(lanes, i, h, exit_lo, exit_hi, contact, reversal, settings,
                                shared)
        if h_end > 0.0:
            bounded, exit_lo, exit_hi, contact, reversal = event_values(lanes, i, h_end, settings,
                                                                        shared)
            if not (bounded and min(exit_lo, exit_hi, contact, reversal) <= 0.0):
                h_end = h  # no usable end found this way: bisect the bound
                bounded = False
    if not bounded:
        diverged = np.int64(EV_DIVERGED)  # one argument type for every call: one compilation
        h_end = locate_event(diverged, lanes, i, h, -1.0, settings, shared)
        h_end = h_end * (1.0 - 1e-12)  # the first bad size; step back to a good one
        while h_end > 0.0 and event_value(diverged, lanes, i, h_end, settings, shared) <= 0.0:
            h_end *= 0.5
        bounded, exit_lo, exit_hi, contact, reversal = event_values(lanes, i, h_end, settings, shared)
    # 2. the earliest event within [0, h_end] (ties: the order below)
    values = (exit_lo, exit_hi, contact, reversal)  # the order of EV_EXIT_LO .. EV_REVERSAL
    best_kind = EV_NONE
    best_h = h_end
    if h_end > 0.0:
        for k in range(4):
            value = values[k]
            if value <= 0.0:
                kind = np.int64(EV_EXIT_LO + k)
                h_k = locate_event(kind, lanes, i, h_end, value, settings, shared)
                if best_kind == EV_NONE or h_k < best_h:
                    best_h = h_k
                    best_kind = kind
    # A long step can hold two events of which its end shows only one (a
    # block that passes the domain's end and comes back shows only its
    # reversal): check every event function at the earliest event found.
    checked_h = -1.0  # the step at which bounded_there was evaluated
    bounded_there = True
    for _ in range(4):
        if best_kind == EV_NONE or best_h <= 0.0:
            break
        bounded_there, exit_lo, exit_hi, contact, reversal = event_values(lanes, i, best_h,
                                                                          settings, shared)
        checked_h = best_h
        values = (exit_lo, exit_hi, contact, reversal)
        earlier = False
        for k in range(4):
            kind = np.int64(EV_EXIT_LO + k)
            if kind != best_kind and not values[k] > 0.0:
                best_h = locate_event(kind, lanes, i, best_h, values[k], settings, shared)
                best_kind = kind
                earlier = True
                break
        if not earlier:
            break
    if best_kind != EV_NONE and best_h > 0.0:
        if checked_h != best_h:
            bounded_there = event_values(lanes, i, best_h, settings, shared)[0]
        if not bounded_there:
            # the partial step to the event is itself unusable (a step far too
            # long: e.g. its friction work comes out negative)
            rebase(lanes, i, t_now, settings, shared)
            finish_lane(lanes, i, st.DIVERGED, np.nan, outputs, shared)
            return False
    return take_event(lanes, i, best_kind, best_h, h_end, t_now, settings, outputs, shared)


def _locate_earliest(lanes, i, h, exit_lo, exit_hi, contact, reversal, settings, shared):
    """The smallest step size in (0, h] at which one of the event functions
    whose values after a step h are given (<= 0: it happened) has happened;
    0 if none did."""
    values = (exit_lo, exit_hi, contact, reversal)  # the order of EV_EXIT_LO .. EV_REVERSAL
    earliest = 0.0
    for k in range(4):
        value = values[k]
        if value <= 0.0:
            h_k = locate_event(np.int64(EV_EXIT_LO + k), lanes, i, h, value, settings, shared)
            if h_k > 0.0 and (earliest == 0.0 or h_k < earliest):
                earliest = h_k
    return earliest


def _take_event(lanes, i, best_kind, best_h, h_end, t_now, settings, outputs, shared):
    """The end of resolving lane i's frozen step, whose earliest event is
    ``best_kind`` at step size ``best_h`` (EV_NONE: none within the usable
    size ``h_end``): t_max may come first; then take the partial step to the
    event and apply it.  Returns True if the trajectory goes on."""
    h = settings[SET_DT]
    h_time = settings[SET_TMAX] - t_now
    if h_time < best_h or (best_kind == EV_NONE and h_time <= h_end):
        best_h = max(h_time, 0.0)
        best_kind = EV_TIMEOUT
    if best_kind == EV_NONE and h_end >= h:
        # frozen only by the step limit, with a rounding's worth of time left
        apply_step(lanes, i, h, shared)
        lanes[CASCADE * LANES + i] = 0.0
        rebase(lanes, i, t_now + h, settings, shared)
        refresh_slope(lanes, i, shared)
        return True
    if best_kind == EV_NONE:
        # the state goes bad within this step and no event comes first
        rebase(lanes, i, t_now, settings, shared)
        finish_lane(lanes, i, st.DIVERGED, np.nan, outputs, shared)
        return False
    if best_h > 0.0:
        apply_step(lanes, i, best_h, shared)
    return apply_event(lanes, i, best_kind, t_now + best_h, settings, outputs, shared)


def _resolve_linear(lanes, i, t_now, exit_lo, exit_hi, reversal, settings, outputs, shared):
    """:func:`_resolve_lane` for explicit Euler, whose full step is bounded
    and keeps contact.  Within the step x(h) = x + h v and v(h) = v + h a
    are linear in h (a is the step start's, drag included), so an exit or a
    reversal happens at one h, found in closed form instead of by root
    finding; each is monotone within the step, so the earliest is the first."""
    h = settings[SET_DT]
    x = lanes[X * LANES + i]
    v = lanes[V * LANES + i]
    best_kind = EV_NONE
    best_h = h
    # ties go to the first in the order exit_lo, exit_hi, reversal (as in _resolve_lane)
    # (v = 0: a departure from rest, whose first step does not move x; it
    # can only exit where it already is, at h = 0)
    if exit_lo <= 0.0:
        best_kind = np.int64(EV_EXIT_LO)
        best_h = min((settings[SET_XLO] - x) / v, h) if v != 0.0 else 0.0
    if exit_hi <= 0.0:
        h_hi = min((settings[SET_XHI] - x) / v, h) if v != 0.0 else 0.0
        if best_kind == EV_NONE or h_hi < best_h:
            best_kind = np.int64(EV_EXIT_HI)
            best_h = h_hi
    if reversal <= 0.0:
        n = normal_term(v, lanes[FPP * LANES + i], lanes[G * LANES + i])
        a = acceleration(n, lanes[FP * LANES + i], lanes[Q * LANES + i])
        if DRAG:  # as in steppers.euler_step (zero drag leaves a exactly as it is)
            kd = drag_rate(v, lanes[FP * LANES + i], lanes[DRAG_B * LANES + i],
                           lanes[DRAG_C * LANES + i], lanes[D * LANES + i], DRAG_LINEAR, DRAG_QUADRATIC)
            a = fma(-kd, v, a)
        h_stop = min(-v / a, h)
        if best_kind == EV_NONE or h_stop < best_h:
            best_kind = np.int64(EV_REVERSAL)
            best_h = h_stop
    # the whole step is usable: h_end = h
    return take_event(lanes, i, best_kind, max(best_h, 0.0), h, t_now, settings, outputs, shared)


def _apply_event(lanes, i, kind, t_event, settings, outputs, shared):
    """Apply an event of ``kind`` to lane i, which is at the event (at time
    t_event; t_max for a timeout).  Returns True if the trajectory goes on."""
    if kind == EV_TIMEOUT:
        t_event = settings[SET_TMAX]
    if kind == EV_EXIT_HI:
        lanes[X * LANES + i] = settings[SET_XHI]
    elif kind == EV_EXIT_LO:
        lanes[X * LANES + i] = settings[SET_XLO]
    elif kind == EV_REVERSAL:
        # Within a mode x moves only in direction d.  A stop located to the
        # rounding of the step, in a mode shorter than that (a launch at
        # v0 = -1e-200), can leave x a rounding behind the mode's start.
        if lanes[D * LANES + i] * (lanes[X * LANES + i] - lanes[XM * LANES + i]) < 0.0:
            lanes[X * LANES + i] = lanes[XM * LANES + i]
    if PAPER_CRITERION:  # the mode ends here: look for eq. (26) along it
        paper_scan(lanes, i, lanes[X * LANES + i], shared)
    rebase(lanes, i, t_event, settings, shared)
    if kind == EV_TIMEOUT:
        finish_lane(lanes, i, st.TIMEOUT, np.nan, outputs, shared)
        return False
    if kind == EV_EXIT_HI or kind == EV_EXIT_LO:
        finish_lane(lanes, i, st.EXITED, np.nan, outputs, shared)
        return False
    x = lanes[X * LANES + i]
    fp, fpp = refresh_slope(lanes, i, shared)
    if kind == EV_CONTACT:
        if ONE_SIDED:
            finish_lane(lanes, i, st.LIFTED_OFF, x, outputs, shared)
            return False
        # two-sided: the sign inside |n| flips and the motion goes on
        lanes[SN * LANES + i] = -lanes[SN * LANES + i]
        lanes[FRESH * LANES + i] = 1.0  # n starts from 0 (adaptive.py's contact control)
        set_mode(lanes, i, lanes[D * LANES + i], settings)
        return True
    # reversal: v reached 0 and the rest rule decides
    lanes[V * LANES + i] = 0.0
    lanes[SN * LANES + i] = 1.0  # at rest n = g > 0
    direction = departure_direction(fp, lanes[MUS * LANES + i], lanes[MUK * LANES + i],
                                    lanes[G * LANES + i])
    if direction == 0.0:
        finish_lane(lanes, i, st.STUCK, np.nan, outputs, shared)
        return False
    if direction != lanes[D * LANES + i]:
        lanes[NREV * LANES + i] += 1.0
    set_mode(lanes, i, direction, settings)
    return True
