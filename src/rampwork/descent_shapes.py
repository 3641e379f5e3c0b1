"""Shape families for optimisation: candidate curves from A through B, a
population per batched kernel call (docs/brachistochrone.md).

A shape family for optimisation has ``names`` (its K parameters),
``bounds`` (K (lo, hi) pairs) and ``evaluate(population, scene)``: one
trajectory per row of ``population`` (S, K), all in ONE curve-kernel call,
returned as a Dataset on the dimension ``candidate`` with ``t_end``,
``W_friction``, ``W_excess``, ``speed_end``, ``status``, ``arrived`` and
``admissible`` (a candidate that is not admissible is flagged, never
dropped, and its numbers stay finite).

:class:`CuspCurve` is the family that holds the frictional brachistochrone
(:mod:`rampwork.brachistochrone`): convex curves that leave A vertically,
with radius of curvature ``ds/dphi = cos(phi) exp(c_0 + sum_k c_k T_k(t))``
(the curve family ``convex_cusp``).  The K parameters are ``c_1 .. c_K``;
per candidate a root-find (jitted, ``core/cusp_end.py``) sets the end
angle so that the end lies in B's direction, and ``c_0`` scales the curve
onto B::

    >>> import rampwork as rw
    >>> from rampwork.curves import Curve
    >>> from rampwork.curve_scene import CurveScene
    >>> from rampwork.descent_shapes import CuspCurve
    >>> shape = CuspCurve(end=(2.0, -1.0), k=4)
    >>> scene = CurveScene(curve=Curve.create("brachistochrone", radius=1.0),
    ...                    friction=rw.Friction(mu_k=0.1),
    ...                    integrator=rw.Integrator(method="dopri5", rtol=1e-12))
    >>> ds = shape.evaluate(np.zeros((1, 4)), scene)   # all zero: the cycloid through B
    >>> bool(ds.admissible[0])
    True
"""

from __future__ import annotations

import math

import numpy as np
import xarray as xr

from . import schema, validate
from .core import status as st
from .core.cusp_end import cusp_end_angles
from .core.threads import max_threads, using_threads
from .curve_families import _END_WEIGHTS, _NODES, contract, convex_cusp_end
from .curve_scene import FIRST_STEP, CurveScene
from .curves import Curve, prepare_curve_run
from .errors import ConfigError

#: end angles tried to bracket the root (rad, from -pi/2): the first bracket is taken
_BRACKETS = 96
#: the largest end angle tried: short of vertical upwards, where rho(phi) = 0 again
_END_ANGLE_MAX = 0.5 * math.pi - 1e-3


class CuspCurve:
    """Convex curves from rest at A = (0, 0), leaving vertically, to
    ``end`` = B = (dx, dy) (dx > 0 > dy): ``ds/dphi = cos(phi) exp(E(t))``,
    ``E = c_0 + sum_{k=1..K} c_k T_k(t)``, ``t = 2 (phi + pi/2) / (phi_B +
    pi/2) - 1``.  The optimiser's parameters are ``c_1 .. c_K``
    (``names`` ``c1 .. cK``); ``phi_B`` (the end angle) and ``c_0`` (the
    size) follow from B.  ``bounds``: ``+-bound * decay**(k - 1)``, room for
    the optimum's coefficients from mu = 0 (all zero: the cycloid) to 0.4
    (|c_2| about 2, |c_4| 0.45 towards (2, -1))."""

    def __init__(self, end, k: int = 8, *, bound: float = 4.0, decay: float = 0.6):
        try:
            dx, dy = (float(v) for v in end)
        except (TypeError, ValueError):
            raise ConfigError("end", f"expected two numbers (dx, dy), got {end!r}") from None
        if not (math.isfinite(dx) and math.isfinite(dy) and dx > 0 > dy):
            raise ConfigError("end", f"B must lie right of and below A: dx > 0 > dy, got ({dx}, {dy})")
        if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or not 1 <= k <= 40:
            raise ConfigError("k", f"the number of shape coefficients must be an integer in [1, 40], got {k!r}")
        if not (bound > 0 and 0 < decay <= 1):
            raise ConfigError("bound", f"need bound > 0 and 0 < decay <= 1, got {bound!r}, {decay!r}")
        self.end = (dx, dy)
        self.k = int(k)
        self.names = tuple(f"c{i}" for i in range(1, self.k + 1))
        self.bounds = tuple((-bound * decay ** i, bound * decay ** i) for i in range(self.k))

    def __repr__(self) -> str:
        return f"CuspCurve(end={self.end!r}, k={self.k})"

    def describe(self) -> str:
        """One line for the history dataset and the checkpoint's fingerprint."""
        return (f"CuspCurve: convex curves from rest at a vertical start (0, 0) to {list(self.end)}, "
                f"K = {self.k}, bounds {[list(b) for b in self.bounds]}")

    # -- geometry ----------------------------------------------------------------------------
    def _population(self, population) -> np.ndarray:
        c = np.asarray(population, dtype=np.float64)
        if c.ndim == 1 and c.size == self.k:
            c = c[None, :]
        if c.ndim != 2 or c.shape[1] != self.k:
            raise ConfigError("population", f"expected shape (S, {self.k}), got {np.shape(population)}")
        if not np.isfinite(c).all():
            raise ConfigError("population", "must be finite numbers")
        return c

    def curves(self, population) -> dict[str, np.ndarray]:
        """Each candidate's curve through B: ``coefficients`` (S, K + 1) of E
        (``c_0`` first), ``end_angle`` (rad), ``through_b`` (a root was found;
        where not, the end angle whose direction came closest and the size
        that puts its end at B's distance, so the candidate still runs)."""
        c = self._population(population)
        target = math.atan2(self.end[1], self.end[0])
        # E without c_0 at the quadrature nodes does not depend on the end
        # angle; the root-finding per candidate is jitted (core/cusp_end.py)
        exponent = np.exp(np.polynomial.chebyshev.chebval(_NODES, np.hstack(
            [np.zeros((c.shape[0], 1)), c]).T))
        step = (_END_ANGLE_MAX + 0.5 * math.pi) / _BRACKETS
        angles = np.empty(c.shape[0])
        through = np.empty(c.shape[0], dtype=np.bool_)
        cusp_end_angles(np.ascontiguousarray(exponent), _NODES, _END_WEIGHTS, target, step, _BRACKETS,
                        angles, through)
        coefficients = np.hstack([np.zeros((c.shape[0], 1)), c])
        x, y, _ = convex_cusp_end(coefficients, angles)
        coefficients[:, 0] = np.log(math.hypot(*self.end) / np.hypot(x, y))
        return {"coefficients": coefficients, "end_angle": angles, "through_b": through}

    # -- the protocol ------------------------------------------------------------------------
    def evaluate(self, population, scene, *, threads: int | None = None) -> xr.Dataset:
        """One trajectory per candidate (row of ``population``), from A
        (at rest, or ``scene.u0`` along the curve) towards B, in one
        curve-kernel call with ``scene``'s physics and integrator (its curve
        is not used).  ``dopri5`` at a tight ``rtol`` (1e-12) resolves the
        0.005 % differences of the frictional brachistochrone.  ``threads``:
        the curve kernel's threads (None: all)."""
        if not isinstance(scene, CurveScene):
            raise ConfigError("scene", f"a curve shape runs in a rampwork.curve_scene.CurveScene, "
                              f"got {type(scene).__name__}")
        threads = (max_threads() if threads is None
                   else validate.integer("threads", threads, 1, max_threads()))
        c = self._population(population)
        shapes = self.curves(c)
        n = c.shape[0]
        curve = Curve.convex_cusp(shapes["coefficients"], shapes["end_angle"])
        integrator = scene.integrator
        adaptive = {"rtol": integrator.rtol, "atol": integrator.atol} if integrator.adaptive else {}
        friction = scene.friction
        run = prepare_curve_run(
            curve, s0=0.0, u0=scene.u0, mu_k=friction.mu_k, mu_s=friction.mu_s, g=scene.g,
            m=scene.m, method=integrator.method,
            dt=integrator.dt if integrator.dt is not None else FIRST_STEP, t_max=scene.t_max,
            contact=scene.contact, drag_linear=scene.drag.linear,
            drag_quadratic=scene.drag.quadratic, row=np.arange(n, dtype=np.float64),
            end_angle=shapes["end_angle"], kernel="specialised", **adaptive)  # many generations: it pays
        with using_threads(threads):
            raw = {name: np.reshape(values, (n,)) for name, values in run.run().items()}  # (n,) for n = 1
        p_end = 1.0 + np.sin(shapes["end_angle"])
        status = raw["status"].astype(np.int8)
        arrived = shapes["through_b"] & (status == st.EXITED) & (raw["p_end"] == p_end)
        w_path = friction.mu_k * scene.m * scene.g * raw["path_length_X"]
        dims = ("candidate",)
        _, _, length = convex_cusp_end(shapes["coefficients"], shapes["end_angle"])
        data = {
            "t_end": (dims, raw["t_end"], {"units": "s", "long_name": "time when the trajectory ended"}),
            "W_friction": (dims, raw["W_friction"], {"units": "J", "long_name": "work against friction"}),
            "W_excess": (dims, raw["W_friction"] - w_path, {
                "units": "J", "long_name": "work against friction beyond mu_k m g times the "
                "horizontal path"}),
            "speed_end": (dims, np.abs(raw["u_end"]), {"units": "m s-1",
                                                       "long_name": "speed when the trajectory ended"}),
            "status": (dims, status, schema.spec_attrs(schema.CURVE_OUTPUTS["status"])),
            "arrived": (dims, arrived, {"long_name": "the block reached B"}),
            "admissible": (dims, arrived.copy(), {
                "long_name": "a curve through A and B on which the block stayed in contact and "
                "arrived"}),
            "inside": (dims, shapes["through_b"].copy(), {
                "long_name": "the shape is admissible: a curve through A and B"}),
            "through_b": (dims, shapes["through_b"], {
                "long_name": "an end angle puts the curve's end at B (else it ran towards the "
                "closest direction)"}),
            "end_angle": (dims, shapes["end_angle"], {"units": "rad",
                                                      "long_name": "tangent angle at the end"}),
            "length": (dims, length, {"units": "m", "long_name": "arc length of the curve"}),
            "X_end": (dims, raw["X_end"], {"units": "m", "long_name": "X where the trajectory ended"}),
            "Y_end": (dims, raw["Y_end"], {"units": "m", "long_name": "Y where the trajectory ended"}),
            "nu_min": (dims, raw["nu_min"], {"units": "N", "long_name": "least normal force"}),
            "steps": (dims, raw["steps"].astype(np.int64), {"units": "1", "long_name": "steps"}),
        }
        coords = {name: ("candidate", c[:, i], {"units": "1", "long_name": f"shape coefficient {name}"})
                  for i, name in enumerate(self.names)}
        coords["candidate"] = ("candidate", np.arange(n), {"long_name": "candidate number", "units": "1"})
        ds = xr.Dataset(data, coords=coords)
        ds.attrs.update({"shape": repr(self), "end_x": self.end[0], "end_y": self.end[1],
                         "mu_k": friction.mu_k, "g": scene.g, "m": scene.m,
                         "integrator_method": integrator.method, "contact": scene.contact})
        if integrator.adaptive:
            ds.attrs.update({"integrator_rtol": integrator.rtol, "integrator_atol": integrator.atol})
        return ds
