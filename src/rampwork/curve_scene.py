"""Curve scenes: a planar curve through the one entry point (docs/physics.md §5).

A :class:`CurveScene` is what a scene file with a ``[curve]`` table (instead
of ``[ramp]``) describes; :func:`rampwork.simulate` runs it over a
:class:`~rampwork.scene.Sweep` and returns the standard dataset: labelled
sweep dims, the schema registry's curve outputs (``schema.CURVE_OUTPUTS``),
CF status flags, history and the scene file that reproduces it::

    >>> import rampwork as rw
    >>> from rampwork.curves import Curve
    >>> scene = CurveScene(curve=Curve.create("loop", radius=1.0), s0=0.0, u0=7.5)
    >>> ds = rw.simulate(scene, rw.Sweep.grid(radius=[0.8, 1.0, 1.2], mu=[0.0, 0.1]))

The curve kernel runs trajectories in SIMD lanes over threads
(core/curve_lanes.py), each with its own operations, so results do not
depend on the sweep they are part of nor on the thread count.  Everything is checked before any work.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace

import numpy as np
import xarray as xr

from . import schema, validate
from .curves import Curve, prepare_curve_run
from .core.curve_kernel import CURVE_STEPPERS, OUTPUTS as KERNEL_OUTPUTS
from .core.threads import current_threads
from .errors import ConfigError
from .scene import CONTACTS, Drag, Friction, Integrator, Record, Sweep

#: sweep axes of a curve scene that are not curve parameters
CURVE_SCENE_AXES = ("mu", "mu_k", "mu_s", "s0", "u0", "m", "g", "drag_linear", "drag_quadratic")
#: an adaptive method's first step where the scene gives none (s)
FIRST_STEP = 1e-3
#: kernel output -> dataset variable, where the names differ
_RENAMED = {"p_end": "s_end", "p_lift_off": "s_lift_off"}
CASE_ATTRS = {"long_name": "case number", "units": "1"}


@dataclass(frozen=True)
class CurveScene:
    """One set-up on a planar curve: the curve (family, parameters, side),
    start ``s0`` (m of arc length; may be left out when swept) and ``u0``
    (m/s along the curve, > 0 towards larger s), friction, drag, contact,
    integrator (``euler``, ``semi_implicit_euler``, ``rk4``, ``dopri5`` or ``dop853``),
    ``t_max``, ``m``, ``g``; ``record``: trajectories to record
    (:func:`curve_traces`)."""

    curve: Curve
    friction: Friction = field(default_factory=Friction)
    integrator: Integrator = field(default_factory=Integrator)
    s0: float | None = None
    u0: float = 0.0
    m: float = 1.0
    g: float = 9.81
    t_max: float = 60.0
    contact: str = "one_sided"
    title: str = "rampwork curve simulation"
    drag: Drag = field(default_factory=Drag)
    record: Record = field(default_factory=Record)

    def __post_init__(self):
        if not isinstance(self.curve, Curve):
            raise ConfigError("curve", f"expected a rampwork.curves.Curve, got {type(self.curve).__name__}")
        if self.curve.ramp is not None:
            raise ConfigError("curve", "a ramp y = f(x) runs as a rampwork.Scene (its own kernel); "
                              "a curve scene takes a curve family")
        for name, kind in (("friction", Friction), ("integrator", Integrator), ("drag", Drag),
                           ("record", Record)):
            if not isinstance(getattr(self, name), kind):
                raise ConfigError(name, f"expected a rampwork.{kind.__name__}, got {getattr(self, name)!r}")
        method = self.integrator.method
        if method not in CURVE_STEPPERS:
            raise ConfigError("integrator.method", f"curves run with {', '.join(CURVE_STEPPERS)}; "
                              f"got {method!r}")
        if self.integrator.dt_max is not None:
            raise ConfigError("integrator.dt_max", "not supported on curves yet")
        if self.s0 is not None:
            s0 = validate.real("s0", self.s0)
            lo, hi = self.curve.domain()
            if not lo[0] <= s0 <= hi[0]:
                raise ConfigError("s0", f"the start must lie on the curve, in [{lo[0]!r}, {hi[0]!r}] m "
                                  f"of arc length, got {s0!r}")
            object.__setattr__(self, "s0", s0)
        object.__setattr__(self, "u0", validate.real("u0", self.u0))
        object.__setattr__(self, "m", validate.positive("m", self.m))
        object.__setattr__(self, "g", validate.positive("g", self.g))
        object.__setattr__(self, "t_max", validate.positive("t_max", self.t_max))
        validate.choice("contact", self.contact, CONTACTS)
        if not isinstance(self.title, str):
            raise ConfigError("title", f"expected a string, got {self.title!r}")

    def replace(self, **changes) -> "CurveScene":
        return replace(self, **changes)

    @property
    def axis_names(self) -> tuple[str, ...]:
        """Every name a sweep may use with this scene."""
        return CURVE_SCENE_AXES + self.curve.spec.parameter_names

    @property
    def axis_specs(self) -> tuple:
        """What schema.axis_spec needs beyond its AXES for this scene's axes."""
        return tuple(schema.CURVE_AXES.values()) + self.curve.spec.parameters


# ------------------------------------------------------------------------------
# sweep -> flat per-trajectory values
# ------------------------------------------------------------------------------
def check_sweep(scene: CurveScene, sweep: Sweep) -> None:
    """The sweep's axes and size for this scene (cheap: nothing drawn)."""
    if not isinstance(sweep, Sweep):
        raise ConfigError("sweep", f"expected a rampwork.Sweep or None, got {type(sweep).__name__}")
    for name in sweep.names:
        if name not in scene.axis_names:
            raise ConfigError(f"sweep.{name}", f"unknown axis for a curve scene; allowed: "
                              f"{', '.join(scene.axis_names)}")
    if scene.s0 is None and "s0" not in sweep.names:
        raise ConfigError("s0", "required: the start's arc length (or a sweep axis s0)")
    if sweep.size > validate.MAX_TRAJECTORIES:
        raise ConfigError("sweep", f"{sweep.size:.3g} trajectories; at most "
                          f"{validate.MAX_TRAJECTORIES:.0e}")
    for k, index in enumerate(scene.record.indices or ()):
        if index >= sweep.size:
            raise ConfigError(f"record.indices[{k}]", f"{index} is beyond the sweep's "
                              f"{sweep.size:,} trajectories (flat indices 0 .. {sweep.size - 1:,})")


def flat_values(sweep: Sweep) -> dict[str, np.ndarray]:
    """Each axis's value for every trajectory, in the sweep's flat (C) order."""
    if sweep.kind == "grid" and sweep.design is None:
        columns = [values for _, values in sweep.axes]
        grids = np.meshgrid(*columns, indexing="ij") if columns else []
        return {name: grid.ravel() for (name, _), grid in zip(sweep.axes, grids)}
    return {name: np.asarray(sweep.values(name), dtype=np.float64) for name in sweep.names}


def _prepare(scene: CurveScene, sweep: Sweep, kernel: str | None = None,
             sweep_size: int | None = None):
    """``(run, values, mu_k, masses, gravity)`` of the sweep; its kernel's tier
    (``kernel``, rampwork.curves.curve_tier) chosen for ``sweep_size``
    trajectories (default: the sweep's)."""
    values = flat_values(sweep)
    n = sweep.size
    friction = scene.friction
    mu_k = values.get("mu_k", values.get("mu", friction.mu_k))
    mu_s = values.get("mu_s", values.get("mu", friction.mu_s))  # checked >= mu_k
    integrator = scene.integrator
    adaptive = {"rtol": integrator.rtol, "atol": integrator.atol} if integrator.adaptive else {}
    shape = {name: values[name] for name in scene.curve.spec.parameter_names if name in values}
    run = prepare_curve_run(
        scene.curve, s0=values.get("s0", scene.s0), u0=values.get("u0", scene.u0),
        mu_k=np.broadcast_to(mu_k, (n,)), mu_s=mu_s, g=values.get("g", scene.g),
        m=values.get("m", scene.m), method=integrator.method,
        dt=integrator.dt if integrator.dt is not None else FIRST_STEP, t_max=scene.t_max,
        contact=scene.contact, drag_linear=values.get("drag_linear", scene.drag.linear),
        drag_quadratic=values.get("drag_quadratic", scene.drag.quadratic), kernel=kernel,
        sweep_size=n if sweep_size is None else sweep_size, **adaptive, **shape)
    masses = np.broadcast_to(values.get("m", scene.m), (n,))
    gravity = np.broadcast_to(values.get("g", scene.g), (n,))
    return run, values, np.broadcast_to(mu_k, (n,)), masses, gravity


def check(scene: CurveScene, sweep: Sweep | None = None) -> Sweep:
    """Every check of a run, before any work; returns the sweep."""
    if not isinstance(scene, CurveScene):
        raise ConfigError("scene", f"expected a CurveScene, got {type(scene).__name__}")
    sweep = Sweep.single() if sweep is None else sweep
    check_sweep(scene, sweep)
    _prepare(scene, sweep)
    return sweep


def _drag_on(scene: CurveScene, sweep: Sweep) -> bool:
    return scene.drag.enabled or any(name.startswith("drag_") for name in sweep.names)


def simulate_curve_scene(scene: CurveScene, sweep: Sweep | None = None,
                         kernel: str | None = None) -> xr.Dataset:
    """The dataset of ``scene`` over ``sweep`` (see :func:`rampwork.simulate`)."""
    sweep = check(scene, sweep)
    run, values, mu_k, masses, gravity = _prepare(scene, sweep, kernel)
    started = time.perf_counter()
    run.compile()
    compile_seconds = time.perf_counter() - started
    started = time.perf_counter()
    raw = run.run()
    run_seconds = time.perf_counter() - started
    variables = curve_variables(scene, sweep, raw, mu_k, masses, gravity)
    dims, shape, coords = _layout(scene, sweep, values)
    data = {name: (dims, array.reshape(shape), schema.spec_attrs(schema.CURVE_OUTPUTS[name]))
            for name, array in variables.items()}
    dataset = xr.Dataset(data, coords=coords)
    if scene.record.enabled:
        started = time.perf_counter()
        def traced(j):  # trajectory j's column alone, on the sweep's kernel
            one = {name: column[j:j + 1] for name, column in values.items()}
            alone = replace(run, inputs=np.ascontiguousarray(run.inputs[:, j:j + 1]), shape=(1,))
            return alone, one

        dataset = dataset.merge(curve_traces(scene, sweep, traced))
        dataset.attrs["trace_time_s"] = time.perf_counter() - started
    dataset.attrs.update(attributes(scene, sweep, compile_seconds, run_seconds,
                                    int(variables["steps"].sum()), threads=current_threads(),
                                    tier=run.tier))
    return dataset


def traced_indices(record: Record, size: int) -> np.ndarray:
    """The flat indices a ``[record]`` table selects (as for ramp scenes)."""
    if record.indices:
        return np.array(record.indices, dtype=np.int64)
    count = min(record.count, size)
    return np.unique(np.linspace(0, size - 1, count).round().astype(np.int64))


def curve_traces(scene: CurveScene, sweep: Sweep, traced) -> xr.Dataset:
    """The recorded trajectories of ``scene.record`` (dims ``schema.TRACE_DIMS``,
    variables ``schema.curve_trace_names``): each a replay of its trajectory
    alone on the run's own kernel (core/curve_trace.py), whose last sample is
    the trajectory's outputs bit for bit.  ``traced(j)``: the
    :class:`~rampwork.curves.CurveRun` of flat trajectory j alone and its
    sweep values (a chunk of one, on the whole sweep's kernel)."""
    record = scene.record
    indices = traced_indices(record, sweep.size)
    traces, traced_values = [], []
    for j in indices:
        run, values = traced(int(j))
        traces.append(run.trace(0, record.every, record.max_samples))
        traced_values.append(values)
    lengths = np.array([t.shape[1] for t in traces], dtype=np.int64)
    names = schema.curve_trace_names(drag=_drag_on(scene, sweep))
    samples = np.full((len(names), len(indices), max(int(lengths.max()), 1)), np.nan)
    for k, trace in enumerate(traces):
        samples[:, k, :trace.shape[1]] = trace[:len(names)]
    dims = schema.TRACE_DIMS
    data = {name: (dims, samples[row], schema.spec_attrs(schema.CURVE_RECORD[name]))
            for row, name in enumerate(names)}
    coords = {"traced_index": (dims[0], indices, {"long_name": "flat index of the traced "
                                                  "trajectory in the sweep", "units": "1"}),
              "trace_length": (dims[0], lengths, {"long_name": "number of samples recorded",
                                                  "units": "1"})}
    for name in sweep.names:
        coords[f"traced_{name}"] = (dims[0], np.array([float(v[name][0]) for v in traced_values]),
                                    schema.traced_attrs(name, scene.axis_specs))
    return xr.Dataset(data, coords=coords)


def curve_variables(scene: CurveScene, sweep: Sweep, raw: dict, mu_k, masses,
                    gravity) -> dict[str, np.ndarray]:
    """The dataset's per-trajectory variables, flat, from a :class:`CurveRun`'s
    outputs ``raw`` and the run's ``mu_k``, masses and gravity (the whole
    sweep's, or a chunk's: rampwork.curve_chunks)."""
    n = len(mu_k)
    raw = {_RENAMED.get(name, name): np.broadcast_to(raw[name], (n,)).ravel()
           for name in KERNEL_OUTPUTS + ("status",)}
    raw["W_path"] = mu_k * masses * gravity * raw["path_length_X"]
    raw["W_excess"] = raw["W_friction"] - raw["W_path"]
    return {name: raw[name].astype(schema.CURVE_OUTPUTS[name].np_dtype)
            for name in schema.curve_output_names(drag=_drag_on(scene, sweep))}


def _layout(scene: CurveScene, sweep: Sweep, values: dict):
    specs = scene.axis_specs
    if not sweep.names:
        return (), (), {}
    coords = {}
    if sweep.kind == "grid":
        for name, axis in sweep.axes:
            coords[name] = (name, np.array(axis), schema.spec_attrs(schema.axis_spec(name, specs)))
        return sweep.dims, sweep.shape, coords
    for name in sweep.names:
        coords[name] = ("case", np.array(values[name]), schema.spec_attrs(schema.axis_spec(name, specs)))
    coords["case"] = ("case", np.arange(sweep.size), CASE_ATTRS)
    return ("case",), (sweep.size,), coords


def attributes(scene: CurveScene, sweep: Sweep, compile_seconds: float, run_seconds: float,
               steps: int, entry: str = "rampwork.simulate", threads: int = 1,
               tier: str = "specialised") -> dict:
    from .scenefile import dump_scene

    integrator = scene.integrator
    curve = scene.curve
    return schema.global_attrs(
        scene.title, dump_scene(scene, sweep, stored=True),
        f"{entry}: {sweep.size} trajectories on a {curve.family} curve, "
        f"{integrator.describe()}",
        {
            "curve_family": curve.family,
            "curve_side": curve.side,
            **{f"curve_{name}": value for name, value in curve.params},
            **{f"integrator_{key}": value for key, value in integrator.settings().items()},
            "integrator_used": integrator.method,
            "integrator_order": CURVE_STEPPERS[integrator.method][1],
            "integrator_adaptive": int(integrator.adaptive),
            "t_max": scene.t_max,
            "contact": scene.contact,
            **({"drag_linear": scene.drag.linear, "drag_quadratic": scene.drag.quadratic}
               if _drag_on(scene, sweep) else {}),
            "sweep_kind": sweep.kind,
            "kernel_closed_form": 0,
            "kernel_effects": f"curve kernel ({curve.family}, {scene.contact}; SIMD lanes)",
            "kernel_tier": tier,
            "n_trajectories": sweep.size,
            "trajectory_steps": steps,
            "compile_time_s": compile_seconds,
            "run_time_s": run_seconds,
            "threads": threads,
        },
    )
