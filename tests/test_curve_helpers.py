"""The curve kernels' shared helpers (core/curve_lanes._helper): one name per
distinct code, so that numba's disk cache cannot hand one kernel another's
helper.

A kernel loaded from the cache brings its helpers' symbols into the process;
a helper compiled later under the same name links to those.  Euler's and
semi-implicit Euler's steps read the same constants, and were once named
alike: with Euler's kernel in the cache, semi-implicit Euler returned
Euler's results."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from rampwork.core import curve_lanes
from rampwork.core.curve_steppers import CURVE_STEPPERS
from rampwork.curve_families import FAMILIES

SRC = Path(__file__).resolve().parents[1] / "src"


def test_distinct_helpers_have_distinct_names():
    """Every helper built for the methods and effects below (built, not
    compiled: dispatchers are lazy) has its own name, unless it is the same
    template with the same constants."""
    for family in ("loop", "quarter_pipe"):
        spec = FAMILIES[family]
        for method in CURVE_STEPPERS:
            for one_sided, friction in ((True, True), (False, False)):
                curve_lanes.build_curve_kernel(
                    spec.key, spec.frame, spec.point, method, one_sided=one_sided,
                    friction=friction, joints=1 if family == "quarter_pipe" else 0,
                    point_anywhere=spec.point_anywhere)
    names: dict = {}
    for key, helper in curve_lanes._HELPERS.items():
        names.setdefault(helper.py_func.__qualname__, set()).add(key)
    shared = {name: keys for name, keys in names.items() if len(keys) > 1}
    assert not shared, shared
    templates = {key[0] for key in curve_lanes._HELPERS}
    assert len(templates) > len(CURVE_STEPPERS)  # the steps and the other templates


_RUN = """
import sys, numpy as np
from rampwork.curves import Curve, simulate_curve
rng = np.random.default_rng(3)
s0, u0, mu = rng.uniform(0.05, 1.0, 60), rng.uniform(3, 8.5, 60), rng.uniform(0, 0.3, 60)
for method in sys.argv[2].split(","):
    out = simulate_curve(Curve.create("loop", radius=1.0), s0=s0, u0=u0, mu_k=mu,
                         method=method, dt=1e-3, t_max=3.0)
np.save(sys.argv[1], np.stack([out["t_end"], out["p_end"], out["u_end"], out["W_friction"]]))
"""


def _run(cache: Path, result: Path, methods: str) -> np.ndarray:
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache),
               PYTHONPATH=os.pathsep.join(filter(None, [str(SRC), os.environ.get("PYTHONPATH")])))
    subprocess.run([sys.executable, "-c", _RUN, str(result), methods], env=env, check=True)
    return np.load(result)


@pytest.mark.slow
def test_a_method_gives_its_own_results_whatever_the_cache_holds(tmp_path):
    """Semi-implicit Euler compiled beside Euler's kernel loaded from the
    disk cache gives what it gives from an empty cache, and not Euler's."""
    shared_cache, fresh_cache = tmp_path / "shared", tmp_path / "fresh"
    euler = _run(shared_cache, tmp_path / "euler.npy", "euler")  # fills the cache
    after_cached_euler = _run(shared_cache, tmp_path / "mixed.npy", "euler,semi_implicit_euler")
    alone = _run(fresh_cache, tmp_path / "alone.npy", "semi_implicit_euler")
    np.testing.assert_array_equal(after_cached_euler, alone)
    assert not np.array_equal(alone, euler)
