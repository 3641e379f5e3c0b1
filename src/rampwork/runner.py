"""The entry point: run a scene over a sweep and return a labelled Dataset.

Data flows one way: validated :class:`~rampwork.scene.Scene` and
:class:`~rampwork.scene.Sweep` -> a :class:`RunPlan` (every value checked, the
kernel's compile-time choices made) -> flat per-trajectory parameter arrays,
chunk by chunk -> the compiled kernel fills flat result arrays ->
``xarray.Dataset`` following the registry in :mod:`rampwork.schema`.
"""

from __future__ import annotations

import contextlib
import functools
import math
import os
import time
from dataclasses import dataclass

import numba
import numpy as np
import xarray as xr

from . import schema
from .core import kernel as K
from .core import reduce
from .core import straight
from .core.status import STATUS_NAMES
from .errors import ConfigError
from .ramps import Ramp
from .scene import Scene, Sweep

#: trajectories per kernel call; bounds the temporary input/output arrays
CHUNK_SIZE = 1 << 18
#: an adaptive step below this many rounding units of t_max counts as collapsed
H_MIN_ROUNDING = 4.0
#: families whose f', f'' cost less to re-evaluate than to carry in the lanes
CHEAP_FAMILIES = ("straight", "quadratic")
#: families whose f'' is the same all along the ramp (no curvature integral needed)
CONSTANT_CURVATURE_FAMILIES = ("straight", "quadratic")
#: refuse sweeps whose results would not fit in this share of physical memory
MEMORY_SHARE = 0.5
#: bytes held per trajectory in memory: result variables plus a chunk's temporaries
BYTES_PER_TRAJECTORY = 8 * len(schema.OUTPUTS) + 8


@dataclass(frozen=True)
class RunPlan:
    """A validated run: the kernel's compile-time choices and how to build each
    trajectory's parameters from the sweep."""

    scene: Scene
    sweep: Sweep
    shape: tuple[int, ...]
    size: int
    check_contact: bool
    carry_slope: bool
    closed_form: bool  # a straight ramp solved exactly, without stepping
    friction: bool  # mu_k > 0 somewhere: the kernel has a friction branch
    drag_linear: bool = False  # compile air drag's linear term (some b > 0 in the run)
    drag_quadratic: bool = False  # and its quadratic term (some c > 0)

    @property
    def drag(self) -> bool:
        return self.drag_linear or self.drag_quadratic

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
    def uniform_parameters(self) -> bool:
        """g and the ramp's shape the same for every trajectory (not swept)."""
        return not any(name in self.sweep.names
                       for name in ("g",) + self.scene.ramp.spec.parameter_names)

    @property
    def paper_criterion(self) -> bool:
        return "x_lift_off_paper" in self.scene.diagnostics

    @property
    def output_names(self) -> tuple[str, ...]:
        return schema.output_names(self.scene.integrator.adaptive, self.scene.diagnostics, self.drag)

    @property
    def kernel_key(self):
        scene = self.scene
        if self.closed_form:
            return (scene.ramp.spec.key, "closed_form", self.paper_criterion)
        return (scene.ramp.spec.key, scene.integrator.method, scene.contact == "one_sided",
                self.check_contact, self.carry_slope, self.paper_criterion, self.friction,
                self.drag_linear, self.drag_quadratic, self.uniform_parameters)

    @property
    def effects(self) -> tuple[str, ...]:
        """What the compiled kernel simulates, in words (for attributes and the CLI)."""
        scene = self.scene
        if self.closed_form:
            solver = "closed form (straight ramp: constant acceleration between events)"
        else:
            solver = f"stepping: {scene.integrator.method}"
        effects = [solver, "kinetic friction" if self.friction else "no friction (mu_k = 0)"]
        if self.closed_form:
            effects.append("contact never lost (n = g > 0)")
        elif scene.contact == "two_sided":
            effects.append("two-sided contact (bead on a wire)" + (
                ", sign switches of n" if self.check_contact else ", n > 0 known in advance"))
        else:
            effects.append("one-sided contact, " + (
                "lift-off check" if self.check_contact else "no lift-off check (f'' >= 0)"))
        if self.drag:
            effects.append("air drag (" + " and ".join(
                kind for kind, on in (("linear", self.drag_linear), ("quadratic", self.drag_quadratic))
                if on) + ")")
        effects += [f"diagnostic {name}" for name in scene.diagnostics]
        if scene.record.enabled:
            effects.append("trajectory recording")
        return tuple(effects)


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
            raise ConfigError(f"sweep.{name}", f"unknown axis; allowed: {', '.join(allowed)}")
    size = sweep.size
    axes = dict(sweep.axes)
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
        if name in axes and min(axes[name]) < 0:
            raise ConfigError(f"sweep.{name}", f"must be >= 0, got {float(min(axes[name]))!r}")
    for name in ("drag_linear", "drag_quadratic"):
        if name in axes and min(axes[name]) < 0:
            raise ConfigError(f"sweep.{name}", f"must be >= 0, got {float(min(axes[name]))!r}")
    for name in ("m", "g"):
        if name in axes and min(axes[name]) <= 0:
            raise ConfigError(f"sweep.{name}", f"must be > 0, got {float(min(axes[name]))!r}")
    _check_static_friction(scene, sweep)

    # ramp parameters: every combination that occurs must be a valid ramp
    spec = scene.ramp.spec
    base = scene.ramp.param_dict()
    swept = [name for name in spec.parameter_names if name in axes]
    if sweep.kind == "grid" and swept:
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
    carry_slope = scene.ramp.family not in CHEAP_FAMILIES
    # air drag is compiled in only where some trajectory of the run has it
    drag_linear = bool(max(axes.get("drag_linear", (scene.drag.linear,))) > 0)
    drag_quadratic = bool(max(axes.get("drag_quadratic", (scene.drag.quadratic,))) > 0)
    # f'' == 0 everywhere: f' is constant, the motion has a closed form (without drag)
    closed_form = (scene.integrator.closed_form and sign == 0
                   and not (drag_linear or drag_quadratic))
    mu_k = axes.get("mu", axes.get("mu_k", (scene.friction.mu_k,)))
    friction = bool(max(mu_k) > 0.0)
    if "x_lift_off_paper" in scene.diagnostics and (drag_linear or drag_quadratic):
        raise ConfigError("diagnostics", "x_lift_off_paper (the paper's eq. 26) is defined for "
                          "friction without air drag; remove the drag or the diagnostic")
    return RunPlan(scene, sweep, sweep.shape, size, check_contact, carry_slope, closed_form,
                   friction, drag_linear, drag_quadratic)


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
# kernels
# ------------------------------------------------------------------------------
_KERNELS: dict = {}


def get_kernel(plan: RunPlan):
    """The compiled ``(run_batch, trace_one)`` for a plan, built once per process
    (and loaded from numba's on-disk cache when it was compiled before).
    Returns ``(kernels, seconds)``, seconds spent building and loading."""
    key = plan.kernel_key
    if key in _KERNELS:
        return _KERNELS[key], 0.0
    started = time.perf_counter()
    spec = plan.scene.ramp.spec
    if plan.closed_form:
        kernels = straight.build_closed_form(spec.height, spec.slope_curvature, name=spec.key,
                                             paper_criterion=plan.paper_criterion,
                                             cache=spec.cacheable)
        _KERNELS[key] = kernels
        return kernels, time.perf_counter() - started
    kernels = K.build_kernel(
        plan.scene.integrator.method, spec.height, spec.slope_curvature, name=spec.key,
        one_sided=plan.scene.contact == "one_sided", check_contact=plan.check_contact,
        carry_slope=plan.carry_slope, drag_linear=plan.drag_linear,
        drag_quadratic=plan.drag_quadratic, paper_criterion=plan.paper_criterion,
        friction=plan.friction,
        constant_curvature=plan.scene.ramp.family in CONSTANT_CURVATURE_FAMILIES,
        uniform_parameters=plan.uniform_parameters, cache=spec.cacheable)
    _KERNELS[key] = kernels
    return kernels, time.perf_counter() - started


def _settings(scene: Scene) -> np.ndarray:
    settings = np.zeros(K.N_SETTINGS)
    settings[K.SET_XLO], settings[K.SET_XHI] = scene.ramp.domain
    settings[K.SET_TMAX] = scene.t_max
    # the scene's own g and ramp shape: what every trajectory has where the
    # sweep does not set them (kernels built with uniform_parameters read them)
    settings[K.SET_G] = scene.g
    settings[K.SET_P0:K.SET_P3 + 1] = scene.ramp.packed()
    integrator = scene.integrator
    if integrator.adaptive:
        settings[K.SET_DT] = 0.0 if integrator.dt is None else integrator.dt  # 0: estimate
        settings[K.SET_RTOL] = integrator.rtol
        settings[K.SET_ATOL] = integrator.atol
        settings[K.SET_HMAX] = math.inf if integrator.dt_max is None else integrator.dt_max
        # below a few rounding units of the time a step no longer advances it
        settings[K.SET_HMIN] = H_MIN_ROUNDING * np.finfo(np.float64).eps * scene.t_max
    else:
        settings[K.SET_DT] = integrator.dt
    return settings


@dataclass(frozen=True)
class Prepared:
    """A plan with its compiled kernels and the arrays every chunk shares."""

    plan: RunPlan
    run_batch: object
    trace_one: object
    settings: np.ndarray
    shared: np.ndarray
    compile_seconds: float


def prepare(plan: RunPlan) -> Prepared:
    """Build (or load) the plan's kernels and compile them on one trajectory."""
    (run_batch, trace_one), build_seconds = get_kernel(plan)
    settings = _settings(plan.scene)
    compile_seconds = build_seconds + _warm_up(run_batch, plan, settings)
    return Prepared(plan, run_batch, trace_one, settings, plan.scene.ramp.shared_array(),
                    compile_seconds)


def empty_results(plan: RunPlan, n: int) -> dict[str, np.ndarray]:
    """Uninitialised arrays for the plan's output variables, ``n`` long."""
    return {name: np.empty(n, dtype=schema.OUTPUTS[name].np_dtype)
            for name in plan.output_names}


class ChunkBuffers:
    """The arrays one chunk needs besides its results, allocated once per run
    and reused by every chunk: fresh arrays of this size (60 MB for a full
    chunk) cost more in first-touch page faults than the work done in them."""

    def __init__(self, plan: RunPlan, size: int):
        self.size = size
        self._inputs = np.empty(K.N_INPUTS * size)
        self._raw = np.empty(K.N_OUTPUTS * size)
        self._columns = np.empty(len(plan.axis_arrays) * size)

    def arrays(self, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(inputs, raw, columns) for a chunk of n <= size trajectories: C-contiguous
        (rows, n) views (slices of (rows, size) arrays would not be, and the
        kernel would compile again for strided arrays)."""
        return (self._inputs[:K.N_INPUTS * n].reshape(K.N_INPUTS, n),
                self._raw[:K.N_OUTPUTS * n].reshape(K.N_OUTPUTS, n),
                self._columns[:self._columns.size // self.size * n].reshape(-1, n))


def run_chunk(prepared: Prepared, start: int, stop: int, threads: int,
              out: dict[str, np.ndarray] | None = None,
              buffers: ChunkBuffers | None = None) -> dict[str, np.ndarray]:
    """Run the flat trajectories start..stop-1 and reduce them to the output
    variables (into ``out`` when given; ``buffers`` to reuse a run's scratch
    arrays). Call inside :func:`using_threads`."""
    plan = prepared.plan
    n = stop - start
    if buffers is None or buffers.size < n:
        buffers = ChunkBuffers(plan, n)
    inputs, raw, columns = buffers.arrays(n)
    inputs = chunk_inputs(plan, start, stop, out=inputs, columns=columns)
    raw.fill(0.0)
    prepared.run_batch(inputs, prepared.settings, raw, prepared.shared, tile_size(n, threads))
    if out is None:
        out = empty_results(plan, n)
    return reduce_outputs(raw, inputs, _masses(plan, start, stop), out=out)


@contextlib.contextmanager
def using_threads(threads: int):
    """numba's thread count (restored afterwards) and one-tile scheduling."""
    previous_threads = numba.get_num_threads()
    numba.set_num_threads(threads)
    try:
        with numba.parallel_chunksize(1):
            yield
    finally:
        numba.set_num_threads(previous_threads)


def _warm_up(run_batch, plan: RunPlan, settings: np.ndarray) -> float:
    """Compile (or load) the kernel on one trajectory that ends at once (it
    starts on the domain's upper end moving out), so that compile time is
    measured apart from run time."""
    started = time.perf_counter()  # the array passes around the kernel compile too
    inputs = chunk_inputs(plan, 0, 1)
    inputs[K.IN_X0] = plan.scene.ramp.domain[1]
    inputs[K.IN_V0] = 1.0
    raw = np.zeros((K.N_OUTPUTS, 1))
    run_batch(inputs, settings, raw, plan.scene.ramp.shared_array(), 1)
    reduce_outputs(raw, inputs, np.ones(1), out=empty_results(plan, 1))
    return time.perf_counter() - started


# ------------------------------------------------------------------------------
# per-trajectory parameters
# ------------------------------------------------------------------------------
def axis_values(plan: RunPlan, start: int, stop: int,
                columns: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """Each swept axis's value for the flat trajectories start..stop-1
    (a grid's into the rows of ``columns`` when given)."""
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
                 columns: np.ndarray | None = None) -> np.ndarray:
    """The kernel's input rows (K.N_INPUTS, stop - start) for a flat range
    (into ``out`` when given; ``columns``: scratch for a grid's axis values)."""
    scene = plan.scene
    n = stop - start
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


def _masses(plan: RunPlan, start: int, stop: int) -> np.ndarray:
    if "m" not in plan.sweep.names:
        return np.full(stop - start, plan.scene.m)
    return axis_values(plan, start, stop)["m"]


# ------------------------------------------------------------------------------
# reduction to the schema's variables
# ------------------------------------------------------------------------------
def reduce_outputs(raw: np.ndarray, inputs: np.ndarray, mass: np.ndarray,
                   out: dict[str, np.ndarray] | None = None) -> dict[str, np.ndarray]:
    """The schema's per-trajectory variables from the kernel's per-unit-mass rows.

    With ``out`` (name -> array of the chunk's length), the variables are
    written into those arrays (only the names present), without temporaries
    of their own; returns ``out``.  One parallel pass (``core.reduce``):
    W_friction = m w, W_linear = mu_k m g |x_end - x0|, W_excess their
    difference, W_path = mu_k m g path_length_x, energy_balance_error =
    W_friction (+ W_drag) - m (energy lost per unit mass)."""
    n = raw.shape[1]
    if out is None:
        out = {name: np.empty(n, dtype=schema.OUTPUTS[name].np_dtype)
               for name in schema.OUTPUTS}

    def target(name):
        if name in out:
            return out[name]
        # optional variables are skipped; the others go to scratch
        length = 0 if name in _OPTIONAL_OUTPUTS else n
        return np.empty(length, dtype=schema.OUTPUTS[name].np_dtype)

    reduce.reduce_rows(raw, inputs[K.IN_X0], inputs[K.IN_MUK], inputs[K.IN_G],
                       np.ascontiguousarray(mass, dtype=np.float64),
                       *(target(name) for name in _REDUCED_OUTPUTS))
    return out


#: reduce_rows's output arguments, in its order
_REDUCED_OUTPUTS = ("status", "t_end", "x_end", "v_end", "convexity_mean", "path_length_x",
                    "n_reversals", "x_lift_off", "x_lift_off_paper", "steps", "steps_rejected",
                    "W_friction", "W_energy", "W_friction_error_estimate", "W_drag", "W_linear",
                    "W_excess", "W_path", "energy_balance_error")
#: the ones reduce_rows skips when given an empty array
_OPTIONAL_OUTPUTS = ("x_lift_off_paper", "steps_rejected", "W_friction_error_estimate", "W_drag")


def tile_size(n: int, threads: int) -> int:
    """Trajectories per tile: enough tiles for every thread to stay busy
    (dynamic scheduling), each big enough to keep its lanes full."""
    target = math.ceil(n / (8 * max(threads, 1)))
    return int(min(16384, max(4 * 64, target)))


# ------------------------------------------------------------------------------
# the entry point
# ------------------------------------------------------------------------------
def simulate(scene: Scene, sweep: Sweep | None = None, *, threads: int | None = None,
             progress=None) -> xr.Dataset:
    """Run ``scene`` over ``sweep`` (default: one trajectory) and return the
    per-trajectory results as an ``xarray.Dataset`` (DESIGN §2).

    ``threads``: worker threads (default: all of numba's).  ``progress``: an
    optional callable ``progress(done, total)`` called after each chunk.
    """
    plan = plan_run(scene, sweep)
    check_memory(plan)
    threads = thread_count(threads)
    prepared = prepare(plan)

    results = empty_results(plan, plan.size)
    started = time.perf_counter()
    buffers = ChunkBuffers(plan, min(plan.size, CHUNK_SIZE))
    with using_threads(threads):
        for start in range(0, plan.size, CHUNK_SIZE):
            stop = min(plan.size, start + CHUNK_SIZE)
            run_chunk(prepared, start, stop, threads,
                      out={name: array[start:stop] for name, array in results.items()},
                      buffers=buffers)
            if progress is not None:
                progress(stop, plan.size)
    run_seconds = time.perf_counter() - started

    layout = dataset_layout(plan)
    dataset = xr.Dataset({name: (layout.dims, values.reshape(layout.shape), layout.attrs[name])
                          for name, values in results.items()}, coords=layout.coords)
    if scene.record.enabled:
        dataset, trace_seconds = with_traces(prepared, dataset)
        dataset.attrs["trace_time_s"] = trace_seconds
    steps = int(results["steps"].sum())
    dataset.attrs.update(attributes(plan, prepared.compile_seconds, run_seconds, threads, steps))
    return dataset


def with_traces(prepared: Prepared, dataset: xr.Dataset) -> tuple[xr.Dataset, float]:
    """``dataset`` with the scene's recorded trajectories merged in, and the
    seconds they took (including ``trace_one``'s own first compilation)."""
    started = time.perf_counter()
    traces = _traces(prepared.plan, prepared.trace_one, prepared.settings, prepared.shared)
    return dataset.merge(traces), time.perf_counter() - started


def thread_count(threads: int | None) -> int:
    available = numba.config.NUMBA_NUM_THREADS
    if threads is None:
        return available
    if isinstance(threads, bool) or not isinstance(threads, (int, np.integer)) or threads < 1:
        raise ConfigError("threads", f"must be a positive integer, got {threads!r}")
    if threads > available:
        raise ConfigError("threads", f"at most {available} on this machine "
                          f"(NUMBA_NUM_THREADS), got {threads}")
    return int(threads)


@dataclass(frozen=True)
class DatasetLayout:
    """What a run's dataset looks like before it has values: the output
    variables' dims, shape and attributes, and the coordinates (small arrays,
    the sweep's own axes)."""

    dims: tuple[str, ...]
    shape: tuple[int, ...]
    attrs: dict[str, dict]
    coords: dict[str, tuple]


def dataset_layout(plan: RunPlan) -> DatasetLayout:
    sweep = plan.sweep
    ramp_parameters = plan.scene.ramp.spec.parameters
    dims = sweep.dims if sweep.axes else ()
    shape = plan.shape if sweep.axes else ()
    coords = {}
    for name, values in sweep.axes:
        spec = schema.axis_spec(name, ramp_parameters)
        attrs = schema.spec_attrs(spec)
        coords[name] = ((sweep.dims[0] if sweep.kind == "cases" else name), np.asarray(values), attrs)
    if sweep.kind == "cases" and sweep.axes:
        coords["case"] = ("case", np.arange(plan.size), {"long_name": "case number", "units": "1"})
    attrs = {name: schema.output_attrs(name) for name in plan.output_names}
    return DatasetLayout(tuple(dims), tuple(shape), attrs, coords)


def _traces(plan: RunPlan, trace_one, settings, shared) -> xr.Dataset:
    record = plan.scene.record
    if record.indices:
        indices = np.array(record.indices, dtype=np.int64)  # checked by plan_run
    else:
        count = min(record.count, plan.size)
        indices = np.unique(np.linspace(0, plan.size - 1, count).round().astype(np.int64))
    samples = np.full((4, len(indices), record.max_samples), np.nan)
    lengths = np.zeros(len(indices), dtype=np.int64)
    for k, j in enumerate(indices):
        inputs = chunk_inputs(plan, int(j), int(j) + 1)
        trace = np.full((4, record.max_samples), np.nan)
        lengths[k] = trace_one(0, inputs, settings, shared, record.every, trace)
        mass = _masses(plan, int(j), int(j) + 1)[0]
        trace[3] *= mass
        samples[:, k, :] = trace
    samples = samples[:, :, :max(int(lengths.max()), 1)]  # no all-NaN tail
    dims = schema.TRACE_DIMS
    data_vars = {name: (dims, samples[row], schema.output_attrs(name))
                 for row, name in enumerate(("trace_t", "trace_x", "trace_v", "trace_W_friction"))}
    coords = {"traced_index": (dims[0], indices, {"long_name": "flat index of the traced trajectory in the sweep",
                                                   "units": "1"}),
              "trace_length": (dims[0], lengths, {"long_name": "number of samples recorded", "units": "1"})}
    traced_values = [axis_values(plan, int(j), int(j) + 1) for j in indices]
    for name in plan.sweep.names:
        coords[f"traced_{name}"] = (dims[0], np.array([values[name][0] for values in traced_values]),
                                    {"long_name": f"{name} of the traced trajectory"})
    return xr.Dataset(data_vars, coords=coords)


def scene_text(scene: Scene, sweep: Sweep) -> str:
    """The scene file that reproduces a run; for a ramp of user functions,
    which no file can hold, the same file with the ramp described in comments
    (the rest still documents every setting)."""
    from .scenefile import dump_scene

    if scene.ramp.family != "callable":
        return dump_scene(scene, sweep)
    spec = scene.ramp.spec
    stand_in = scene.replace(ramp=Ramp.create("straight", slope=0.0, domain=scene.ramp.domain))
    lines = dump_scene(stand_in, sweep).splitlines()
    start = lines.index("[ramp]")
    end = next((k for k in range(start + 1, len(lines)) if lines[k].startswith("[")), len(lines))
    note = [f"# [ramp]: user functions {spec.name!r} (Ramp.from_functions) on domain "
            f"{list(scene.ramp.domain)}, curvature sign {spec.curvature_sign({}, scene.ramp.domain)}; "
            "not reproducible from this file"]
    return "\n".join(lines[:start] + note + lines[end:]) + "\n"


def attributes(plan: RunPlan, compile_seconds, run_seconds, threads, steps,
               entry: str = "rampwork.simulate") -> dict:
    """The dataset's global attributes (``entry``: what made it, for history)."""
    scene = plan.scene
    return schema.global_attrs(
        scene.title,
        scene_text(scene, plan.sweep),
        f"{entry}: {plan.size} trajectories, {scene.integrator.describe()}",
        {
            "ramp_family": scene.ramp.family,
            "ramp_domain": np.array(scene.ramp.domain),
            **{f"integrator_{key}": value for key, value in scene.integrator.settings().items()},
            "integrator_order": scene.integrator.order,
            "integrator_adaptive": int(scene.integrator.adaptive),
            "t_max": scene.t_max,
            "contact": scene.contact,
            **({"drag_linear": scene.drag.linear, "drag_quadratic": scene.drag.quadratic}
               if plan.drag else {}),
            "sweep_kind": plan.sweep.kind,
            "kernel_checks_contact": int(plan.check_contact),
            "kernel_closed_form": int(plan.closed_form),
            "kernel_effects": "; ".join(plan.effects),
            "n_trajectories": plan.size,
            "trajectory_steps": steps,
            "compile_time_s": compile_seconds,
            "run_time_s": run_seconds,
            "threads": threads,
        },
    )


__all__ = ["simulate", "plan_run", "RunPlan", "STATUS_NAMES"]
