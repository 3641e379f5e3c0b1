"""The curve kernel in SIMD lanes (docs/physics.md §5): many trajectories on a
planar curve at once, the same results as one at a time, bit for bit.

Why lanes: one trajectory at a time is bound by the latency of its divisions
and its branches (core/kernel.py's docstring says it for ramps).  Here a tile
of trajectories runs through a block of ``LANES`` lanes whose state is a
structure of arrays (curve_kernel.py's layout: field F of lane i at
``lanes[F * LANES + i]``).  The vector loop (curve_vector.py) takes one
step on every lane with no data-dependent branch, so LLVM turns it into
vector code, and commits the clean ones by selects; a lane whose step holds
an event either locates it there, trial by trial (the adaptive pairs,
curve_events.py), or waits for the next scalar pass, where
``curve_kernel._iterate`` takes its step in full: the event located on the
step size, the rest rule, lift-off, exits, divergence.  Every ``SUBSTEPS``
vector steps a scalar pass resolves frozen lanes (commits the located
events), writes finished trajectories out and refills their lanes from
the tile; once the tile has nothing left to load, the running lanes move
to the front so that its tail steps few empty lanes.

So every trajectory sees the same floating-point operations whichever lane,
tile, block or thread runs it, and the same as with the vector loop off
(``vector=False``: every step through ``_iterate``, the scalar kernel the
tests compare with).  Tiles run over threads (core/threads.py).
"""

from __future__ import annotations

import hashlib
import math
import types

import numpy as np

from . import curve_events as ce
from . import curve_kernel as ck
from . import curve_trace
from . import status as st
from .control import ERROR_FLOOR
from .curve_kernel import (  # the lane layout, the inputs' and outputs' rows
    B, BRANCH, C, CURV, D, DISP, DRAGW, E0, EMPTY, EPREV, EVENT, FLAG, G, HI, HN, I_B, I_C, I_G,
    I_HI, I_JOINT, I_JOINT2, I_LO, I_M, I_MUK, I_MUS, I_P, I_S0, I_S1, I_S2, I_S3, I_U, INROW,
    JOINT, JOINT2, KAPPA0, LANES, LO, MUK, MUS, N_FIELDS, NREJ, NREV, NUMIN, O_BAL, O_DISP,
    O_KMEAN, O_NREV, O_NUMIN, O_P, O_PATH, O_PLIFT, O_REJECTED, O_STEPS, O_T, O_U, O_W, O_WD,
    O_WE, O_X, O_XLIFT, O_XPATH, O_Y, O_YLIFT, P, PATH, PATHX, PLIFT, REJB, S0, S1, S2, SN,
    STATUS, STEPS, T, TRAJ, U, WORK, XNOW, MANY_JOINTS, field, set_field, store_frame)
from .curve_track import joints_behind
from .curve_steppers import CURVE_STEPPERS, _dop853_stages, _stage, _stage_from, normal_along_n
from .curve_vector import BLOCK, BLOCK_FIRST_ORDER, _vector_step
from .jit import fma, jit, specialise
from .threads import current_threads, run_items

# bound per scene by build_curve_kernel (compile-time constants)
curve_frame = curve_point = rest_rule = contact_sign = None
start_lane = iterate = finish_lane = vector_step = vector_pass = run_tile = None
ADAPTIVE = False
JOINTS = 0  # the curve's joints (0, 1, 2 or MANY_JOINTS)
ONE_SIDED = True
VECTOR = True  # False: every step through curve_kernel._iterate (the scalar reference)
#: vector steps between scalar passes: a lane whose step holds an event waits
#: for the next pass, so fewer, costlier steps want more frequent passes.
#: Fixed steps: 4, not 8: with 8 (or 6, 16) the compiled pass ran 2.5-3.7x
#: slower per step (Euler, RK4; benchmarks/README.md, i20-speed-6), while
#: 1 to 4 are alike, so the pass itself costs little
SUBSTEPS = 4
SUBSTEPS_ADAPTIVE = 4


def _start_lane(lanes, i, inputs, j, shared, h, side):
    """Load trajectory j (column j of ``inputs``) into lane i: its state at
    t = 0 and, at rest, the rest rule's verdict (STATUS stays NOT_RUN while
    it moves).  ``h``: the step (an adaptive pair's first)."""
    p = inputs[I_P, j]
    u = inputs[I_U, j]
    mu_k = inputs[I_MUK, j]
    mu_s = inputs[I_MUS, j]
    g = inputs[I_G, j]
    s0 = inputs[I_S0, j]
    s1 = inputs[I_S1, j]
    s2 = inputs[I_S2, j]
    s3 = inputs[I_S3, j]
    p_lo = inputs[I_LO, j]
    p_hi = inputs[I_HI, j]
    x_now, y0 = curve_point(p, s0, s1, s2, s3, shared)
    status = st.NOT_RUN
    p_lift = math.nan
    frame0 = curve_frame(p, s0, s1, s2, s3, shared)
    _, cos0, kappa0, _ = frame0
    nu = normal_along_n(u, cos0, kappa0, g)
    d = 0.0
    if u == 0.0:
        d, status = rest_rule(p, mu_k, mu_s, g, side, s0, s1, s2, s3, shared)
    else:
        d = 1.0 if u > 0.0 else -1.0
        if ONE_SIDED and side * nu <= 0.0:
            status = st.LIFTED_OFF
    if status == st.LIFTED_OFF:
        p_lift = p
    if status == st.NOT_RUN and ((d > 0.0 and p >= p_hi) or (d < 0.0 and p <= p_lo)):
        status = st.EXITED
    for index in (WORK, CURV, DISP, PATH, PATHX, DRAGW, T, STEPS, NREJ, INROW, NREV, REJB, FLAG,
                  EVENT):
        set_field(lanes, index, i, 0.0)
    set_field(lanes, P, i, p)
    set_field(lanes, U, i, u)
    set_field(lanes, D, i, d)
    set_field(lanes, SN, i, contact_sign(nu, kappa0, side))
    set_field(lanes, HN, i, h)
    set_field(lanes, EPREV, i, ERROR_FLOOR)
    set_field(lanes, NUMIN, i, side * nu)
    set_field(lanes, XNOW, i, x_now)
    store_frame(lanes, i, frame0)
    set_field(lanes, PLIFT, i, p_lift)
    set_field(lanes, STATUS, i, status)
    set_field(lanes, TRAJ, i, j)
    set_field(lanes, E0, i, fma(g, y0, 0.5 * u * u))
    set_field(lanes, KAPPA0, i, kappa0)
    set_field(lanes, BRANCH, i, s3)
    set_field(lanes, MUK, i, mu_k)
    set_field(lanes, MUS, i, mu_s)
    set_field(lanes, G, i, g)
    set_field(lanes, S0, i, s0)
    set_field(lanes, S1, i, s1)
    set_field(lanes, S2, i, s2)
    set_field(lanes, LO, i, p_lo)
    set_field(lanes, HI, i, p_hi)
    set_field(lanes, B, i, inputs[I_B, j])
    set_field(lanes, C, i, inputs[I_C, j])
    set_field(lanes, JOINT, i, inputs[I_JOINT, j])
    set_field(lanes, JOINT2, i, inputs[I_JOINT2, j])
    if JOINTS == MANY_JOINTS:  # the branch that curve_track.branch_near keeps up
        set_field(lanes, BRANCH, i, 1.0 + joints_behind(
            p, d, shared, int(inputs[I_JOINT, j]), int(inputs[I_JOINT2, j])))


def _finish_lane(lanes, i, inputs, shared, out, status):
    """Write lane i's trajectory (finished) to its column of ``out`` and
    ``status``; the lane becomes empty."""
    j = int(field(lanes, TRAJ, i))
    p = field(lanes, P, i)
    u = field(lanes, U, i)
    g = field(lanes, G, i)
    s0 = field(lanes, S0, i)
    s1 = field(lanes, S1, i)
    s2 = field(lanes, S2, i)
    s3 = field(lanes, BRANCH, i)
    work = field(lanes, WORK, i)
    drag_work = field(lanes, DRAGW, i)
    path = field(lanes, PATH, i)
    p_lift = field(lanes, PLIFT, i)
    energy_start = field(lanes, E0, i)
    m = inputs[I_M, j]
    x_end, y_end = curve_point(p, s0, s1, s2, s3, shared)
    energy_end = fma(g, y_end, 0.5 * u * u)
    out[O_T, j] = field(lanes, T, i)
    out[O_P, j] = p
    out[O_U, j] = u
    out[O_X, j] = x_end
    out[O_Y, j] = y_end
    out[O_W, j] = m * work
    out[O_WE, j] = m * (energy_start - energy_end)
    out[O_WD, j] = m * drag_work
    out[O_BAL, j] = m * (work + drag_work - (energy_start - energy_end))
    out[O_DISP, j] = field(lanes, DISP, i)
    out[O_PATH, j] = path
    out[O_XPATH, j] = field(lanes, PATHX, i)
    out[O_KMEAN, j] = field(lanes, CURV, i) / path if path > 0.0 else field(lanes, KAPPA0, i)
    out[O_NUMIN, j] = m * field(lanes, NUMIN, i)
    out[O_PLIFT, j] = p_lift
    if p_lift == p_lift:
        x_lift, y_lift = curve_point(p_lift, s0, s1, s2, s3, shared)
        out[O_XLIFT, j] = x_lift
        out[O_YLIFT, j] = y_lift
    else:
        out[O_XLIFT, j] = math.nan
        out[O_YLIFT, j] = math.nan
    out[O_NREV, j] = field(lanes, NREV, i)
    out[O_STEPS, j] = field(lanes, STEPS, i)
    out[O_REJECTED, j] = field(lanes, NREJ, i)
    status[j] = int(field(lanes, STATUS, i))
    set_field(lanes, STATUS, i, EMPTY)


def _vector_pass(lanes, shared, t_max, side, rtol, atol, n_blocks):
    """``SUBSTEPS`` vector steps on lanes 0 .. n_blocks * BLOCK - 1."""
    for _ in range(SUBSTEPS_ADAPTIVE if ADAPTIVE else SUBSTEPS):
        for block in range(n_blocks):
            vector_step(lanes, block * BLOCK, shared, t_max, side, rtol, atol)


@jit(internal=True, refcount=False)
def _move_lane(lanes, source, target):
    for index in range(N_FIELDS):
        set_field(lanes, index, target, field(lanes, index, source))


def _run_tile(begin, end, lanes, inputs, shared, h, t_max, side, rtol, atol, out, status):
    """Trajectories begin .. end - 1 through the lanes (see the module docstring)."""
    if not VECTOR:
        for j in range(begin, end):
            start_lane(lanes, 0, inputs, j, shared, h, side)
            while field(lanes, STATUS, 0) == st.NOT_RUN:
                iterate(lanes, 0, shared, t_max, side, rtol, atol)
            finish_lane(lanes, 0, inputs, shared, out, status)
        return
    for i in range(LANES):
        set_field(lanes, STATUS, i, EMPTY)
        set_field(lanes, FLAG, i, 0.0)
    next_j = begin
    n_blocks = LANES // BLOCK
    while True:
        running = 0
        for i in range(n_blocks * BLOCK):
            state = field(lanes, STATUS, i)
            if state == st.NOT_RUN and field(lanes, FLAG, i) != 0.0:
                set_field(lanes, FLAG, i, 0.0)
                iterate(lanes, i, shared, t_max, side, rtol, atol)
                state = field(lanes, STATUS, i)
            while state != st.NOT_RUN:
                if state != EMPTY:
                    finish_lane(lanes, i, inputs, shared, out, status)
                if next_j >= end:
                    break
                start_lane(lanes, i, inputs, next_j, shared, h, side)
                next_j += 1
                state = field(lanes, STATUS, i)
            if state == st.NOT_RUN:
                running += 1
        if running == 0:
            return
        if next_j >= end and running <= (n_blocks - 1) * BLOCK:
            # nothing left to load: running lanes to the front, fewer blocks
            target = 0
            for i in range(n_blocks * BLOCK):
                if field(lanes, STATUS, i) == st.NOT_RUN:
                    if i != target:
                        _move_lane(lanes, i, target)
                        set_field(lanes, STATUS, i, EMPTY)
                    target += 1
            n_blocks = (running + BLOCK - 1) // BLOCK
        vector_pass(lanes, shared, t_max, side, rtol, atol, n_blocks)


def _run_tiles(first_tile, stop_tile, tile_size, inputs, shared, h, t_max, side, rtol, atol,
               out, status):
    """Tiles first_tile .. stop_tile - 1 of the columns of ``inputs``."""
    lanes = np.zeros(N_FIELDS * LANES)
    n = inputs.shape[1]
    for tile in range(first_tile, stop_tile):
        begin = tile * tile_size
        run_tile(begin, min(n, begin + tile_size), lanes, inputs, shared, h, t_max, side, rtol,
                 atol, out, status)


def tile_size(n: int, threads: int) -> int:
    """Trajectories per tile: enough tiles for every thread to stay busy
    (dynamic scheduling), each big enough to keep its lanes full."""
    return int(min(16384, max(4 * LANES, -(-n // (8 * max(threads, 1))))))


class CurveKernel:
    """``kernel(inputs, shared, h, t_max, side, rtol, atol, out, status)``:
    every column of ``inputs`` (rows ``curve_kernel.INPUTS``) into ``out``
    (rows ``curve_kernel.OUTPUTS``) and ``status``, in tiles over
    :func:`threads.current_threads` threads (``threads.using_threads``)."""

    def __init__(self, run_tiles, trace_one=None):
        self.run_tiles = run_tiles
        #: ``trace_one(j, inputs, shared, h, t_max, side, rtol, atol, every, trace)``:
        #: one trajectory recorded (core/curve_trace.py), compiled on first use
        self.trace_one = trace_one

    def __call__(self, inputs, shared, h, t_max, side, rtol, atol, out, status):
        n = inputs.shape[1]
        if n == 0:
            return
        size = tile_size(n, current_threads())
        run_items(self.run_tiles, -(-n // size), size, inputs, shared, float(h), float(t_max),
                  float(side), float(rtol), float(atol), out, status)


#: link-only helpers built so far, by template and the values of the
#: constants its code reads (see :func:`_helper`)
_HELPERS: dict = {}


def _names_read(code) -> set:
    """The global names a function's code (nested code included) reads."""
    names = set(code.co_names)
    for const in code.co_consts:
        if isinstance(const, types.CodeType):
            names |= _names_read(const)
    return names


def _function_name(function) -> str:
    """Module and qualified name: what tells one function's code from another's."""
    return f"{function.__module__}.{function.__qualname__}"


def _helper(template, name: str, suffix: str, constants: dict, *, shared: bool):
    """``template`` specialised on ``constants`` as a helper only jitted code
    calls: link-only (jit.INTERNAL_OPTIONS), compiled into the kernels'
    modules and cached with them, and without reference counting (no
    helper allocates; with it, the calls that pass the lane array kept the
    vector loop, optimised inside the kernel's module, from vectorising:
    4-7x slower).  ``shared``: one per process for the constants its code
    reads (a step's stages serve every family with the same effects, the
    rest rule every method, ...), named by the template and those values,
    so a kernel compiles only the helpers no kernel before it needed.  The
    name must differ wherever the code does: a kernel loaded from numba's
    cache brings its helpers' symbols, and a helper compiled later under the
    same name would link to those (two steps that read the same constants,
    Euler's and semi-implicit Euler's, once gave one method the other's
    results; tests/test_curve_helpers.py)."""
    if not shared:
        return specialise(template, f"{name}_{suffix}", dict(constants), internal=True,
                          refcount=False)
    used = tuple(sorted((k, constants[k]) for k in _names_read(template.__code__)
                        if k in constants))
    key = (template, used)
    if key not in _HELPERS:
        label = repr([_function_name(template)]
                     + [(k, _function_name(v.py_func) if hasattr(v, "py_func") else v)
                        for k, v in used])
        digest = hashlib.sha256(label.encode()).hexdigest()[:12]
        _HELPERS[key] = specialise(template, f"curve_{suffix}_{digest}", dict(constants),
                                   internal=True, refcount=False)
    return _HELPERS[key]


def build_curve_kernel(key: str, frame, point, method: str, *, one_sided: bool = True,
                       friction: bool = True, drag_linear: bool = False,
                       drag_quadratic: bool = False, joints: int = 0, cache: bool = True,
                       vector: bool = True, point_anywhere: bool = False) -> CurveKernel:
    """The :class:`CurveKernel` of one curve family (``key`` names it uniquely;
    ``frame``, ``point`` its jitted functions) and ``method`` (any
    ``CURVE_STEPPERS`` entry), compiled with only the effects asked for.
    ``vector=False``: the scalar reference (every step through ``_iterate``);
    ``joints``: the curve's joints (0 to 2; with one, the second's logic is
    compiled out, with none all of it; ``MANY_JOINTS``: any number, a
    sorted run of ``shared`` per trajectory); ``point_anywhere``: the
    family's (curve_families.CurveFamily.point_anywhere)."""
    if method not in CURVE_STEPPERS:
        raise ValueError(f"unknown curve method {method!r}; allowed: {', '.join(CURVE_STEPPERS)}")
    step, order, adaptive, control = CURVE_STEPPERS[method]
    flags = "".join(suffix for on, suffix in (
        (one_sided, "_one"), (friction, "_friction"), (drag_linear, "_dragb"),
        (drag_quadratic, "_dragc"), (joints == 1, "_joints"), (joints == 2, "_joints2"),
        (joints == MANY_JOINTS, "_jointsmany"),
        (not vector, "_scalar")) if on)
    name = f"curve_{key}_{method}{flags}"
    alpha, beta, shrink = control if adaptive else (0.0, 0.0, 0.0)
    constants = {"curve_frame": frame, "curve_point": point, "ONE_SIDED": one_sided,
                 "ADAPTIVE": adaptive, "LANE_EVENTS": adaptive, "JOINTS": int(joints),
                 "FRICTION": friction, "POINT_ANYWHERE": point_anywhere,
                 "DRAG_LINEAR": drag_linear, "DRAG_QUADRATIC": drag_quadratic,
                 "DRAG": drag_linear or drag_quadratic, "VECTOR": vector, "PI_ALPHA": alpha,
                 "PI_BETA": beta, "REJECT_EXPONENT": shrink,
                 "BLOCK": BLOCK_FIRST_ORDER if order == 1 else BLOCK}
    options = {} if cache else {"cache": False}

    def build(template, suffix, entry=False, **more):
        constants.update(more)
        if entry:
            return specialise(template, f"{name}_{suffix}", dict(constants), **options)
        return _helper(template, name, suffix, constants, shared=cache)

    code = step.__code__  # a step without the frame argument works too, one frame dearer
    constants["STEP_TAKES_FRAME"] = "frame" in code.co_varnames[:code.co_argcount]
    built_stage_from = build(_stage_from, "stage_from")
    built_stage = build(_stage, "stage", stage_from=built_stage_from)
    # dop853's twelve stages, apart from its error norm (compiled only where a step calls them)
    built_rates = build(_dop853_stages, "rates", stage=built_stage, stage_from=built_stage_from)
    constants["curve_step"] = build(step, "step", stage=built_stage, stage_rates=built_rates)
    constants["try_step"] = build(ck._try_step, "try")
    for template, bound in ((ck._rest_rule, "rest_rule"), (ck._contact_sign, "contact_sign"),
                            (ck._x_travelled, "x_travelled"), (ce._event_guess, "event_guess"),
                            (ce._event_trial, "event_trial"), (ce._locate_event, "locate_event"),
                            (ce._lane_trial, "lane_trial"),
                            (ck._accepted_factor, "accepted_factor"),
                            (ck._rejected_factor, "rejected_factor"),
                            (_start_lane, "start_lane"), (ck._iterate, "iterate"),
                            (_finish_lane, "finish_lane"), (_vector_step, "vector_step"),
                            (_vector_pass, "vector_pass"), (_run_tile, "run_tile")):
        constants[bound] = build(template, bound)
    trace_one = build(curve_trace._trace_one, "trace", entry=True,
                      sample=build(curve_trace._sample, "trace_sample"))
    return CurveKernel(build(_run_tiles, "tiles", entry=True), trace_one)
