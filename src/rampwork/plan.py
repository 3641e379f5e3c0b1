"""Planning a run: every value checked and the kernel variant chosen before any work starts.

:func:`plan_run` turns a validated :class:`~rampwork.scene.Scene` and
:class:`~rampwork.scene.Sweep` into a :class:`RunPlan`: the sweep's size and
shape, and the :class:`~rampwork.core.variant.KernelVariant` the run needs
(what the scene leaves out is left out of the compiled kernel).  Running it
is :mod:`rampwork.runner`'s job.
"""

from __future__ import annotations

import functools
import os
from dataclasses import dataclass

import numpy as np

from . import schema
from .core import kernel as K
from .core import reduce
from .core.steppers import STEPPERS as FIXED_STEP_METHODS
from .core.variant import CLOSED_FORM, KernelVariant
from .errors import ClosedFormNotice, ConfigError, option, warn
from .scene import Integrator, Scene, Sweep

#: refuse sweeps whose results would not fit in this share of physical memory
MEMORY_SHARE = 0.5
#: bytes held per trajectory in memory: result variables plus a chunk's temporaries
BYTES_PER_TRAJECTORY = 8 * len(schema.OUTPUTS) + 8


@dataclass(frozen=True)
class RunPlan:
    """A validated run: the kernel variant it needs and how to build each
    trajectory's parameters from the sweep."""

    scene: Scene
    sweep: Sweep
    shape: tuple[int, ...]
    size: int
    variant: KernelVariant

    @functools.cached_property
    def axis_arrays(self) -> dict[str, np.ndarray]:
        """The sweep's axes as arrays, converted once (not once a chunk)."""
        return {name: np.asarray(values) for name, values in self.sweep.axes}

    @functools.cached_property
    def grid_lengths(self) -> np.ndarray:
        """The grid's axis lengths, for :func:`core.reduce.grid_columns`."""
        return np.array([len(array) for array in self.axis_arrays.values()], dtype=np.int64)

    @functools.cached_property
    def grid_values(self) -> np.ndarray:
        """The grid's axes as rows padded to the longest (float64 axes only)."""
        values = np.zeros((len(self.axis_arrays), int(self.grid_lengths.max(initial=1))))
        for row, array in enumerate(self.axis_arrays.values()):
            values[row, :len(array)] = array
        return values

    @property
    def output_names(self) -> tuple[str, ...]:
        return schema.output_names(self.variant.adaptive, self.scene.diagnostics, self.variant.drag)

    @property
    def effects(self) -> tuple[str, ...]:
        """What the run simulates, in words (for attributes and the CLI)."""
        recording = ("trajectory recording",) if self.scene.record.enabled else ()
        return self.variant.effects + recording


# ------------------------------------------------------------------------------
# validation and planning
# ------------------------------------------------------------------------------
def _physical_memory() -> int:
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):  # pragma: no cover - non-POSIX
        return 8 << 30


def check_memory(plan: RunPlan) -> None:
    """Refuse an in-memory run whose results would not fit (a file written
    chunk by chunk, :func:`rampwork.run_to_file`, has no such limit)."""
    memory = plan.size * BYTES_PER_TRAJECTORY
    if memory > MEMORY_SHARE * _physical_memory():
        raise ConfigError("sweep", f"{plan.size:,} trajectories need about {memory / 2**30:.1f} GiB for "
                          f"their results, more than {MEMORY_SHARE:.0%} of this machine's "
                          f"{_physical_memory() / 2**30:.1f} GiB; split the sweep, or write it to a file "
                          "chunk by chunk (rampwork.run_to_file, or `rampwork run`)")


def plan_run(scene: Scene, sweep: Sweep | None = None) -> RunPlan:
    """Check everything about a run before any work starts (except the memory
    an in-memory result needs: :func:`check_memory`)."""
    if not isinstance(scene, Scene):
        raise ConfigError("scene", f"expected a rampwork.Scene, got {type(scene).__name__}")
    sweep = Sweep.single() if sweep is None else sweep
    if not isinstance(sweep, Sweep):
        raise ConfigError("sweep", f"expected a rampwork.Sweep, got {type(sweep).__name__}")
    allowed = scene.axis_names
    for name in sweep.names:
        if name not in allowed:
            if name in scene.ramp.spec.renamed:  # a parameter's old name
                raise scene.ramp.spec.unknown_parameter(f"sweep.{name}", name, allowed)
            raise ConfigError(f"sweep.{name}", f"unknown axis; allowed: {', '.join(allowed)}")
    if sweep.design is None:
        return _plan(scene, sweep, sweep)
    # a design's values all lie in its ranges: the grid of the ranges' ends
    # stands for them in every check (each is monotone in a value, or, for a
    # ramp's shape, convex in its parameters)
    ends = Sweep.grid(**{axis.name: sorted({axis.low, axis.high}) for axis in sweep.design.axes})
    try:
        return _plan(scene, sweep, ends)
    except ConfigError as error:
        name = error.where.removeprefix("sweep.")
        if name not in sweep.design.names:
            raise
        axis = sweep.design.axis(name)
        raise ConfigError(error.where, f"{error.problem} (the {sweep.kind} design draws {name} from "
                          f"[{axis.low!r}, {axis.high!r}])") from None


def _plan(scene: Scene, sweep: Sweep, checked: Sweep) -> RunPlan:
    """The plan of ``sweep``, its values checked as those of ``checked``."""
    size = sweep.size
    axes = dict(checked.axes)
    lo, hi = scene.ramp.domain
    for k, index in enumerate(scene.record.indices or ()):
        if index >= size:  # refused before the run, not after it
            raise ConfigError(f"record.indices[{k}]", f"{index} is beyond the sweep's {size:,} "
                              f"trajectories (flat indices 0 .. {size - 1:,})")

    x0 = axes.get("x0")
    if x0 is None:
        if scene.x0 is None:
            raise ConfigError("x0", "not given: set the scene's x0 or sweep over x0")
        x0 = (scene.x0,)
    x0 = np.asarray(x0)
    outside = (x0 < lo) | (x0 > hi)
    if outside.any():
        where = "sweep.x0" if "x0" in axes else "x0"
        raise ConfigError(where, f"{float(x0[outside][0])!r} is outside the ramp's domain [{lo!r}, {hi!r}]")
    for name in ("mu", "mu_k", "mu_s"):
        if name in axes and np.min(axes[name]) < 0:
            raise ConfigError(f"sweep.{name}", f"must be >= 0, got {float(np.min(axes[name]))!r}")
    for name in ("drag_linear", "drag_quadratic"):
        if name in axes and np.min(axes[name]) < 0:
            raise ConfigError(f"sweep.{name}", f"must be >= 0, got {float(np.min(axes[name]))!r}")
    for name in ("m", "g"):
        if name in axes and np.min(axes[name]) <= 0:
            raise ConfigError(f"sweep.{name}", f"must be > 0, got {float(np.min(axes[name]))!r}")
    _check_static_friction(scene, checked)

    # ramp parameters: every combination that occurs must be a valid ramp
    spec = scene.ramp.spec
    base = scene.ramp.param_dict()
    swept = [name for name in spec.parameter_names if name in axes]
    if checked.kind == "grid" and swept:
        mesh = np.meshgrid(*[np.asarray(axes[name]) for name in swept], indexing="ij")
        combos = {name: grid.ravel() for name, grid in zip(swept, mesh)}
    else:
        combos = {name: np.asarray(axes[name]) for name in swept}
    values = {name: combos.get(name, np.array([base[name]])) for name in spec.parameter_names}
    shared = scene.ramp.shared or None
    spec.check_values(values, scene.ramp.domain, shared)
    # n = g + v^2 f'' > 0 for all v where f'' >= 0: no lift-off or contact switch
    sign = spec.curvature_sign(values, scene.ramp.domain, shared)
    check_contact = not (sign is not None and sign >= 0)
    # air drag is compiled in only where some trajectory of the run has it
    drag_linear = bool(np.max(axes.get("drag_linear", (scene.drag.linear,))) > 0)
    drag_quadratic = bool(np.max(axes.get("drag_quadratic", (scene.drag.quadratic,))) > 0)
    # f'' == 0 everywhere: f' is constant, the motion has a closed form (without drag)
    closed_form = (scene.integrator.closed_form and sign == 0
                   and not (drag_linear or drag_quadratic))
    if closed_form:
        _note_closed_form(scene.integrator)
    mu_k = axes.get("mu", axes.get("mu_k", (scene.friction.mu_k,)))
    paper_criterion = "x_lift_off_paper" in scene.diagnostics
    if paper_criterion and (drag_linear or drag_quadratic):
        raise ConfigError("diagnostics", "x_lift_off_paper (the paper's eq. 26) is defined for "
                          "friction without air drag; remove the drag or the diagnostic")
    method = CLOSED_FORM if closed_form else scene.integrator.method
    short_stages = method in FIXED_STEP_METHODS and _short_stages(scene, axes, values, mu_k)
    variant = KernelVariant(
        spec.key, method,
        one_sided=scene.contact == "one_sided", check_contact=check_contact,
        carry_slope=not spec.cheap_slope, friction=bool(np.max(mu_k) > 0.0),
        drag_linear=drag_linear, drag_quadratic=drag_quadratic, paper_criterion=paper_criterion,
        constant_curvature=spec.constant_curvature,
        # g and the ramp's shape the same for every trajectory (not swept)
        uniform_parameters=not any(name in sweep.names
                                   for name in ("g",) + spec.parameter_names),
        short_stages=short_stages, project_energy=scene.integrator.project_energy)
    return RunPlan(scene, sweep, sweep.shape, size, variant)


def _short_stages(scene: Scene, axes: dict, values: dict, mu_k) -> bool:
    """Whether the ramp family's short stage evaluation serves every fixed
    step of the run (``RampFamily.short_stages``, from the largest starting
    speed, g, friction and drag of the run)."""
    def largest(name, default):
        return float(np.max(np.abs(np.asarray(axes.get(name, (default,)), dtype=float))))

    return scene.ramp.spec.short_stages(
        values, scene.ramp.domain, dt=scene.integrator.dt, v0=largest("v0", scene.v0),
        g=largest("g", scene.g), mu=float(np.max(mu_k)),
        drag_linear=largest("drag_linear", scene.drag.linear),
        drag_quadratic=largest("drag_quadratic", scene.drag.quadratic))


def _note_closed_form(integrator: Integrator) -> None:
    """A straight ramp is solved exactly, whatever the integrator: say so
    (once a process) where the scene asked for an integrator of its own."""
    if integrator == Integrator():  # the default: nothing was asked for
        return
    warn(f"a straight ramp is solved in closed form (exact, no steps): the integrator "
         f"asked for ({integrator.describe()}) is not used; {option('closed_form')} "
         "steps with it anyway", ClosedFormNotice)


def _check_static_friction(scene: Scene, sweep: Sweep) -> None:
    axes = dict(sweep.axes)
    if "mu" in axes:
        return
    mu_k = np.asarray(axes.get("mu_k", (scene.friction.mu_k,)))
    mu_s = np.asarray(axes.get("mu_s", (scene.friction.mu_s,)))
    if sweep.kind == "cases" and "mu_k" in axes and "mu_s" in axes:
        bad = mu_s < mu_k
        if bad.any():
            i = int(np.argmax(bad))
            raise ConfigError("sweep.mu_s", f"must be >= mu_k in every case; case {i} has "
                              f"mu_s = {float(mu_s[i])!r} < mu_k = {float(mu_k[i])!r}")
    elif mu_s.min() < mu_k.max():
        raise ConfigError("sweep.mu_s" if "mu_s" in axes else "friction.mu_s",
                          f"must be >= mu_k: mu_s = {float(mu_s.min())!r} < mu_k = {float(mu_k.max())!r}; "
                          "sweep 'mu' to set both together")


# ------------------------------------------------------------------------------
# per-trajectory parameters
# ------------------------------------------------------------------------------
def axis_values(plan: RunPlan, start: int, stop: int,
                columns: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """Each swept axis's value for the flat trajectories start..stop-1
    (a grid's into the rows of ``columns`` when given)."""
    if plan.sweep.design is not None:
        return plan.sweep.design.draw(start, stop)
    if not plan.sweep.axes:
        return {}
    arrays = plan.axis_arrays
    if plan.sweep.kind == "cases":
        return {name: array[start:stop].copy() for name, array in arrays.items()}
    if not all(array.dtype == np.float64 for array in arrays.values()):
        index = np.unravel_index(np.arange(start, stop), plan.shape)
        return {name: array[index[k]] for k, (name, array) in enumerate(arrays.items())}
    if columns is None:
        columns = np.empty((len(arrays), stop - start))
    reduce.grid_columns(start, plan.grid_lengths, plan.grid_values, columns)
    return dict(zip(arrays, columns))


def chunk_inputs(plan: RunPlan, start: int, stop: int, out: np.ndarray | None = None,
                 columns: np.ndarray | None = None,
                 values: dict[str, np.ndarray] | None = None) -> np.ndarray:
    """The kernel's input rows (K.N_INPUTS, stop - start) for a flat range
    (into ``out`` when given; ``columns``: scratch for a grid's axis values;
    ``values``: the range's :func:`axis_values`, when already drawn)."""
    scene = plan.scene
    n = stop - start
    if values is None:
        values = axis_values(plan, start, stop, columns)

    def column(name, default):
        return values[name] if name in values else default

    inputs = np.empty((K.N_INPUTS, n)) if out is None else out
    inputs[K.IN_X0] = column("x0", scene.x0)
    inputs[K.IN_V0] = column("v0", scene.v0)
    inputs[K.IN_G] = column("g", scene.g)
    if "mu" in values:
        inputs[K.IN_MUK] = values["mu"]
        inputs[K.IN_MUS] = values["mu"]
    else:
        inputs[K.IN_MUK] = column("mu_k", scene.friction.mu_k)
        inputs[K.IN_MUS] = column("mu_s", scene.friction.mu_s)
    inputs[K.IN_DRAG_B] = column("drag_linear", scene.drag.linear)
    inputs[K.IN_DRAG_C] = column("drag_quadratic", scene.drag.quadratic)
    spec = scene.ramp.spec
    rows = (K.IN_P0, K.IN_P1, K.IN_P2, K.IN_P3)
    if not any(name in values for name in spec.parameter_names):
        for row, value in zip(rows, scene.ramp.packed()):  # the scene's own shape throughout
            inputs[row] = value
        return inputs
    base = scene.ramp.param_dict()
    params = {name: values[name] if name in values else np.full(n, base[name])
              for name in spec.parameter_names}
    for row, packed in zip(rows, spec.pack(params, n)):
        inputs[row] = packed
    return inputs


def trajectory_masses(plan: RunPlan, start: int, stop: int,
                      values: dict[str, np.ndarray] | None = None) -> np.ndarray:
    if "m" not in plan.sweep.names:
        return np.full(stop - start, plan.scene.m)
    return (axis_values(plan, start, stop) if values is None else values)["m"]
