"""The Ishigami function and its analytic Sobol' indices: the check of
:mod:`rampwork.sensitivity` against known answers.

f(x1, x2, x3) = sin x1 + a sin^2 x2 + b x3^4 sin x1, each x_i uniform on
[-pi, pi] (Ishigami and Homma 1990; the indices: Sobol' and Levitan 1999).
With a = 7, b = 0.1: S1 = (0.3139, 0.4424, 0), ST = (0.5576, 0.4424, 0.2437);
x3 acts only through its interaction with x1 (S2[x1, x3] = 0.2437).  Run it
through :func:`rampwork.sensitivity.sobol_indices_of`, the code path every
rampwork output takes, and compare with :func:`misses`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

__all__ = ["RANGES", "A", "B", "ishigami", "indices", "misses"]

#: the usual constants
A, B = 7.0, 0.1
#: the inputs: each uniform on [-pi, pi]
RANGES = {"x1": (-math.pi, math.pi), "x2": (-math.pi, math.pi), "x3": (-math.pi, math.pi)}


def ishigami(columns: Mapping[str, np.ndarray], a: float = A, b: float = B) -> np.ndarray:
    """sin x1 + a sin^2 x2 + b x3^4 sin x1 (Ishigami and Homma 1990)."""
    x1, x2, x3 = (np.asarray(columns[k]) for k in ("x1", "x2", "x3"))
    return np.sin(x1) + a * np.sin(x2) ** 2 + b * x3**4 * np.sin(x1)


def indices(a: float = A, b: float = B) -> dict[str, np.ndarray]:
    """The analytic S1, ST (over x1, x2, x3) and S2 (3 x 3, mirrored, NaN on
    the diagonal) of :func:`ishigami`: only x1 and x3 interact."""
    pi4 = math.pi**4
    v1 = (1 + b * pi4 / 5) ** 2 / 2
    v2 = a**2 / 8
    v13 = 8 * b**2 * pi4**2 / 225
    total = a**2 / 8 + b * pi4 / 5 + b**2 * pi4**2 / 18 + 0.5
    s2 = np.zeros((3, 3))
    s2[0, 2] = s2[2, 0] = v13 / total
    np.fill_diagonal(s2, np.nan)
    return {"S1": np.array([v1, v2, 0.0]) / total, "ST": np.array([v1 + v13, v2, v13]) / total,
            "S2": s2}


def misses(ds, a: float = A, b: float = B, slack: float = 0.01, widest: float = 0.1) -> list[str]:
    """Where the estimates of a :func:`~rampwork.sensitivity.sobol_indices_of` run of :func:`ishigami`
    miss the analytic indices: each must lie within its confidence interval
    plus ``slack`` (the interval is itself an estimate), and no interval may
    be wider than ``widest`` (half-width).  An empty list: the check passed."""
    exact = indices(a, b)
    found = []
    for key in ("S1", "ST", "S2"):
        if key not in ds:
            continue
        estimate, conf = ds[key].values, ds[f"{key}_conf"].values
        for index in zip(*np.nonzero(np.isfinite(exact[key]))):
            label = f"{key}[{', '.join(str(ds['parameter'].values[i]) for i in index)}]"
            error = abs(estimate[index] - exact[key][index])
            if error > conf[index] + slack:
                found.append(f"{label} = {estimate[index]:.4f} +/- {conf[index]:.4f}, analytic "
                              f"{exact[key][index]:.4f} (off by {error:.4f})")
            elif conf[index] > widest:
                found.append(f"{label}: confidence interval +/- {conf[index]:.4f} wider than "
                              f"+/- {widest}")
    return found
