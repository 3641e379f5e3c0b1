"""Fixed-step integrators, as templates specialised per scene (see ``jit.specialise``).

Each advances the state of one trajectory by ``h`` within a mode (direction
``d`` and signed friction ``q`` fixed) and returns

    (x_new, v_new, friction_work, curvature_integral)

the last two being the increments over the step of the per-unit-mass
integrals  ∫ q n v dt  (= ∫ mu_k |n| |v| dt, paper eq. 13)  and  ∫ f'' d v dt,
each integrated with the method's own order.  Using ``d v`` rather than ``|v|``
keeps every integrand smooth up to the event.  The path ∫ |v| dt needs no
integral of its own: within a mode it is ``d (x_end - x_start)``.

``fp, fpp`` are f', f'' at the start point (carried over from the previous
step, or re-evaluated where that is cheaper).  The global
``ramp_slope_curvature(x, p0, p1, p2, p3, shared) -> (f', f'')`` is bound by
``specialise``.
"""

from .jit import fma
from .physics import acceleration, normal_term

ramp_slope_curvature = None  # bound per scene by jit.specialise


def euler_step(x, v, fp, fpp, q, d, h, g, p0, p1, p2, p3, shared):
    """The paper's explicit Euler scheme, eqs. (22)-(23)."""
    n = normal_term(v, fpp, g)
    a = acceleration(n, fp, q)
    return fma(h, v, x), fma(h, a, v), h * q * n * v, h * fpp * d * v


def semi_implicit_euler_step(x, v, fp, fpp, q, d, h, g, p0, p1, p2, p3, shared):
    """Symplectic Euler: velocity first, then position with the new velocity."""
    n = normal_term(v, fpp, g)
    a = acceleration(n, fp, q)
    v_new = fma(h, a, v)
    x_new = fma(h, v_new, x)
    return x_new, v_new, h * q * n * v, h * fpp * d * v


def rk4_step(x, v, fp, fpp, q, d, h, g, p0, p1, p2, p3, shared):
    """Classical fourth-order Runge-Kutta on (x, v) and the three integrals."""
    half = 0.5 * h
    n1 = normal_term(v, fpp, g)
    a1 = acceleration(n1, fp, q)

    x2 = fma(half, v, x)
    v2 = fma(half, a1, v)
    fp2, fpp2 = ramp_slope_curvature(x2, p0, p1, p2, p3, shared)
    n2 = normal_term(v2, fpp2, g)
    a2 = acceleration(n2, fp2, q)

    x3 = fma(half, v2, x)
    v3 = fma(half, a2, v)
    fp3, fpp3 = ramp_slope_curvature(x3, p0, p1, p2, p3, shared)
    n3 = normal_term(v3, fpp3, g)
    a3 = acceleration(n3, fp3, q)

    x4 = fma(h, v3, x)
    v4 = fma(h, a3, v)
    fp4, fpp4 = ramp_slope_curvature(x4, p0, p1, p2, p3, shared)
    n4 = normal_term(v4, fpp4, g)
    a4 = acceleration(n4, fp4, q)

    sixth = h / 6.0
    x_new = fma(sixth, v + 2.0 * (v2 + v3) + v4, x)
    v_new = fma(sixth, a1 + 2.0 * (a2 + a3) + a4, v)
    work = q * sixth * (n1 * v + 2.0 * (n2 * v2 + n3 * v3) + n4 * v4)
    curvature = d * sixth * (fpp * v + 2.0 * (fpp2 * v2 + fpp3 * v3) + fpp4 * v4)
    return x_new, v_new, work, curvature


#: method name -> (template, order)
STEPPERS = {
    "euler": (euler_step, 1),
    "semi_implicit_euler": (semi_implicit_euler_step, 1),
    "rk4": (rk4_step, 4),
}
