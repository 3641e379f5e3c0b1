"""Fixed-step integrators, as templates specialised per scene (see ``jit.specialise``).

Each advances the state of one trajectory by ``h`` within a mode (direction
``d`` and signed friction ``q`` fixed) and returns

    (x_new, v_new, friction_work, curvature_integral, drag_work)

the last three being the increments over the step of the per-unit-mass
integrals  ∫ q n v dt  (= ∫ mu_k |n| |v| dt, paper eq. 13),  ∫ f'' d v dt  and
∫ k v^2 (1 + f'^2) dt  (air drag's power, ``physics.drag_rate``; 0.0 in
kernels built without drag), each integrated with the method's own order.  Using ``d v`` rather than ``|v|``
keeps every integrand smooth up to the event.  The path ∫ |v| dt needs no
integral of its own: within a mode it is ``d (x_end - x_start)``.

``qh`` is ``h * q`` as the caller computed it (the vector loop keeps it per
lane: one multiplication fewer per step).

``fp, fpp`` are f', f'' at the start point (carried over from the previous
step, or re-evaluated where that is cheaper).  The global
``ramp_slope_curvature(x, p0, p1, p2, p3, shared) -> (f', f'')`` is bound by
``specialise``, and so are the air-drag switches ``DRAG_LINEAR``,
``DRAG_QUADRATIC`` and ``DRAG`` (either): without drag every ``if DRAG:``
block is removed and the arithmetic is that of a build without the feature.
Drag's coefficients ``b`` (1/s) and ``c`` (1/m) come per trajectory.
"""

from typing import Callable, NamedTuple

from . import dop853
from .control import (PI_DOP853, PI_DOPRI5, error_norm2, error_norm2_drag,
                      error_norm2_two_estimates, error_norm2_two_estimates_drag)
from .jit import fma, jit
from .physics import acceleration, drag_rate, normal_term

ramp_slope_curvature = None  # bound per scene by jit.specialise
# A family may offer f', f'' at a stage point x0 + dx from those at the step's
# start x0 (cheaper than evaluating them afresh: the sine's angle sum):
# ``ramp_slope_curvature_near(x, dx, fp0, fpp0, p0, p1, p2, p3, shared)``,
# x = x0 + dx rounded.  RK4 uses it where STAGE_FROM_START (bound per scene), and
# every fixed-step kernel for its steps' ends (kernel_vector._step_and_check).
STAGE_FROM_START = False
ramp_slope_curvature_near = None
# RK4's two parts, bound per scene (build_kernel specialises the templates
# _rk4_first_stages and _rk4_last_stages under these names)
rk4_first_stages = rk4_last_stages = None
DRAG_LINEAR = DRAG_QUADRATIC = DRAG = False  # bound per scene by jit.specialise
FRICTION = True  # False: mu_k = 0 everywhere; no friction work (and `acceleration` frictionless)


def euler_step(x, v, fp, fpp, q, qh, d, h, g, p0, p1, p2, p3, shared, b, c):
    """The paper's explicit Euler scheme, eqs. (22)-(23)."""
    n = normal_term(v, fpp, g)
    a = acceleration(n, fp, q)
    drag = 0.0
    if DRAG:
        kd = drag_rate(v, fp, b, c, d, DRAG_LINEAR, DRAG_QUADRATIC)
        a = fma(-kd, v, a)
        drag = h * kd * (v * v) * fma(fp, fp, 1.0)
    work = qh * n * v if FRICTION else 0.0  # h q n v
    return fma(h, v, x), fma(h, a, v), work, h * fpp * d * v, drag


def semi_implicit_euler_step(x, v, fp, fpp, q, qh, d, h, g, p0, p1, p2, p3, shared, b, c):
    """Symplectic Euler: velocity first, then position with the new velocity."""
    n = normal_term(v, fpp, g)
    a = acceleration(n, fp, q)
    drag = 0.0
    if DRAG:
        kd = drag_rate(v, fp, b, c, d, DRAG_LINEAR, DRAG_QUADRATIC)
        a = fma(-kd, v, a)
        drag = h * kd * (v * v) * fma(fp, fp, 1.0)
    v_new = fma(h, a, v)
    x_new = fma(h, v_new, x)
    work = qh * n * v if FRICTION else 0.0  # h q n v
    return x_new, v_new, work, h * fpp * d * v, drag


def rk4_step(x, v, fp, fpp, q, qh, d, h, g, p0, p1, p2, p3, shared, b, c):
    """Classical fourth-order Runge-Kutta on (x, v) and the integrals: its
    first two stages, then its last two and the sums (two parts so that the
    vector loop can run them in two lane loops, kernel_globals.SPLIT_STEP; called
    together here, the arithmetic is the same)."""
    a1, v2, a2, n1v, n2v2, fpp2v2, pd1, pd2 = rk4_first_stages(
        x, v, fp, fpp, q, d, h, g, p0, p1, p2, p3, shared, b, c)
    return rk4_last_stages(x, v, fp, fpp, q, d, h, g, p0, p1, p2, p3, shared, b, c,
                           a1, v2, a2, n1v, n2v2, fpp2v2, pd1, pd2)


def _rk4_first_stages(x, v, fp, fpp, q, d, h, g, p0, p1, p2, p3, shared, b, c):
    """RK4's stages 1 and 2: what the last two stages and the sums need of
    them, ``(a1, v2, a2, n1 v, n2 v2, f''2 v2, pd1, pd2)`` (drag's powers
    0.0 without drag)."""
    half = 0.5 * h
    n1 = normal_term(v, fpp, g)
    a1 = acceleration(n1, fp, q)
    pd1 = pd2 = 0.0
    if DRAG:
        a1, pd1 = _with_drag(a1, v, fp, b, c, d)

    x2 = fma(half, v, x)
    v2 = fma(half, a1, v)
    if STAGE_FROM_START:
        fp2, fpp2 = ramp_slope_curvature_near(x2, half * v, fp, fpp, p0, p1, p2, p3, shared)
    else:
        fp2, fpp2 = ramp_slope_curvature(x2, p0, p1, p2, p3, shared)
    n2 = normal_term(v2, fpp2, g)
    a2 = acceleration(n2, fp2, q)
    if DRAG:
        a2, pd2 = _with_drag(a2, v2, fp2, b, c, d)
    return a1, v2, a2, n1 * v, n2 * v2, fpp2 * v2, pd1, pd2


def _rk4_last_stages(x, v, fp, fpp, q, d, h, g, p0, p1, p2, p3, shared, b, c,
                     a1, v2, a2, n1v, n2v2, fpp2v2, pd1, pd2):
    """RK4's stages 3 and 4 and the step's sums, from the step's start and
    what :func:`_rk4_first_stages` returned: ``(x_new, v_new, friction_work,
    curvature_integral, drag_work)``."""
    half = 0.5 * h
    x3 = fma(half, v2, x)
    v3 = fma(half, a2, v)
    if STAGE_FROM_START:
        fp3, fpp3 = ramp_slope_curvature_near(x3, half * v2, fp, fpp, p0, p1, p2, p3, shared)
    else:
        fp3, fpp3 = ramp_slope_curvature(x3, p0, p1, p2, p3, shared)
    n3 = normal_term(v3, fpp3, g)
    a3 = acceleration(n3, fp3, q)
    pd3 = pd4 = 0.0
    if DRAG:
        a3, pd3 = _with_drag(a3, v3, fp3, b, c, d)

    x4 = fma(h, v3, x)
    v4 = fma(h, a3, v)
    if STAGE_FROM_START:
        fp4, fpp4 = ramp_slope_curvature_near(x4, h * v3, fp, fpp, p0, p1, p2, p3, shared)
    else:
        fp4, fpp4 = ramp_slope_curvature(x4, p0, p1, p2, p3, shared)
    n4 = normal_term(v4, fpp4, g)
    a4 = acceleration(n4, fp4, q)
    if DRAG:
        a4, pd4 = _with_drag(a4, v4, fp4, b, c, d)

    sixth = h / 6.0
    x_new = fma(sixth, v + 2.0 * (v2 + v3) + v4, x)
    v_new = fma(sixth, a1 + 2.0 * (a2 + a3) + a4, v)
    work = q * sixth * (n1v + 2.0 * (n2v2 + n3 * v3) + n4 * v4) if FRICTION else 0.0
    curvature = d * sixth * (fpp * v + 2.0 * (fpp2v2 + fpp3 * v3) + fpp4 * v4)
    drag = 0.0
    if DRAG:
        drag = sixth * (pd1 + 2.0 * (pd2 + pd3) + pd4)
    return x_new, v_new, work, curvature, drag


@jit
def no_stage_shortcut(x, dx, fp, fpp, p0, p1, p2, p3, shared):
    """The binding of ``ramp_slope_curvature_near`` for families without one
    (never called: STAGE_FROM_START is False)."""
    return fp, fpp


def _with_drag(a, v, fp, b, c, d):
    """The acceleration with air drag added, and drag's power per unit mass."""
    kd = drag_rate(v, fp, b, c, d, DRAG_LINEAR, DRAG_QUADRATIC)
    return fma(-kd, v, a), kd * (v * v) * fma(fp, fp, 1.0)


class FixedStepMethod(NamedTuple):
    """A fixed-step method: its step template and what is known of its steps.

    ``first_order``: a step uses the start's n and v, so its friction work
    h q n v = h mu_k |n| |v| is >= 0, and a step that ends with d v > 0 moved
    x in direction d (explicit Euler: x + h v; semi-implicit: x + h v_new).
    ``linear_in_h``: x and v are linear in the step size (explicit Euler,
    drag included: its rate is the step start's): events are located in
    closed form.  ``split``: the step in two parts, ``(first, last)``
    (templates), with ``step`` = last(first): the vector loop runs them in
    two lane loops (kernel_globals.SPLIT_STEP)."""
    step: Callable
    order: int
    first_order: bool = False
    linear_in_h: bool = False
    split: tuple | None = None


#: fixed-step method name -> its method
STEPPERS = {
    "euler": FixedStepMethod(euler_step, 1, first_order=True, linear_in_h=True),
    "semi_implicit_euler": FixedStepMethod(semi_implicit_euler_step, 1, first_order=True),
    "rk4": FixedStepMethod(rk4_step, 4, split=(_rk4_first_stages, _rk4_last_stages)),
}


# ------------------------------------------------------------------------------
# Dormand-Prince 5(4): embedded pair with a 4th-order dense output
# ------------------------------------------------------------------------------
# Butcher tableau (Dormand & Prince 1980); the 7th stage is evaluated at the
# new state, so it is the next step's first ("first same as last").
A21 = 1 / 5
A31, A32 = 3 / 40, 9 / 40
A41, A42, A43 = 44 / 45, -56 / 15, 32 / 9
A51, A52, A53, A54 = 19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729
A61, A62, A63, A64, A65 = 9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656
B1, B3, B4, B5, B6 = 35 / 384, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84
# error weights: 5th-order minus embedded 4th-order solution
E1, E3, E4, E5, E6, E7 = (71 / 57600, -71 / 16695, 71 / 1920, -17253 / 339200, 22 / 525,
                          -1 / 40)
# dense output y(t0 + theta h) = y0 + h sum_j theta^j sum_s k_s P[s][j-1]
# (Shampine's 4th-order continuous extension, as in scipy's RK45)
P1 = (1.0, -8048581381 / 2820520608, 8663915743 / 2820520608, -12715105075 / 11282082432)
P3 = (0.0, 131558114200 / 32700410799, -68118460800 / 10900136933, 87487479700 / 32700410799)
P4 = (0.0, -1754552775 / 470086768, 14199869525 / 1410260304, -10690763975 / 1880347072)
P5 = (0.0, 127303824393 / 49829197408, -318862633887 / 49829197408,
      701980252875 / 199316789632)
P6 = (0.0, -282668133 / 205662961, 2019193451 / 616988883, -1453857185 / 822651844)
P7 = (0.0, 40617522 / 29380423, -110615467 / 29380423, 69997945 / 29380423)


def _stage(x, v, q, g, p0, p1, p2, p3, shared, b, c, d):
    """f', f'', n, the acceleration and drag's power at one stage point."""
    fp, fpp = ramp_slope_curvature(x, p0, p1, p2, p3, shared)
    n = normal_term(v, fpp, g)
    a = acceleration(n, fp, q)
    if DRAG:
        a, pd = _with_drag(a, v, fp, b, c, d)
        return fp, fpp, n, a, pd
    return fp, fpp, n, a, 0.0


def _dopri5_stages(x, v, fp, fpp, a1, q, d, h, g, p0, p1, p2, p3, shared, b, c):
    """The stages of one Dormand-Prince step: the 7th is at the new state
    ``(x7, v7)``.  Returns ``(x7, v3..v7, a3..a7, n1, n3..n7, fpp3..fpp7,
    fp7, n_low, n_high, pd1, pd3..pd7)`` (the pd: drag's power, 0.0
    without drag; stage 2 only feeds the later stages; n_low and
    n_high bound the normal term over stages 2..7, which sample the step's
    interior: a sign change there that the step's ends do not show is how a
    long step would otherwise step over a lift-off)."""
    n1 = normal_term(v, fpp, g)
    pd1 = 0.0
    if DRAG:  # a1 (carried over) has its drag already
        pd1 = drag_rate(v, fp, b, c, d, DRAG_LINEAR, DRAG_QUADRATIC) * (v * v) * fma(fp, fp, 1.0)
    x2 = fma(h * A21, v, x)
    v2 = fma(h * A21, a1, v)
    _, _, n2, a2, pd2 = _stage(x2, v2, q, g, p0, p1, p2, p3, shared, b, c, d)
    x3 = fma(h, fma(A32, v2, A31 * v), x)
    v3 = fma(h, fma(A32, a2, A31 * a1), v)
    _, fpp3, n3, a3, pd3 = _stage(x3, v3, q, g, p0, p1, p2, p3, shared, b, c, d)
    x4 = fma(h, fma(A43, v3, fma(A42, v2, A41 * v)), x)
    v4 = fma(h, fma(A43, a3, fma(A42, a2, A41 * a1)), v)
    _, fpp4, n4, a4, pd4 = _stage(x4, v4, q, g, p0, p1, p2, p3, shared, b, c, d)
    x5 = fma(h, fma(A54, v4, fma(A53, v3, fma(A52, v2, A51 * v))), x)
    v5 = fma(h, fma(A54, a4, fma(A53, a3, fma(A52, a2, A51 * a1))), v)
    _, fpp5, n5, a5, pd5 = _stage(x5, v5, q, g, p0, p1, p2, p3, shared, b, c, d)
    x6 = fma(h, fma(A65, v5, fma(A64, v4, fma(A63, v3, fma(A62, v2, A61 * v)))), x)
    v6 = fma(h, fma(A65, a5, fma(A64, a4, fma(A63, a3, fma(A62, a2, A61 * a1)))), v)
    _, fpp6, n6, a6, pd6 = _stage(x6, v6, q, g, p0, p1, p2, p3, shared, b, c, d)
    x7 = fma(h, fma(B6, v6, fma(B5, v5, fma(B4, v4, fma(B3, v3, B1 * v)))), x)
    v7 = fma(h, fma(B6, a6, fma(B5, a5, fma(B4, a4, fma(B3, a3, B1 * a1)))), v)
    fp7, fpp7, n7, a7, pd7 = _stage(x7, v7, q, g, p0, p1, p2, p3, shared, b, c, d)
    n_low = min(min(n2, n3), min(min(n4, n5), min(n6, n7)))
    n_high = max(max(n2, n3), max(max(n4, n5), max(n6, n7)))
    return (x7, v3, v4, v5, v6, v7, a3, a4, a5, a6, a7, n1, n3, n4, n5, n6, n7,
            fpp3, fpp4, fpp5, fpp6, fpp7, fp7, n_low, n_high, pd1, pd3, pd4, pd5, pd6, pd7)


def dopri5_step(x, v, fp, fpp, a1, q, d, h, g, p0, p1, p2, p3, shared, b, c):
    """One Dormand-Prince step of size h from (x, v), whose acceleration a1 is
    carried from the previous step (FSAL).  Returns

        (x_new, v_new, friction_work, curvature_integral,
         a_new, fp_new, fpp_new, err_x, err_v, err_work, err_curvature, n_low, n_high,
         err3_x, err3_v, err3_work, err3_curvature, drag_work, err_drag, err3_drag)

    the integrals' increments as in the fixed-step methods (5th order), the
    acceleration and f', f'' at the new state (the next step's first stage),
    the embedded error estimate of each of the four components, the range
    of the normal term over the stages, and a second (lower-order) error
    estimate where the pair has one (DOP853; zeros here), then the drag
    work's increment and estimates (zeros without drag)."""
    (x7, v3, v4, v5, v6, v7, a3, a4, a5, a6, a7, n1, n3, n4, n5, n6, n7,
     fpp3, fpp4, fpp5, fpp6, fpp7, fp7, n_low, n_high, pd1, pd3, pd4, pd5, pd6, pd7) = _dopri5_stages(
        x, v, fp, fpp, a1, q, d, h, g, p0, p1, p2, p3, shared, b, c)
    w1, w3, w4, w5, w6, w7 = n1 * v, n3 * v3, n4 * v4, n5 * v5, n6 * v6, n7 * v7
    k1, k3, k4, k5, k6, k7 = fpp * v, fpp3 * v3, fpp4 * v4, fpp5 * v5, fpp6 * v6, fpp7 * v7
    qh = q * h
    dh = d * h
    work = qh * _weigh5(w1, w3, w4, w5, w6) if FRICTION else 0.0
    curvature = dh * _weigh5(k1, k3, k4, k5, k6)
    err_x = h * _error6(v, v3, v4, v5, v6, v7)
    err_v = h * _error6(a1, a3, a4, a5, a6, a7)
    err_work = qh * _error6(w1, w3, w4, w5, w6, w7) if FRICTION else 0.0
    err_curvature = dh * _error6(k1, k3, k4, k5, k6, k7)
    drag = 0.0
    err_drag = 0.0
    if DRAG:
        drag = h * _weigh5(pd1, pd3, pd4, pd5, pd6)
        err_drag = h * _error6(pd1, pd3, pd4, pd5, pd6, pd7)
    return (x7, v7, work, curvature, a7, fp7, fpp7, err_x, err_v, err_work, err_curvature,
            n_low, n_high, 0.0, 0.0, 0.0, 0.0, drag, err_drag, 0.0)


def dopri5_dense(x, v, fp, fpp, a1, q, d, h, g, p0, p1, p2, p3, shared, b, c):
    """The step's dense output and end point, for events.  Returns

        (dense, x_new, v_new, fpp_new, err_work, n_low, n_high)

    ``dense`` holds the coefficients c_j (j = 1..4) of y(theta) = y0 + h sum_j
    c_j theta^j for x, v, the friction work and the curvature integral, in
    that order (16 numbers; 4th order, exact at both ends), and with drag
    four more for the drag work."""
    (x7, v3, v4, v5, v6, v7, a3, a4, a5, a6, a7, n1, n3, n4, n5, n6, n7,
     fpp3, fpp4, fpp5, fpp6, fpp7, _, n_low, n_high, pd1, pd3, pd4, pd5, pd6, pd7) = _dopri5_stages(
        x, v, fp, fpp, a1, q, d, h, g, p0, p1, p2, p3, shared, b, c)
    w1, w3, w4, w5, w6, w7 = q * n1 * v, q * n3 * v3, q * n4 * v4, q * n5 * v5, q * n6 * v6, q * n7 * v7
    k1, k3, k4, k5, k6, k7 = (d * fpp * v, d * fpp3 * v3, d * fpp4 * v4, d * fpp5 * v5,
                              d * fpp6 * v6, d * fpp7 * v7)
    dense = (_dense_row(0, v, v3, v4, v5, v6, v7), _dense_row(1, v, v3, v4, v5, v6, v7),
             _dense_row(2, v, v3, v4, v5, v6, v7), _dense_row(3, v, v3, v4, v5, v6, v7),
             _dense_row(0, a1, a3, a4, a5, a6, a7), _dense_row(1, a1, a3, a4, a5, a6, a7),
             _dense_row(2, a1, a3, a4, a5, a6, a7), _dense_row(3, a1, a3, a4, a5, a6, a7),
             _dense_row(0, w1, w3, w4, w5, w6, w7), _dense_row(1, w1, w3, w4, w5, w6, w7),
             _dense_row(2, w1, w3, w4, w5, w6, w7), _dense_row(3, w1, w3, w4, w5, w6, w7),
             _dense_row(0, k1, k3, k4, k5, k6, k7), _dense_row(1, k1, k3, k4, k5, k6, k7),
             _dense_row(2, k1, k3, k4, k5, k6, k7), _dense_row(3, k1, k3, k4, k5, k6, k7))
    if DRAG:
        dense = dense + (
            _dense_row(0, pd1, pd3, pd4, pd5, pd6, pd7), _dense_row(1, pd1, pd3, pd4, pd5, pd6, pd7),
            _dense_row(2, pd1, pd3, pd4, pd5, pd6, pd7), _dense_row(3, pd1, pd3, pd4, pd5, pd6, pd7))
    err_work = h * _error6(w1, w3, w4, w5, w6, w7)
    return dense, x7, v7, fpp7, err_work, n_low, n_high


@jit
def _dense_row(j, k1, k3, k4, k5, k6, k7):
    """sum_s k_s P[s][j] over the stages that enter the dense output."""
    return fma(P7[j], k7, fma(P6[j], k6, fma(P5[j], k5, fma(P4[j], k4, fma(P3[j], k3, P1[j] * k1)))))


# Weighted sums of stage values as chains of fused multiply-adds (fewer
# operations and roundings than products and sums; no fast-math needed).
@jit
def _weigh5(k1, k3, k4, k5, k6):
    """sum_s B_s k_s: the 5th-order solution's quadrature."""
    return fma(B6, k6, fma(B5, k5, fma(B4, k4, fma(B3, k3, B1 * k1))))


@jit
def _error6(k1, k3, k4, k5, k6, k7):
    """sum_s E_s k_s: the embedded error estimate."""
    return fma(E7, k7, fma(E6, k6, fma(E5, k5, fma(E4, k4, fma(E3, k3, E1 * k1)))))


def dopri5_dense_point(dense, h, theta, component):
    """Increment over [0, theta] of component 0 (x), 1 (v), 2 (friction work),
    3 (curvature integral) or, with drag, 4 (drag work) of the dense output."""
    o = 4 * component
    return h * theta * (dense[o] + theta * (dense[o + 1] + theta * (
        dense[o + 2] + theta * dense[o + 3])))


class AdaptivePair(NamedTuple):
    """An embedded pair: its templates, bound per scene by ``kernel.build_kernel``."""
    step: Callable
    order: int
    dense: Callable  # the step's dense output, for events
    dense_point: Callable  # evaluates ``dense``
    error_norm2: Callable  # squared error norm from the step's estimates
    pi_gains: tuple  # (alpha, beta) of the step-size controller
    helpers: tuple  # (global name, template) pairs the templates call
    error_norm2_drag: Callable  # the norm with the drag work as a fifth component
    #: largest h omega accepted (adaptive.py's swing test): beyond it the
    #: pair's embedded estimate no longer grows with its true error
    swing_limit: float = 0.5
    first_order = False  # (as FixedStepMethod's)
    linear_in_h = False


#: DOP853's estimate follows its error further out (8th order): on
#: throughput.py's bowl a bound of 2.0 takes its worst W error at rtol 1e-3
#: from 0.14 to 1.4e-3 and leaves its steps at rtol <= 1e-6 within 0.3 %
DOP853_SWING = 2.0

#: adaptive method name -> its pair
ADAPTIVE_STEPPERS = {
    "dopri5": AdaptivePair(dopri5_step, 5, dopri5_dense, dopri5_dense_point, error_norm2,
                           PI_DOPRI5, (("_with_drag", _with_drag), ("_stage", _stage),
                                       ("_dopri5_stages", _dopri5_stages)),
                           error_norm2_drag),
    "dop853": AdaptivePair(dop853.dop853_step, 8, dop853.dop853_dense,
                           dop853.dop853_dense_point, error_norm2_two_estimates, PI_DOP853,
                           (("_with_drag", _with_drag), ("_stage", _stage),
                            ("_dop853_stages", dop853._dop853_stages)),
                           error_norm2_two_estimates_drag, swing_limit=DOP853_SWING),
}

#: every stepping method by name: fixed-step methods, then adaptive pairs
METHODS = {**STEPPERS, **ADAPTIVE_STEPPERS}
