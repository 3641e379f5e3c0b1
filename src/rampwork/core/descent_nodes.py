"""The nodes and integration matrices of core/descent_quadrature.py: the
path in equal panels (PANEL_LAYOUTS: 4, then 8 for a candidate the 4 do
not prove), each on nested Chebyshev-Lobatto levels of tau
(n = 2 .. 64 points), stored in LEVEL ORDER (each level's new points one
contiguous block, so that the per-point passes vectorise); each level's
spectral integration matrix, transposed and padded, so that its product
with the integrand runs over the points integrated to (_integrate)."""

from __future__ import annotations

import functools

import numpy as np

from .jit import jit

#: the path's panels (equal lengths in x): each integrates on its own points,
#: refined on its own, so a difficulty in one panel costs no points elsewhere
PANELS = 8
#: the layouts ChordModes.evaluate tries in turn: 4 panels (90 points a candidate at rtol 1e-5 .. 1e-6
#: against 131 on 8, the estimate as honest), then PANELS for the few candidates the 4 do not prove
#: valid (their levels run out, or a point falls within a contact margin), then the ODE kernel
PANEL_LAYOUTS = (4, PANELS)
#: the points per panel n of the levels (Chebyshev-Lobatto: n + 1, each level's a subset of the next)
LEVELS = (2, 4, 8, 16, 32, 64)
LEVEL_POINTS = np.array(LEVELS, dtype=np.int64)
#: the slot of tau = 1 (B's side of each panel; see _slots)
END_SLOT = 2
#: a panel's slots: the finest level's points
PANEL_SLOTS = LEVELS[-1] + 1


def _slots() -> np.ndarray:
    """A panel's points are stored in LEVEL ORDER: level l's n + 1 points are
    the panel's first n + 1 slots (tau = 0, 1/2, 1, then each level's new
    points in order of tau), so that each level's new points are one
    contiguous block (the per-point passes vectorise).  Entry m: the slot of
    the finest level's m-th point in order of tau."""
    finest = LEVELS[-1]
    slot = np.empty(finest + 1, dtype=np.int64)
    slot[[0, finest // 2, finest]] = 0, 1, END_SLOT  # the first level, n = 2
    for n in LEVELS[1:]:
        slot[np.arange(1, n, 2) * (finest // n)] = np.arange(n // 2 + 1, n + 1)  # its new (odd) points
    return slot


#: the slot of each of the finest level's points (in order of tau)
SLOT = _slots()
#: the integration matrices' columns are padded with zeros to a multiple of this (no scalar remainder
#: in the vectorised product; 8 = two 256-bit vectors, LLVM's interleaved vector body)
PADDING = 8


@jit
def _row_length(n):
    """The padded length of a column of level n's (n + 1)^2 integration matrix."""
    return (n + PADDING) // PADDING * PADDING


@functools.lru_cache(maxsize=None)
def node_tables(panels: int = PANELS) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(xi / L and dxi/dtau / L at each panel's finest points, ``panels`` rows of
    n + 1 in level order (SLOT), flattened; every level's integration matrix
    (n + 1)^2 on tau in [0, 1], TRANSPOSED with its rows (the points
    integrated to) in level order, flattened one after another; each
    level's offset into them).  Panel 0 is xi = h tau^2 (h = L / panels: the
    start's 1 / sqrt(E) made smooth), the others xi = h (p + tau).  Entry
    [k, SLOT[i]] of a level's block integrates the interpolant's k-th point
    (in order of tau) from tau = 0 to its point i; [k, END_SLOT] holds the
    Clenshaw-Curtis weights."""
    finest = LEVELS[-1]
    natural = 0.5 * (1.0 - np.cos(np.pi * np.arange(finest + 1) / finest))
    natural[0], natural[-1] = 0.0, 1.0
    tau = np.empty(finest + 1)
    tau[SLOT] = natural
    h = 1.0 / panels
    xi = np.concatenate([h * tau * tau] + [h * (p + tau) for p in range(1, panels)])
    jacobian = np.concatenate([2.0 * h * tau] + [np.full(finest + 1, h) for _ in range(1, panels)])
    blocks, offsets, offset = [], [], 0
    for n in LEVELS:
        z = 2.0 * natural[:: finest // n] - 1.0
        vandermonde = np.polynomial.chebyshev.chebvander(z, n)
        integrals = np.empty((n + 1, n + 1))
        for k in range(n + 1):
            unit = np.zeros(n + 1)
            unit[k] = 1.0
            integrals[:, k] = np.polynomial.chebyshev.chebval(z, np.polynomial.chebyshev.chebint(unit, lbnd=-1.0))
        matrix = 0.5 * integrals @ np.linalg.inv(vandermonde)  # d tau = dz / 2
        matrix[0] = 0.0
        transposed = np.zeros((n + 1, _row_length(n)))
        transposed[:, SLOT[:: finest // n]] = matrix.T
        blocks.append(transposed.ravel())
        offsets.append(offset)
        offset += transposed.size
    return xi, jacobian, np.concatenate(blocks), np.array(offsets, dtype=np.int64)


@jit
def _integrate(matrix, integrand, n, stride, rows, total):
    """``total`` (``rows``, padded) = a level's transposed integration matrix
    times the integrand at its n + 1 points (a panel's views, level order):
    by columns in order of tau, four at a time, so that each row's sum stays
    in a register for four columns (a column at a time, it went through
    memory: a load, an add and a store a column) and is rounded in the same
    order as one column at a time."""
    for i in range(rows):
        total[i] = 0.0
    k = 0
    while k + 4 <= n + 1:
        v0, v1 = integrand[SLOT[k * stride]], integrand[SLOT[(k + 1) * stride]]
        v2, v3 = integrand[SLOT[(k + 2) * stride]], integrand[SLOT[(k + 3) * stride]]
        c0, c1 = matrix[k * rows:(k + 1) * rows], matrix[(k + 1) * rows:(k + 2) * rows]
        c2, c3 = matrix[(k + 2) * rows:(k + 3) * rows], matrix[(k + 3) * rows:(k + 4) * rows]
        for i in range(rows):
            total[i] = (((total[i] + c0[i] * v0) + c1[i] * v1) + c2[i] * v2) + c3[i] * v3
        k += 4
    while k <= n:
        value = integrand[SLOT[k * stride]]
        column = matrix[k * rows:(k + 1) * rows]
        for i in range(rows):
            total[i] += column[i] * value
        k += 1
