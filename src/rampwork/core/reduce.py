"""The array work around a kernel call, each as one parallel pass over memory.

Before a chunk runs, a grid sweep's flat indices become axis values; after it,
the kernel's per-unit-mass rows become the dataset's variables.  Written with
numpy these were about 25 single-threaded passes over arrays of the chunk's
length: 13-15 % of a 10^6-trajectory run's time (80 ms each way on the
quadratic-bowl benchmark grid, measured beside a 1.1 s kernel).  Here each is
one pass, split over the run's threads, with the same arithmetic in the same
order as the numpy expressions it replaces (bit-identical results).
"""

from __future__ import annotations

from .jit import jit
from .threads import run_items
from .layout import (OUT_CONVEXITY, OUT_DRAG_WORK, OUT_ENERGY_LOSS, OUT_NREJ, OUT_NREV, OUT_PATH,
                     OUT_STATUS, OUT_STEPS, OUT_T, OUT_V, OUT_WORK, OUT_WORK_ERROR, OUT_X,
                     OUT_XLIFT, OUT_XLIFT_PAPER, OUT_PROJECTED)

#: trajectories per parallel work item (the runner hands out one item at a
#: time, which suits the kernel's tiles; single trajectories would drown in
#: the scheduling)
BLOCK = 8192


def grid_columns(start, lengths, values, out):
    """Axis values of the flat C-order grid indices start .. start + n - 1:
    ``out[k, i] = values[k, index_k]`` where ``index_k`` is axis k's index of
    flat index ``start + i``; ``lengths[k]`` is axis k's length and
    ``values[k, :lengths[k]]`` its values (rows padded to the longest axis)."""
    run_items(_grid_blocks, _blocks(out.shape[1]), start, lengths, values, out)


def _blocks(n):
    return (n + BLOCK - 1) // BLOCK


@jit
def _grid_blocks(first_block, stop_block, start, lengths, values, out):
    """Blocks first_block .. stop_block - 1 of :func:`grid_columns`."""
    n_axes = lengths.size
    n = out.shape[1]
    for block in range(first_block, stop_block):
        for i in range(block * BLOCK, min(n, (block + 1) * BLOCK)):
            _grid_point(start, i, n_axes, lengths, values, out)


@jit(refcount=False)  # no reference counting of the arrays per call
def _grid_point(start, i, n_axes, lengths, values, out):
    """Column i of :func:`grid_columns`."""
    rest = start + i
    for k in range(n_axes - 1, -1, -1):  # the last axis varies fastest
        out[k, i] = values[k, rest % lengths[k]]
        rest //= lengths[k]


def reduce_rows(raw, x0, mu_k, g, mass, status, t_end, x_end, v_end, w_friction, w_energy, w_linear,
                w_excess, w_path, energy_balance_error, convexity_mean, path_length_x, n_reversals,
                x_lift_off, x_lift_off_paper, steps, steps_rejected, w_friction_error_estimate,
                w_drag):
    """Fill the per-trajectory variables from the kernel's rows ``raw``
    (N_OUTPUTS, n) and the trajectories' x0, mu_k, g and mass.  A variable the
    run does not have is passed as an empty array and skipped.  Integer
    variables take the rows' values truncated, as numpy's casts do."""
    run_items(_reduce_blocks, _blocks(raw.shape[1]), raw, x0, mu_k, g, mass, status, t_end, x_end,
              v_end, w_friction, w_energy, w_linear, w_excess, w_path, energy_balance_error,
              convexity_mean, path_length_x, n_reversals, x_lift_off, x_lift_off_paper, steps,
              steps_rejected, w_friction_error_estimate, w_drag)


@jit
def _reduce_blocks(first_block, stop_block, raw, x0, mu_k, g, mass, status, t_end, x_end, v_end,
                   w_friction, w_energy, w_linear, w_excess, w_path, energy_balance_error,
                   convexity_mean, path_length_x, n_reversals, x_lift_off, x_lift_off_paper, steps,
                   steps_rejected, w_friction_error_estimate, w_drag):
    """Blocks first_block .. stop_block - 1 of :func:`reduce_rows`."""
    with_drag = w_drag.size > 0
    n = raw.shape[1]
    for block in range(first_block, stop_block):
        for i in range(block * BLOCK, min(n, (block + 1) * BLOCK)):
            _reduce_one(i, raw, x0, mu_k, g, mass, status, t_end, x_end, v_end, w_friction,
                        w_energy, w_linear, w_excess, w_path, energy_balance_error, convexity_mean,
                        path_length_x, n_reversals, x_lift_off, x_lift_off_paper, steps,
                        steps_rejected, w_friction_error_estimate, w_drag, with_drag)


@jit(refcount=False)
def _reduce_one(i, raw, x0, mu_k, g, mass, status, t_end, x_end, v_end, w_friction, w_energy,
                w_linear, w_excess, w_path, energy_balance_error, convexity_mean, path_length_x,
                n_reversals, x_lift_off, x_lift_off_paper, steps, steps_rejected,
                w_friction_error_estimate, w_drag, with_drag):
    """Trajectory i of :func:`reduce_rows`."""
    m = mass[i]
    status[i] = raw[OUT_STATUS, i]
    t_end[i] = raw[OUT_T, i]
    x_end[i] = raw[OUT_X, i]
    v_end[i] = raw[OUT_V, i]
    convexity_mean[i] = raw[OUT_CONVEXITY, i]
    path_length_x[i] = raw[OUT_PATH, i]
    n_reversals[i] = raw[OUT_NREV, i]
    x_lift_off[i] = raw[OUT_XLIFT, i]
    steps[i] = raw[OUT_STEPS, i]
    if x_lift_off_paper.size:
        x_lift_off_paper[i] = raw[OUT_XLIFT_PAPER, i]
    if steps_rejected.size:
        steps_rejected[i] = raw[OUT_NREJ, i]
    if w_friction_error_estimate.size:
        w_friction_error_estimate[i] = m * raw[OUT_WORK_ERROR, i]
    friction = m * raw[OUT_WORK, i]
    w_friction[i] = friction
    w_energy[i] = m * raw[OUT_ENERGY_LOSS, i]
    weight = m * g[i]  # m g: the straight-ramp estimate's force per unit mu
    linear = abs(raw[OUT_X, i] - x0[i]) * mu_k[i] * weight
    w_linear[i] = linear
    w_excess[i] = friction - linear
    w_path[i] = (mu_k[i] * weight) * raw[OUT_PATH, i]
    if with_drag:
        drag = m * raw[OUT_DRAG_WORK, i]
        w_drag[i] = drag
        energy_balance_error[i] = ((friction + drag) - m * raw[OUT_ENERGY_LOSS, i]
                                   + m * raw[OUT_PROJECTED, i])
    else:
        # plus what the adaptive pairs' energy projection removed on the way
        # (0 without it): the balance error the integrator made, to first order
        energy_balance_error[i] = (friction - m * raw[OUT_ENERGY_LOSS, i]
                                   + m * raw[OUT_PROJECTED, i])
