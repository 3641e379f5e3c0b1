"""Kernels on user functions (Ramp.from_functions) are cached under a digest
of what the functions compute, so a second process loads them."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap

import numba
import numpy as np
import pytest

import rampwork as rw
from rampwork.userfunctions import content_digest

SLOPE = 0.3


def f(x):
    return SLOPE * x * x


def fp(x):
    return 2.0 * SLOPE * x


def fpp(x):
    return 2.0 * SLOPE + 0.0 * x


def test_the_digest_names_what_the_functions_compute():
    global SLOPE
    first = content_digest([f, fp, fpp])
    assert first == content_digest([f, fp, fpp])  # stable
    assert first != content_digest([fp, f, fpp])  # order
    saved = SLOPE
    try:
        SLOPE = 0.4  # a global the functions read
        assert content_digest([f, fp, fpp]) != first
    finally:
        SLOPE = saved
    assert content_digest([f, fp, fpp]) == first
    assert content_digest([numba.njit(f), fp, fpp]) == content_digest([numba.njit(f), fp, fpp])
    scale = 2.0

    def closure(x):
        return scale * x

    digest = content_digest([closure])
    scale = 3.0  # noqa: F841 - read through the closure cell
    assert content_digest([closure]) != digest
    assert content_digest([numba.njit(fastmath=True)(f)]) != content_digest([numba.njit(f)])


def test_no_digest_for_values_without_a_stable_name():
    table = {"a": 1.0}

    def reads_an_object(x):
        return table["a"] * x

    assert content_digest([reads_an_object]) is None
    assert content_digest([f, reads_an_object]) is None
    assert content_digest([object()]) is None


_PROBE = textwrap.dedent("""
    import json, sys
    sys.path.insert(0, sys.argv[1])
    import rampwork as rw
    from userramp import f, fp, fpp
    ramp = rw.Ramp.from_functions(f, fp, fpp, domain=(-1.0, 1.0), curvature_sign=1)
    scene = rw.Scene(ramp=ramp, friction=rw.Friction(0.2), x0=-0.8,
                     integrator=rw.Integrator("rk4", 1e-3), t_max=5.0)
    ds = rw.simulate(scene, rw.Sweep.grid(v0=[0.0, 0.5, 1.0]))
    print(json.dumps({"source": ds.attrs["kernel_source"], "x_end": ds.x_end.values.tolist()}))
""")


@pytest.mark.slow  # two subprocesses, the first compiles a user-function kernel (~50 s)
def test_a_second_process_loads_the_kernel_of_user_functions(tmp_path):
    (tmp_path / "userramp.py").write_text(textwrap.dedent("""
        import numba
        CURVATURE = 0.8

        @numba.njit
        def f(x):
            return 0.5 * CURVATURE * x * x

        @numba.njit
        def fp(x):
            return CURVATURE * x

        @numba.njit
        def fpp(x):
            return CURVATURE + 0.0 * x
    """))
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache")}
    runs = [json.loads(subprocess.run([sys.executable, "-c", _PROBE, str(tmp_path)], env=env,
                                      capture_output=True, text=True, timeout=600,
                                      check=True).stdout.strip().splitlines()[-1])
            for _ in range(2)]
    assert [run["source"] for run in runs] == ["compiled", "disk cache"]
    assert runs[0]["x_end"] == runs[1]["x_end"]
    assert np.all(np.isfinite(runs[0]["x_end"]))
