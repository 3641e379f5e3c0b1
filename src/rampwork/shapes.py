"""Shape families for optimisation: a ramp through two points A and B set by
K numbers, evaluated for a whole population of candidates in one batched call.

The protocol every shape family keeps (docs/optimise.md):

* ``names``: its K parameter names (each one a sweep axis);
* ``bounds``: K (lo, hi) pairs for the optimiser;
* ``evaluate(population, scene)``: ``population`` of shape (S, K); ONE kernel
  call runs a trajectory per row from A towards B and returns a Dataset on
  dimension ``candidate`` with at least ``t_end``, ``W_friction``,
  ``W_excess``, ``speed_end``, ``status``, ``arrived`` and ``admissible``.

:class:`ChordModes` is the y = f(x) family: the chord AB plus K sine modes,
each vanishing at both ends; the population's coefficient table is the
``sine_modes`` ramp's ``shared`` data and each candidate is one case of a
sweep over its ``row``, so the kernel compiles once (not once per population).

    >>> shape = ChordModes(start=(0.0, 1.0), end=(2.0, 0.0), k=6)
    >>> scene = shape.scene(friction=rw.Friction(mu_k=0.1))
    >>> ds = shape.evaluate(np.zeros((1, 6)), scene)   # the chord itself
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np
import xarray as xr

from . import validate
from .core.status import EXITED, LIFTED_OFF
from .errors import ConfigError
from .ramps import MAX_MODES, Ramp
from .scene import Friction, Integrator, Scene, Sweep
from .schema import output_attrs, spec_attrs
from .schema import OPTIMISE_OUTPUTS

__all__ = ["ChordModes", "EVALUATORS", "SHAPE_OUTPUTS"]

#: the variables every shape family's ``evaluate`` returns (the protocol)
SHAPE_OUTPUTS = ("t_end", "W_friction", "W_excess", "speed_end", "status", "arrived", "admissible")
#: an exit within this share of the chord's horizontal length from B counts as at B
ARRIVAL_TOLERANCE = 1e-9
#: how ``evaluate`` runs a population: ``kernel``: the ODE kernel for every
#: candidate; ``quadrature``: the descent by quadrature (core/descent_quadrature.py)
#: where it is valid, the ODE kernel for the rest in the same call
EVALUATORS = ("kernel", "quadrature")
#: the kernel run's outputs that ``evaluate`` reads
KERNEL_READ = ("status", "t_end", "x_end", "v_end", "W_friction", "W_excess", "x_lift_off")
#: candidates per work item of the quadrature (items spread over threads)
QUADRATURE_TILE = 64


def _point(where: str, value) -> tuple[float, float]:
    if isinstance(value, (str, bytes)) or not hasattr(value, "__len__") or len(value) != 2:
        raise ConfigError(where, f"expected a point [x, y] in m, got {value!r}")
    return validate.real(f"{where}[0]", value[0]), validate.real(f"{where}[1]", value[1])


@dataclass(frozen=True)
class ChordModes:
    """y = f(x) through ``start`` = A and ``end`` = B (points (x, y) in m,
    x_A != x_B): the chord plus ``k`` sine modes,
    f(x) = chord(x) + sum_j c_j sin(j pi (x - x_min) / (x_max - x_min)).

    ``amplitude`` (m, default half the chord's length) bounds mode j's
    coefficient to +-amplitude / j**decay (``decay`` default 1; 2 keeps the
    slopes' bound at A from growing with K, which DE needs at larger K).  ``y_bounds`` = (y_low, y_high): the
    allowed region (None: no bound on that side); a candidate whose ramp
    leaves it (checked at ``check_points`` points) is not admissible.
    ``basis``: ``"sine"`` (the only one so far)."""

    start: tuple[float, float]
    end: tuple[float, float]
    k: int
    amplitude: float | None = None
    y_bounds: tuple[float | None, float | None] = (None, None)
    basis: str = "sine"
    check_points: int = 513
    decay: float = 1.0

    def __post_init__(self):
        start = _point("shape.start", self.start)
        end = _point("shape.end", self.end)
        if start[0] == end[0]:
            raise ConfigError("shape.end", f"x of B must differ from x of A = {start[0]!r} (a vertical "
                              "chord is not a graph y = f(x); use a curve shape)")
        object.__setattr__(self, "start", start)
        object.__setattr__(self, "end", end)
        object.__setattr__(self, "k", validate.integer("shape.k", self.k, 1, MAX_MODES))
        validate.choice("shape.basis", self.basis, ("sine",))
        length = math.hypot(end[0] - start[0], end[1] - start[1])
        amplitude = 0.5 * length if self.amplitude is None else validate.positive("shape.amplitude",
                                                                                  self.amplitude)
        object.__setattr__(self, "amplitude", amplitude)
        if isinstance(self.y_bounds, (str, bytes)) or len(self.y_bounds) != 2:
            raise ConfigError("shape.y_bounds", f"expected [y_low, y_high] (None: unbounded), got "
                              f"{self.y_bounds!r}")
        low, high = (None if b is None else validate.real(f"shape.y_bounds[{i}]", b)
                     for i, b in enumerate(self.y_bounds))
        for name, bound, ok in (("y_low", low, low is None or low <= min(start[1], end[1])),
                                ("y_high", high, high is None or high >= max(start[1], end[1]))):
            if not ok:
                raise ConfigError("shape.y_bounds", f"{name} = {bound!r} excludes A or B "
                                  f"(y = {start[1]!r}, {end[1]!r})")
        object.__setattr__(self, "y_bounds", (low, high))
        decay = validate.nonnegative("shape.decay", self.decay)
        if decay > 4:
            raise ConfigError("shape.decay", f"must be in [0, 4], got {decay!r}")
        object.__setattr__(self, "decay", decay)
        object.__setattr__(self, "check_points",
                           validate.integer("shape.check_points", self.check_points, 3, 100_000))

    # -- the protocol ---------------------------------------------------------

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(f"c{j}" for j in range(1, self.k + 1))

    @property
    def bounds(self) -> tuple[tuple[float, float], ...]:
        return tuple((-self.amplitude / j**self.decay, self.amplitude / j**self.decay)
                     for j in range(1, self.k + 1))

    @property
    def domain(self) -> tuple[float, float]:
        return (min(self.start[0], self.end[0]), max(self.start[0], self.end[0]))

    def describe(self) -> str:
        return (f"ChordModes: chord {list(self.start)} -> {list(self.end)} plus K = {self.k} "
                f"{self.basis} modes, |c_j| <= {self.amplitude!r} / j^{self.decay!r}, y_bounds {list(self.y_bounds)}")

    def ramp(self, population) -> Ramp:
        """The ``sine_modes`` ramp whose coefficient table is ``population``
        (S, K): row r is candidate r."""
        table = self._population(population)
        lo, hi = self.domain
        ends = [self.start[1], self.end[1]] if self.start[0] < self.end[0] else [self.end[1], self.start[1]]
        return Ramp.create("sine_modes", domain=(lo, hi), row=0.0, y_ends=ends, n_modes=[self.k],
                           coefficients=table.ravel())

    def scene(self, **settings) -> Scene:
        """A :class:`~rampwork.Scene` that starts at A, on the chord (the
        ramp ``evaluate`` replaces); ``settings``: Scene's other fields."""
        settings.setdefault("friction", Friction())
        settings.setdefault("integrator", Integrator("dopri5", rtol=1e-8))
        return Scene(ramp=self.ramp(np.zeros((1, self.k))), x0=self.start[0], **settings)

    def evaluate(self, population, scene: Scene, *, threads: int | None = None,
                 evaluator: str = "kernel") -> xr.Dataset:
        """Run one trajectory per row of ``population`` (S, K) from A (with
        ``scene``'s v0) towards B in ONE batched call; the Dataset on
        ``candidate`` holds :data:`SHAPE_OUTPUTS` and ``x_end``, ``inside``,
        ``stayed_on``, ``shortfall`` and the ``coefficients``.

        ``evaluator`` (:data:`EVALUATORS`): ``"quadrature"`` computes each
        candidate that slides from A to B in contact (drag-free scenes with an
        adaptive integrator, whose rtol it meets) by quadrature of the
        linear energy equation, and runs the rest (stops, reversals,
        lift-off, grazes, unresolved) on the kernel in the same call:
        statuses and penalties are the kernel's (docs/optimise.md)."""
        from .runner import run_scene

        if not isinstance(scene, Scene):
            raise ConfigError("scene", f"expected a rampwork.Scene, got {type(scene).__name__}")
        validate.choice("evaluator", evaluator, EVALUATORS)
        table = self._population(population)
        rows = np.arange(table.shape[0], dtype=np.float64)
        ramp_scene = scene.replace(ramp=self.ramp(table), x0=self.start[0], record=type(scene.record)())
        if evaluator == "quadrature":
            outputs, run_attrs = self._quadrature(ramp_scene, table, threads)
        else:
            # the scene file is not stored: the Dataset keeps the attributes
            # below and the table itself, and writing the table as text cost a
            # fifth of the call at rtol 1e-6
            run = run_scene(ramp_scene, Sweep.cases(row=rows), threads=threads, store_scene=False)
            outputs = {name: run[name].values for name in KERNEL_READ}
            outputs["speed_end"] = self._speed(table, outputs["x_end"], outputs["v_end"])
            run_attrs = run.attrs
        lo, hi = self.domain
        length = hi - lo
        x_end = outputs["x_end"]
        status = outputs["status"]
        arrived = (status == EXITED) & (np.abs(x_end - self.end[0]) <= ARRIVAL_TOLERANCE * length)
        stayed_on = (status != LIFTED_OFF) & ~np.isfinite(outputs["x_lift_off"])
        inside = self.inside(table)
        # the share of the way from A to B not covered (0 where arrived)
        shortfall = np.where(arrived, 0.0, np.clip(np.abs(self.end[0] - np.nan_to_num(x_end, nan=self.start[0]))
                                                   / length, 0.0, 1.0))
        candidate = np.arange(table.shape[0])
        data = {name: ("candidate", outputs[name], output_attrs(name))
                for name in ("status", "t_end", "x_end", "W_friction", "W_excess")}
        for name, values in (("speed_end", outputs["speed_end"]), ("arrived", arrived), ("stayed_on", stayed_on),
                             ("inside", inside), ("admissible", inside & arrived & stayed_on),
                             ("shortfall", shortfall)):
            data[name] = ("candidate", values, spec_attrs(OPTIMISE_OUTPUTS[name]))
        data["coefficients"] = (("candidate", "parameter"), table, spec_attrs(OPTIMISE_OUTPUTS["coefficients"]))
        attrs = {key: run_attrs[key] for key in ("Conventions", "source", "history", "integrator_method",
                                                 "compile_time_s", "run_time_s", "evaluator",
                                                 "quadrature_share", "quadrature_nodes_mean") if key in run_attrs}
        attrs["title"] = f"rampwork shape evaluation: {self.describe()}"
        attrs["shape"] = self.describe()
        return xr.Dataset(data, coords={"candidate": candidate, "parameter": list(self.names)}, attrs=attrs)

    def _quadrature(self, scene: Scene, table: np.ndarray, threads) -> tuple[dict, dict]:
        """The outputs that ``evaluate`` reads (KERNEL_READ and speed_end) and
        the run's attributes: by quadrature where valid (on 4 panels, then on
        8 for the candidates the 4 do not prove valid: descent_nodes.PANEL_LAYOUTS),
        by the kernel (one call over the rest) elsewhere."""
        from .core import descent_quadrature as quadrature
        from .core.descent_nodes import PANEL_LAYOUTS, node_tables
        from .core.threads import run_items, using_threads
        from .runner import run_outputs, thread_count
        from .schema import global_attrs

        if scene.drag.linear != 0.0 or scene.drag.quadratic != 0.0:
            raise ConfigError("evaluator", "'quadrature' needs a drag-free scene (its energy equation is "
                              "linear only without drag); use evaluator 'kernel'")
        if not scene.integrator.adaptive:
            raise ConfigError("evaluator", f"'quadrature' takes its tolerance from an adaptive integrator's "
                              f"rtol (dopri5 or dop853), got {scene.integrator.method!r}")
        threads_used = thread_count(threads)
        size = table.shape[0]
        started = time.perf_counter()
        compiled = bool(quadrature.descent_quadrature.signatures)
        lo, hi = self.domain
        direction = 1.0 if self.start[0] < self.end[0] else -1.0
        rtol = scene.integrator.rtol
        mu_s = scene.friction.mu_k if scene.friction.mu_s is None else scene.friction.mu_s
        t_end, work, energy_end, slope_end, estimate = (np.empty(size) for _ in range(5))
        nodes, valid = np.empty(size, dtype=np.int64), np.empty(size, dtype=np.bool_)
        shared = scene.ramp.shared_array()
        settings = (self.start[0], direction, hi - lo, scene.g, scene.friction.mu_k, mu_s, scene.v0,
                    scene.t_max, rtol)
        outputs = (t_end, work, energy_end, slope_end, estimate, nodes, valid)

        def run_tiles(first, stop, rows, tables, found):  # tiles of QUADRATURE_TILE candidates: each alone
            tiles = slice(first * QUADRATURE_TILE, stop * QUADRATURE_TILE)
            quadrature.descent_quadrature(shared, rows[tiles], *settings, *tables, *(out[tiles] for out in found))

        compile_s = 0.0
        rest = np.arange(size)
        for panels in PANEL_LAYOUTS:  # each layout on the candidates the ones before did not prove valid
            found = tuple(np.empty(rest.size, dtype=out.dtype) for out in outputs)
            work_items = (rest.astype(np.float64), node_tables(panels), found)
            if not compiled:  # compile (or load from numba's disk cache) on one tile, timed apart
                run_tiles(0, 1, *work_items)
                compile_s = time.perf_counter() - started
                compiled = True
            with using_threads(threads_used):
                run_items(run_tiles, -(-rest.size // QUADRATURE_TILE), *work_items)
            for out, values in zip(outputs, found):
                out[rest] = values
            rest = rest[~found[-1]]
            if not rest.size:
                break
        status = np.full(size, EXITED, dtype=np.int8)
        x_end = np.full(size, self.end[0])
        x_lift_off = np.full(size, np.nan)
        v_end = direction * np.sqrt(2.0 * energy_end / (1.0 + slope_end * slope_end))
        speed_end = np.sqrt(2.0 * energy_end)  # E = v^2 (1 + f'^2) / 2
        w_friction = scene.m * work
        w_excess = w_friction - scene.friction.mu_k * scene.m * scene.g * (hi - lo)
        outputs = dict(zip(KERNEL_READ, (status, t_end, x_end, v_end, w_friction, w_excess, x_lift_off)))
        if rest.size:  # the kernel's arrays, no Dataset (1 ms of a call's ~12 at rtol 1e-6)
            run, kernel_compile_s = run_outputs(scene, Sweep.cases(row=rest.astype(np.float64)), threads)
            compile_s += kernel_compile_s
            for name, values in outputs.items():
                values[rest] = run[name]
            speed_end[rest] = self._speed(table[rest], x_end[rest], v_end[rest])
        outputs["speed_end"] = speed_end
        attrs = global_attrs(scene.title, "", f"rampwork.ChordModes.evaluate: {size} candidates, "
                             f"{size - rest.size} by quadrature, {rest.size} by {scene.integrator.describe()}",
                             {"integrator_method": scene.integrator.method, "evaluator": "quadrature",
                              "quadrature_share": (size - rest.size) / size,
                              "quadrature_nodes_mean": float(nodes[valid].mean()) if rest.size < size else 0.0,
                              "compile_time_s": compile_s,
                              "run_time_s": time.perf_counter() - started - compile_s})
        return outputs, attrs

    def _speed(self, table, x_end, v_end) -> np.ndarray:
        """The speed along the ramp at x_end of each row of ``table`` from the kernel's v_end = dx/dt."""
        _, slope, _ = self.profile(table, x_end)
        return np.abs(v_end) * np.sqrt(1.0 + slope * slope)

    # -- the shapes themselves ------------------------------------------------

    def profile(self, coefficients, x) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """f, f', f'' of each row of ``coefficients`` (S, K) at ``x`` (S,) or
        (S, N), in closed form by numpy (the kernel's own evaluation is
        :meth:`ramp`'s ``evaluate``)."""
        table = np.atleast_2d(np.asarray(coefficients, dtype=np.float64))
        x = np.asarray(x, dtype=np.float64)
        squeeze = x.ndim == 1
        x = x.reshape(table.shape[0], -1) if squeeze else x
        lo, hi = self.domain
        y_lo, y_hi = ((self.start[1], self.end[1]) if self.start[0] < self.end[0]
                      else (self.end[1], self.start[1]))
        w = math.pi / (hi - lo)
        j = np.arange(1, self.k + 1, dtype=np.float64)
        angle = w * (x - lo)[..., None] * j  # (S, N, K)
        c = table[:, None, :]
        sin, cos = np.sin(angle), np.cos(angle)
        f = y_lo + (y_hi - y_lo) / (hi - lo) * (x - lo) + (c * sin).sum(-1)
        fp = (y_hi - y_lo) / (hi - lo) + w * (c * j * cos).sum(-1)
        fpp = -(w * w) * (c * j * j * sin).sum(-1)
        if squeeze:
            return f[:, 0], fp[:, 0], fpp[:, 0]
        return f, fp, fpp

    def inside(self, population) -> np.ndarray:
        """Whether each candidate's ramp stays within ``y_bounds`` (all True
        without bounds), proven: f at ``check_points`` evenly spaced points
        (spacing h), widened by h^2/8 times a bound on |f''| (the most f can
        pass a sampled value by between two points), so a dip between two
        points is never missed; a ramp that touches a bound within that
        margin counts as outside."""
        table = self._population(population)
        low, high = self.y_bounds
        if low is None and high is None:
            return np.ones(table.shape[0], dtype=bool)
        lo, hi = self.domain
        x = np.linspace(lo, hi, self.check_points)
        w = math.pi / (hi - lo)
        j = np.arange(1, self.k + 1, dtype=np.float64)
        y_lo, y_hi = ((self.start[1], self.end[1]) if self.start[0] < self.end[0]
                      else (self.end[1], self.start[1]))
        f = y_lo + (y_hi - y_lo) * (x - lo) / (hi - lo) + table @ np.sin(w * np.outer(j, x - lo))
        margin = (x[1] - x[0]) ** 2 / 8.0 * (np.abs(table) @ (j * w) ** 2)
        ok = np.ones(table.shape[0], dtype=bool)
        if low is not None:
            ok &= f.min(axis=1) - margin >= low
        if high is not None:
            ok &= f.max(axis=1) + margin <= high
        return ok

    def _population(self, population) -> np.ndarray:
        table = np.asarray(population, dtype=np.float64)
        if table.ndim == 1 and table.size == self.k:
            table = table[None, :]
        if table.ndim != 2 or table.shape[1] != self.k or table.shape[0] < 1:
            raise ConfigError("population", f"expected an array of shape (S, K = {self.k}), got shape "
                              f"{np.shape(population)}")
        if not np.isfinite(table).all():
            raise ConfigError("population", "holds NaN or infinite coefficients")
        return np.ascontiguousarray(table)
