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
located inside the step by bisection on the step size with the scene's own
method, to rounding: the largest clean step size and the smallest that is
not are adjacent floats, and the step of the latter is committed.  Then the
rest rule (§5) decides at a stop.

The functions here are templates: ``curve_frame``, ``curve_point``,
``curve_step`` and the helper names are globals bound per scene by
:func:`build_curve_kernel` through ``jit.specialise``, with the switches
``ONE_SIDED``, ``FRICTION`` and ``DRAG*``: a scene compiles only the effects
it uses.  Each trajectory runs alone, with no data-dependent choice shared
between trajectories, so results do not depend on the batch it is run in.
"""

from __future__ import annotations

import math

import numpy as np

from . import status as st
from .control import ERROR_FLOOR, FACTOR_MAX, FACTOR_MIN, SAFETY
from .curve_steppers import CURVE_STEPPERS, _dop853_stages, _stage, normal_along_n
from .jit import fma, specialise

# bound per scene by build_curve_kernel (compile-time constants)
curve_frame = curve_point = curve_step = try_step = rest_rule = trajectory = None
contact_sign = x_travelled = None
ADAPTIVE = False  # an embedded pair with step-size control (per trajectory)
PI_ALPHA = PI_BETA = SHRINK = 0.0  # the pair's step-size control (CURVE_STEPPERS)
JOINTS = False  # the curve has a joint (a curvature jump): steps end there, and the
# family reads its last shape parameter as the branch (core/curves.py)
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
          "drag_b", "drag_c", "p_joint")
(I_P, I_U, I_MUK, I_MUS, I_G, I_M, I_S0, I_S1, I_S2, I_S3, I_LO, I_HI, I_B, I_C,
 I_JOINT) = range(len(INPUTS))
#: events in a row without a full step between them before a trajectory is declared diverged
MAX_EVENTS_IN_ROW = 100
#: an adaptive step that shrinks below this fraction of the time reached is a divergence
SMALLEST_STEP = 1e-14


def _try_step(p, u, q, d, sn, h, g, s0, s1, s2, s3, shared, b, c, p_lo, p_hi, joint, rtol, atol):
    """One step and whether it is clean (no event condition fired):
    ``(p1, u1, dw, dk, dx, dwd, err, nu1, clean, cos_phi1)``.  NaN fails every comparison,
    so a non-finite step is not clean.  Reaching an end exactly is not an
    exit (a first-order step from rest does not move p); passing it is.
    With ``JOINTS``, a step that crosses ``joint`` (a curvature jump; NaN:
    none) is not clean either: the step is cut to end just past it, so no
    step integrates across the jump and every method keeps its order."""
    p1, u1, dw, dk, dx, dwd, err = curve_step(p, u, q, d, h, g, s0, s1, s2, s3, shared, b, c,
                                             rtol, atol)
    _, cos1, kappa1, _ = curve_frame(p1, s0, s1, s2, s3, shared)
    nu1 = normal_along_n(u1, cos1, kappa1, g)
    clean = (d * u1 > 0.0) and (p1 >= p_lo) and (p1 <= p_hi) and (sn * nu1 > 0.0)
    if JOINTS:
        clean = clean and not ((p - joint) * (p1 - joint) < 0.0)
    return p1, u1, dw, dk, dx, dwd, err, nu1, clean, cos1


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


def _trajectory(inputs, j, shared, h, t_max, side, rtol, atol, out):
    """One trajectory from column j of ``inputs``; writes column j of ``out``
    and returns its status.  ``h``: the step (an adaptive pair's first).

    An adaptive step is accepted where its error norm is <= 1, with the ramp
    kernel's PI controller (control.py); a step with an event is judged at
    the event, after it is located (its error is that of the shorter step)."""
    p = inputs[I_P, j]
    u = inputs[I_U, j]
    mu_k = inputs[I_MUK, j]
    mu_s = inputs[I_MUS, j]
    g = inputs[I_G, j]
    s0 = inputs[I_S0, j]
    s1 = inputs[I_S1, j]
    s2 = inputs[I_S2, j]
    s3 = inputs[I_S3, j]
    p_lo = inputs[I_LO, j]
    p_hi = inputs[I_HI, j]
    b = inputs[I_B, j]
    c = inputs[I_C, j]
    joint = inputs[I_JOINT, j]
    x_now, y0 = curve_point(p, s0, s1, s2, s3, shared)
    energy_start = fma(g, y0, 0.5 * u * u)
    t = 0.0
    work = curvature = displacement = path = path_x = drag_work = 0.0
    reversals = 0
    steps = 0
    rejected = 0
    in_row = 0
    h_next = h
    error_previous = ERROR_FLOOR
    rejected_before = False
    status = st.NOT_RUN
    p_lift = math.nan
    sin0, cos0, kappa0, _ = curve_frame(p, s0, s1, s2, s3, shared)
    cos_now = cos0
    nu = normal_along_n(u, cos0, kappa0, g)
    nu_min = side * nu
    d = 0.0
    if u == 0.0:
        d, status = rest_rule(p, mu_k, mu_s, g, side, s0, s1, s2, s3, shared)
    else:
        d = 1.0 if u > 0.0 else -1.0
        if ONE_SIDED and side * nu <= 0.0:
            status = st.LIFTED_OFF
    if status == st.LIFTED_OFF:
        p_lift = p
    sn = contact_sign(nu, kappa0, side)
    if status == st.NOT_RUN and ((d > 0.0 and p >= p_hi) or (d < 0.0 and p <= p_lo)):
        status = st.EXITED
    while status == st.NOT_RUN:
        if t >= t_max:
            status = st.TIMEOUT
            break
        step_size = h_next if t + h_next <= t_max else t_max - t
        q = d * mu_k * sn
        if JOINTS:  # the piece the step starts on, or moves into from the joint
            s3 = d if p == joint else (1.0 if p > joint else -1.0)
            if joint != joint:
                s3 = 0.0
        p1, u1, dw, dk, dx, dwd, err, nu1, clean, cos1 = try_step(
            p, u, q, d, sn, step_size, g, s0, s1, s2, s3, shared, b, c, p_lo, p_hi, joint, rtol,
            atol)
        if not clean:
            # the event: bisect on the step size to adjacent floats lo < hi,
            # lo clean, hi not, and take the step of size hi
            lo = 0.0
            hi = step_size
            while True:
                mid = 0.5 * (lo + hi)
                if not (lo < mid < hi):
                    break
                if try_step(p, u, q, d, sn, mid, g, s0, s1, s2, s3, shared, b, c, p_lo, p_hi,
                            joint, rtol, atol)[8]:
                    lo = mid
                else:
                    hi = mid
            step_size = hi
            p1, u1, dw, dk, dx, dwd, err, nu1, clean, cos1 = try_step(
                p, u, q, d, sn, step_size, g, s0, s1, s2, s3, shared, b, c, p_lo, p_hi, joint, rtol,
            atol)
        if ADAPTIVE:
            if not (err <= 1.0):  # rejected (NaN included): shrink and try again
                rejected += 1
                factor = FACTOR_MIN
                if err == err:
                    factor = max(FACTOR_MIN, SAFETY * err ** -SHRINK)
                h_next = step_size * factor
                rejected_before = True
                if not (h_next > SMALLEST_STEP * max(t, 1.0)):
                    status = st.DIVERGED
                    break
                continue
            if clean:  # an event step's size says nothing of the next one's
                factor = SAFETY * max(err, 1e-30) ** -PI_ALPHA * error_previous ** PI_BETA
                factor = min(max(factor, FACTOR_MIN), 1.0 if rejected_before else FACTOR_MAX)
                h_next = step_size * factor
                error_previous = max(err, ERROR_FLOOR)
            rejected_before = False
        if clean:
            in_row = 0
        else:
            in_row += 1
        # nu may be +-inf at a cusp (infinite curvature, frictionless): not NaN
        finite = (math.isfinite(p1) and math.isfinite(u1) and math.isfinite(dw)
                  and nu1 == nu1 and math.isfinite(dk))
        if not finite or in_row > MAX_EVENTS_IN_ROW:
            status = st.DIVERGED
            break
        t += step_size
        steps += 1
        work += dw
        curvature += dk
        displacement += dx
        path += d * dx
        if DRAG:
            drag_work += dwd
        nu_min = min(nu_min, side * nu1)
        # an exit step ends on the end (p1 passes it by the bisection's last float)
        dx_step, x_now = x_travelled(p, x_now, cos_now, min(max(p1, p_lo), p_hi), cos1, s0, s1,
                                     s2, s3, shared)
        cos_now = cos1
        path_x += dx_step
        if clean:
            p = p1
            u = u1
            continue
        if not (p1 <= p_hi):  # exits first: the end is where the trajectory ends
            p = p_hi
            u = u1
            status = st.EXITED
            break
        if not (p1 >= p_lo):
            p = p_lo
            u = u1
            status = st.EXITED
            break
        p = p1
        u = u1
        if not (sn * nu1 > 0.0):
            if ONE_SIDED:
                p_lift = p
                status = st.LIFTED_OFF
                break
            sn = -sn
        if not (d * u1 > 0.0):
            u = 0.0
            d, status = rest_rule(p, mu_k, mu_s, g, side, s0, s1, s2, s3, shared)
            if status == st.NOT_RUN:
                reversals += 1
                _, cos_r, kappa_r, _ = curve_frame(p, s0, s1, s2, s3, shared)
                sn = contact_sign(g * cos_r, kappa_r, side)
            elif status == st.LIFTED_OFF:
                p_lift = p
    m = inputs[I_M, j]
    x_end, y_end = curve_point(p, s0, s1, s2, s3, shared)
    energy_end = fma(g, y_end, 0.5 * u * u)
    out[O_T, j] = t
    out[O_P, j] = p
    out[O_U, j] = u
    out[O_X, j] = x_end
    out[O_Y, j] = y_end
    out[O_W, j] = m * work
    out[O_WE, j] = m * (energy_start - energy_end)
    out[O_WD, j] = m * drag_work
    out[O_BAL, j] = m * (work + drag_work - (energy_start - energy_end))
    out[O_DISP, j] = displacement
    out[O_PATH, j] = path
    out[O_XPATH, j] = path_x
    out[O_KMEAN, j] = curvature / path if path > 0.0 else kappa0
    out[O_NUMIN, j] = m * nu_min
    out[O_PLIFT, j] = p_lift
    if p_lift == p_lift:
        x_lift, y_lift = curve_point(p_lift, s0, s1, s2, s3, shared)
        out[O_XLIFT, j] = x_lift
        out[O_YLIFT, j] = y_lift
    else:
        out[O_XLIFT, j] = math.nan
        out[O_YLIFT, j] = math.nan
    out[O_NREV, j] = reversals
    out[O_STEPS, j] = steps
    out[O_REJECTED, j] = rejected
    return status


def _batch(inputs, shared, h, t_max, side, rtol, atol, out, status):
    """Every column of ``inputs`` (rows :data:`INPUTS`) into ``out`` (rows
    :data:`OUTPUTS`) and ``status``."""
    for j in range(inputs.shape[1]):
        status[j] = trajectory(inputs, j, shared, h, t_max, side, rtol, atol, out)


def build_curve_kernel(key: str, frame, point, method: str, *, one_sided: bool = True,
                       friction: bool = True, drag_linear: bool = False,
                       drag_quadratic: bool = False, joints: bool = False, cache: bool = True):
    """The batch function ``(inputs, shared, h, t_max, side, rtol, atol,
    out, status)`` of one curve family (``key`` names it uniquely;
    ``frame``, ``point`` its jitted functions) and ``method``, compiled with
    only the effects asked for."""
    if method not in CURVE_STEPPERS:
        raise ValueError(f"unknown curve method {method!r}; allowed: {', '.join(CURVE_STEPPERS)}")
    flags = "".join(suffix for on, suffix in (
        (one_sided, "_one"), (friction, "_friction"), (drag_linear, "_dragb"),
        (drag_quadratic, "_dragc"), (joints, "_joints")) if on)
    name = f"curve_{key}_{method}{flags}"
    _, _, adaptive, control = CURVE_STEPPERS[method]
    alpha, beta, shrink = control if adaptive else (0.0, 0.0, 0.0)
    constants = {"curve_frame": frame, "curve_point": point, "ONE_SIDED": one_sided,
                 "ADAPTIVE": adaptive, "PI_ALPHA": alpha, "PI_BETA": beta, "SHRINK": shrink,
                 "JOINTS": joints,
                 "FRICTION": friction, "DRAG_LINEAR": drag_linear,
                 "DRAG_QUADRATIC": drag_quadratic, "DRAG": drag_linear or drag_quadratic}
    options = {} if cache else {"cache": False}

    def build(template, suffix, **more):
        constants.update(more)
        return specialise(template, f"{name}_{suffix}", dict(constants), **options)

    built_stage = build(_stage, "stage")
    more = {"stage": built_stage}
    if method == "dop853":  # its stages are a template of their own (they call `stage`)
        more["stage_rates"] = build(_dop853_stages, "rates", stage=built_stage)
    built_step = build(CURVE_STEPPERS[method][0], "step", **more)
    built_try = build(_try_step, "try", curve_step=built_step)
    built_rest = build(_rest_rule, "rest")
    built_sign = build(_contact_sign, "sign")
    built_x = build(_x_travelled, "xpath")
    built_trajectory = build(_trajectory, "trajectory", try_step=built_try, rest_rule=built_rest,
                             contact_sign=built_sign, x_travelled=built_x)
    return build(_batch, "batch", trajectory=built_trajectory)


def empty_outputs(n: int) -> tuple[np.ndarray, np.ndarray]:
    """``out`` and ``status`` arrays for ``n`` trajectories."""
    return np.zeros((len(OUTPUTS), n)), np.zeros(n, dtype=np.int8)
