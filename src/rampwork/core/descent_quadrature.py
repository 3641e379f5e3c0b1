"""The descent of a y = f(x) sine-modes ramp by quadrature, not stepping.

Drag-free motion in one direction ``d`` with the normal term ``n > 0``
(docs/physics.md §1.2) has, for the kinetic energy per unit mass
``E = v^2 (1 + f'^2) / 2`` along ``xi = d (x - x_A)``,

    dE/dxi = -g (d f' + mu) - 2 mu E dtheta/dxi,   theta = d (atan f'(x) - atan f'(x_A)),

a LINEAR first-order equation (dtheta/dxi = f'' / (1 + f'^2)), so

    E(xi) = exp(-2 mu theta) [E_0 - g int_0^xi (d f' + mu) exp(2 mu theta) dxi'],
    T = int sqrt(1 + f'^2) / sqrt(2 E) dxi,   W / m = mu int (g + 2 E f'' / (1 + f'^2)) dxi.

The start at rest makes 1 / sqrt(E) singular like xi^(-1/2).  The path is
cut into PANELS equal lengths in x; on the first, xi = h tau^2 (h = L /
PANELS) makes every integrand smooth (analytic for sine modes) in tau, the
others are linear in tau.  On a panel's Chebyshev-Lobatto points of tau the
cumulative integral is a precomputed spectral integration matrix (its last
row: the Clenshaw-Curtis weights).  Each panel, in turn from A, is refined
on its own (n = 2, 4, ... 64 points, each level's a subset of the next)
until its estimate meets rtol relative for its share of T, of W and of the
energy integral: the change since the level below, times the ratio of the
last two changes where that is below 1 (the change bounds the coarser
level's error; a geometric rate makes the accepted one's smaller by that
ratio).  Why panels: the arc length sqrt(1 + f'^2) and atan f' have
branch points where f' = +-i, close to the real axis for steep, wavy
slopes; a global rule needs 128-256 points for every candidate, panels
refine only where they sit.

A candidate is *valid* only where the estimate meets rtol and, on the
accepted level's points, E > 0 and n > 0 with a margin that also covers a
dip between points (bounded by a quarter of the neighbouring second
differences, twice a parabola's); otherwise, or where the start does not
slide towards B, or T reaches t_max, ``valid`` is False and the caller runs
the ODE kernel for it (whose statuses are the contract).
"""

from __future__ import annotations

import functools
import math

import numpy as np

from .jit import jit
from .ramps import sine_modes_slope_curvature

#: the path's panels (equal lengths in x): each integrates on its own points,
#: refined on its own, so a difficulty in one panel costs no points elsewhere
PANELS = 8
#: the points per panel n of the levels (Chebyshev-Lobatto: n + 1, each level's a subset of the next)
LEVELS = (2, 4, 8, 16, 32, 64)
LEVEL_POINTS = np.array(LEVELS, dtype=np.int64)
#: the lowest level a panel may be accepted at (a coarser one can agree with the level below by chance)
FIRST_ACCEPTED = 3
#: the estimate: the change since the level below times min(1, SAFETY * the ratio of the latest two changes)
SAFETY = 1.0
#: the smallest normal term accepted, as a share of g (a graze goes to the kernel)
NU_MARGIN = 1e-2
#: the smallest E accepted, as a share of the start's scale E_0 + |dE/dxi(A)| xi
ENERGY_MARGIN = 1e-3
#: a start this close to the static threshold (|f'_A| - mu_k) goes to the kernel
START_MARGIN = 1e-9
#: the dip between two points: at most this times the larger neighbouring second difference
DIP_FACTOR = 0.25


@functools.lru_cache(maxsize=None)
def node_tables() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(xi / L and dxi/dtau / L at each panel's finest points, PANELS rows of
    n + 1 flattened; every level's integration matrix (n + 1)^2 on tau in
    [0, 1], flattened one after another; each level's offset into them).
    Panel 0 is xi = h tau^2 (h = L / PANELS: the start's 1 / sqrt(E) made
    smooth), the others xi = h (p + tau).  Row i of a level's matrix
    integrates the interpolant of values at its points from tau = 0 to its
    point i; row n holds Clenshaw-Curtis weights."""
    finest = LEVELS[-1]
    tau = 0.5 * (1.0 - np.cos(np.pi * np.arange(finest + 1) / finest))
    tau[0], tau[-1] = 0.0, 1.0
    h = 1.0 / PANELS
    xi = np.concatenate([h * tau * tau] + [h * (p + tau) for p in range(1, PANELS)])
    jacobian = np.concatenate([2.0 * h * tau] + [np.full(finest + 1, h) for _ in range(1, PANELS)])
    blocks, offsets, offset = [], [], 0
    for n in LEVELS:
        z = 2.0 * tau[:: finest // n] - 1.0
        vandermonde = np.polynomial.chebyshev.chebvander(z, n)
        integrals = np.empty((n + 1, n + 1))
        for k in range(n + 1):
            unit = np.zeros(n + 1)
            unit[k] = 1.0
            integrals[:, k] = np.polynomial.chebyshev.chebval(z, np.polynomial.chebyshev.chebint(unit, lbnd=-1.0))
        matrix = 0.5 * integrals @ np.linalg.inv(vandermonde)  # d tau = dz / 2
        matrix[0] = 0.0
        blocks.append(matrix.ravel())
        offsets.append(offset)
        offset += (n + 1) ** 2
    return xi, jacobian, np.concatenate(blocks), np.array(offsets, dtype=np.int64)


@jit
def _dip_bound(values, first, n, margin):
    """Whether values[first .. first + n] (equally spaced in the Lobatto
    angle) stay above ``margin`` between the points too: each interval's
    smaller end less DIP_FACTOR times the larger second difference at its ends."""
    for i in range(first, first + n):
        low = min(values[i], values[i + 1])
        left = values[i - 1] - 2.0 * values[i] + values[i + 1] if i > first else 0.0
        right = values[i] - 2.0 * values[i + 1] + values[i + 2] if i + 1 < first + n else 0.0
        if not low - DIP_FACTOR * max(abs(left), abs(right)) > margin:
            return False
    return True


@jit
def descent_quadrature(shared, rows, x_a, direction, length, g, mu_k, mu_s, v0, t_max, rtol,
                       xi_unit, jacobian_unit, matrices, offsets, t_end, work, energy_end, slope_end,
                       estimate, nodes, valid):
    """For each row r of ``rows`` (a row of the sine_modes table ``shared``)
    from x_a towards x_a + direction * length: ``t_end``, ``work`` (W / m),
    ``energy_end`` (E at B), ``slope_end`` (f' at B), ``estimate`` (relative
    error: each panel's worst of T, W and the energy integral, the largest),
    ``nodes`` (points used) and ``valid`` (see the module)."""
    size = xi_unit.size
    finest = size // PANELS - 1
    fp = np.empty(size)
    bend = np.empty(size)  # f'' / (1 + f'^2) = dtheta/dxi
    grow = np.empty(size)  # exp(2 mu theta)
    integrand = np.empty(size)
    energy = np.empty(size)  # at one level's points of a panel, then the accepted level's
    ratio = np.empty(finest + 1)
    nu = np.empty(finest + 1)
    for c in range(rows.size):
        row = float(rows[c])
        valid[c] = False
        t_end[c] = np.nan
        work[c] = np.nan
        energy_end[c] = np.nan
        slope_end[c] = np.nan
        estimate[c] = np.inf
        nodes[c] = 0
        slope_a, _ = sine_modes_slope_curvature(x_a, row, 0.0, 0.0, 0.0, shared)
        atan_a = math.atan(slope_a)
        energy_0 = 0.5 * v0 * v0 * (1.0 + slope_a * slope_a)
        pull = -g * (direction * slope_a + mu_k)  # dE/dxi at the start (no curvature term at E = 0)
        if v0 == 0.0:
            # the rest rule: it slides, towards B, and not within rounding of the threshold
            if not (abs(slope_a) > mu_s and -direction * slope_a - mu_k > START_MARGIN * (1.0 + abs(slope_a))):
                continue
        elif v0 * direction < 0.0:
            continue
        carried = energy_0  # E_0 plus the energy integral up to the panel's start
        t_total = 0.0
        w_total = 0.0
        worst = 0.0
        used = 0
        ok = True
        for p in range(PANELS):
            start = p * (finest + 1)
            filled = 0  # the stride of the points filled so far (0: none)
            previous_t = previous_w = previous_c = np.nan
            previous_change = 1.0
            accepted = -1
            panel_t = panel_w = panel_c = 0.0
            for level in range(offsets.size):
                n = LEVEL_POINTS[level]
                stride = finest // n
                for i in range(n + 1):
                    j = start + i * stride
                    if filled != 0 and (i * stride) % filled == 0:
                        continue
                    x = x_a + direction * length * xi_unit[j]
                    slope, curvature = sine_modes_slope_curvature(x, row, 0.0, 0.0, 0.0, shared)
                    fp[j] = slope
                    bend[j] = curvature / (1.0 + slope * slope)
                    grow[j] = math.exp(2.0 * mu_k * direction * (math.atan(slope) - atan_a))
                    integrand[j] = -g * (direction * slope + mu_k) * grow[j] * length * jacobian_unit[j]
                filled = stride
                base = offsets[level]
                last = base + n * (n + 1)  # the weights' row
                panel_t = 0.0
                panel_w = 0.0
                for i in range(n + 1):
                    j = start + i * stride
                    total = 0.0
                    for k in range(n + 1):
                        total += matrices[base + i * (n + 1) + k] * integrand[start + k * stride]
                    e = (carried + total) / grow[j]
                    energy[j] = e
                    if i == n:
                        panel_c = total
                    jacobian = length * jacobian_unit[j]
                    if p == 0 and i == 0 and energy_0 == 0.0:
                        # jacobian / sqrt(2 E) -> sqrt(2 h / pull) at the start from rest
                        speed_factor = math.sqrt(2.0 * length / PANELS / pull)
                    else:
                        speed_factor = jacobian / math.sqrt(2.0 * e)
                    weight = matrices[last + i]
                    panel_t += weight * math.sqrt(1.0 + fp[j] * fp[j]) * speed_factor
                    panel_w += weight * (g + 2.0 * e * bend[j]) * jacobian
                if not (math.isfinite(panel_t) and math.isfinite(panel_w) and math.isfinite(panel_c)):
                    # E <= 0 at a point of a level too coarse to see the panel: refine
                    previous_t = previous_w = previous_c = np.nan
                    previous_change = 1.0
                    continue
                if level == 0 or not math.isfinite(previous_t):
                    previous_t, previous_w, previous_c = panel_t, panel_w, panel_c
                    continue
                end_energy = carried + panel_c
                change = max(abs(panel_t - previous_t) / panel_t,
                             abs(panel_c - previous_c) / max(abs(end_energy), 1e-300))
                if mu_k > 0.0:
                    change = max(change, abs(panel_w - previous_w) / max(panel_w, NU_MARGIN * g * length / PANELS))
                # the change since the level below bounds that level's error; with a
                # geometric rate, the accepted level's is smaller by the latest ratio
                error = change * min(1.0, SAFETY * change / previous_change) if previous_change > 0.0 else change
                if error <= rtol and level >= FIRST_ACCEPTED:
                    accepted = level
                    worst = max(worst, error)
                    used += n
                    break
                previous_t, previous_w, previous_c = panel_t, panel_w, panel_c
                previous_change = change
            if accepted < 0:
                ok = False
                break
            # E > 0 and n > 0 between the points too, with margins
            n = LEVEL_POINTS[accepted]
            stride = finest // n
            for i in range(n + 1):
                j = start + i * stride
                e = energy[j]
                if p == 0 and i == 0:
                    ratio[i] = 1.0
                else:
                    ratio[i] = e / (energy_0 + abs(pull) * length * xi_unit[j])
                    ok = ok and e > 0.0
                nu[i] = 1.0 + 2.0 * e * bend[j] / g
            if not (ok and _dip_bound(ratio, 0, n, ENERGY_MARGIN) and _dip_bound(nu, 0, n, NU_MARGIN)):
                ok = False
                break
            carried += panel_c
            t_total += panel_t
            w_total += panel_w
            if t_total >= t_max * (1.0 - 1e-9):
                ok = False
                break
        if not ok:
            continue
        valid[c] = True
        t_end[c] = t_total
        work[c] = mu_k * w_total
        energy_end[c] = energy[size - 1]
        slope_end[c] = fp[size - 1]
        estimate[c] = worst
        nodes[c] = used
