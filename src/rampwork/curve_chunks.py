"""Curve scenes run in chunks: :class:`CurveSweepRun` is the
:class:`rampwork.sweepruns.SweepRun` of a :class:`~rampwork.curve_scene.CurveScene`,
so that :func:`rampwork.run_to_file` (netCDF or Zarr, resume, Dask) and
``rampwork run`` write a curve sweep chunk by chunk as they do a ramp's.

Bit for bit the one-call run: no curve trajectory depends on the batch it runs in, and
every chunk runs on the kernel chosen for the whole sweep (friction, each
drag term, joints: a chunk whose trajectories all have ``mu_k = 0`` would
otherwise get a kernel without friction, whose adaptive error norm has one
component fewer).  A chunk's inputs are prepared from its own sweep values
only (a design draws its chunk), so memory per chunk is bounded.
"""

from __future__ import annotations

import time

import numpy as np
import xarray as xr

from . import runner, schema
from .core.threads import using_threads
from .curve_scene import (CASE_ATTRS, CurveScene, _drag_on, _layout, _prepare, attributes, check,
                          curve_traces, curve_variables)
from .scene import Sweep

#: trajectories per chunk where the caller gives none: the curve kernel runs
#: about 1e3-1e4 trajectories a second, so a chunk is seconds of work
CURVE_CHUNK_SIZE = 1 << 12


class _CurvePrepared:
    """:class:`rampwork.sweepruns.PreparedSweep` of a curve scene."""

    kernel_source = None

    def __init__(self, run: "CurveSweepRun"):
        self.run = run
        self.tier = run.tier
        started = time.perf_counter()
        run.chunk(0, 1)[0].compile()
        self.compile_seconds = time.perf_counter() - started

    def run_chunk(self, start: int, stop: int, threads: int) -> dict[str, np.ndarray]:
        with using_threads(threads):
            return self.run.compute(start, stop)

    def traces(self) -> tuple[xr.Dataset, float]:
        """The scene's recorded trajectories (``[record]``), each a chunk of
        one on the whole sweep's kernel, and the seconds they took."""
        started = time.perf_counter()
        run = self.run

        def traced(j):
            values = run.chunk_values(j, j + 1)
            return run.chunk(j, j + 1, values)[0], values

        traces = curve_traces(run.scene, run.sweep, traced)
        return traces, time.perf_counter() - started


class CurveSweepRun:
    """A checked curve scene over a sweep, run chunk by chunk (see the module)."""

    chunk_size = CURVE_CHUNK_SIZE

    def __init__(self, scene: CurveScene, sweep: Sweep | None):
        self.sweep = check(scene, sweep)  # every check, on the whole sweep
        self.scene = scene
        self.records = scene.record.enabled
        self.size = self.sweep.size
        self.choose_kernel(None)

    def choose_kernel(self, kernel: str | None) -> None:
        """The whole sweep's kernel and its tier (``kernel``: as for
        rampwork.simulate); its inputs are dropped: chunks make their own."""
        run = _prepare(self.scene, self.sweep, kernel)[0]
        self.kernel, self.tier = run.kernel, run.tier

    def check_shippable(self) -> None:
        """Every curve scene can be rebuilt from its text."""

    def thread_count(self, threads: int | None) -> int:
        return runner.thread_count(threads)

    def output_dtype(self, name: str) -> np.dtype:
        return schema.CURVE_OUTPUTS[name].np_dtype

    def layout(self) -> runner.DatasetLayout:
        scene, sweep = self.scene, self.sweep
        names = schema.curve_output_names(drag=_drag_on(scene, sweep))
        attrs = {name: schema.spec_attrs(schema.CURVE_OUTPUTS[name]) for name in names}
        if sweep.design is None:
            values = ({name: sweep.values(name) for name in sweep.names} if sweep.kind == "cases"
                      else {})
            dims, shape, coords = _layout(scene, sweep, values)
            return runner.DatasetLayout(tuple(dims), tuple(shape), attrs, coords)
        # a design's values are drawn chunk by chunk: stand-ins until then
        shape = (self.size,)
        coords = {name: ("case", np.broadcast_to(np.float64(0.0), shape),
                         schema.spec_attrs(schema.axis_spec(name, scene.axis_specs)))
                  for name in sweep.names}
        coords["case"] = ("case", np.broadcast_to(np.int64(0), shape), CASE_ATTRS)
        return runner.DatasetLayout(("case",), shape, attrs, coords, sweep.names + ("case",))

    def prepare(self, kernel: str | None = None) -> _CurvePrepared:
        if kernel is not None:
            self.choose_kernel(kernel)
        return _CurvePrepared(self)

    def attributes(self, compile_seconds, run_seconds, threads, steps, entry,
                   kernel_source=None, kernel_tier=None) -> dict:
        return attributes(self.scene, self.sweep, compile_seconds, run_seconds, steps,
                          entry=entry, threads=threads, tier=self.tier)

    # --------------------------------------------------------------------------
    def chunk_values(self, start: int, stop: int) -> dict[str, np.ndarray]:
        """Each swept axis's value for the flat trajectories start..stop-1
        (those of ``curve_scene.flat_values`` on the whole sweep)."""
        sweep = self.sweep
        if sweep.design is not None:
            return sweep.design.draw(start, stop)
        if not sweep.names:  # a single trajectory
            return {}
        if sweep.kind == "cases":
            return {name: np.asarray(values, dtype=np.float64)[start:stop]
                    for name, values in sweep.axes}
        index = np.unravel_index(np.arange(start, stop), sweep.shape)
        return {name: np.asarray(values, dtype=np.float64)[index[k]]
                for k, (name, values) in enumerate(sweep.axes)}

    def chunk(self, start: int, stop: int, values: dict | None = None):
        """``(run, mu_k, masses, gravity)`` of trajectories start..stop-1: their
        :class:`~rampwork.curves.CurveRun`, on the whole sweep's kernel
        (``values``: their :meth:`chunk_values`, when already drawn)."""
        values = self.chunk_values(start, stop) if values is None else values
        run, _, mu_k, masses, gravity = _prepare(
            self.scene, Sweep.cases(**values) if values else Sweep.single(), self.tier)
        run.kernel = self.kernel
        return run, mu_k, masses, gravity

    def compute(self, start: int, stop: int) -> dict[str, np.ndarray]:
        """The output variables of trajectories start..stop-1 (and a design's
        drawn coordinates)."""
        values = self.chunk_values(start, stop)
        run, mu_k, masses, gravity = self.chunk(start, stop, values)
        out = curve_variables(self.scene, self.sweep, run.run(), mu_k, masses, gravity)
        if self.sweep.design is not None:
            out.update(values)
            out["case"] = np.arange(start, stop, dtype=np.int64)
        return out
