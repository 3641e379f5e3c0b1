"""The curve kernel: a point mass on a planar curve, in arc length (docs/physics.md §5).

State ``(p, u)``: the curve's position parameter (the arc length ``s`` for
the arc-length families, ``x`` for a wrapped ramp) and the signed speed along
the curve ``u = ds/dt``, so ``dp/dt = u dp/ds`` and, per unit mass,

    nu = kappa u^2 + g cos phi          (normal force along the left normal N)
    du/dt = -g sin phi - q nu  (- k u with air drag, k = b + c |u|)

with ``q = d mu_k s_nu``: the direction ``d = sign(u)`` and the contact sign
``s_nu`` are held fixed within a mode, as in the ramp kernel (docs/physics.md
§1.2), so every right-hand side is smooth up to the next event.  One-sided
contact: ``s_nu`` is the curve's side (+1 the side N points to, -1 the
other), and ``s_nu nu`` reaching 0 is lift-off; two-sided: a sign change of
``nu`` is an event that flips ``s_nu``.

Events (a stop, lift-off or a contact switch, an exit, a non-finite state) are
located inside the step on the step size with the scene's own method, to
rounding: the largest clean step size and the smallest that is not are
adjacent floats, and the step of the latter is committed (secant guesses
on the failing condition, bisection as the safeguard: curve_events.py, in
the lanes for the adaptive pairs).  Then the rest rule (§5) decides at a stop.

This module holds a trajectory's scalar parts, on the lane state of
``curve_lanes.py`` (field F of lane i at ``lanes[F * LANES + i]``):
:func:`_iterate` (one step, with its event resolved in full), the rest
rule, the contact sign and the horizontal path.  The lane kernel (curve_lanes.py) takes
clean steps for a block of lanes at once and hands every other step to
:func:`_iterate` (an adaptive pair's event step once the lanes have located
it); run with its vector loop off, it is the scalar kernel the tests
compare it with, bit for bit.

The functions here are templates: ``curve_frame``, ``curve_point``,
``curve_step`` and the helper names are globals bound per scene by
``curve_lanes.build_curve_kernel`` through ``jit.specialise``, with the
switches ``ONE_SIDED``, ``FRICTION`` and ``DRAG*``: a scene compiles only
the effects it uses.  No data-dependent choice is shared between
trajectories, so results do not depend on the batch, lane or thread.
"""

from __future__ import annotations

import math

import numpy as np

from . import status as st
from .control import (ERROR_FLOOR, ERROR_TINY, FACTOR_MAX, FACTOR_MIN, SAFETY, exp2_approx,
                      log2_approx)
from .curve_steppers import CURVE_STEPPERS, normal_along_n  # noqa: F401 (CURVE_STEPPERS: public)
from .curve_fields import LANES, field, set_field
from .curve_track import branch_near
from .jit import fma, jit

# bound per scene by curve_lanes.build_curve_kernel (compile-time constants)
curve_frame = curve_point = curve_step = try_step = rest_rule = None
contact_sign = x_travelled = accepted_factor = rejected_factor = None
locate_event = None
ADAPTIVE = False  # an embedded pair with step-size control (per trajectory)
# the pair's PI gains (control.PI_DOPRI5, PI_DOP853) and the exponent of a
# rejected step's shrink factor (1 / order)
PI_ALPHA = PI_BETA = REJECT_EXPONENT = 0.0
# the step takes the frame at its start as its last argument (curve_steppers.py)
STEP_TAKES_FRAME = True
JOINTS = 0  # the curve's joints (curvature jumps: 0, 1, 2 or MANY_JOINTS): steps end
# there, and the family reads its last shape parameter as the branch (core/curves.py)
#: JOINTS for any number of joints: a trajectory's JOINT is the offset of its
#: sorted joints in ``shared`` and JOINT2 their count (core/curve_track.py)
MANY_JOINTS = 3
ONE_SIDED = True  # a block on the curve's declared side (lift-off) rather than a bead
FRICTION = True  # False: mu_k = 0 everywhere, no friction branch
DRAG_LINEAR = DRAG_QUADRATIC = DRAG = False  # air drag's terms (DRAG: either)

#: rows of the kernel's float output, in order
OUTPUTS = ("t_end", "p_end", "u_end", "X_end", "Y_end", "W_friction", "W_energy", "W_drag",
           "energy_balance_error", "displacement", "path_length", "path_length_X", "curvature_mean",
           "nu_min", "p_lift_off", "X_lift_off", "Y_lift_off", "n_reversals", "steps",
           "steps_rejected")
(O_T, O_P, O_U, O_X, O_Y, O_W, O_WE, O_WD, O_BAL, O_DISP, O_PATH, O_XPATH, O_KMEAN, O_NUMIN,
 O_PLIFT, O_XLIFT, O_YLIFT, O_NREV, O_STEPS, O_REJECTED) = range(len(OUTPUTS))
#: rows of the kernel's per-trajectory input
INPUTS = ("p0", "u0", "mu_k", "mu_s", "g", "m", "s0", "s1", "s2", "s3", "p_lo", "p_hi",
          "drag_b", "drag_c", "p_joint", "p_joint2")
(I_P, I_U, I_MUK, I_MUS, I_G, I_M, I_S0, I_S1, I_S2, I_S3, I_LO, I_HI, I_B, I_C,
 I_JOINT, I_JOINT2) = range(len(INPUTS))
# --- a trajectory's state: field F of lane i at lanes[F * LANES + i] (curve_lanes.py) ---
# P, U: position parameter and signed speed; D, SN: direction and contact sign
# of the mode; T, HN: time and the next step size; EPREV, REJB: the PI
# controller's last accepted error and whether the last attempt was
# rejected; the integrals per unit mass WORK, CURV, DISP, PATH, PATHX,
# DRAGW, and NUMIN (side nu, smallest); XNOW, COSNOW: X and cos phi at P;
# STEPS, NREJ, INROW (events in a row), NREV; PLIFT; STATUS (-1.0: an empty
# lane; st.NOT_RUN while running); TRAJ: the input column; E0, KAPPA0: the
# start's energy and curvature; BRANCH: the joint branch (family's p3) of the
# last step; FLAG: 1.0 where the vector loop left the lane's step to the
# scalar code; then the trajectory's inputs; last SINNOW, KAPNOW, DPDSNOW:
# with COSNOW the frame at P, as the last step's end evaluated it (the
# next step's first stage, without joints: the same bits as evaluated anew);
# JOINT2: the second joint (JOINT < JOINT2; NaN: none).  With MANY_JOINTS,
# JOINT and JOINT2 are the offset and count of the joints in ``shared``.
# EVENT: 1.0 while the lanes locate an event in the lane's step (the
# adaptive pairs, curve_lanes.py), with the bracket's state in EV_* (as
# curve_events.py names it); its step is committed by _iterate once closed.
(P, U, D, SN, T, HN, EPREV, REJB, WORK, CURV, DISP, PATH, PATHX, DRAGW, NUMIN, XNOW,
 COSNOW, STEPS, NREJ, INROW, NREV, PLIFT, STATUS, TRAJ, E0, KAPPA0, BRANCH, FLAG,
 MUK, MUS, G, S0, S1, S2, LO, HI, B, C, JOINT, SINNOW, KAPNOW, DPDSNOW, JOINT2, EVENT,
 EV_LO, EV_HI, EV_LOP, EV_LOU, EV_LONU, EV_HIP, EV_HIU, EV_HINU, EV_WLO, EV_WHI, EV_MOVED,
 EV_WBEFORE, EV_WLAST, EV_GBEFORE) = range(58)
N_FIELDS = 58
#: the bracket's fields, in curve_events.py's order of its state
BRACKET = (EV_LO, EV_HI, EV_LOP, EV_LOU, EV_LONU, EV_HIP, EV_HIU, EV_HINU, EV_WLO, EV_WHI,
           EV_MOVED, EV_WBEFORE, EV_WLAST, EV_GBEFORE)
#: the empty lane's STATUS
EMPTY = -1.0
#: events in a row without a full step between them before a trajectory is declared diverged
MAX_EVENTS_IN_ROW = 100
#: an adaptive step that shrinks below this fraction of the time reached is a divergence
SMALLEST_STEP = 1e-14
#: a rough step (a dip of nu inside it, _iterate) is retried at this fraction of
#: its size (adaptive), or probed there (fixed steps)
ROUGH_SHRINK = 0.5


@jit(internal=True, refcount=False)
def fresh(lanes, i):
    """Lane i's next step is its trajectory's first or the first after an
    event: exempt from the rough-step check, since nu may start from 0 there
    (a two-sided switch, a start at rest on a vertical tangent) and a
    stage's rounding would refuse every step size."""
    return (field(lanes, STEPS, i) == 0.0) | (field(lanes, INROW, i) > 0.0)


def _try_step(p, u, q, d, sn, h, g, s0, s1, s2, s3, shared, b, c, p_lo, p_hi, joint, rtol, atol,
              frame):
    """One step from p (``frame``: the curve's frame there) and whether it is
    clean (no event condition fired):
    ``(p1, u1, dw, dk, dx, dwd, err, nu1, clean, frame1, rough)``, ``frame1``
    the frame at p1 ``(sin phi, cos phi, kappa, dp/ds)``.  NaN fails every
    comparison, so a non-finite step is not clean.  Reaching an end exactly
    is not an exit (a first-order step from rest does not move p); passing
    it is.  With ``JOINTS``, a step that crosses ``joint`` (the next
    curvature jump ahead, :func:`branch`; NaN: none) is not clean either:
    the step is cut to end just past it, so no step integrates across the
    jump and every method keeps its order.  ``rough``: clean, yet the step's
    stages before its end (with the parabolas through them,
    curve_steppers.nu_range) reach ``s_nu nu <= 0``: a dip through 0 and
    back that the end does not see (:func:`_iterate` decides what to do).
    ``clean`` looks at the end alone, so the event bisection's predicate
    stays monotone."""
    if STEP_TAKES_FRAME:
        p1, u1, dw, dk, dx, dwd, err, nu_low, nu_high = curve_step(
            p, u, q, d, h, g, s0, s1, s2, s3, shared, b, c, rtol, atol, frame)
    else:
        p1, u1, dw, dk, dx, dwd, err, nu_low, nu_high = curve_step(
            p, u, q, d, h, g, s0, s1, s2, s3, shared, b, c, rtol, atol)
    frame1 = curve_frame(p1, s0, s1, s2, s3, shared)
    nu1 = normal_along_n(u1, frame1[1], frame1[2], g)
    clean = (d * u1 > 0.0) and (p1 >= p_lo) and (p1 <= p_hi) and (sn * nu1 > 0.0)
    if JOINTS:
        clean = clean and not ((p - joint) * (p1 - joint) < 0.0)
    rough = clean and ((nu_low <= 0.0) if sn > 0.0 else (nu_high >= 0.0))
    return p1, u1, dw, dk, dx, dwd, err, nu1, clean, frame1, rough


def _rest_rule(p, mu_k, mu_s, g, side, s0, s1, s2, s3, shared):
    """At rest at p: ``(direction, status)``; direction 0.0 with status STUCK
    or LIFTED_OFF, or the direction it starts in with status NOT_RUN (moving).

    At rest nu = g cos phi.  One-sided (docs/physics.md §5): side nu < 0 is
    not held (lift-off); side nu = 0 exactly (a vertical tangent) lets the
    curvature decide: bending towards the block's side (side kappa > 0), the
    surface is in the way and it slides off in contact; otherwise it leaves.
    Held (|sin phi| <= mu_s |cos phi|) it stays; else it starts downhill,
    unless the departing acceleration rounds to 0 or the wrong sign."""
    sin_phi, cos_phi, kappa, _ = curve_frame(p, s0, s1, s2, s3, shared)
    nu = g * cos_phi
    direction = -1.0 if sin_phi > 0.0 else 1.0
    if ONE_SIDED:
        if side * nu < 0.0:
            return 0.0, st.LIFTED_OFF
        if nu == 0.0:
            if side * kappa > 0.0 and sin_phi != 0.0:
                return direction, st.NOT_RUN
            return 0.0, st.LIFTED_OFF
    if abs(sin_phi) <= mu_s * abs(cos_phi):
        return 0.0, st.STUCK
    if -fma(g, sin_phi, direction * mu_k * abs(nu)) * direction <= 0.0:
        return 0.0, st.STUCK
    return direction, st.NOT_RUN


def _x_travelled(p, x, cos_phi, p1, cos1, s0, s1, s2, s3, shared):
    """``(|dX| summed from p to p1, X(p1))`` (``cos1``: cos phi at p1): the horizontal
    distance of one step, exact to rounding from the curve's closed-form
    point, not integrated.  Within a step p moves one way, so X is monotone
    between the points where cos phi changes sign; a step that crosses one
    (a vertical tangent) is split there, the tangent found by bisection on p
    to adjacent floats (geometry alone, no integration).  A step that turns
    the tangent by more than pi could hide a pair of them: steps are far
    shorter than that on every family here."""
    x1, _ = curve_point(p1, s0, s1, s2, s3, shared)
    if not (cos_phi * cos1 < 0.0):
        return abs(x1 - x), x1
    lo = p
    hi = p1
    while True:
        mid = 0.5 * (lo + hi)
        if mid == lo or mid == hi:
            break
        _, cos_mid, _, _ = curve_frame(mid, s0, s1, s2, s3, shared)
        if cos_mid * cos_phi > 0.0:
            lo = mid
        else:
            hi = mid
    x_turn, _ = curve_point(lo, s0, s1, s2, s3, shared)
    return abs(x_turn - x) + abs(x1 - x_turn), x1


def _contact_sign(nu, kappa, side):
    """s_nu for a mode that starts where the normal force is nu."""
    if ONE_SIDED:
        return side
    if nu > 0.0 or (nu == 0.0 and kappa >= 0.0):
        return 1.0
    return -1.0


@jit(internal=True, refcount=False)
def store_frame(lanes, i, frame):
    """The frame at lane i's P (``(sin phi, cos phi, kappa, dp/ds)``) into its fields."""
    set_field(lanes, SINNOW, i, frame[0])
    set_field(lanes, COSNOW, i, frame[1])
    set_field(lanes, KAPNOW, i, frame[2])
    set_field(lanes, DPDSNOW, i, frame[3])


@jit(internal=True)
def branch(p, d, joint, joint2):
    """JOINTS (joints ``joint`` < ``joint2``, NaN: none): ``(s3, ahead)``,
    s3 the piece a step from p in direction d starts on, or moves into from
    a joint (the family's p3: 1.0 + the number of joints behind; 0.0 where
    there is no joint), and ``ahead`` the next joint in direction d (NaN:
    none), the one the step must not cross."""
    past = (p > joint) or (p == joint and d > 0.0)
    past2 = (p > joint2) or (p == joint2 and d > 0.0)
    s3 = 0.0 if joint != joint else 1.0 + (1.0 if past else 0.0) + (1.0 if past2 else 0.0)
    if d > 0.0:
        ahead = joint2 if past else joint
    else:
        ahead = joint2 if past2 else (joint if past else math.nan)
    return s3, ahead


def _accepted_factor(err, error_previous, rejected_before):
    """The next step's factor after an accepted step (the PI controller of
    control.py, with its vectorisable log2 / exp2: no pow, so the lane loop
    of curve_lanes.py vectorises)."""
    factor = SAFETY * exp2_approx(PI_BETA * log2_approx(error_previous)
                                  - PI_ALPHA * log2_approx(max(err, ERROR_TINY)))
    return min(max(factor, FACTOR_MIN), 1.0 if rejected_before else FACTOR_MAX)


def _rejected_factor(err):
    """The factor that shrinks a rejected step (NaN: the smallest)."""
    if err == err:
        return max(FACTOR_MIN, SAFETY * exp2_approx(-REJECT_EXPONENT * log2_approx(err)))
    return FACTOR_MIN


def _iterate(lanes, i, shared, t_max, side, rtol, atol):
    """One pass of lane i's loop, in full: an attempted step with its event
    located and resolved, or the verdict (timeout, divergence).  The vector
    loop (curve_lanes.py) does the same for a clean step with selects and
    leaves every other step to this.

    An adaptive step is accepted where its error norm is <= 1, with the ramp
    kernel's PI controller (control.py); a step with an event is judged at
    the event, after it is located (its error is that of the shorter step)."""
    p = field(lanes, P, i)
    u = field(lanes, U, i)
    d = field(lanes, D, i)
    sn = field(lanes, SN, i)
    t = field(lanes, T, i)
    mu_k = field(lanes, MUK, i)
    g = field(lanes, G, i)
    s0 = field(lanes, S0, i)
    s1 = field(lanes, S1, i)
    s2 = field(lanes, S2, i)
    s3 = field(lanes, BRANCH, i)
    p_lo = field(lanes, LO, i)
    p_hi = field(lanes, HI, i)
    b = field(lanes, B, i)
    c = field(lanes, C, i)
    joint = field(lanes, JOINT, i)
    h_next = field(lanes, HN, i)
    if t >= t_max:
        set_field(lanes, STATUS, i, st.TIMEOUT)
        return
    step_size = h_next if t + h_next <= t_max else t_max - t
    q = d * mu_k * sn
    if JOINTS == MANY_JOINTS:  # s3 from the last step's (core/curve_track.py)
        s3, joint = branch_near(p, d, shared, int(joint), int(field(lanes, JOINT2, i)), s3)
        set_field(lanes, BRANCH, i, s3)
    elif JOINTS == 2:
        s3, joint = branch(p, d, joint, field(lanes, JOINT2, i))
        set_field(lanes, BRANCH, i, s3)
    elif JOINTS:  # one joint: the only one a step may cross
        s3 = branch(p, d, joint, math.nan)[0]
        set_field(lanes, BRANCH, i, s3)
    frame = curve_frame(p, s0, s1, s2, s3, shared)
    located = field(lanes, EVENT, i) != 0.0  # by the lanes: the step of EV_HI is the event's
    if located:
        step_size = field(lanes, EV_HI, i)
        set_field(lanes, EVENT, i, 0.0)
    p1, u1, dw, dk, dx, dwd, err, nu1, clean, frame1, rough = try_step(
        p, u, q, d, sn, step_size, g, s0, s1, s2, s3, shared, b, c, p_lo, p_hi, joint, rtol, atol,
        frame)
    hi = step_size
    if rough and not fresh(lanes, i):  # (never a located step: it is not clean)
        # a dip of s_nu nu through 0 and back inside the step (docs/physics.md
        # §5.1): shrink the step until the event shows at a step's end, where
        # locate_event below finds it on the end's sign alone
        if ADAPTIVE:
            if err <= 1.0:  # (a step rejected for its error shrinks as usual, below)
                set_field(lanes, NREJ, i, field(lanes, NREJ, i) + 1.0)
                h_next = step_size * ROUGH_SHRINK
                set_field(lanes, HN, i, h_next)
                set_field(lanes, REJB, i, 1.0)
                if not (h_next > SMALLEST_STEP * max(t, 1.0)):
                    set_field(lanes, STATUS, i, st.DIVERGED)
                return
        else:
            # a fixed step keeps its size: the shorter step only probes the
            # dip, and where its end sees it, that is the event to locate
            probe = try_step(p, u, q, d, sn, ROUGH_SHRINK * step_size, g, s0, s1, s2, s3, shared,
                             b, c, p_lo, p_hi, joint, rtol, atol, frame)
            if not probe[8]:
                hi = ROUGH_SHRINK * step_size
                p1, u1, dw, dk, dx, dwd, err, nu1, clean, frame1, rough = probe
    if not clean and not located:
        # the event: the step size hi of the first step that is not clean
        # (the one before it, lo, adjacent, is), and that step
        step_size, (p1, u1, dw, dk, dx, dwd, err, nu1, clean, frame1, rough) = locate_event(
            p, u, q, d, sn, hi, g, s0, s1, s2, s3, shared, b, c, p_lo, p_hi, joint, rtol,
            atol, frame, (p1, u1, dw, dk, dx, dwd, err, nu1, clean, frame1, rough))
    if ADAPTIVE:
        if not (err <= 1.0):  # rejected (NaN included): shrink and try again
            set_field(lanes, NREJ, i, field(lanes, NREJ, i) + 1.0)
            h_next = step_size * rejected_factor(err)
            set_field(lanes, HN, i, h_next)
            set_field(lanes, REJB, i, 1.0)
            if not (h_next > SMALLEST_STEP * max(t, 1.0)):
                set_field(lanes, STATUS, i, st.DIVERGED)
            return
        if clean:  # an event step's size says nothing of the next one's
            set_field(lanes, HN, i, step_size * accepted_factor(
                err, field(lanes, EPREV, i), field(lanes, REJB, i) != 0.0))
            set_field(lanes, EPREV, i, max(err, ERROR_FLOOR))
        set_field(lanes, REJB, i, 0.0)
    in_row = 0.0 if clean else field(lanes, INROW, i) + 1.0
    set_field(lanes, INROW, i, in_row)
    # nu may be +-inf at a cusp (infinite curvature, frictionless): not NaN
    finite = (math.isfinite(p1) and math.isfinite(u1) and math.isfinite(dw)
              and nu1 == nu1 and math.isfinite(dk))
    if not finite or in_row > MAX_EVENTS_IN_ROW:
        set_field(lanes, STATUS, i, st.DIVERGED)
        return
    set_field(lanes, T, i, t + step_size)
    set_field(lanes, STEPS, i, field(lanes, STEPS, i) + 1.0)
    set_field(lanes, WORK, i, field(lanes, WORK, i) + dw)
    set_field(lanes, CURV, i, field(lanes, CURV, i) + dk)
    set_field(lanes, DISP, i, field(lanes, DISP, i) + dx)
    set_field(lanes, PATH, i, field(lanes, PATH, i) + (d * dx))
    if DRAG:
        set_field(lanes, DRAGW, i, field(lanes, DRAGW, i) + dwd)
    set_field(lanes, NUMIN, i, min(field(lanes, NUMIN, i), side * nu1))
    # an exit step ends on the end (p1 passes it by the bisection's last float)
    dx_step, x_now = x_travelled(p, field(lanes, XNOW, i), field(lanes, COSNOW, i),
                                 min(max(p1, p_lo), p_hi), frame1[1], s0, s1, s2, s3, shared)
    set_field(lanes, XNOW, i, x_now)
    store_frame(lanes, i, frame1)
    set_field(lanes, PATHX, i, field(lanes, PATHX, i) + dx_step)
    set_field(lanes, U, i, u1)
    if clean:
        set_field(lanes, P, i, p1)
        return
    if not (p1 <= p_hi):  # exits first: the end is where the trajectory ends
        set_field(lanes, P, i, p_hi)
        set_field(lanes, STATUS, i, st.EXITED)
        return
    if not (p1 >= p_lo):
        set_field(lanes, P, i, p_lo)
        set_field(lanes, STATUS, i, st.EXITED)
        return
    set_field(lanes, P, i, p1)
    if not (sn * nu1 > 0.0):
        if ONE_SIDED:
            set_field(lanes, PLIFT, i, p1)
            set_field(lanes, STATUS, i, st.LIFTED_OFF)
            return
        sn = -sn
        set_field(lanes, SN, i, sn)
    if not (d * u1 > 0.0):
        set_field(lanes, U, i, 0.0)
        d, status = rest_rule(p1, mu_k, field(lanes, MUS, i), g, side, s0, s1, s2, s3, shared)
        set_field(lanes, D, i, d)
        set_field(lanes, STATUS, i, status)
        if status == st.NOT_RUN:
            set_field(lanes, NREV, i, field(lanes, NREV, i) + 1.0)
            _, cos_r, kappa_r, _ = curve_frame(p1, s0, s1, s2, s3, shared)
            set_field(lanes, SN, i, contact_sign(g * cos_r, kappa_r, side))
        elif status == st.LIFTED_OFF:
            set_field(lanes, PLIFT, i, p1)


def empty_outputs(n: int) -> tuple[np.ndarray, np.ndarray]:
    """``out`` and ``status`` arrays for ``n`` trajectories."""
    return np.zeros((len(OUTPUTS), n)), np.zeros(n, dtype=np.int8)
