"""The lane kernel's frame: blocks of lanes through tiles of trajectories.

A tile runs through one block of ``LANES`` lanes: the vector loop, then a
scan that books clean lanes and resolves the others (``_scan_lanes``),
refilling finished lanes and compacting running ones to the front once the
tile has nothing left to load; ``_run_tiles`` takes a range of tiles
(``threads.TiledKernel`` spreads them over threads) and ``_trace_one``
records one trajectory.

Templates: their globals (``kernel_globals.py``) are bound per variant by
``kernel.build_kernel``.
"""

from __future__ import annotations

import numpy as np
from numba.cpython.unsafe.numbers import trailing_zeros

from . import status as st
from .jit import flip_sign
from .layout import *  # noqa: F403 - the lane layout
from .kernel_globals import *  # noqa: F403 - the templates' globals, bound per variant


def _scan_lanes(lanes, history, settings, outputs, shared, n_substeps, n_active):
    """After ``n_substeps`` vector steps: resolve lanes with a pending event
    and stop lanes past the speed bound.  Returns the lanes that finished
    (now empty) as bits, lane k at bit k (with LANES > 64: every bit set
    where any lane finished), so that the refill visits only those.

    A vectorised pass over each word of up to 64 lanes books what every lane
    needs booked and sets one bit per lane that needs attention; the scalar
    work then visits only those lanes, found by their bits (on an event-rich
    sweep one or two of 64 lanes in most blocks: a scalar visit of every
    lane would cost about as much as the block's vector steps).  For fixed
    steps a lane whose steps were all clean, with its t_max step limit
    beyond the block (and, for first-order methods, its last state short of
    the end ahead), takes the block's last state and its steps; any other
    lane is pending: the scalar work finds its first unclean step (or the
    limit) in the history banks, takes the state before it and resolves the
    event from there.  A lane that stepped in the block has made progress:
    its event cascade count restarts."""
    freed = np.uint64(0)
    # the block's last state (SUBSTEPS, a constant: constant offsets, which vectorise)
    last = HIST + N_HIST * SUBSTEPS
    for word in range((LANES + 63) // 64):  # a constant count: one word for 64 lanes
        base = 64 * word
        bits = np.uint64(0)
        for k in range(min(64, n_active - base)):
            i = base + k
            if ADAPTIVE:
                v = lanes[V * LANES + i]
                pending = lanes[PENDING * LANES + i] > 0.0
                stepped = lanes[STEPS * LANES + i] > lanes[BLOCK_STEPS * LANES + i]
            else:
                x_end = history[(last + HIST_X) * LANES + i]
                clean = (lanes[CLEAN * LANES + i] == 0.0) & (
                    lanes[LIMIT * LANES + i] - lanes[STEPS * LANES + i] >= n_substeps)
                if MONOTONE_STEP:  # the exit test left out of the vector loop
                    clean = clean & (flip_sign(lanes[AHEAD * LANES + i] - x_end,
                                               lanes[DSIGN * LANES + i]) > 0.0)
                # the block's last state, whether clean or not (plain
                # stores: a select against the stored value would be a
                # masked store); the scalar work takes a lane that was not
                # back to the start of its first unclean step
                v = history[(last + HIST_V) * LANES + i]
                lanes[X * LANES + i] = x_end
                lanes[V * LANES + i] = v
                lanes[W * LANES + i] = history[(last + HIST_W) * LANES + i]
                if DRAG:
                    lanes[WD * LANES + i] = history[(last + HIST_WD) * LANES + i]
                lanes[STEPS * LANES + i] += n_substeps if clean else 0.0
                lanes[CLEAN * LANES + i] = 0.0 if clean else -1.0  # for the scalar work
                pending = not clean
                stepped = clean
            # a product, not a select against the loaded value (a masked store)
            lanes[CASCADE * LANES + i] *= 0.0 if stepped else 1.0
            attention = (lanes[TRAJ * LANES + i] >= 0.0) & (
                pending | (v * v > lanes[VLIM2 * LANES + i]))
            bits |= np.uint64(1 if attention else 0) << np.uint64(k)
        while bits != 0:
            k = np.int64(trailing_zeros(bits))
            bits &= bits - np.uint64(1)
            i = base + k
            if ADAPTIVE:
                clean = lanes[PENDING * LANES + i] == 0.0
            else:
                clean = lanes[CLEAN * LANES + i] == 0.0  # took the block: past the speed bound
                if not clean:
                    # the clean steps before the first unclean one or the step limit
                    left = lanes[LIMIT * LANES + i] - lanes[STEPS * LANES + i]
                    taken = clean_steps(lanes, history, i, settings, shared,
                                        np.int64(min(max(left, 0.0), float(n_substeps))))
                    restore_bank(lanes, history, i, taken)
                    lanes[STEPS * LANES + i] += taken
                    if taken > 0:
                        lanes[CASCADE * LANES + i] = 0.0
                    if CARRY_SLOPE:
                        # the vector loop carried f', f'' on past this state
                        # (from the step start by the angle sum where
                        # STAGE_FROM_START): evaluated afresh at x, as
                        # _trace_one does
                        refresh_slope(lanes, i, shared)
                    if taken == n_substeps:  # (a lane is pending for an unclean step)
                        v = lanes[V * LANES + i]
                        if not v * v > lanes[VLIM2 * LANES + i]:
                            continue
                        clean = True
            # this lane's bit in the mask of finished lanes (all bits past 64 lanes)
            lane_bit = np.uint64(1) << np.uint64(k) if LANES <= 64 else ~np.uint64(0)
            if clean:
                # past the speed bound: the step is far too large
                rebase(lanes, i, current_time(lanes, i, settings[SET_DT]), settings, shared)
                finish_lane(lanes, i, st.DIVERGED, np.nan, outputs, shared)
                freed |= lane_bit
            elif not resolve_lane(lanes, i, settings, outputs, shared):
                freed |= lane_bit
    return freed


def _compact_lanes(lanes):
    """Move running lanes to the front, in order; returns how many run.

    Used once a tile has no trajectories left to load, so that the vector loop
    stops stepping empty lanes at the tile's tail (and on small sweeps).  A
    trajectory's arithmetic does not depend on its lane, so results do not
    change."""
    running = 0
    for i in range(LANES):
        if lanes[TRAJ * LANES + i] < 0.0:
            continue
        if running != i:
            for field in range(N_FIELDS):
                lanes[field * LANES + running] = lanes[field * LANES + i]
            make_empty(lanes, i)
        running += 1
    return running


def _active_span(running):
    """Lanes the vector loop covers for ``running`` running lanes at the front:
    rounded up to whole vector blocks, because stepping a few empty lanes in
    vector code costs far less than the scalar remainder loop would."""
    if running == 0:
        return 0
    return min(LANES, (running + VECTOR_BLOCK - 1) // VECTOR_BLOCK * VECTOR_BLOCK)


def _run_tile(start, stop, inputs, settings, outputs, shared):
    """Run trajectories start..stop-1 through one block of LANES lanes."""
    lanes = new_lanes()
    runtime_flags(lanes, settings)  # a general kernel's choices (general.py)
    # fixed steps: the states of a block's steps (see _advance_lanes)
    history = lanes
    next_j = start
    for i in range(LANES):
        next_j = fill_lane(lanes, i, next_j, stop, inputs, settings, outputs, shared)
    n_active = LANES if next_j < stop else active_span(compact_lanes(lanes))
    while n_active > 0:
        if ADAPTIVE:  # the step counts at the block's start (for CASCADE)
            for i in range(n_active):
                lanes[BLOCK_STEPS * LANES + i] = lanes[STEPS * LANES + i]
        else:
            start_block(lanes, n_active)
        if ADAPTIVE:
            advance_lanes(lanes, settings, shared, SUBSTEPS, n_active)
        else:
            advance_lanes(lanes, history, settings, shared, SUBSTEPS, n_active)
        freed = scan_lanes(lanes, history, settings, outputs, shared, SUBSTEPS, n_active)
        if freed == 0:
            continue
        if next_j < stop and LANES <= 64:
            # while trajectories are left every lane runs but those just
            # finished: refill them by their bits, in lane order
            while freed != 0:
                i = np.int64(trailing_zeros(freed))
                freed &= freed - np.uint64(1)
                next_j = fill_lane(lanes, i, next_j, stop, inputs, settings, outputs, shared)
        elif next_j < stop:
            for i in range(LANES):
                if lanes[TRAJ * LANES + i] < 0.0:
                    next_j = fill_lane(lanes, i, next_j, stop, inputs, settings, outputs, shared)
        if next_j >= stop:
            n_active = active_span(compact_lanes(lanes))


def _run_tiles(first_tile, stop_tile, tile_size, inputs, settings, outputs, shared):
    """Tiles first_tile .. stop_tile - 1 of the trajectories (columns of
    ``inputs``); ``threads.TiledKernel`` spreads the tiles over threads."""
    n = inputs.shape[1]
    for tile in range(first_tile, stop_tile):
        start = tile * tile_size
        stop = min(n, start + tile_size)
        run_tile(start, stop, inputs, settings, outputs, shared)


def _trace_one(j, inputs, settings, shared, every, trace):
    """Run trajectory j alone (lane 0) and record (t, x, v, W) at the start,
    every ``every`` steps and at every event, into ``trace`` (4, max_samples).
    Returns the number of samples written."""
    outputs = np.zeros((N_OUTPUTS, inputs.shape[1]))
    lanes = new_lanes()
    runtime_flags(lanes, settings)
    max_samples = trace.shape[1]
    h = settings[SET_DT]
    count = 0
    running = load_lane(lanes, 0, j, inputs, settings, outputs, shared)
    if max_samples > 0:
        trace[0, 0] = 0.0
        trace[1, 0] = inputs[IN_X0, j]
        trace[2, 0] = inputs[IN_V0, j]
        trace[3, 0] = 0.0
        count = 1
    while running:
        before = lanes[STEPS * LANES]
        if ADAPTIVE:  # a rejected attempt also takes no step
            attempt_once(lanes, 0, settings, shared)
            event = lanes[PENDING * LANES] > 0.0
        else:
            event = replay_lane(lanes, 0, settings, shared, 1) == 0
            if CARRY_SLOPE and event:
                # f', f'' afresh at x, as the scan does for a lane the vector
                # loop stopped: the event is resolved from the same values
                refresh_slope(lanes, 0, shared)
        stepped = lanes[STEPS * LANES] > before
        if stepped:
            lanes[CASCADE * LANES] = 0.0
        if event:
            running = resolve_lane(lanes, 0, settings, outputs, shared)
        if count < max_samples and (
                event or (stepped and np.int64(lanes[STEPS * LANES]) % every == 0)):
            if running:
                trace[0, count] = current_time(lanes, 0, h)
                trace[1, count] = lanes[X * LANES]
                trace[2, count] = lanes[V * LANES]
                trace[3, count] = lanes[W * LANES]
            else:
                trace[0, count] = outputs[OUT_T, j]
                trace[1, count] = outputs[OUT_X, j]
                trace[2, count] = outputs[OUT_V, j]
                trace[3, count] = outputs[OUT_WORK, j]
            count += 1
    return count
