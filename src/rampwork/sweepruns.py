"""What a sweep run in chunks (:mod:`rampwork.streaming`, :mod:`rampwork.cluster`)
asks of a scene kind: a small interface that ramp scenes (``y = f(x)``,
:class:`RampSweepRun`) and curve scenes (:class:`rampwork.curve_chunks.CurveSweepRun`)
implement, so that the chunking, resume and Dask code is written once.

A :class:`SweepRun` is a checked run (every check made on construction, before
any work): its scene and sweep, the layout of its dataset, and the attributes
of the finished file. :meth:`SweepRun.prepare` compiles its kernel once and
gives a :class:`PreparedSweep`, which computes any contiguous range of flat
trajectory indices, equal bit for bit to the same trajectories of the one-call
run (``rampwork.simulate``).
"""

from __future__ import annotations

from typing import Protocol

import numpy as np
import xarray as xr

from . import runner, schema
from .errors import ConfigError


class PreparedSweep(Protocol):
    """A run with its kernel compiled (or loaded)."""

    compile_seconds: float
    kernel_source: str | None  # see kernels.kernel_source(); None: not told
    tier: str  # the kernel's tier ("specialised", "general", "curve")

    def run_chunk(self, start: int, stop: int, threads: int) -> dict[str, np.ndarray]:
        """The output variables (and a design's drawn coordinates) of the
        flat trajectories start..stop-1, by name."""

    def traces(self) -> tuple[xr.Dataset, float]:
        """The recorded trajectories alone, and the seconds they took."""


class SweepRun(Protocol):
    """A checked run of one scene over one sweep."""

    scene: object
    sweep: object
    size: int  # trajectories
    records: bool  # the scene records traces ([record])
    chunk_size: int  # trajectories per chunk when the caller gives none

    def check_shippable(self) -> None:
        """Refuse (ConfigError at ``scheduler``) a run that workers cannot
        rebuild from its stored scene text."""

    def thread_count(self, threads: int | None) -> int:
        """The threads a chunk runs on, ``threads`` asked (None: all)."""

    def layout(self) -> runner.DatasetLayout:
        """The dataset's variables, dims and coordinates before any value."""

    def output_dtype(self, name: str) -> np.dtype:
        """The dtype of output variable ``name``."""

    def prepare(self, kernel: str | None = None) -> PreparedSweep:
        """Compile (or load) the kernel (``kernel``: a ramp scene's tier)."""

    def attributes(self, compile_seconds: float, run_seconds: float, threads: int, steps: int,
                   entry: str, kernel_source: str | None = None,
                   kernel_tier: str | None = None) -> dict:
        """The dataset's global attributes."""


class _RampPrepared:
    """:class:`PreparedSweep` of a ramp scene: ``runner.Prepared``."""

    def __init__(self, prepared: runner.Prepared):
        self.prepared = prepared
        self.compile_seconds = prepared.compile_seconds
        self.kernel_source = prepared.kernel_source
        self.tier = prepared.tier

    def run_chunk(self, start, stop, threads):
        return runner.run_chunk(self.prepared, start, stop, threads)

    def traces(self):
        return runner.with_traces(self.prepared, xr.Dataset())


class RampSweepRun:
    """:class:`SweepRun` of a ramp scene: its ``runner.RunPlan``."""

    chunk_size = runner.CHUNK_SIZE

    def __init__(self, scene, sweep):
        self.plan = runner.plan_run(scene, sweep)
        self.scene = self.plan.scene
        self.sweep = self.plan.sweep
        self.size = self.plan.size
        self.records = self.scene.record.enabled

    def check_shippable(self) -> None:
        if self.scene.ramp.family == "callable":
            raise ConfigError("scheduler", "a ramp of user functions cannot be shipped to workers "
                              "(they rebuild the scene from its text); run it with threads")

    def thread_count(self, threads):
        return runner.thread_count(threads)

    def layout(self):
        return runner.dataset_layout(self.plan)

    def output_dtype(self, name):
        return schema.OUTPUTS[name].np_dtype

    def prepare(self, kernel=None):
        return _RampPrepared(runner.prepare(self.plan, kernel))

    def attributes(self, compile_seconds, run_seconds, threads, steps, entry,
                   kernel_source=None, kernel_tier=None):
        return runner.attributes(self.plan, compile_seconds, run_seconds, threads, steps,
                                 entry=entry, kernel_source=kernel_source,
                                 kernel_tier=kernel_tier or "specialised")


def sweep_run(scene, sweep) -> SweepRun:
    """The checked run of ``scene`` (a ramp's or a curve's) over ``sweep``."""
    from .curve_scene import CurveScene

    if isinstance(scene, CurveScene):
        from .curve_chunks import CurveSweepRun

        return CurveSweepRun(scene, sweep)
    return RampSweepRun(scene, sweep)
