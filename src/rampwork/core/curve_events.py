"""The curve kernel's event locator (docs/physics.md §5.3): one trial at a time.

An event inside a step (a stop, lift-off or a contact switch, an exit, a
joint, a non-finite state) is located on the step size, to rounding: the
largest clean step size ``lo`` and the smallest that is not, ``hi``, end up
adjacent floats, and the step of ``hi`` is committed.  Every trial is a
whole step of the scene's method, so the bracket is exact whatever the
method's error.  The bracket's state is

    (lo, hi, lo_p, lo_u, lo_nu, hi_p, hi_u, hi_nu, weight_lo, weight_hi,
     moved, width_before, width_last, guess_before)

(p, u and nu at the ends of the steps ``lo`` and ``hi``, the Illinois
weights, which end moved last, the bracket's last two widths and the last
guess), and one trial is :func:`_event_trial` (its step size), the step,
then :func:`bracket_after`.  The scalar code runs the trials in a loop
(:func:`_locate_event`); the adaptive pairs' lane kernel (curve_lanes.py)
keeps the state in lane fields and takes each trial as a vector step
beside the other lanes' steps, with the same operations on the same
values, so both give the same bracket bit for bit.

The functions are templates (``try_step``, ``event_guess``, ``event_trial``
and ``JOINTS`` bound per scene by ``curve_lanes.build_curve_kernel``), but
:func:`bracket_after` and :func:`bracket_closed`; the lanes' part is
:func:`_lane_trial` (before a vector step) and :func:`_lane_bracket` (after).
"""

from __future__ import annotations

import math

from .curve_kernel import (EV_GBEFORE, EV_HI, EV_HINU, EV_HIP, EV_HIU, EV_LO, EV_LONU, EV_LOP,
                           EV_LOU, EV_MOVED, EV_WBEFORE, EV_WHI, EV_WLAST, EV_WLO, EVENT)
from .curve_fields import field, set_field
from .curve_steppers import normal_along_n
from .jit import jit

try_step = event_guess = event_trial = None  # bound per scene
JOINTS = 0
#: the event locator's least push past a guess, relative to it (2 ulps or so)
PUSH_ULPS = 2.0 ** -51


def _event_guess(lo, hi, lo_p, lo_u, lo_nu, hi_p, hi_u, hi_nu, weight_lo, weight_hi, p, d, sn,
                 p_lo, p_hi, joint):
    """Where the first event condition that fails at step size ``hi`` (and
    holds at ``lo``) crosses 0, by the secant through its values at the two
    (``lo_*``, ``hi_*``: p, u and nu at the ends of those steps; each end's
    value times its ``weight``, the Illinois method's): the earliest such
    crossing, or inf where no condition's secant says (a non-finite step,
    a condition this does not model)."""
    best = math.inf
    span = hi - lo
    # each condition's value: > 0 where it holds, as _try_step.  An end
    # reached exactly holds, and p is rounded: the step's p passes p_hi where
    # the exact one passes p_hi + half an ulp, so the guess aims there (on a
    # p held on the end over many step sizes the secant has no slope, and
    # bisection took ~50 trials)
    half_hi = abs(p_hi) * 2.0 ** -53
    half_lo = abs(p_lo) * 2.0 ** -53
    for value_lo, value_hi, fails in (
            (d * lo_u, d * hi_u, not (d * hi_u > 0.0)),
            (sn * lo_nu, sn * hi_nu, not (sn * hi_nu > 0.0)),
            (p_hi - lo_p + half_hi, p_hi - hi_p + half_hi, not (hi_p <= p_hi)),
            (lo_p - p_lo + half_lo, hi_p - p_lo + half_lo, not (hi_p >= p_lo)),
            ((lo_p - joint) * (p - joint), (hi_p - joint) * (p - joint),
             (p - joint) * (hi_p - joint) < 0.0 if JOINTS else False)):
        if fails and value_lo > 0.0:
            a = weight_lo * value_lo
            guess = lo + span * (a / (a - weight_hi * value_hi))
            if guess < best:
                best = guess
    return best


def _event_trial(lo, hi, lo_p, lo_u, lo_nu, hi_p, hi_u, hi_nu, weight_lo, weight_hi, moved,
                 width_before, guess_before, p, d, sn, p_lo, p_hi, joint):
    """``(trial, guess_before)``: the next trial step size inside the
    bracket (open: :func:`bracket_closed` is false) and the last guess after
    it.  The Illinois method's secant guess on the failing condition
    (:func:`_event_guess`), pushed past the guess towards the end that did
    not move last by the guess's last change, at least PUSH_ULPS of it, so
    that the bracket closes from both sides (a plain secant closes one side
    and then crawls: ~50 trials, bisection's count, on a linear condition
    such as Euler's reversal); the midpoint where the guess is not strictly
    inside or the bracket has not halved over the last two trials."""
    trial = 0.5 * (lo + hi)
    if hi - lo <= 0.5 * width_before:
        guess = event_guess(lo, hi, lo_p, lo_u, lo_nu, hi_p, hi_u, hi_nu, weight_lo, weight_hi,
                            p, d, sn, p_lo, p_hi, joint)
        if lo < guess < hi:
            push = abs(guess - guess_before)
            push = max(push if push == push else 0.0, abs(guess) * PUSH_ULPS)
            trial = guess + push if moved > 0.0 else guess - push
            if not (lo < trial < hi):
                trial = guess
            guess_before = guess
    return trial, guess_before


@jit(internal=True)
def bracket_after(clean, trial, p1, u1, nu1, lo, hi, lo_p, lo_u, lo_nu, hi_p, hi_u, hi_nu,
                  weight_lo, weight_hi, moved):
    """The bracket after the step of size ``trial`` (``p1``, ``u1``, ``nu1``
    at its end; ``clean``: no event condition fired): ``(lo, hi, lo_p, lo_u,
    lo_nu, hi_p, hi_u, hi_nu, weight_lo, weight_hi, moved)``.  A side kept
    twice in a row has its weight halved (Illinois)."""
    if clean:
        return (trial, hi, p1, u1, nu1, hi_p, hi_u, hi_nu, 1.0,
                0.5 * weight_hi if moved > 0.0 else 1.0, 1.0)
    return (lo, trial, lo_p, lo_u, lo_nu, p1, u1, nu1, 0.5 * weight_lo if moved < 0.0 else 1.0,
            1.0, -1.0)


@jit(internal=True)
def bracket_closed(lo, hi):
    """No float lies strictly between lo and hi: the event is located."""
    mid = 0.5 * (lo + hi)
    return not (lo < mid < hi)


def _locate_event(p, u, q, d, sn, h, g, s0, s1, s2, s3, shared, b, c, p_lo, p_hi, joint, rtol,
                  atol, frame, step_h):
    """The event inside the step of size ``h`` from p (``step_h``: that
    step, not clean): ``(hi, step)``: the step size hi and its step, with
    lo < hi adjacent floats, lo's step clean (0 at first) and hi's not.  The
    same bracket as bisection gives where cleanness switches once over the
    step (a switch that flickers within rounding may come out an ulp
    apart), found in fewer steps (:func:`_event_trial`)."""
    lo = 0.0
    hi = h
    lo_p, lo_u = p, u
    lo_nu = normal_along_n(u, frame[1], frame[2], g)
    hi_p, hi_u, hi_nu = step_h[0], step_h[1], step_h[7]
    weight_lo = weight_hi = 1.0
    moved = 0.0  # +1.0: lo moved last, -1.0: hi did
    width_before = width_last = math.inf
    guess_before = math.nan
    while not bracket_closed(lo, hi):
        trial, guess_before = event_trial(lo, hi, lo_p, lo_u, lo_nu, hi_p, hi_u, hi_nu, weight_lo,
                                          weight_hi, moved, width_before, guess_before, p, d, sn,
                                          p_lo, p_hi, joint)
        width_before = width_last
        width_last = hi - lo
        step = try_step(p, u, q, d, sn, trial, g, s0, s1, s2, s3, shared, b, c, p_lo, p_hi,
                        joint, rtol, atol, frame)
        if not step[8]:
            step_h = step
        lo, hi, lo_p, lo_u, lo_nu, hi_p, hi_u, hi_nu, weight_lo, weight_hi, moved = bracket_after(
            step[8], trial, step[0], step[1], step[7], lo, hi, lo_p, lo_u, lo_nu, hi_p, hi_u,
            hi_nu, weight_lo, weight_hi, moved)
    return hi, step_h


def _lane_trial(lanes, i, locating, step_size, p, d, sn, p_lo, p_hi, joint):
    """The size of lane i's next step: its bracket's next trial where it is
    ``locating`` (the bracket's widths and last guess advanced, as
    :func:`_locate_event` does before its step), else ``step_size``."""
    lo = field(lanes, EV_LO, i)
    hi = field(lanes, EV_HI, i)
    width_before = field(lanes, EV_WBEFORE, i)
    width_last = field(lanes, EV_WLAST, i)
    guess_before = field(lanes, EV_GBEFORE, i)
    trial, guess = event_trial(
        lo, hi, field(lanes, EV_LOP, i), field(lanes, EV_LOU, i), field(lanes, EV_LONU, i),
        field(lanes, EV_HIP, i), field(lanes, EV_HIU, i), field(lanes, EV_HINU, i),
        field(lanes, EV_WLO, i), field(lanes, EV_WHI, i), field(lanes, EV_MOVED, i),
        width_before, guess_before, p, d, sn, p_lo, p_hi, joint)
    set_field(lanes, EV_WBEFORE, i, width_last if locating else width_before)
    set_field(lanes, EV_WLAST, i, hi - lo if locating else width_last)
    set_field(lanes, EV_GBEFORE, i, guess if locating else guess_before)
    return trial if locating else step_size


@jit(internal=True, refcount=False)
def _pick(lanes, index, i, begins, start, locating, narrowed):
    """Field ``index`` of the lanes: ``start`` where the bracket begins,
    ``narrowed`` where it is narrowed, else as it was (loaded whatever the
    case: a load under a condition keeps the lane loop from vectorising)."""
    old = field(lanes, index, i)
    set_field(lanes, index, i, start if begins else (narrowed if locating else old))


@jit
def lane_bracket(lanes, i, locating, begins, clean, h, p1, u1, nu1, p, u, nu):
    """Lane i's bracket after its step of size ``h`` (from ``p``, ``u``,
    ``nu`` to ``p1``, ``u1``, ``nu1``; ``clean``: no event condition
    fired): narrowed where it is ``locating``, started where the step
    ``begins`` an event (not clean), as :func:`_locate_event` starts it;
    whether the lane locates an event now with its bracket closed."""
    lo, hi, lo_p, lo_u, lo_nu, hi_p, hi_u, hi_nu, weight_lo, weight_hi, moved = bracket_after(
        clean, h, p1, u1, nu1, field(lanes, EV_LO, i), field(lanes, EV_HI, i),
        field(lanes, EV_LOP, i), field(lanes, EV_LOU, i), field(lanes, EV_LONU, i),
        field(lanes, EV_HIP, i), field(lanes, EV_HIU, i), field(lanes, EV_HINU, i),
        field(lanes, EV_WLO, i), field(lanes, EV_WHI, i), field(lanes, EV_MOVED, i))
    _pick(lanes, EV_LO, i, begins, 0.0, locating, lo)
    _pick(lanes, EV_HI, i, begins, h, locating, hi)
    _pick(lanes, EV_LOP, i, begins, p, locating, lo_p)
    _pick(lanes, EV_LOU, i, begins, u, locating, lo_u)
    _pick(lanes, EV_LONU, i, begins, nu, locating, lo_nu)
    _pick(lanes, EV_HIP, i, begins, p1, locating, hi_p)
    _pick(lanes, EV_HIU, i, begins, u1, locating, hi_u)
    _pick(lanes, EV_HINU, i, begins, nu1, locating, hi_nu)
    _pick(lanes, EV_WLO, i, begins, 1.0, locating, weight_lo)
    _pick(lanes, EV_WHI, i, begins, 1.0, locating, weight_hi)
    _pick(lanes, EV_MOVED, i, begins, 0.0, locating, moved)  # +1.0: lo moved last
    # (:func:`_lane_trial` advanced these where the bracket is narrowed)
    _pick(lanes, EV_WBEFORE, i, begins, math.inf, False, 0.0)
    _pick(lanes, EV_WLAST, i, begins, math.inf, False, 0.0)
    _pick(lanes, EV_GBEFORE, i, begins, math.nan, False, 0.0)
    on = locating | begins
    _pick(lanes, EVENT, i, on, 1.0, False, 0.0)
    return on & bracket_closed(field(lanes, EV_LO, i), field(lanes, EV_HI, i))
