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
# how many kernel variants the run compiled (printed at the end; the suite's
# time is mostly compilation, so this is the number to keep down)
# ------------------------------------------------------------------------------
_COMPILED: dict[str, int] = {"specialised": 0, "general": 0}


def _count_compilations() -> None:
    from numba.core import event

    class Counter(event.Listener):
        def on_start(self, ev):
            pass

        def on_end(self, ev):
            name = ev.data["dispatcher"].py_func.__name__
            if name.startswith("run_tiles_"):  # one per kernel variant
                _COMPILED["general" if "_runtime_" in name else "specialised"] += 1

    event.register("numba:compile", Counter())


def pytest_configure(config):
    _count_compilations()
    config._rampwork_compiled = dict.fromkeys(_COMPILED, 0)
    if not hasattr(config, "workerinput") and not config.option.collectonly:
        _compile_general_kernels()  # in the controller (or a run without workers)


def pytest_sessionfinish(session):
    if hasattr(session.config, "workeroutput"):  # an xdist worker: report to the controller
        session.config.workeroutput["rampwork_compiled"] = dict(_COMPILED)


@pytest.hookimpl(optionalhook=True)
def pytest_testnodedown(node, error):
    for kind, count in getattr(node, "workeroutput", {}).get("rampwork_compiled", {}).items():
        node.config._rampwork_compiled[kind] += count


def pytest_terminal_summary(terminalreporter, config):
    counts = {kind: config._rampwork_compiled[kind] + _COMPILED[kind] for kind in _COMPILED}
    terminalreporter.write_line(
        f"kernel variants compiled in this run: {counts['specialised']} specialised, "
        f"{counts['general']} general (the rest came from numba's disk cache)")


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
