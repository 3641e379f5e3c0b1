"""The brachistochrone with Coulomb friction, for rampwork's physics
(docs/brachistochrone.md).

The fastest curve from rest at A to B when the normal force includes the
centripetal term, ``nu = kappa u^2 + g cos(phi)`` (docs/physics.md §5), is a
quadrature in the tangent angle ``phi``: with ``alpha = atan(mu)`` and two
constants fixed by B,

    u(phi) = cos(phi) / F(phi),
    F(phi) = A (1 + sin(alpha) sin(2 phi + alpha)) + B sin(alpha) cos(2 phi + alpha),
    ds/dphi = -u (u' + mu u) / (g (sin(phi) + mu cos(phi))),    dt/dphi = (ds/dphi) / u.

It leaves A vertically (``phi = -pi/2``), its curvature is positive all the
way, and at ``mu = 0`` it is the cycloid.  The derivation (Pontryagin on the
states x, y and ``z = u^2 exp(2 mu phi) / 2``, in which the centripetal
friction has no curvature term) and its checks are in docs/brachistochrone.md::

    >>> from rampwork.brachistochrone import frictional_brachistochrone
    >>> best = frictional_brachistochrone((1.0, -1.0), mu=0.2)
    >>> round(best.time, 6)                     # seconds, g = 9.81
    0.641003
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.integrate import quad
from scipy.optimize import brentq

from . import validate
from .errors import ConfigError

_QUAD = dict(epsabs=1e-15, epsrel=1e-13, limit=400)
#: radius of the circle on which Cauchy's formula evaluates the removable 0/0 at phi = -alpha
_CAUCHY_RADIUS = 0.1
_CAUCHY_NODES = np.exp(2j * np.pi * (np.arange(64) + 0.5) / 64)


class _Extremal:
    """One member of the family, in units with g = 1 and A = 1."""

    def __init__(self, mu: float, b: float):
        self.mu, self.b = mu, b
        self.alpha = math.atan(mu)
        self.sin_alpha = math.sin(self.alpha)

    @staticmethod
    def b_at_end(mu: float, phi_end: float) -> float:
        """B from the free end's transversality (the costate of z vanishes at B)."""
        if mu == 0.0:
            return 0.0  # B does not enter the frictionless curve
        alpha = math.atan(mu)
        sa = math.sin(alpha)
        return -((math.sin(phi_end) ** 2 + sa * math.sin(2 * phi_end + alpha))
                 / (sa * math.cos(2 * phi_end + alpha) + 0.5 * math.sin(2 * phi_end)))

    def F(self, phi):
        angle = 2 * phi + self.alpha
        return 1 + self.sin_alpha * (np.sin(angle) + self.b * np.cos(angle))

    def speed(self, phi):
        return np.cos(phi) / self.F(phi)

    def _ratio(self, phi):
        # (u' + mu u) / (sin(phi) + mu cos(phi)); also takes complex phi
        angle = 2 * phi + self.alpha
        F = self.F(phi)
        dF = 2 * self.sin_alpha * (np.cos(angle) - self.b * np.sin(angle))
        numerator = (-np.sin(phi) * F - np.cos(phi) * dF + self.mu * np.cos(phi) * F) / (F * F)
        return numerator / (np.sin(phi) + self.mu * np.cos(phi))

    def ratio(self, phi: float) -> float:
        offset = phi + self.alpha
        if abs(offset) < 0.5 * _CAUCHY_RADIUS:  # both vanish at phi = -alpha: analytic there
            z = _CAUCHY_RADIUS * _CAUCHY_NODES
            return float(np.real(np.mean(self._ratio(-self.alpha + z) * z / (z - offset))))
        return float(self._ratio(phi))

    def ds_dphi(self, phi: float) -> float:
        return -self.speed(phi) * self.ratio(phi)

    def dt_dphi(self, phi: float) -> float:
        return -self.ratio(phi)

    def admissible(self, phi_end: float, samples: int = 64) -> bool:
        """Speed and curvature positive from the start to phi_end."""
        phi = np.linspace(-math.pi / 2, phi_end, samples)[1:]
        return bool(np.all(self.F(phi) > 0) and all(self.ds_dphi(p) > 0 for p in phi))

    def integrals(self, phi_a: float, phi_b: float) -> tuple[float, float, float]:
        """(x, y, t) gained from phi_a to phi_b."""
        x = quad(lambda p: math.cos(p) * self.ds_dphi(p), phi_a, phi_b, **_QUAD)[0]
        y = quad(lambda p: math.sin(p) * self.ds_dphi(p), phi_a, phi_b, **_QUAD)[0]
        t = quad(self.dt_dphi, phi_a, phi_b, **_QUAD)[0]
        return x, y, t


@dataclass(frozen=True)
class Brachistochrone:
    """The fastest curve from rest at the origin to ``end`` for friction ``mu``."""

    mu: float
    g: float
    end: tuple[float, float]
    phi_end: float  #: tangent angle at B (rad); > 0: the curve dips below B and climbs back
    b: float  #: the second constant of the family (A = 1)
    scale: float  #: lengths of the g = 1, A = 1 member times this are the curve's
    time: float  #: descent time (s)

    @property
    def _extremal(self) -> _Extremal:
        return _Extremal(self.mu, self.b)

    def curve(self, n: int = 201) -> dict[str, np.ndarray]:
        """``n`` points evenly spaced in the tangent angle: phi, X, Y, s
        (arc length), u (speed), t (time), kappa (curvature)."""
        n = validate.integer("n", n, minimum=2)
        e = self._extremal
        phi = np.linspace(-math.pi / 2, self.phi_end, n)
        gains = np.array([e.integrals(a, b) for a, b in zip(phi[:-1], phi[1:])])
        s_gain = [quad(e.ds_dphi, a, b, **_QUAD)[0] for a, b in zip(phi[:-1], phi[1:])]
        cumulative = np.vstack([np.zeros(3), np.cumsum(gains, axis=0)])
        s = np.concatenate([[0.0], np.cumsum(s_gain)]) * self.scale
        rho = np.array([0.0] + [e.ds_dphi(p) for p in phi[1:]]) * self.scale
        speed = np.concatenate([[0.0], e.speed(phi[1:])])  # the start is a cusp: at rest,
        with np.errstate(divide="ignore"):                  # its radius of curvature 0
            kappa = 1.0 / rho
        return {"phi": phi, "X": cumulative[:, 0] * self.scale, "Y": cumulative[:, 1] * self.scale,
                "s": s, "u": speed * math.sqrt(self.scale * self.g),
                "t": cumulative[:, 2] * math.sqrt(self.scale / self.g), "kappa": kappa}


def frictional_brachistochrone(end, mu: float, g: float = 9.81) -> Brachistochrone:
    """The fastest curve from rest at (0, 0) to ``end = (dx, dy)``, ``dx > 0 > dy``,
    with Coulomb friction ``mu`` and the centripetal term in the normal force.

    Raises :class:`~rampwork.errors.ConfigError` where no curve of the family
    reaches B (too much friction for the drop: the block cannot arrive).
    """
    mu = validate.nonnegative("mu", mu)
    g = validate.positive("g", g)
    try:
        dx, dy = (float(v) for v in end)
    except (TypeError, ValueError):
        raise ConfigError("end", f"expected two numbers (dx, dy), got {end!r}") from None
    if not (math.isfinite(dx) and math.isfinite(dy) and dx > 0 and dy < 0):
        raise ConfigError("end", f"B must lie right of and below the start: dx > 0 > dy, got ({dx}, {dy})")
    target = math.atan2(dy, dx)

    def chord_angle(phi_end):
        e = _Extremal(mu, _Extremal.b_at_end(mu, phi_end))
        if not e.admissible(phi_end):
            return math.nan
        x, y, _ = e.integrals(-math.pi / 2, phi_end)
        return math.atan2(y, x) - target

    # the chord's angle grows with phi_end over the admissible range: bracket it
    grid = np.linspace(-math.pi / 2 + 1e-3, math.pi / 2 - 1e-3, 121)
    values = [chord_angle(p) for p in grid]
    for lo, hi, v_lo, v_hi in zip(grid, grid[1:], values, values[1:]):
        if np.isfinite(v_lo) and np.isfinite(v_hi) and v_lo * v_hi <= 0:
            phi_end = brentq(chord_angle, lo, hi, xtol=1e-15, rtol=4 * np.finfo(float).eps)
            break
    else:
        reach = max((v for v in values if np.isfinite(v)), default=math.nan) + target
        raise ConfigError("end", f"no curve from rest reaches ({dx}, {dy}) with mu = {mu}: the "
                          f"friction takes the drop's energy; with this mu B must lie at least "
                          f"{math.degrees(-reach):.2f} degrees below the start's horizontal")
    e = _Extremal(mu, _Extremal.b_at_end(mu, phi_end))
    x, y, t = e.integrals(-math.pi / 2, phi_end)
    scale = math.hypot(dx, dy) / math.hypot(x, y)
    return Brachistochrone(mu=mu, g=g, end=(dx, dy), phi_end=phi_end, b=e.b, scale=scale,
                           time=t * math.sqrt(scale / g))
