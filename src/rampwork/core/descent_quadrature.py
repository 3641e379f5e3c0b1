"""The descent of a y = f(x) sine-modes ramp by quadrature, not stepping.

Drag-free motion in one direction ``d`` with the normal term ``n > 0``
(docs/physics.md §1.2) has, for the kinetic energy per unit mass
``E = v^2 (1 + f'^2) / 2`` along ``xi = d (x - x_A)``,

    dE/dxi = -g (d f' + mu) - 2 mu E dtheta/dxi,   theta = d (atan f'(x) - atan f'(x_A)),

a LINEAR first-order equation (dtheta/dxi = f'' / (1 + f'^2)), so

    E(xi) = exp(-2 mu theta) [E_0 - g int_0^xi (d f' + mu) exp(2 mu theta) dxi'],
    T = int sqrt(1 + f'^2) / sqrt(2 E) dxi,   W / m = mu int (g + 2 E f'' / (1 + f'^2)) dxi.

The start at rest makes 1 / sqrt(E) singular like xi^(-1/2).  The path is
cut into P equal lengths in x (the node tables' layout: 4 or 8, see
descent_nodes.PANEL_LAYOUTS); on the first, xi = h tau^2 (h = L / P) makes
every integrand smooth (analytic for sine modes) in tau, the
others are linear in tau.  On a panel's Chebyshev-Lobatto points of tau the
cumulative integral is a precomputed spectral integration matrix (its last
row: the Clenshaw-Curtis weights).  Each panel, in turn from A, is refined
on its own (n = 2, 4, ... 64 points, each level's a subset of the next)
until its estimate meets rtol relative for its share of T, of W and of the
energy integral: the change since the level below, times the ratio of the
last two changes where that is below 1 (the change bounds the coarser
level's error; a geometric rate makes the accepted one's smaller by that
ratio), and only once the change between the two levels below is at most
TRUSTED_CHANGE_* (before, two levels can agree by chance: near a stop, errors
reached 59x the rtol on a benchmark population).  Why panels: the arc
length sqrt(1 + f'^2) and atan f' have branch points where f' = +-i,
close to the real axis for steep, wavy slopes; a global rule needs 128-256 points for every candidate, panels
refine only where they sit.

A candidate is *valid* only where the estimate meets rtol and, on the
accepted level's points, E > 0 and n > 0 with a margin that also covers a
dip between points (bounded by a quarter of the neighbouring second
differences, twice a parabola's); a panel whose points keep the margins
but whose bound between them fails is refined (closer points bound it
closer), one with a point within a margin is not; otherwise, or where
the start does not slide towards B, or T reaches t_max, ``valid`` is
False and the caller runs the ODE kernel for it (whose statuses are the
contract).

Vectorised (the loops over points are SIMD loops; no libm call in them):
a panel's points are stored in level order (each level's new points one
contiguous block: core/descent_nodes.py); the point values do not depend on E, so every
panel's points up to the first accepted level come in one pass per
candidate; cos(j theta), sin(j theta) of the modes at every node are one
table per call (_mode_basis); atan and exp are core.vmath_exp's (<= 1 ulp);
the integration matrices are descent_nodes' (transposed and padded, their
product four columns at a time, _integrate); loops index views from 0 (an
index numba cannot prove non-negative is wrapped around, which keeps a
loop scalar).  Sums are rounded in the same order as row by row: only
atan and exp (<= 1 ulp against libm's ~0.5) move results, by ~1e-15.
"""

from __future__ import annotations

import math

import numpy as np

from . import vmath, vmath_exp
from .descent_nodes import END_SLOT, LEVEL_POINTS, PADDING, PANEL_SLOTS, SLOT, _integrate, _row_length
from .jit import fma, jit
from .ramps import MODES_HEADER, sine_modes_slope_curvature

#: the lowest level a panel may be accepted at (a coarser one can agree with the level below by chance)
FIRST_ACCEPTED = 3
#: the lowest level computed: the estimate at FIRST_ACCEPTED reads the changes of the two levels below
FIRST_COMPUTED = max(0, FIRST_ACCEPTED - 2)
#: the estimate: the change since the level below times min(1, SAFETY * the ratio of the latest two changes)
SAFETY = 1.0
#: the largest change between the two levels below the accepted one, TRUSTED_CHANGE_SCALE sqrt(rtol)
#: within [TRUSTED_CHANGE_LEAST, TRUSTED_CHANGE_MOST]: a larger one says the panel's levels are not yet
#: converging, and the next two may agree by chance (a near-stop's 1 / sqrt(E)).  On the benchmark's 2048
#: candidates every error of t_end and W stays below 0.51 rtol (rtol 1e-5 .. 1e-10); 1e-2 at every rtol
#: let it reach 7.8 rtol at 1e-10, 1e-3 at every rtol costs 13 % more points at 1e-5 .. 1e-6
TRUSTED_CHANGE_SCALE, TRUSTED_CHANGE_LEAST, TRUSTED_CHANGE_MOST = 10.0, 1e-3, 1e-2
#: the smallest normal term accepted, as a share of g (a graze goes to the kernel)
NU_MARGIN = 1e-2
#: the smallest E accepted, as a share of the start's scale E_0 + |dE/dxi(A)| xi
ENERGY_MARGIN = 1e-3
#: a start this close to the static threshold (|f'_A| - mu_k) goes to the kernel
START_MARGIN = 1e-9
#: the dip between two points: at most this times the larger neighbouring second difference
DIP_FACTOR = 0.25

@jit
def _mode_basis(shared, x_a, span, xi_unit, basis, scratch):
    """cos(j theta) and sin(j theta) of each mode j at every node, exactly as
    core.ramps.sine_modes_slope_curvature forms them (the same sincos and
    the same recurrence, bit for bit: tests/test_descent_quadrature.py), with
    its loop over the modes made the OUTER loop so that the loop over the
    nodes vectorises: ``basis`` holds mode by mode the cosines, then the
    sines.  They are the same for every candidate of a call."""
    k = int(shared[0])
    w = shared[6]
    size = xi_unit.size
    two_c, s_prev, s = scratch[:size], scratch[size:2 * size], scratch[2 * size:3 * size]
    c_prev, c = scratch[3 * size:4 * size], scratch[4 * size:5 * size]
    for j in range(size):
        s1, c1 = vmath.sincos(w * ((x_a + span * xi_unit[j]) - shared[1]))
        two_c[j] = 2.0 * c1
        s_prev[j] = 0.0
        s[j] = s1
        c_prev[j] = 1.0
        c[j] = c1
    for mode in range(k):
        cosines = basis[2 * mode * size:(2 * mode + 1) * size]
        sines = basis[(2 * mode + 1) * size:(2 * mode + 2) * size]
        for j in range(size):
            cosines[j] = c[j]
            sines[j] = s[j]
            s_next = fma(two_c[j], s[j], -s_prev[j])
            c_next = fma(two_c[j], c[j], -c_prev[j])
            s_prev[j] = s[j]
            s[j] = s_next
            c_prev[j] = c[j]
            c[j] = c_next


@jit
def _panel_points(shared, row, basis, jacobian_unit, first_panel, stop_panel, first, stop, atan_a, two_mu_d,
                  direction, length, g, mu_k, fp, arc, bend, grow, integrand, slope, curve):
    """f', sqrt(1 + f'^2), f'' / (1 + f'^2), exp(2 mu theta) and the energy
    integrand at the slots [first, stop) of the panels first_panel ..
    stop_panel - 1: the slope and curvature sums of
    core.ramps.sine_modes_slope_curvature on _mode_basis's table (the same
    operations, so the same values), atan and exp by core.vmath_exp.
    Every loop runs over views from 0 (an index numba cannot prove
    non-negative is wrapped around, and that keeps the loop scalar)."""
    k = int(shared[0])
    base = MODES_HEADER + int(row) * k
    w = shared[6]
    size = basis.size // (2 * k)
    count = stop - first
    for p in range(first_panel, stop_panel):
        low = p * PANEL_SLOTS + first
        high = low + count
        slope_p, curve_p = slope[low:high], curve[low:high]
        for j in range(count):
            slope_p[j] = 0.0  # sum j c_j cos(j theta)
            curve_p[j] = 0.0  # sum j^2 c_j sin(j theta)
        for mode in range(k):
            order = float(mode + 1)
            coefficient = shared[base + mode] * order
            cosines = basis[2 * mode * size + low:2 * mode * size + high]
            sines = basis[(2 * mode + 1) * size + low:(2 * mode + 1) * size + high]
            for j in range(count):
                slope_p[j] = fma(coefficient, cosines[j], slope_p[j])
                curve_p[j] = fma(coefficient * order, sines[j], curve_p[j])
        fp_p, arc_p, bend_p, grow_p = fp[low:high], arc[low:high], bend[low:high], grow[low:high]
        integrand_p, jacobian_p = integrand[low:high], jacobian_unit[low:high]
        for j in range(count):
            f1 = fma(w, slope_p[j], shared[5])
            fp_p[j] = f1
            arc_p[j] = math.sqrt(1.0 + f1 * f1)
            bend_p[j] = (-(w * w) * curve_p[j]) / (1.0 + f1 * f1)
            grow_p[j] = vmath_exp.exp(two_mu_d * (vmath_exp.atan(f1) - atan_a))
            integrand_p[j] = -g * (direction * f1 + mu_k) * grow_p[j] * length * jacobian_p[j]


@jit
def _dip_bound(values, n, margin, spread):
    """Whether values[0 .. n] (equally spaced in the Lobatto angle) stay above
    ``margin`` between the points too: each interval's smaller end less
    DIP_FACTOR times the larger |second difference| at its ends (0 at the
    path's ends), into ``spread``.  Branch-free, so that its loops vectorise."""
    spread[0] = 0.0
    spread[n] = 0.0
    inner, before, middle, after = spread[1:n], values[0:n - 1], values[1:n], values[2:n + 1]
    for i in range(n - 1):
        inner[i] = abs(before[i] - 2.0 * middle[i] + after[i])
    low, high, spread_low, spread_high = values[0:n], values[1:n + 1], spread[0:n], spread[1:n + 1]
    kept = True
    for i in range(n):
        kept &= min(low[i], high[i]) - DIP_FACTOR * max(spread_low[i], spread_high[i]) > margin
    return kept


#: _contact_margins' verdicts: every margin kept; a point itself within one; only the bound between points
MARGINS_KEPT, MARGINS_BROKEN, MARGINS_BETWEEN = 0, 1, 2


@jit
def _contact_margins(energy, bend, xi_unit, n, first_panel, energy_0, pull_length, g, ratio, nu, spread):
    """Whether E > 0 and n > 0 hold on a panel's level-n points (the panel's
    views, level order) with the margins, between the points too (_dip_bound):
    MARGINS_KEPT; MARGINS_BROKEN where a point itself is within a margin (no
    finer level lifts it: the kernel's case); MARGINS_BETWEEN where only the
    bound between points fails (a finer level's closer points may prove it).
    E is measured against the start's scale E_0 + |dE/dxi(A)| xi (at A from
    rest, 0 / 0: set to 1)."""
    finest = xi_unit.size - 1
    stride = finest // n
    for i in range(n + 1):  # in order of tau
        j = SLOT[i * stride]
        e = energy[j]
        ratio[i] = e / (energy_0 + pull_length * xi_unit[j])
        nu[i] = 1.0 + 2.0 * e * bend[j] / g
    if first_panel:
        ratio[0] = 1.0
    kept = True
    for i in range(n + 1):
        kept &= (ratio[i] > ENERGY_MARGIN) & (nu[i] > NU_MARGIN)
    if not kept:
        return MARGINS_BROKEN
    if _dip_bound(ratio, n, ENERGY_MARGIN, spread) and _dip_bound(nu, n, NU_MARGIN, spread):
        return MARGINS_KEPT
    return MARGINS_BETWEEN


@jit
def descent_quadrature(shared, rows, x_a, direction, length, g, mu_k, mu_s, v0, t_max, rtol,
                       xi_unit, jacobian_unit, matrices, offsets, t_end, work, energy_end, slope_end,
                       estimate, nodes, valid):
    """For each row r of ``rows`` (a row of the sine_modes table ``shared``)
    from x_a towards x_a + direction * length: ``t_end``, ``work`` (W / m),
    ``energy_end`` (E at B), ``slope_end`` (f' at B), ``estimate`` (relative
    error: each panel's worst of T, W and the energy integral, the largest),
    ``nodes`` (points used) and ``valid`` (see the module).  The tables are
    node_tables(P)'s (level order; P panels: xi_unit.size // PANEL_SLOTS)."""
    size = xi_unit.size
    finest = PANEL_SLOTS - 1
    panels = size // PANEL_SLOTS
    first_points = LEVEL_POINTS[FIRST_ACCEPTED] + 1  # every panel's points up to the first accepted level
    padded = size + PADDING  # the per-level passes run over padded lengths (no scalar remainder)
    fp = np.zeros(padded)
    bend = np.zeros(padded)  # f'' / (1 + f'^2) = dtheta/dxi
    grow = np.ones(padded)  # exp(2 mu theta)
    integrand = np.zeros(padded)
    energy = np.zeros(padded)  # at one level's points of a panel, then the accepted level's
    arc = np.zeros(padded)  # sqrt(1 + f'^2)
    slope = np.zeros(padded)
    curve = np.zeros(padded)
    jacobian = np.zeros(padded)  # dxi/dtau
    for j in range(size):
        jacobian[j] = length * jacobian_unit[j]
    basis = np.empty(2 * int(shared[0]) * size)
    _mode_basis(shared, x_a, direction * length, xi_unit, basis, np.empty(5 * size))
    total = np.empty(_row_length(finest))  # the energy integral to each point of a panel's level
    speed_factor = np.empty(_row_length(finest))  # dxi/dtau / sqrt(2 E)
    power = np.empty(_row_length(finest))  # g + 2 E f'' / (1 + f'^2)
    ratio = np.empty(finest + 1)
    nu = np.empty(finest + 1)
    spread = np.empty(finest + 1)  # _dip_bound's scratch
    two_mu_d = 2.0 * mu_k * direction
    trusted_change = min(TRUSTED_CHANGE_MOST, max(TRUSTED_CHANGE_LEAST, TRUSTED_CHANGE_SCALE * math.sqrt(rtol)))
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
        atan_a = vmath_exp.atan(slope_a)
        energy_0 = 0.5 * v0 * v0 * (1.0 + slope_a * slope_a)
        pull = -g * (direction * slope_a + mu_k)  # dE/dxi at the start (no curvature term at E = 0)
        if v0 == 0.0:
            # the rest rule: it slides, towards B, and not within rounding of the threshold
            if not (abs(slope_a) > mu_s and -direction * slope_a - mu_k > START_MARGIN * (1.0 + abs(slope_a))):
                continue
        elif v0 * direction < 0.0:
            continue
        # the point values do not depend on E: every panel's first levels in one pass
        _panel_points(shared, row, basis, jacobian_unit, 0, panels, 0, first_points, atan_a, two_mu_d, direction,
                      length, g, mu_k, fp, arc, bend, grow, integrand, slope, curve)
        carried = energy_0  # E_0 plus the energy integral up to the panel's start
        t_total = 0.0
        w_total = 0.0
        worst = 0.0
        used = 0
        ok = True
        for p in range(panels):
            start = p * (finest + 1)
            previous_t = previous_w = previous_c = np.nan
            previous_change = 1.0
            accepted = -1
            panel_t = panel_w = panel_c = 0.0
            for level in range(FIRST_COMPUTED, offsets.size):
                n = LEVEL_POINTS[level]
                stride = finest // n
                if n + 1 > first_points:  # its new points: slots n/2 + 1 .. n
                    _panel_points(shared, row, basis, jacobian_unit, p, p + 1, n // 2 + 1, n + 1, atan_a,
                                  two_mu_d, direction, length, g, mu_k, fp, arc, bend, grow, integrand, slope, curve)
                base = offsets[level]
                # the integration matrix times the integrand, by columns (in order of tau: the
                # sums are rounded in the same order as row by row), vectorised over the rows
                rows_padded = _row_length(n)
                _integrate(matrices[base:base + (n + 1) * rows_padded], integrand[start:start + finest + 1], n,
                           stride, rows_padded, total)
                stop = start + rows_padded  # the slots beyond n: values never read
                grow_p, energy_p = grow[start:stop], energy[start:stop]
                bend_p, jacobian_p = bend[start:stop], jacobian[start:stop]
                for i in range(rows_padded):
                    e = (carried + total[i]) / grow_p[i]
                    energy_p[i] = e
                    speed_factor[i] = jacobian_p[i] / math.sqrt(2.0 * e)
                    power[i] = g + 2.0 * e * bend_p[i]
                if p == 0 and energy_0 == 0.0:
                    # jacobian / sqrt(2 E) -> sqrt(2 h / pull) at the start from rest (slot 0)
                    speed_factor[0] = math.sqrt(2.0 * length / panels / pull)
                panel_c = total[END_SLOT]
                panel_t = 0.0
                panel_w = 0.0
                for i in range(n + 1):  # in order of tau
                    slot = SLOT[i * stride]
                    weight = matrices[base + i * rows_padded + END_SLOT]
                    panel_t += weight * arc[start + slot] * speed_factor[slot]
                    panel_w += weight * power[slot] * jacobian[start + slot]
                if not (math.isfinite(panel_t) and math.isfinite(panel_w) and math.isfinite(panel_c)):
                    # E <= 0 at a point of a level too coarse to see the panel: refine
                    previous_t = previous_w = previous_c = np.nan
                    previous_change = 1.0
                    continue
                if level == FIRST_COMPUTED or not math.isfinite(previous_t):
                    previous_t, previous_w, previous_c = panel_t, panel_w, panel_c
                    continue
                end_energy = carried + panel_c
                change = max(abs(panel_t - previous_t) / panel_t,
                             abs(panel_c - previous_c) / max(abs(end_energy), 1e-300))
                if mu_k > 0.0:
                    change = max(change, abs(panel_w - previous_w) / max(panel_w, NU_MARGIN * g * length / panels))
                # the change since the level below bounds that level's error; with a
                # geometric rate, the accepted level's is smaller by the latest ratio
                error = change * min(1.0, SAFETY * change / previous_change) if previous_change > 0.0 else change
                if error <= rtol and level >= FIRST_ACCEPTED and previous_change <= trusted_change:
                    margins = _contact_margins(energy[start:start + finest + 1], bend[start:start + finest + 1],
                                               xi_unit[start:start + finest + 1], n, p == 0, energy_0,
                                               abs(pull) * length, g, ratio, nu, spread)
                    if margins == MARGINS_KEPT:
                        accepted = level
                        worst = max(worst, error)
                        used += n
                        break
                    if margins == MARGINS_BROKEN:
                        break  # a point itself within a margin: the kernel's case (accepted stays -1)
                    # only the bound between points fails: the next level's points bound it closer
                previous_t, previous_w, previous_c = panel_t, panel_w, panel_c
                previous_change = change
            if accepted < 0:
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
        energy_end[c] = energy[size - (finest + 1) + END_SLOT]
        slope_end[c] = fp[size - (finest + 1) + END_SLOT]
        estimate[c] = worst
        nodes[c] = used
