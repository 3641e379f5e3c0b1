"""The entry point: run a scene over a sweep and return a labelled Dataset.

Data flows one way: validated :class:`~rampwork.scene.Scene` and
:class:`~rampwork.scene.Sweep` -> a :class:`~rampwork.plan.RunPlan` (every value checked, the
kernel's compile-time choices made) -> flat per-trajectory parameter arrays,
chunk by chunk -> the compiled kernel fills flat result arrays ->
``xarray.Dataset`` following the registry in :mod:`rampwork.schema`.
"""

from __future__ import annotations

import concurrent.futures
import contextlib
import math
import time
import warnings
from dataclasses import dataclass

import numpy as np
import xarray as xr

from . import kernels, schema
from .core import kernel as K
from .core import reduce
from .core.jit import quick_codegen
from .core.threads import max_threads, using_threads
from .core.status import STATUS_NAMES
from .errors import ConfigError
from .plan import (RunPlan, axis_values, check_memory, chunk_inputs, plan_run,  # noqa: F401
                   trajectory_masses)
from .ramps import Ramp
from .scene import Scene, Sweep

#: trajectories per kernel call; bounds the temporary input/output arrays
CHUNK_SIZE = 1 << 18
#: an adaptive step below this many rounding units of t_max counts as collapsed
H_MIN_ROUNDING = 4.0
# ------------------------------------------------------------------------------
# kernels
# ------------------------------------------------------------------------------
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
    kernel_source: str  # see kernels.kernel_source()
    tier: str  # "general" or "specialised" (see rampwork.kernels)


def prepare(plan: RunPlan, kernel: str | None = None, warm_up: bool = True) -> Prepared:
    """Build (or load) the kernels of the plan's tier (``kernel``: a tier of
    ``kernels.TIERS``; None: the default) and compile them on one trajectory
    (``warm_up=False``: only where not loaded in this process already)."""
    tier = kernels.choose_tier(plan, kernel)
    variant = kernels.tier_variant(plan, tier)
    source = kernels.kernel_source(variant, plan)
    (run_batch, trace_one), build_seconds = kernels.get_kernel(variant, plan)
    settings = np.concatenate([_settings(plan.scene), kernels.runtime_settings(plan)])
    shared = kernels.tier_shared(plan, tier)
    with _codegen(tier):
        compile_seconds = build_seconds + (_warm_up(run_batch, plan, settings, shared)
                                           if warm_up or source != "loaded" else 0.0)
    if source == "compiled" and tier == "specialised":
        # the general kernels, once per machine, in the background: started
        # after this compilation, so that the two do not share the cores
        kernels.start_warmup()
    return Prepared(plan, run_batch, trace_one, settings, shared, compile_seconds, source, tier)


#: trajectories per chunk while the general kernel may hand over: the hand-over points
GENERAL_CHUNK = 4096
#: general-kernel seconds still to go above which the specialised kernel is
#: compiled in the background (its compilation takes 2-9 s on 2 cores)
SPECIALISE_AFTER_S = 2.0
_COMPILER = concurrent.futures.ThreadPoolExecutor(max_workers=1, thread_name_prefix="rampwork-compile")


class _Handover:
    """The prepared kernel for each chunk of a run.  A run that starts on the
    general kernel (``auto``) and would keep it busy for more than
    SPECIALISE_AFTER_S compiles its specialised kernel in the background
    and hands over to it at the next chunk boundary (equal results)."""

    def __init__(self, plan: RunPlan, prepared: Prepared, auto: bool):
        self.plan = plan
        self.first = self.prepared = prepared
        self.may_specialise = auto and prepared.tier == "general"
        self.compiling = None

    def current(self) -> Prepared:
        if self.compiling is not None and self.compiling.done():
            error = self.compiling.exception()
            if error is None:
                self.prepared = self.compiling.result()
            else:  # the general kernel goes on: the run loses nothing
                warnings.warn(f"rampwork: the specialised kernel did not compile ({error!r}); "
                              "the run goes on on the general kernel", RuntimeWarning, stacklevel=3)
            self.compiling = None
            self.may_specialise = False
        return self.prepared

    def chunk_size(self) -> int:
        waiting = self.may_specialise or self.compiling is not None
        return GENERAL_CHUNK if self.prepared.tier == "general" and waiting else CHUNK_SIZE

    def after_chunk(self, done: int, left: int, seconds: float) -> None:
        if (self.may_specialise and self.compiling is None and left > 0
                and seconds / max(done, 1) * left > SPECIALISE_AFTER_S):
            self.compiling = _COMPILER.submit(prepare, self.plan, "specialised")


def _codegen(tier: str):
    """How a tier's kernels are compiled (see core.jit.quick_codegen)."""
    return quick_codegen() if tier == "general" else contextlib.nullcontext()


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
    values = axis_values(plan, start, stop, columns)  # a design's: drawn once a chunk
    inputs = chunk_inputs(plan, start, stop, out=inputs, values=values)
    raw.fill(0.0)
    prepared.run_batch(inputs, prepared.settings, raw, prepared.shared, tile_size(n, threads))
    if out is None:
        out = empty_results(plan, n)
        out.update(drawn_coordinates(plan, start, stop, values))
    else:
        for name, array in drawn_coordinates(plan, start, stop, values).items():
            if name in out:
                out[name][...] = array
    return reduce_outputs(raw, inputs, trajectory_masses(plan, start, stop, values), out=out)


def drawn_coordinates(plan: RunPlan, start: int, stop: int,
                      values: dict[str, np.ndarray] | None = None) -> dict[str, np.ndarray]:
    """The values of the coordinates a run draws (:attr:`DatasetLayout.drawn`:
    a design's axes and its ``case`` numbers) for the flat range start..stop-1;
    ``values``: the range's :func:`axis_values`, when already drawn. Empty
    for a grid or cases sweep, whose coordinates are its own values."""
    if plan.sweep.design is None:
        return {}
    values = axis_values(plan, start, stop) if values is None else values
    return {"case": np.arange(start, stop, dtype=np.int64), **values}




def _warm_up(run_batch, plan: RunPlan, settings: np.ndarray, shared: np.ndarray) -> float:
    """Compile (or load) the kernel on one trajectory that ends at once (it
    starts on the domain's upper end moving out), so that compile time is
    measured apart from run time."""
    started = time.perf_counter()  # the array passes around the kernel compile too
    inputs = chunk_inputs(plan, 0, 1)
    inputs[K.IN_X0] = plan.scene.ramp.domain[1]
    inputs[K.IN_V0] = 1.0
    raw = np.zeros((K.N_OUTPUTS, 1))
    run_batch(inputs, settings, raw, shared, 1)
    reduce_outputs(raw, inputs, np.ones(1), out=empty_results(plan, 1))
    return time.perf_counter() - started


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
                       *(target(name) for name in schema.OUTPUTS))  # in the schema's order
    return out


#: outputs a run may not have: reduce_rows skips those given as empty arrays
_OPTIONAL_OUTPUTS = tuple(name for name, spec in schema.OUTPUTS.items() if spec.present != "always")


def tile_size(n: int, threads: int) -> int:
    """Trajectories per tile: enough tiles for every thread to stay busy
    (dynamic scheduling), each big enough to keep its lanes full.  One
    thread needs no balance: as few tiles as the cap allows, of equal size,
    because each tile ends in a tail where its last, longest trajectories
    run with most lanes empty (2 tiles instead of 8 on benchmarks/families.py's
    grid: the general tier 1.11-1.15x faster, dopri5 1.07-1.17x; results are
    the same bits whatever the tiles; benchmarks/README.md, sixth pass)."""
    if max(threads, 1) == 1:
        return int(max(1, math.ceil(n / math.ceil(max(n, 1) / 16384))))
    target = math.ceil(n / (8 * max(threads, 1)))
    return int(min(16384, max(4 * 64, target)))


# ------------------------------------------------------------------------------
# the entry point
# ------------------------------------------------------------------------------
def simulate(scene: Scene, sweep: Sweep | None = None, *, threads: int | None = None,
             progress=None, kernel: str | None = None) -> xr.Dataset:
    """Run ``scene`` over ``sweep`` (default: one trajectory) and return the
    per-trajectory results as an ``xarray.Dataset`` (docs/physics.md §2).

    ``threads``: worker threads (default: all of numba's).  ``progress``: an
    optional callable ``progress(done, total)`` called after each chunk.
    ``kernel``: ``"auto"`` (default, or ``RAMPWORK_KERNEL``), ``"general"``
    or ``"specialised"`` (see :mod:`rampwork.kernels`; results are equal).

    A straight ramp (f'' = 0 on the whole domain, no air drag) is solved in
    closed form, exact to rounding, whatever ``scene.integrator`` says:
    ``Integrator(method, ..., closed_form=False)`` steps with the method
    instead (to measure its error).  The dataset says which ran
    (``integrator_used``, ``kernel_closed_form``), and a scene that asks for
    an integrator of its own gets a one-time :class:`~rampwork.errors.ClosedFormNotice`.

    A :class:`~rampwork.curve_scene.CurveScene` (a planar curve, docs/physics.md §5)
    runs on the curve kernel, in SIMD lanes over ``threads`` threads
    (``kernel`` checked, not used), into the same kind of dataset with the
    curve's outputs (``schema.CURVE_OUTPUTS``).
    """
    return run_scene(scene, sweep, threads=threads, progress=progress, kernel=kernel)


def run_scene(scene: Scene, sweep: Sweep | None = None, *, threads: int | None = None,
              progress=None, kernel: str | None = None, store_scene: bool = True) -> xr.Dataset:
    """:func:`simulate`; ``store_scene=False`` leaves the scene file out of
    the dataset (``rampwork_scene`` then says so): for callers that keep
    what it would hold otherwise, such as ``ChordModes.evaluate``, whose
    population table would be written number by number (a fifth of its time
    at rtol 1e-6).  A y = f(x) scene only."""
    from .curve_scene import CurveScene, simulate_curve_scene

    if isinstance(scene, CurveScene):
        kernels.requested_tier(kernel)
        with using_threads(thread_count(threads)):
            dataset = simulate_curve_scene(scene, sweep, kernel)
        if progress is not None:
            progress(dataset.attrs["n_trajectories"], dataset.attrs["n_trajectories"])
        return dataset
    plan = plan_run(scene, sweep)
    requested = kernels.requested_tier(kernel)  # a bad tier is refused before any work
    check_memory(plan)
    threads = thread_count(threads)
    prepared = prepare(plan, kernel)
    tiers = [prepared.tier]
    handover = _Handover(plan, prepared, requested == "auto")

    results = empty_results(plan, plan.size)
    layout = dataset_layout(plan)
    coords = dict(layout.coords)
    drawn = {name: np.empty(plan.size, dtype=coords[name][1].dtype) for name in layout.drawn}
    started = time.perf_counter()
    buffers = ChunkBuffers(plan, min(plan.size, CHUNK_SIZE))
    with using_threads(threads):
        start = 0
        while start < plan.size:
            prepared = handover.current()
            if prepared.tier not in tiers:
                tiers.append(prepared.tier)
            stop = min(plan.size, start + handover.chunk_size())
            chunk_started = time.perf_counter()
            run_chunk(prepared, start, stop, threads,
                      out={name: array[start:stop] for name, array in (results | drawn).items()},
                      buffers=buffers)
            handover.after_chunk(stop - start, plan.size - stop, time.perf_counter() - chunk_started)
            if progress is not None:
                progress(stop, plan.size)
            start = stop
    run_seconds = time.perf_counter() - started

    for name, values in drawn.items():
        coords[name] = (coords[name][0], values, coords[name][2])
    dataset = xr.Dataset({name: (layout.dims, values.reshape(layout.shape), layout.attrs[name])
                          for name, values in results.items()}, coords=coords)
    if scene.record.enabled:
        dataset, trace_seconds = with_traces(prepared, dataset)
        dataset.attrs["trace_time_s"] = trace_seconds
    steps = int(results["steps"].sum())
    dataset.attrs.update(attributes(plan, handover.first.compile_seconds, run_seconds, threads,
                                    steps, kernel_source=handover.first.kernel_source,
                                    kernel_tier=", then ".join(tiers), store_scene=store_scene))
    return dataset


def run_outputs(scene: Scene, sweep: Sweep, threads: int | None = None) -> tuple[dict[str, np.ndarray], float]:
    """The output variables of ``scene`` over ``sweep`` as flat arrays, and
    the kernel's compile seconds: :func:`run_scene`'s results (the same
    kernel tier) without its Dataset, attributes, traces and background
    specialisation, for callers that hand a few rows over per call
    (ChordModes.evaluate's quadrature: those cost ~1.5 ms a call)."""
    plan = plan_run(scene, sweep)
    check_memory(plan)
    threads = thread_count(threads)
    prepared = prepare(plan, warm_up=False)
    results = empty_results(plan, plan.size)
    buffers = ChunkBuffers(plan, min(plan.size, CHUNK_SIZE))
    with using_threads(threads):
        for start in range(0, plan.size, CHUNK_SIZE):
            stop = min(plan.size, start + CHUNK_SIZE)
            run_chunk(prepared, start, stop, threads, out={name: array[start:stop] for name, array in results.items()},
                      buffers=buffers)
    return results, prepared.compile_seconds


def with_traces(prepared: Prepared, dataset: xr.Dataset) -> tuple[xr.Dataset, float]:
    """``dataset`` with the scene's recorded trajectories merged in, and the
    seconds they took (including ``trace_one``'s own first compilation)."""
    started = time.perf_counter()
    with _codegen(prepared.tier):
        traces = _traces(prepared.plan, prepared.trace_one, prepared.settings, prepared.shared)
    return dataset.merge(traces), time.perf_counter() - started


def thread_count(threads: int | None) -> int:
    available = max_threads()
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
    variables' dims, shape and attributes, and the coordinates: the sweep's
    own axes, or for a design (``drawn``: their names) zero-stride stand-ins
    of the right dtype and length whose values come chunk by chunk with the
    results (:func:`drawn_coordinates`; :func:`run_chunk` returns them)."""

    dims: tuple[str, ...]
    shape: tuple[int, ...]
    attrs: dict[str, dict]
    coords: dict[str, tuple]
    drawn: tuple[str, ...] = ()


CASE_ATTRS = {"long_name": "case number", "units": "1"}


def dataset_layout(plan: RunPlan) -> DatasetLayout:
    sweep = plan.sweep
    ramp_parameters = plan.scene.ramp.spec.parameters
    dims = sweep.dims if sweep.names else ()
    shape = plan.shape if sweep.names else ()
    coords = {}
    drawn = ()
    if sweep.design is not None:
        drawn = sweep.names + ("case",)
        for name in sweep.names:
            attrs = schema.spec_attrs(schema.axis_spec(name, ramp_parameters))
            coords[name] = ("case", np.broadcast_to(np.float64(0.0), shape), attrs)
        coords["case"] = ("case", np.broadcast_to(np.int64(0), shape), CASE_ATTRS)
    for name, values in sweep.axes:
        spec = schema.axis_spec(name, ramp_parameters)
        attrs = schema.spec_attrs(spec)
        # a copy: the sweep's own arrays are read-only, a dataset's are the user's
        coords[name] = ((sweep.dims[0] if sweep.kind == "cases" else name), np.array(values), attrs)
    if sweep.kind == "cases" and sweep.axes:
        coords["case"] = ("case", np.arange(plan.size), CASE_ATTRS)
    attrs = {name: schema.output_attrs(name) for name in plan.output_names}
    return DatasetLayout(tuple(dims), tuple(shape), attrs, coords, drawn)


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
        mass = trajectory_masses(plan, int(j), int(j) + 1)[0]
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
                                    schema.traced_attrs(name, plan.scene.ramp.spec.parameters))
    return xr.Dataset(data_vars, coords=coords)


#: ``rampwork_scene`` of a dataset made with ``run_scene(..., store_scene=False)``
SCENE_NOT_STORED = "# the scene file was not stored with this dataset (run_scene(store_scene=False))\n"


def scene_text(scene: Scene, sweep: Sweep, stored: bool = False) -> str:
    """The scene file that reproduces a run; for a ramp of user functions,
    which no file can hold, the same file with the ramp described in comments
    (the rest still documents every setting).  ``stored``: the form stored
    with the dataset, whose long explicit axes refer to its coordinates
    (see ``scenefile.dump_scene``): a few lines whatever the sweep's size."""
    from .scenefile import dump_scene

    if not isinstance(scene, Scene) or scene.ramp.family != "callable":  # (or a CurveScene)
        return dump_scene(scene, sweep, stored=stored)
    spec = scene.ramp.spec
    stand_in = scene.replace(ramp=Ramp.create("straight", slope=0.0, domain=scene.ramp.domain))
    lines = dump_scene(stand_in, sweep, stored=stored).splitlines()
    start = lines.index("[ramp]")
    end = next((k for k in range(start + 1, len(lines)) if lines[k].startswith("[")), len(lines))
    note = [f"# [ramp]: user functions {spec.name!r} (Ramp.from_functions) on domain "
            f"{list(scene.ramp.domain)}, curvature sign {spec.curvature_sign({}, scene.ramp.domain)}; "
            "not reproducible from this file"]
    return "\n".join(lines[:start] + note + lines[end:]) + "\n"


def attributes(plan: RunPlan, compile_seconds, run_seconds, threads, steps,
               entry: str = "rampwork.simulate", kernel_source: str | None = None,
               kernel_tier: str = "specialised", store_scene: bool = True) -> dict:
    """The dataset's global attributes (``entry``: what made it, for history;
    ``store_scene=False``: the scene file left out, see :func:`run_scene`)."""
    scene = plan.scene
    closed_form = plan.variant.closed_form
    how = (f"closed form (straight ramp; {scene.integrator.method} not used)" if closed_form
           else scene.integrator.describe())
    return schema.global_attrs(
        scene.title,
        scene_text(scene, plan.sweep, stored=True) if store_scene else SCENE_NOT_STORED,
        f"{entry}: {plan.size} trajectories, {how}",
        {
            "ramp_family": scene.ramp.family,
            "ramp_domain": np.array(scene.ramp.domain),
            **{f"integrator_{key}": value for key, value in scene.integrator.settings().items()},
            # what integrated: a straight ramp's closed form instead of the integrator asked for
            "integrator_used": "closed_form" if closed_form else scene.integrator.method,
            "integrator_order": scene.integrator.order,
            "integrator_adaptive": int(scene.integrator.adaptive),
            "t_max": scene.t_max,
            "contact": scene.contact,
            **({"drag_linear": scene.drag.linear, "drag_quadratic": scene.drag.quadratic}
               if plan.variant.drag else {}),
            "sweep_kind": plan.sweep.kind,
            "kernel_checks_contact": int(plan.variant.check_contact),
            "kernel_closed_form": int(plan.variant.closed_form),
            "kernel_effects": "; ".join(plan.effects),
            "kernel_variant": plan.variant.name,
            "kernel_tier": kernel_tier,
            **({"kernel_source": kernel_source} if kernel_source else {}),
            "n_trajectories": plan.size,
            "trajectory_steps": steps,
            "compile_time_s": compile_seconds,
            "run_time_s": run_seconds,
            "threads": threads,
        },
    )


__all__ = ["simulate", "plan_run", "RunPlan", "STATUS_NAMES"]
