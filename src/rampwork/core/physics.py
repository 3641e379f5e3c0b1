"""Per-unit-mass physics of a particle on y = f(x) with Coulomb friction (docs/physics.md §1).

State (x, v) with v = dx/dt.  Within a mode the direction ``d = sign(v)`` and
the contact sign ``s_n = sign(n)`` are held fixed, and both enter only through
``q = d * mu_k * s_n`` (the signed friction coefficient), so every right-hand
side below is smooth up to the next event.
"""

import math

from .jit import fma, jit


@jit
def normal_term(v, fpp, g):
    """n = g + v^2 f''; the normal force is m n / sqrt(1 + f'^2) (paper eq. 11)."""
    return fma(v * v, fpp, g)


@jit
def acceleration(n, fp, q):
    """dv/dt = -(f' n + d mu_k |n|) / (1 + f'^2), with |n| = s_n n and q = d mu_k s_n.

    For n > 0 this is the paper's eq. (10).  The division involves f' alone,
    so it is written apart from n: in a step chain (a replayed lane, the
    stages of a step) x gives f' early and the division overlaps the work
    on v, which gives n; the velocity chain then holds no division."""
    return -n * ((fp + q) / fma(fp, fp, 1.0))


@jit
def drag_rate(v, fp, b, c, d, linear, quadratic):
    """Air drag's rate k (1/s), b + c s' with the speed along the path
    s' = d v sqrt(1 + f'^2) (d = sign(v) fixed within a mode): the drag's
    horizontal acceleration is -k v and its power per unit mass
    k v^2 (1 + f'^2) >= 0.  ``linear``, ``quadratic``: which terms are on
    (compile-time constants in the kernels, so the other term costs nothing).

    From the tangential force -m (b s' + c s'^2) along the unit tangent
    (1, f') / sqrt(1 + f'^2): its generalised force on x is that force dotted
    with (1, f'), divided by the mass term m (1 + f'^2)."""
    if quadratic:
        k = c * (d * v) * math.sqrt(fma(fp, fp, 1.0))
        return k + b if linear else k
    return b if linear else 0.0


@jit
def acceleration_frictionless(n, fp, q):
    """:func:`acceleration` with mu_k = 0 (``q`` unused): what kernels of
    scenes without kinetic friction bind as ``acceleration``.  The same
    result as ``acceleration(n, fp, 0.0)`` except perhaps the sign of a zero."""
    return -n * (fp / fma(fp, fp, 1.0))


@jit
def specific_energy(f, fp, v, g):
    """Mechanical energy per unit mass: g f(x) + v^2 (1 + f'^2) / 2 (paper eq. 19)."""
    return g * f + 0.5 * v * v * (1.0 + fp * fp)


@jit
def departure_direction(fp, mu_s, mu_k, g):
    """The rest rule (docs/physics.md §1.4): at rest where the slope is f', the particle
    stays for ever if |f'| <= mu_s (returns 0.0); otherwise it starts moving
    downhill, direction -sign(f').

    The second test catches |f'| within rounding of mu_k (possible only when
    mu_s == mu_k): there the departing acceleration rounds to zero or the wrong
    sign, so the particle cannot actually leave and is treated as stuck rather
    than stepping in place.
    """
    if abs(fp) <= mu_s:
        return 0.0
    direction = -1.0 if fp > 0.0 else 1.0
    # at rest n = g > 0, so s_n = +1 and q = d * mu_k
    if acceleration(g, fp, direction * mu_k) * direction <= 0.0:
        return 0.0
    return direction
