"""The batch kernel: many trajectories in lock-step SIMD lanes, reduced on the fly.

Why lanes: a loop that carries one trajectory at a time is bound by the latency
of its divisions.  Here a tile of trajectories is run through a block of
``LANES`` lanes stored as structure of arrays; the inner loop does one step for
every lane with no data-dependent branch, so LLVM turns it into vector code.
Every lane steps every time, and no step is held back where its event
conditions fire (reversal or stop, lift-off, contact switch, exit,
divergence): the lane steps on, each step's state goes to a history bank,
and a per-lane flag records whether all the block's steps were clean; the
tests run beside the recurrence, not in it.  Every ``SUBSTEPS`` steps a
scan takes each clean lane to the block's last state and books its steps;
a lane that was not clean (or reached its ``t_max`` step limit) goes back
to the start of its first unclean step, found exactly in its history, and
its event is resolved there (located inside the step by root finding on
the step size, to rounding); finished lanes are refilled with the next
trajectory of the tile.  Once a tile has nothing left to load, running
lanes are compacted to the front so that its tail does not step empty lanes.

Every trajectory sees the same sequence of floating-point operations whatever
lane, tile, block size or thread runs it, so results are bit-for-bit
independent of those choices.

The kernel's functions are templates, by part: the vector loop
(``kernel_vector.py``), the scalar event path (``kernel_events.py``), lane
loading, modes and finishing (``kernel_modes.py``) and the frame of blocks,
scans and tiles (``kernel_tiles.py``).  ``step``, ``ramp_height``,
``ramp_slope_curvature``, ``ONE_SIDED`` and the helper names are their
globals (``kernel_globals.py``), bound per scene by :func:`build_kernel`
through ``jit.specialise``.  So is air drag
(``DRAG_LINEAR``, ``DRAG_QUADRATIC``, ``DRAG``): a scene without it compiles
no drag arithmetic at all (every ``if DRAG:`` block is removed).
"""

from __future__ import annotations

from .layout import *  # noqa: F403 - the lane layout (runner.py and tests read it here)
from .jit import specialise
from . import straight
from .variant import KernelVariant
from . import general
from .threads import TiledKernel
from .physics import acceleration, acceleration_frictionless
from . import adaptive as adaptive_parts
from . import kernel_events as events
from . import kernel_modes as modes
from . import kernel_tiles as tiles
from . import kernel_vector as vector
from .kernel_globals import N_CARRY
from . import parameters
from . import steppers
from .ramps import SLOPE_CURVATURE_NEAR, SLOPE_CURVATURE_SHORT
from . import ramps
from .steppers import ADAPTIVE_STEPPERS, STEPPERS

#: families whose RK4 runs its vector step in two lane loops (SPLIT_STEP),
#: measured not slower (benchmarks/families.py, 1 thread, CPU time, two
#: runs: quadratic 1.18-1.22x, sine 1.05x, circular bowl 0.99-1.02x, spline
#: 1.05-1.11x).  Not the cycloid (9x slower split while every stage solved
#: for its parameter by Newton; with its short stage form level, 2.64e8
#: against 2.66e8 steps/s, so left as it was; split again 2026-11-28: 0.90x,
#: benchmarks/README.md's sixth pass) nor user callables (not measured)
SPLIT_STEP_FAMILIES = frozenset((
    ramps.straight_slope_curvature, ramps.quadratic_slope_curvature,
    ramps.circular_bowl_slope_curvature, ramps.circular_dome_slope_curvature,
    ramps.sine_slope_curvature, ramps.spline_slope_curvature))


def build_kernel(variant: KernelVariant, ramp_height_fn, ramp_slope_curvature_fn, *,
                 cache: bool = True):
    """Compile (or load from numba's on-disk cache) the kernels of one variant.

    ``variant`` (:class:`~rampwork.core.variant.KernelVariant`) holds every
    compile-time choice; ``ramp_height_fn`` and ``ramp_slope_curvature_fn``
    are its family's jitted functions (``variant.family`` names them
    uniquely); ``cache=False`` for functions that cannot be found again
    (user callables).  RK4 takes f', f'' at its stage points from those at
    the step's start where the family has such a function
    (``ramps.SLOPE_CURVATURE_NEAR``, ``steppers.STAGE_FROM_START``).  A
    closed-form variant is built by ``straight.build_closed_form``.  Returns ``(run_batch, trace_one)``:
    ``run_batch(inputs, settings, outputs, shared, tile_size)`` fills
    ``outputs`` (N_OUTPUTS, n) from ``inputs`` (N_INPUTS, n), tiles spread
    over threads; ``trace_one(j, inputs, settings, shared, every, trace)``
    records one.  Without drag the inputs' drag rows are ignored; without
    ``paper_criterion`` the OUT_XLIFT_PAPER row is NaN; ``friction=False``
    gives the same results but perhaps the sign of a zero;
    ``constant_curvature`` reports f'' itself as convexity_mean.  Fixed
    steps form the curvature integral per mode, exactly (``kernel_modes._mode_curvature``),
    not per step; the adaptive pairs integrate it (it is part of their error
    norm).
    """
    if variant.closed_form:
        return straight.build_closed_form(variant, ramp_height_fn, ramp_slope_curvature_fn,
                                          cache=cache)
    # fixed steps: the history banks of a block's steps, only the fields the
    # kernel integrates (not the curvature integral: kernel_modes._mode_curvature)
    drag = variant.drag or variant.runtime
    n_hist = 3 + drag
    n_lane_fields = (N_LANE_FIELDS if variant.adaptive
                     else HIST + n_hist * (variant.substeps + 1))
    # RK4's step in two lane loops (not in the general kernel, whose step
    # is chosen at run time); their values pass through N_CARRY fields
    # after the banks: constant offsets, as the lane fields'
    split = (None if variant.adaptive or variant.runtime or variant.unroll != 1
             or ramp_slope_curvature_fn not in SPLIT_STEP_FAMILIES
             else STEPPERS[variant.method].split)
    carry = n_lane_fields
    if split is not None:
        n_lane_fields += N_CARRY
    constants = {
        **variant.constants(),
        "ramp_height": ramp_height_fn,
        "ramp_slope_curvature": ramp_slope_curvature_fn,
        "STAGE_FROM_START": ramp_slope_curvature_fn in SLOPE_CURVATURE_NEAR,
        "ramp_slope_curvature_near": (SLOPE_CURVATURE_SHORT if variant.short_stages
                                      else SLOPE_CURVATURE_NEAR).get(ramp_slope_curvature_fn,
                                                                     steppers.no_stage_shortcut),
        # the lane array: fixed-step kernels leave out the adaptive bank B
        # (a smaller block stays in the L1 cache)
        "N_LANE_FIELDS": n_lane_fields,
        "N_HIST": n_hist, "HIST_WD": 3,
        "SPLIT_STEP": split is not None, "CARRY": carry,
        # every template calls `acceleration` by this global name
        "acceleration": acceleration if variant.friction else acceleration_frictionless,
    }
    name = variant.name
    if variant.runtime:  # general.py: the runtime flags after the lane scratch
        constants.update(N_SCRATCH=N_SCRATCH + general.N_RUNTIME, SET_RUNTIME=N_SETTINGS,
                         RUNTIME_BASE=n_lane_fields * variant.lanes + N_SCRATCH)

    def add(key, function, **options):
        if variant.runtime:
            function = general.read_at_run_time(function)
        constants[key] = specialise(function, f"{key}_{name}", constants, cache=cache, **options)
        return constants[key]

    # Helpers are only called from jitted code: no Python or C wrappers, and
    # no machine code of their own (jit.INTERNAL_OPTIONS).  The scalar
    # helpers allocate nothing, so they are compiled without numba's
    # reference counting: otherwise every call passing the lane array does
    # atomic incref/decref pairs, which cost more than the event arithmetic
    # itself (measured: 20-25 % of the whole run on an event-rich sweep).
    internal = {"internal": True}
    no_refcount = {"refcount": False, **internal}
    add("runtime_flags", general._copy_runtime_flags if variant.runtime
        else general._no_runtime_flags, **no_refcount)
    add("lane_parameters", parameters._lane_parameters, **no_refcount)
    add("uniform_parameters", parameters._uniform_parameters, **no_refcount)

    if variant.adaptive:
        pair = ADAPTIVE_STEPPERS[variant.method]
        constants["PI_ALPHA"], constants["PI_BETA"] = pair.pi_gains
        constants["SWING_LIMIT2"] = pair.swing_limit ** 2
        for key, template in pair.helpers:
            add(key, template, **no_refcount)
        add("step", pair.step, **no_refcount)
        # a copy of its own for the scalar step to an event: a second call
        # site of `step` keeps LLVM from inlining it into the lane loop
        add("event_step", pair.step, **no_refcount)
        add("dense_output", pair.dense, **no_refcount)
        add("dense_point", pair.dense_point, **no_refcount)
        constants["error_norm2"] = pair.error_norm2  # jitted already: no scene constants
        constants["error_norm2_drag"] = pair.error_norm2_drag
        method_parts = (
            ("contact_holds", adaptive_parts._contact_holds),
            ("project_energy", adaptive_parts._project_energy),
            ("attempt", adaptive_parts._attempt),
            ("attempt_once", adaptive_parts._attempt_once),
            ("start_adaptive", adaptive_parts._start_adaptive),
            ("dense_value", adaptive_parts._dense_value),
            ("locate_dense", adaptive_parts._locate_dense),
            ("step_to_event", adaptive_parts._step_to_event),
        )
    else:
        add("_with_drag", steppers._with_drag, **no_refcount)
        # RK4's two parts, which its step calls (and the split vector loop)
        add("rk4_first_stages", steppers._rk4_first_stages, **no_refcount)
        add("rk4_last_stages", steppers._rk4_last_stages, **no_refcount)
        constants["first_stages"] = constants["rk4_first_stages"]
        constants["last_stages"] = constants["rk4_last_stages"]
        if variant.runtime:  # the method by its id in shared[1]
            for k, method in enumerate(STEPPERS.values()):
                add(f"STEP_{k}", method.step, **no_refcount)
            add("step", general._switch_step, **no_refcount)
        else:
            add("step", STEPPERS[variant.method].step, **no_refcount)
        method_parts = (
            ("start_value", events._start_value), ("trial_step", events._trial_step),
            ("event_values", events._event_values), ("event_value", events._event_value),
            ("locate_event", events._locate_event),
            ("locate_earliest", events._locate_earliest),
            ("apply_step", events._apply_step),
            ("start_adaptive", modes._no_adaptive_start),
            ("checked_step", vector._checked_step), ("step_and_check", vector._step_and_check),
            ("first_stages_lane", vector._first_stages_lane),
            ("first_stages_all", vector._first_stages_all),
            ("fixed_step_lane", vector._fixed_step_lane),
            ("start_block", vector._start_block), ("replay_lane", vector._replay_lane),
            ("step_from_bank", vector._step_from_bank), ("clean_steps", vector._clean_steps),
            ("restore_bank", vector._restore_bank),
        )
    if variant.paper_criterion or variant.runtime:
        add("_paper_holds", modes._paper_holds, **no_refcount)
        add("paper_scan", modes._paper_scan, **no_refcount)
    for key, function in method_parts + (
        ("current_time", modes._current_time), ("mode_curvature", modes._mode_curvature),
        ("rebase", modes._rebase), ("make_empty", modes._make_empty),
        ("new_lanes", modes._new_lanes),
        ("set_mode", modes._set_mode), ("refresh_slope", modes._refresh_slope),
        ("finish_lane", modes._finish_lane), ("apply_event", events._apply_event),
        ("take_event", events._take_event), ("resolve_linear", events._resolve_linear),
        ("load_lane", modes._load_lane),
        ("resolve_lane",
         adaptive_parts._resolve_lane_adaptive if variant.adaptive else events._resolve_lane),
        ("fill_lane", modes._fill_lane),
        ("advance_lanes",
         adaptive_parts._advance_lanes_adaptive if variant.adaptive else vector._advance_lanes),
        ("scan_lanes", tiles._scan_lanes), ("compact_lanes", tiles._compact_lanes),
        ("active_span", tiles._active_span), ("run_tile", tiles._run_tile),
    ):
        options = dict(internal) if key in ("run_tile", "new_lanes") else dict(no_refcount)
        add(key, function, **options)
    run_batch = TiledKernel(add("run_tiles", tiles._run_tiles))
    trace_one = add("trace_one", tiles._trace_one)
    return run_batch, trace_one
