"""Shared test helpers.

Kernels are compiled per (ramp family, integrator, contact) and cached on disk
by numba; the physics tests reuse few of those combinations to keep the suite
fast (a fresh compile costs ~20 s, a cached load ~1 s).
"""

from __future__ import annotations

import os

import pytest

# no background compilation of the general kernels while tests measure and
# compare (set before rampwork is imported; subprocesses inherit it)
os.environ["RAMPWORK_WARMUP"] = "0"


@pytest.fixture(scope="session")
def reference():
    """The scipy reference solver module (skips where scipy is missing)."""
    pytest.importorskip("scipy")
    from rampwork import reference as module

    return module


# ------------------------------------------------------------------------------
# how many kernel variants the run compiled, and the seconds each test file
# spent compiling (printed at the end; the suite's time is mostly
# compilation, so these are the numbers to keep down)
# ------------------------------------------------------------------------------
_COMPILED: dict[str, int] = {"specialised": 0, "general": 0, "curve": 0}
_COMPILE_S: dict[str, float] = {}  # test file -> seconds in outermost numba compiles
_RUNNING = {"file": "(collection and fixtures)", "depth": 0, "start": 0.0}


def _count_compilations() -> None:
    import time

    from numba.core import event

    class Counter(event.Listener):
        def on_start(self, ev):
            if _RUNNING["depth"] == 0:  # nested compiles (callees) are inside the outer one
                _RUNNING["start"] = time.perf_counter()
            _RUNNING["depth"] += 1

        def on_end(self, ev):
            _RUNNING["depth"] -= 1
            if _RUNNING["depth"] == 0:
                seconds = time.perf_counter() - _RUNNING["start"]
                _COMPILE_S[_RUNNING["file"]] = _COMPILE_S.get(_RUNNING["file"], 0.0) + seconds
            name = ev.data["dispatcher"].py_func.__name__
            if name.startswith("run_tiles_"):  # one per ramp kernel variant
                _COMPILED["general" if "_runtime_" in name else "specialised"] += 1
            elif name.startswith("curve_") and name.rsplit("_", 2)[-2] == "tiles":  # curve_lanes
                _COMPILED["curve"] += 1

    event.register("numba:compile", Counter())


#: test files that take the longest on an empty cache, heaviest first (the
#: compile seconds this conftest prints, 2026-11-28): they run first, and
#: xdist (--no-loadscope-reorder) hands out files in this order, so the last
#: files to start are cheap and the workers finish closer together (in the
#: order of their test counts, as xdist would, one worker compiled 30 %
#: longer; this order measured 371 s against 389 s for one that put the
#: studies' and streaming tests' run time in front)
HEAVIEST_FIRST = ("test_effects.py", "test_tiers.py", "test_curves.py", "test_curves_track_bare.py",
                  "test_drag.py", "test_curve_tiers.py", "test_properties.py", "test_curve_lanes.py",
                  "test_studies.py", "test_streaming.py", "test_curves_record.py",
                  "test_curves_joints.py", "test_optimise.py", "test_curves_hard.py",
                  "test_adaptive.py", "test_runner.py", "test_curves_spline.py")


def pytest_collection_modifyitems(config, items):
    rank = {name: k for k, name in enumerate(HEAVIEST_FIRST)}
    items.sort(key=lambda item: rank.get(item.path.name, len(rank)))  # stable: in-file order kept


@pytest.hookimpl(tryfirst=True)
def pytest_runtest_setup(item):
    _RUNNING["file"] = item.nodeid.split("::")[0]


def pytest_configure(config):
    _count_compilations()
    config._rampwork_compiled = dict.fromkeys(_COMPILED, 0)
    config._rampwork_compile_s = {}
    if not hasattr(config, "workerinput") and not config.option.collectonly:
        _compile_general_kernels()  # in the controller (or a run without workers)


def pytest_sessionfinish(session):
    if hasattr(session.config, "workeroutput"):  # an xdist worker: report to the controller
        session.config.workeroutput["rampwork_compiled"] = dict(_COMPILED)
        session.config.workeroutput["rampwork_compile_s"] = dict(_COMPILE_S)


@pytest.hookimpl(optionalhook=True)
def pytest_testnodedown(node, error):
    output = getattr(node, "workeroutput", {})
    for kind, count in output.get("rampwork_compiled", {}).items():
        node.config._rampwork_compiled[kind] += count
    for path, seconds in output.get("rampwork_compile_s", {}).items():
        node.config._rampwork_compile_s[path] = node.config._rampwork_compile_s.get(path, 0.0) + seconds


def pytest_terminal_summary(terminalreporter, config):
    counts = {kind: config._rampwork_compiled[kind] + _COMPILED[kind] for kind in _COMPILED}
    terminalreporter.write_line(
        f"kernel variants compiled in this run: {counts['specialised']} specialised and "
        f"{counts['general']} general ramp kernels, {counts['curve']} curve kernels "
        f"(the rest came from numba's disk cache)")
    seconds = dict(config._rampwork_compile_s)
    for path, s in _COMPILE_S.items():
        seconds[path] = seconds.get(path, 0.0) + s
    top = sorted(seconds.items(), key=lambda item: -item[1])[:12]
    if top and top[0][1] >= 1.0:
        terminalreporter.write_line(
            f"numba compilation, {sum(seconds.values()):.0f} s in all; most by test file: "
            + ", ".join(f"{path.removeprefix('tests/')} {s:.0f} s" for path, s in top))


def _compile_general_kernels() -> None:
    """Compile the general kernels missing from the disk cache, one process per
    kind side by side, before the workers start: the tests' small sweeps run
    on them (kernel="auto"; RAMPWORK_KERNEL=specialised runs every test on
    the specialised kernels instead, as CI also does)."""
    import subprocess
    import sys

    if os.environ.get("RAMPWORK_KERNEL", "auto") != "auto":
        return
    from rampwork import kernels

    missing = [variant.method for variant in kernels.missing_general()]
    runs = [subprocess.Popen([sys.executable, "-m", "rampwork.warmup", kind]) for kind in missing]
    _COMPILED["general"] += len(missing)
    for run in runs:
        if run.wait() != 0:
            raise RuntimeError(f"compiling the general kernels failed: {run.args}")
