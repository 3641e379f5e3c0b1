"""The descent of a y = f(x) sine-modes ramp by quadrature, not stepping.

Drag-free motion in one direction ``d`` with the normal term ``n > 0``
(docs/physics.md §1.2) has, for the kinetic energy per unit mass
``E = v^2 (1 + f'^2) / 2`` along ``xi = d (x - x_A)``,

    dE/dxi = -g (d f' + mu) - 2 mu E dtheta/dxi,   theta = d (atan f'(x) - atan f'(x_A)),

a LINEAR first-order equation (dtheta/dxi = f'' / (1 + f'^2)), so

    E(xi) = exp(-2 mu theta) [E_0 - g int_0^xi (d f' + mu) exp(2 mu theta) dxi'],
    T = int sqrt(1 + f'^2) / sqrt(2 E) dxi,   W / m = mu int (g + 2 E f'' / (1 + f'^2)) dxi.

The start at rest makes 1 / sqrt(E) singular like xi^(-1/2); the
substitution xi = L sigma^2 makes every integrand smooth (analytic for sine
modes) in sigma on [0, 1].  On the Chebyshev-Lobatto points of sigma (N + 1
of them, N = 8 ... 256, each level's points a subset of the next) the
cumulative integral is a precomputed spectral integration matrix (its last
row: the Clenshaw-Curtis weights).  A level is accepted where T, E_B and W
differ from the level below by at most rtol relative (the estimate, which
the coarser level's error dominates, so it bounds the accepted one's).

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

#: sigma's panels (equal widths): each integrates on its own points, so the
#: cumulative integral costs N (n + 1) multiply-adds, not N^2
PANELS = 8
#: the points per panel n of the levels (Chebyshev-Lobatto: n + 1, the ends shared)
LEVELS = (4, 8, 16, 32)
LEVEL_POINTS = np.array(LEVELS, dtype=np.int64)
#: the smallest normal term accepted, as a share of g (a graze goes to the kernel)
NU_MARGIN = 1e-2
#: the smallest E accepted, as a share of the start's scale E_0 + L |h_0| sigma^2
ENERGY_MARGIN = 1e-3
#: a start this close to the static threshold (|f'_A| - mu_k) goes to the kernel
START_MARGIN = 1e-9
#: the dip between two points: at most this times the larger neighbouring second difference
DIP_FACTOR = 0.25


@functools.lru_cache(maxsize=None)
def node_tables() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(sigma at the finest level's points, ascending, PANELS * n + 1 of
    them; every level's integration matrix (n + 1)^2 on a panel of unit
    width, flattened one after another; each level's offset into it).  Row
    i of a level's matrix integrates the interpolant of values at its points
    from the panel's start to its point i; row n holds Clenshaw-Curtis
    weights."""
    finest = LEVELS[-1]
    tau = 0.5 * (1.0 - np.cos(np.pi * np.arange(finest + 1) / finest))
    tau[0], tau[-1] = 0.0, 1.0
    sigma = np.concatenate([(p + tau[:-1]) / PANELS for p in range(PANELS)] + [np.array([1.0])])
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
    return sigma, np.concatenate(blocks), np.array(offsets, dtype=np.int64)


def first_level(rtol: float) -> int:
    """The level whose comparison with the one below usually meets ``rtol``
    for a smooth few-mode ramp (measured: benchmarks/shape_evaluations.py)."""
    for level, tolerance in ((1, 1e-6), (2, 1e-10)):
        if rtol >= tolerance:
            return level
    return 3


@jit
def _dip_bound(values, n, margin):
    """Whether values[0..n] (equally spaced in the Lobatto angle) stay above
    ``margin`` between the points too: each interval's smaller end less
    DIP_FACTOR times the larger second difference at its ends."""
    for i in range(n):
        low = min(values[i], values[i + 1])
        left = values[i - 1] - 2.0 * values[i] + values[i + 1] if i > 0 else 0.0
        right = values[i] - 2.0 * values[i + 1] + values[i + 2] if i + 1 < n else 0.0
        if not low - DIP_FACTOR * max(abs(left), abs(right)) > margin:
            return False
    return True


@jit
def descent_quadrature(shared, rows, x_a, direction, length, g, mu_k, mu_s, v0, t_max, rtol, start_level,
                       sigma, matrices, offsets, t_end, work, energy_end, slope_end, estimate, nodes, valid):
    """For each row r of ``rows`` (a row of the sine_modes table ``shared``)
    from x_a towards x_a + direction * length: ``t_end``, ``work`` (W / m),
    ``energy_end`` (E at B), ``slope_end`` (f' at B), ``estimate`` (relative),
    ``nodes`` (the points of the accepted level less one) and ``valid``
    (see the module)."""
    size = sigma.size
    finest = (size - 1) // PANELS  # points per panel at the finest level, less one
    fp = np.empty(size)
    bend = np.empty(size)  # f'' / (1 + f'^2) = dtheta/dxi
    grow = np.empty(size)  # exp(2 mu theta)
    integrand = np.empty(size)
    energy = np.empty(size)
    ratio = np.empty(size)
    nu = np.empty(size)
    width = 1.0 / PANELS
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
        filled = 0  # the stride of the points filled so far (0: none)
        previous_t = previous_w = previous_e = np.nan
        accepted = False
        stride = 0
        count = 0
        for level in range(start_level - 1, offsets.size):
            n = LEVEL_POINTS[level]
            stride = finest // n
            count = PANELS * n  # points less one
            for i in range(count + 1):
                j = i * stride
                if filled != 0 and j % filled == 0:
                    continue
                x = x_a + direction * length * sigma[j] * sigma[j]
                slope, curvature = sine_modes_slope_curvature(x, row, 0.0, 0.0, 0.0, shared)
                fp[j] = slope
                bend[j] = curvature / (1.0 + slope * slope)
                grow[j] = math.exp(2.0 * mu_k * direction * (math.atan(slope) - atan_a))
                integrand[j] = -g * (direction * slope + mu_k) * grow[j] * 2.0 * length * sigma[j]
            filled = stride
            base = offsets[level]
            last = base + n * (n + 1)  # the weights' row
            t = 0.0
            w = 0.0
            carried = energy_0  # E_0 plus the integral up to the panel's start
            for p in range(PANELS):
                first = p * n
                for i in range(1 if p > 0 else 0, n + 1):
                    total = 0.0
                    for k in range(n + 1):
                        total += matrices[base + i * (n + 1) + k] * integrand[(first + k) * stride]
                    j = (first + i) * stride
                    e = (carried + width * total) / grow[j]
                    energy[first + i] = e
                    if i == n:
                        end_total = total
                for i in range(n + 1):
                    j = (first + i) * stride
                    e = energy[first + i]
                    if j == 0 and energy_0 == 0.0:
                        # sigma / sqrt(E) -> 1 / sqrt(L pull) at the start from rest
                        speed_factor = 2.0 * math.sqrt(length / (2.0 * pull))
                    else:
                        speed_factor = 2.0 * length * sigma[j] / math.sqrt(2.0 * e)
                    weight = width * matrices[last + i]
                    t += weight * math.sqrt(1.0 + fp[j] * fp[j]) * speed_factor
                    w += weight * (g + 2.0 * e * bend[j]) * 2.0 * length * sigma[j]
                carried += width * end_total
            w *= mu_k
            e_end = energy[count]
            if not (math.isfinite(t) and math.isfinite(w) and math.isfinite(e_end)):
                break
            error = max(abs(t - previous_t) / t, abs(e_end - previous_e) / e_end)
            if w > 0.0:
                error = max(error, abs(w - previous_w) / w)
            if error <= rtol:
                accepted = True
                t_end[c] = t
                work[c] = w
                energy_end[c] = e_end
                slope_end[c] = fp[size - 1]
                estimate[c] = error
                nodes[c] = count
                break
            previous_t, previous_w, previous_e = t, w, e_end
        if not accepted:
            continue
        # E > 0 and n > 0 between the points too, with margins
        ok = True
        scale_slope = length * abs(pull)
        for i in range(count + 1):
            j = i * stride
            ratio[i] = 1.0 if i == 0 else energy[i] / (energy_0 + scale_slope * sigma[j] * sigma[j])
            nu[i] = 1.0 + 2.0 * energy[i] * bend[j] / g
            if not (energy[i] > 0.0 or (i == 0 and energy_0 == 0.0)):
                ok = False
        if ok and _dip_bound(ratio, count, ENERGY_MARGIN) and _dip_bound(nu, count, NU_MARGIN) \
                and t_end[c] < t_max * (1.0 - 1e-9):
            valid[c] = True
