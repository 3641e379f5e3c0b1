"""Steps of the curve kernel (docs/physics.md §5), as templates specialised per scene.

Each advances ``(p, u)`` by ``h`` within a mode (direction ``d``, signed
friction ``q = d mu_k s_nu`` fixed) and returns

    (p_new, u_new, friction work, turning, displacement, drag work, error,
     nu_low, nu_high)

the increments of the per-unit-mass integrals ∫ q nu u dt
(= ∫ mu_k |nu| |u| dt), ∫ kappa d u dt, ∫ u dt and ∫ k u^2 dt, with the
method's own order, and the step's scaled error norm (an embedded pair's
estimate against ``atol + rtol |y|``; 0.0 for the fixed-step methods),
and the range ``(nu_low, nu_high)`` of the normal force over the step's
stages before its end (``0 <= c < 1``; +inf and -inf where there are
none), widened to 0 where :func:`nu_range`'s parabola through three
stages turns beyond 0 between them (over the wide gaps between the
stages' nodes): the kernel's check for a dip of ``nu`` through 0 and back
within one step (curve_kernel._try_step).  Stages at ``c = 1`` are left out: they are
lower-order predictions of the end, whose ``nu`` may cross 0 a step before
the solution does.
``curve_frame`` and the switches ``FRICTION``, ``DRAG*`` are bound per scene
by ``jit.specialise``; ``stage`` and ``stage_from`` are this module's
:func:`_stage` and :func:`_stage_from`, specialised.  Each step's last
argument ``frame`` is the curve's frame at ``p`` (``curve_frame(p, ...)``,
which the caller has): its first stage starts from it.  A step without
that argument works too (``curve_lanes.build_curve_kernel`` looks at the
signature), one frame evaluation dearer.
"""

from __future__ import annotations

import math

from .control import PI_DOP853, PI_DOPRI5
from .dop853 import (A2, A3, A4, A5, A6, A7, A8, A9, A10, A11, A12, _dot1, _dot2, _dot3, _dot4,
                     _dot5, _dot6, _dot7, _dot8, _dot9, _error3, _error5, _weigh8)
from .jit import fma, jit
from .steppers import (A21, A31, A32, A41, A42, A43, A51, A52, A53, A54, A61, A62, A63, A64,
                       A65, _error6, _weigh5)

curve_frame = stage = stage_from = stage_rates = None  # bound per scene
FRICTION = True
DRAG_LINEAR = DRAG_QUADRATIC = DRAG = False


@jit(internal=True)
def normal_along_n(u, cos_phi, kappa, g):
    """nu = kappa u^2 + g cos phi.  At u = 0 exactly it is g cos phi: at the
    cycloid's cusp the curvature is infinite and inf * 0 would be NaN."""
    centripetal = kappa * (u * u)
    return fma(g, cos_phi, centripetal if u != 0.0 else 0.0)


@jit(internal=True)
def _counts(coefficient):
    """1.0 where a work integral's coefficient is nonzero, else 0.0.  The
    error norm's RMS counts a work integral (and the friction terms exist)
    only for a trajectory that has the effect (friction: ``q != 0``; drag:
    ``|b| + |c| > 0``), so a trajectory steps as it would alone, whatever its
    sweep holds and whichever effects its kernel was compiled with: a kernel
    with every effect gives the specialised one's results bit for bit
    (rampwork.curves.curve_tier)."""
    return 1.0 if coefficient != 0.0 else 0.0


#: the nodes c (fractions of the step) of dopri5's stages 2..5 and of
#: DOP853's stages 2..11: the stages strictly inside a step
C_DOPRI5 = (0.2, 0.3, 0.8, 8.0 / 9.0)
(C2, C3, C4, C5, C6, C7, C8, C9, C10, C11) = (sum(A2), sum(A3), sum(A4), sum(A5), sum(A6),
                                              sum(A7), sum(A8), sum(A9), sum(A10), sum(A11))


@jit(internal=True)
def nu_range(x0, y0, x1, y1, x2, y2, low, high):
    """``(low, high)`` widened by what three stages' values say of nu over
    [x0, x2] (x0 < x1 < x2, fractions of the step): the values, and 0 where
    the parabola through them turns inside (its slopes at x0 and x2 differ
    in sign) beyond 0 (a minimum <= 0: low; a maximum >= 0: high).  So a
    dip of nu through 0 and back between two stages shows, though no stage
    sees it.  (Its vertex y1 - slope^2 / (4 a) is compared without dividing.)"""
    d1 = (y1 - y0) * (1.0 / (x1 - x0))
    d2 = (y2 - y1) * (1.0 / (x2 - x1))
    a = (d2 - d1) * (1.0 / (x2 - x0))
    slope = fma(a, x1 - x0, d1)  # at x1
    turns = fma(2.0 * a, x0 - x1, slope) * fma(2.0 * a, x2 - x1, slope) <= 0.0
    # the vertex is <= 0 for a > 0 (>= 0 for a < 0) iff 4 a y1 <= slope^2
    crosses = turns & (4.0 * a * y1 <= slope * slope)
    low = min(min(low, y0), min(y1, y2))
    high = max(max(high, y0), max(y1, y2))
    low = min(low, 0.0) if crosses & (a > 0.0) else low
    high = max(high, 0.0) if crosses & (a < 0.0) else high
    return low, high


def _stage(p, u, q, d, g, s0, s1, s2, s3, shared, b, c):
    """At one point: (du/dt, nu, kappa u, dp/ds, drag power per unit mass)."""
    return stage_from(curve_frame(p, s0, s1, s2, s3, shared), u, q, d, g, b, c)


def _stage_from(frame, u, q, d, g, b, c):
    """:func:`_stage` from the curve's frame at the point, ``(sin phi, cos phi,
    kappa, dp/ds)``: a step's first stage takes the frame its caller has
    (the lane kernel carries it from the previous step's end).  An infinite
    curvature (a cusp, a single point) turns nothing: kappa u is taken as 0
    there rather than inf * u."""
    sin_phi, cos_phi, kappa, dp_ds = frame
    nu = normal_along_n(u, cos_phi, kappa, g)
    a = -g * sin_phi
    if FRICTION and q != 0.0:  # a frictionless trajectory: no 0 * inf at a cusp
        a = fma(-q, nu, a)
    power = 0.0
    if DRAG:
        k = 0.0
        if DRAG_LINEAR:
            k = b
        if DRAG_QUADRATIC:
            k = fma(c, d * u, k)
        a = fma(-k, u, a)
        power = k * (u * u)
    turn = kappa * u if math.isfinite(kappa) else 0.0
    return a, nu, turn, dp_ds, power


def _euler_step(p, u, q, d, h, g, s0, s1, s2, s3, shared, b, c, rtol, atol, frame):
    a, nu, turn, dp_ds, power = stage_from(frame, u, q, d, g, b, c)
    work = h * q * nu * u if FRICTION and q != 0.0 else 0.0
    return (fma(h, u * dp_ds, p), fma(h, a, u), work, h * d * turn, h * u, h * power, 0.0,
            math.inf, -math.inf)


def _semi_implicit_euler_step(p, u, q, d, h, g, s0, s1, s2, s3, shared, b, c, rtol, atol, frame):
    a, nu, turn, dp_ds, power = stage_from(frame, u, q, d, g, b, c)
    u_new = fma(h, a, u)
    work = h * q * nu * u if FRICTION and q != 0.0 else 0.0
    return (fma(h, u_new * dp_ds, p), u_new, work, h * d * turn, h * u_new, h * power, 0.0,
            math.inf, -math.inf)


def _rk4_step(p, u, q, d, h, g, s0, s1, s2, s3, shared, b, c, rtol, atol, frame):
    half = 0.5 * h
    a1, nu1, k1, r1, pd1 = stage_from(frame, u, q, d, g, b, c)
    u2 = fma(half, a1, u)
    a2, nu2, k2, r2, pd2 = stage(fma(half, u * r1, p), u2, q, d, g, s0, s1, s2, s3, shared, b, c)
    u3 = fma(half, a2, u)
    a3, nu3, k3, r3, pd3 = stage(fma(half, u2 * r2, p), u3, q, d, g, s0, s1, s2, s3, shared, b, c)
    u4 = fma(h, a3, u)
    a4, nu4, k4, r4, pd4 = stage(fma(h, u3 * r3, p), u4, q, d, g, s0, s1, s2, s3, shared, b, c)
    sixth = h / 6.0
    p_new = fma(sixth, u * r1 + 2.0 * (u2 * r2 + u3 * r3) + u4 * r4, p)
    u_new = fma(sixth, a1 + 2.0 * (a2 + a3) + a4, u)
    work = (q * sixth * (nu1 * u + 2.0 * (nu2 * u2 + nu3 * u3) + nu4 * u4)
            if FRICTION and q != 0.0 else 0.0)
    curvature = d * sixth * (k1 + 2.0 * (k2 + k3) + k4)
    displacement = sixth * (u + 2.0 * (u2 + u3) + u4)
    drag = sixth * (pd1 + 2.0 * (pd2 + pd3) + pd4) if DRAG else 0.0
    # the midpoint stages (c = 1/2); the 4th (c = 1) predicts the end to first order
    return (p_new, u_new, work, curvature, displacement, drag, 0.0, min(nu2, nu3),
            max(nu2, nu3))


def _dopri5_step(p, u, q, d, h, g, s0, s1, s2, s3, shared, b, c, rtol, atol, frame):
    """Dormand-Prince 5(4) (the ramp kernel's tableau, steppers.py), without
    carrying the last stage over: the error norm covers p, u and the
    friction work (and the drag work with drag), RMS of err / (atol + rtol |y|)."""
    a1, n1, k1, r1, pd1 = stage_from(frame, u, q, d, g, b, c)
    v1 = u * r1
    u2 = fma(h * A21, a1, u)
    a2, n2, k2, r2, pd2 = stage(fma(h * A21, v1, p), u2, q, d, g, s0, s1, s2, s3, shared, b, c)
    v2 = u2 * r2
    u3 = fma(h, fma(A32, a2, A31 * a1), u)
    a3, n3, k3, r3, pd3 = stage(fma(h, fma(A32, v2, A31 * v1), p), u3, q, d, g, s0, s1, s2, s3,
                                shared, b, c)
    v3 = u3 * r3
    u4 = fma(h, fma(A43, a3, fma(A42, a2, A41 * a1)), u)
    a4, n4, k4, r4, pd4 = stage(fma(h, fma(A43, v3, fma(A42, v2, A41 * v1)), p), u4, q, d, g,
                                s0, s1, s2, s3, shared, b, c)
    v4 = u4 * r4
    u5 = fma(h, fma(A54, a4, fma(A53, a3, fma(A52, a2, A51 * a1))), u)
    a5, n5, k5, r5, pd5 = stage(fma(h, fma(A54, v4, fma(A53, v3, fma(A52, v2, A51 * v1))), p),
                                u5, q, d, g, s0, s1, s2, s3, shared, b, c)
    v5 = u5 * r5
    u6 = fma(h, fma(A65, a5, fma(A64, a4, fma(A63, a3, fma(A62, a2, A61 * a1)))), u)
    a6, n6, k6, r6, pd6 = stage(
        fma(h, fma(A65, v5, fma(A64, v4, fma(A63, v3, fma(A62, v2, A61 * v1)))), p), u6, q, d, g,
        s0, s1, s2, s3, shared, b, c)
    v6 = u6 * r6
    p7 = fma(h, _weigh5(v1, v3, v4, v5, v6), p)
    u7 = fma(h, _weigh5(a1, a3, a4, a5, a6), u)
    a7, n7, k7, r7, pd7 = stage(p7, u7, q, d, g, s0, s1, s2, s3, shared, b, c)
    v7 = u7 * r7
    w1, w3, w4, w5, w6, w7 = n1 * u, n3 * u3, n4 * u4, n5 * u5, n6 * u6, n7 * u7
    work = h * q * _weigh5(w1, w3, w4, w5, w6) if FRICTION and q != 0.0 else 0.0
    turn = h * d * _weigh5(k1, k3, k4, k5, k6)
    displacement = h * _weigh5(u, u3, u4, u5, u6)
    drag = h * _weigh5(pd1, pd3, pd4, pd5, pd6) if DRAG else 0.0
    err_p = h * _error6(v1, v3, v4, v5, v6, v7) / fma(rtol, max(abs(p), abs(p7)), atol)
    err_u = h * _error6(a1, a3, a4, a5, a6, a7) / fma(rtol, max(abs(u), abs(u7)), atol)
    squares = err_p * err_p + err_u * err_u
    count = 2.0
    if FRICTION and q != 0.0:
        err_w = h * q * _error6(w1, w3, w4, w5, w6, w7) / fma(rtol, abs(work), atol)
        squares += err_w * err_w
        count += 1.0
    if DRAG:
        err_d = h * _error6(pd1, pd3, pd4, pd5, pd6, pd7) / fma(rtol, abs(drag), atol)
        squares += err_d * err_d
        count += _counts(abs(b) + abs(c))
    # stages 1..5 (c = 0, 1/5, 3/10, 4/5, 8/9; 6 and 7 are at c = 1), with
    # the parabola over the wide gap from 3/10 to 4/5 (one over each gap
    # cost 27 % of the time per step on a wrapped ramp, this one 1 %)
    _, c3, c4, c5 = C_DOPRI5
    nu_low = min(min(n1, n2), min(n3, min(n4, n5)))
    nu_high = max(max(n1, n2), max(n3, max(n4, n5)))
    nu_low, nu_high = nu_range(c3, n3, c4, n4, c5, n5, nu_low, nu_high)
    return p7, u7, work, turn, displacement, drag, math.sqrt(squares / count), nu_low, nu_high


def _dop853_stages(p, u, q, d, h, g, s0, s1, s2, s3, shared, b, c, frame):
    """DOP853's stages 1..12 (core/dop853.py's tableau): 12-tuples of
    (dp/dt, du/dt, nu u, kappa u, speed, drag power) over the stages, and the
    range of nu over stages 1..11 (0 <= c < 1; the 12th is at c = 1), as
    :func:`_dop853_nu_range` takes it.  The new state uses stages 1 and
    6..12 only, so the 13th (at the new state, which the ramp kernel carries
    over to the next step) is not evaluated here."""
    a1, n1, k1, r1, pd1 = stage_from(frame, u, q, d, g, b, c)
    v1 = u * r1
    p2 = fma(h, _dot1(A2, v1), p)
    u2 = fma(h, _dot1(A2, a1), u)
    a2, n2, k2, r2, pd2 = stage(p2, u2, q, d, g, s0, s1, s2, s3, shared, b, c)
    v2 = u2 * r2
    p3 = fma(h, _dot2(A3, v1, v2), p)
    u3 = fma(h, _dot2(A3, a1, a2), u)
    a3, n3, k3, r3, pd3 = stage(p3, u3, q, d, g, s0, s1, s2, s3, shared, b, c)
    v3 = u3 * r3
    p4 = fma(h, _dot2(A4, v1, v3), p)
    u4 = fma(h, _dot2(A4, a1, a3), u)
    a4, n4, k4, r4, pd4 = stage(p4, u4, q, d, g, s0, s1, s2, s3, shared, b, c)
    v4 = u4 * r4
    p5 = fma(h, _dot3(A5, v1, v3, v4), p)
    u5 = fma(h, _dot3(A5, a1, a3, a4), u)
    a5, n5, k5, r5, pd5 = stage(p5, u5, q, d, g, s0, s1, s2, s3, shared, b, c)
    v5 = u5 * r5
    p6 = fma(h, _dot3(A6, v1, v4, v5), p)
    u6 = fma(h, _dot3(A6, a1, a4, a5), u)
    a6, n6, k6, r6, pd6 = stage(p6, u6, q, d, g, s0, s1, s2, s3, shared, b, c)
    v6 = u6 * r6
    p7 = fma(h, _dot4(A7, v1, v4, v5, v6), p)
    u7 = fma(h, _dot4(A7, a1, a4, a5, a6), u)
    a7, n7, k7, r7, pd7 = stage(p7, u7, q, d, g, s0, s1, s2, s3, shared, b, c)
    v7 = u7 * r7
    p8 = fma(h, _dot5(A8, v1, v4, v5, v6, v7), p)
    u8 = fma(h, _dot5(A8, a1, a4, a5, a6, a7), u)
    a8, n8, k8, r8, pd8 = stage(p8, u8, q, d, g, s0, s1, s2, s3, shared, b, c)
    v8 = u8 * r8
    p9 = fma(h, _dot6(A9, v1, v4, v5, v6, v7, v8), p)
    u9 = fma(h, _dot6(A9, a1, a4, a5, a6, a7, a8), u)
    a9, n9, k9, r9, pd9 = stage(p9, u9, q, d, g, s0, s1, s2, s3, shared, b, c)
    v9 = u9 * r9
    p10 = fma(h, _dot7(A10, v1, v4, v5, v6, v7, v8, v9), p)
    u10 = fma(h, _dot7(A10, a1, a4, a5, a6, a7, a8, a9), u)
    a10, n10, k10, r10, pd10 = stage(p10, u10, q, d, g, s0, s1, s2, s3, shared, b, c)
    v10 = u10 * r10
    p11 = fma(h, _dot8(A11, v1, v4, v5, v6, v7, v8, v9, v10), p)
    u11 = fma(h, _dot8(A11, a1, a4, a5, a6, a7, a8, a9, a10), u)
    a11, n11, k11, r11, pd11 = stage(p11, u11, q, d, g, s0, s1, s2, s3, shared, b, c)
    v11 = u11 * r11
    p12 = fma(h, _dot9(A12, v1, v4, v5, v6, v7, v8, v9, v10, v11), p)
    u12 = fma(h, _dot9(A12, a1, a4, a5, a6, a7, a8, a9, a10, a11), u)
    a12, n12, k12, r12, pd12 = stage(p12, u12, q, d, g, s0, s1, s2, s3, shared, b, c)
    v12 = u12 * r12
    nu_low, nu_high = _dop853_nu_range(n1, n2, n3, n4, n5, n6, n7, n8, n9, n10, n11)
    return ((v1, v2, v3, v4, v5, v6, v7, v8, v9, v10, v11, v12),
            (a1, a2, a3, a4, a5, a6, a7, a8, a9, a10, a11, a12),
            (n1 * u, n2 * u2, n3 * u3, n4 * u4, n5 * u5, n6 * u6, n7 * u7, n8 * u8, n9 * u9,
             n10 * u10, n11 * u11, n12 * u12),
            (k1, k2, k3, k4, k5, k6, k7, k8, k9, k10, k11, k12),
            (u, u2, u3, u4, u5, u6, u7, u8, u9, u10, u11, u12),
            (pd1, pd2, pd3, pd4, pd5, pd6, pd7, pd8, pd9, pd10, pd11, pd12),
            nu_low, nu_high)


@jit(internal=True)
def _dop853_nu_range(n1, n2, n3, n4, n5, n6, n7, n8, n9, n10, n11):
    """The range of nu over DOP853's stages 1..11 (c from 0 to 0.857), with
    :func:`nu_range`'s parabolas over the two wide gaps between them (c =
    0.333 to 0.6 and 0.651 to 0.857; below 0.333 seven stages lie within
    0.13 of each other).  Parabolas over every gap cost dop853 15-20 % of
    its time per step (benchmarks/rough_steps.py), these two ~0 %."""
    low = min(min(min(n1, n2), min(n3, n4)), min(min(n5, n6), min(n7, n8)))
    high = max(max(max(n1, n2), max(n3, n4)), max(max(n5, n6), max(n7, n8)))
    low, high = nu_range(C6, n6, C10, n10, C9, n9, low, high)
    return nu_range(C10, n10, C9, n9, C11, n11, low, high)



def _dop853_step(p, u, q, d, h, g, s0, s1, s2, s3, shared, b, c, rtol, atol, frame):
    """Dormand-Prince 8(5,3) (core/dop853.py's tableau and weights).  Error:
    dop853.f's combination of the fifth- and third-order estimates,
    err5^2 / sqrt(n (err5^2 + 0.01 err3^2)) over the n scaled components
    p, u and the friction work (and the drag work with drag), each against
    atol + rtol |y| as in :func:`_dopri5_step`."""
    velocities, accelerations, works, turns, speeds, powers, nu_low, nu_high = stage_rates(
        p, u, q, d, h, g, s0, s1, s2, s3, shared, b, c, frame)
    p_new = fma(h, _weigh8(velocities), p)
    u_new = fma(h, _weigh8(accelerations), u)
    work = h * q * _weigh8(works) if FRICTION and q != 0.0 else 0.0
    turn = h * d * _weigh8(turns)
    displacement = h * _weigh8(speeds)
    drag = h * _weigh8(powers) if DRAG else 0.0
    scale_p = fma(rtol, max(abs(p), abs(p_new)), atol)
    scale_u = fma(rtol, max(abs(u), abs(u_new)), atol)
    e5 = h * _error5(velocities) / scale_p
    e3 = h * _error3(velocities) / scale_p
    squares5 = e5 * e5
    squares3 = e3 * e3
    e5 = h * _error5(accelerations) / scale_u
    e3 = h * _error3(accelerations) / scale_u
    squares5 += e5 * e5
    squares3 += e3 * e3
    count = 2.0
    if FRICTION and q != 0.0:
        scale_w = fma(rtol, abs(work), atol)
        e5 = h * q * _error5(works) / scale_w
        e3 = h * q * _error3(works) / scale_w
        squares5 += e5 * e5
        squares3 += e3 * e3
        count += 1.0
    if DRAG:
        scale_d = fma(rtol, abs(drag), atol)
        e5 = h * _error5(powers) / scale_d
        e3 = h * _error3(powers) / scale_d
        squares5 += e5 * e5
        squares3 += e3 * e3
        count += _counts(abs(b) + abs(c))
    denominator = fma(0.01, squares3, squares5)
    error = squares5 / math.sqrt(count * denominator) if denominator > 0.0 else 0.0
    return p_new, u_new, work, turn, displacement, drag, error, nu_low, nu_high


#: method name -> (step template, order, adaptive, step-size control): the
#: control is (alpha, beta, shrink) of the PI controller in
#: curve_kernel._accepted_factor / _rejected_factor (control.py's gains per
#: pair; after a rejection the step shrinks by err^-shrink), None for the
#: fixed-step methods
CURVE_STEPPERS = {
    "euler": (_euler_step, 1, False, None),
    "semi_implicit_euler": (_semi_implicit_euler_step, 1, False, None),
    "rk4": (_rk4_step, 4, False, None),
    "dopri5": (_dopri5_step, 5, True, (*PI_DOPRI5, 0.2)),
    "dop853": (_dop853_step, 8, True, (*PI_DOP853, 1.0 / 8.0)),
}
