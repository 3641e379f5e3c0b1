"""Sweeps written to a netCDF file (or a Zarr store) chunk by chunk: bounded
memory, resumable after an interruption, and the same sweep on a Dask cluster.

The output format follows the path's suffix (:func:`rampwork.io.output_format`):
this module runs the sweep, and a chunk store (:mod:`rampwork.chunkstore`)
writes it. What follows is the netCDF file's; a Zarr store
(:mod:`rampwork.zarrstore`) is written the same way, except that each chunk
is written where it is computed, on a Dask worker too, and marked done in a
record of its own.

The file is created whole first, as a partial file ``.NAME.partial`` beside
the target: every variable, coordinate and attribute the in-memory dataset of
:func:`rampwork.simulate` has. The sweep is cut into chunks that are
hyperslabs of the output arrays (a run of indices along one dimension, the
later dimensions whole), so a chunk is a contiguous range of flat trajectory
indices and, in the file, exactly one HDF5 chunk per variable: writing it is
one compressed block, never a read-modify-write. After each chunk the file is
synced to disk and the chunk's bit set in the global attribute
``rampwork_chunks_done``. An interrupted run (Ctrl-C, a killed process)
leaves the finished chunks there; ``resume=True`` runs only the others. At
the end the bookkeeping attributes give way to the run's own and the file is
renamed to the target.

Memory: a chunk's inputs, raw and reduced outputs (about 300 bytes per
trajectory), whatever the sweep size. A ``cases`` sweep also holds its axis
columns (the :class:`~rampwork.scene.Sweep` object keeps them); a design
holds its recipe, and each chunk draws its own values (written with the
chunk's results as the ``case`` coordinates).
"""

from __future__ import annotations

import hashlib
import itertools
import math
import os
import queue
import threading
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import xarray as xr

from . import cluster, io, runner
from ._version import __version__
from .chunkstore import (DIGEST_ATTR, DONE_ATTR, LAYOUT_ATTR, RUN_TIME_ATTR,  # noqa: F401
                         fit_done, open_chunk_store)
from .errors import ConfigError, option
from .scene import Scene, Sweep
from .sweepruns import SweepRun, sweep_run

__all__ = ["run_to_file", "SweepToFile", "ChunkLayout", "partial_path"]

#: changes whenever the partial file's layout or meaning changes
PARTIAL_FORMAT = 1
#: the done bits live in one attribute; HDF5 keeps attributes under 64 KiB compact
MAX_CHUNKS = 8 * 60_000


def partial_path(path: str | os.PathLike) -> Path:
    """Where the unfinished run of ``path`` is kept."""
    path = Path(path)
    return path.with_name(f".{path.name}.partial")


@dataclass(frozen=True)
class ChunkLayout:
    """Chunks of an output array of ``shape``: ``rows`` indices along
    dimension ``axis`` at a time, the dimensions after it whole, one index
    at a time on those before it (C order, so each chunk is a contiguous
    range of flat trajectory indices)."""

    shape: tuple[int, ...]
    axis: int
    rows: int

    @classmethod
    def for_shape(cls, shape: tuple[int, ...], target: int) -> "ChunkLayout":
        """Chunks of at most ``target`` trajectories where the shape allows
        (a later dimension's whole extent is one chunk's smallest piece)."""
        if not shape:
            return cls((), 0, 1)
        axis = next(k for k in range(len(shape)) if math.prod(shape[k + 1:]) <= target)
        rows = max(1, min(shape[axis], target // math.prod(shape[axis + 1:])))
        return cls(tuple(shape), axis, rows)

    @property
    def trajectories(self) -> int:
        """Trajectories in a full chunk (the last along its axis may have fewer)."""
        return self.rows * math.prod(self.shape[self.axis + 1:]) if self.shape else 1

    def describe(self, dims: tuple[str, ...], target: int | None = None) -> str:
        """The chunks in words, and why they hold fewer than ``target``
        trajectories where they do: a chunk is a block of the output
        arrays, whole along every dimension after its axis."""
        text = f"{self.count:,} chunk{'s' if self.count != 1 else ''} of {self.trajectories:,} trajectories"
        if not self.shape or target is None or self.trajectories == target or self.count == 1:
            return text
        inner = math.prod(self.shape[self.axis + 1:])
        later = " x ".join(dims[self.axis + 1:])
        if inner == 1:
            return text
        return (f"{text} ({self.rows:,} {dims[self.axis]} value{'s' if self.rows != 1 else ''} x the "
                f"whole {later} ({inner:,}): a chunk is a block of the grid, so {target:,} is "
                f"rounded down to whole rows)")

    @property
    def _per_outer(self) -> int:
        return -(-self.shape[self.axis] // self.rows) if self.shape else 1

    @property
    def count(self) -> int:
        return math.prod(self.shape[:self.axis]) * self._per_outer

    @property
    def chunksizes(self) -> tuple[int, ...]:
        """The HDF5 chunk shape: one chunk of the layout (a full one)."""
        return (1,) * self.axis + (self.rows,) + self.shape[self.axis + 1:]

    def piece(self, index: int) -> tuple[int, int, tuple, tuple[int, ...]]:
        """Chunk ``index``: flat start and stop, the index into the output
        arrays, and the shape of the values there."""
        if not self.shape:
            return 0, 1, (), ()
        outer, part = divmod(index, self._per_outer)
        first = part * self.rows
        last = min(first + self.rows, self.shape[self.axis])
        inner = math.prod(self.shape[self.axis + 1:])
        start = (outer * self.shape[self.axis] + first) * inner
        where = (tuple(int(k) for k in np.unravel_index(outer, self.shape[:self.axis]))
                 + (slice(first, last),))
        return start, start + (last - first) * inner, where, (last - first,) + self.shape[self.axis + 1:]


def run_digest(plan: runner.RunPlan | SweepRun) -> str:
    """Names the results a run produces: the scene, its sweep and the version
    that computes them. A partial file is resumed only with the same digest
    (``plan``: anything with the run's ``scene`` and ``sweep``)."""
    text = runner.scene_text(plan.scene, plan.sweep, stored=True)
    if plan.sweep.design is not None:  # and the values its recipe gives with this numpy and scipy
        text += f"\ndesign values {plan.sweep.design.fingerprint()}"
    digest = hashlib.sha256(f"rampwork {__version__}\npartial {PARTIAL_FORMAT}\n{text}".encode())
    if plan.sweep.design is None:  # the axes' values, bit for bit (the text may only refer to them)
        for name, values in plan.sweep.axes:
            digest.update(f"\naxis {name}\n".encode())
            digest.update(np.ascontiguousarray(values, dtype="<f8").tobytes())
    return digest.hexdigest()


class SweepToFile:
    """One sweep written to one file; every check is made on construction,
    before any work, and :meth:`run` does the work. See :func:`run_to_file`.
    The scene is a ramp's or a curve's (:mod:`rampwork.sweepruns`)."""

    def __init__(self, scene: Scene, sweep: Sweep | None, path: str | os.PathLike, *,
                 chunk_size: int | None = None, threads: int | None = None, resume: bool = False,
                 overwrite: bool = False, scheduler=None, compression_level: int = 4):
        self.plan = sweep_run(scene, sweep)  # a SweepRun: every check of the scene and sweep
        self.compression_level = io.check_compression_level(compression_level)
        if chunk_size is not None and (isinstance(chunk_size, bool)
                                       or not isinstance(chunk_size, (int, np.integer)) or chunk_size < 1):
            raise ConfigError("chunk_size", f"must be a positive integer, got {chunk_size!r}")
        self.scheduler = cluster.check_scheduler(scheduler, self.plan)
        if self.scheduler is not None and threads is not None:
            raise ConfigError("threads", "not used with a scheduler: each worker runs a chunk on "
                              "its own threads")
        self.threads = self.plan.thread_count(threads) if self.scheduler is None else None
        self.path = io.check_writable(path, overwrite, store=Path(path).suffix.lower() == io.ZARR_SUFFIX)
        self.overwrite = overwrite
        self.partial = partial_path(self.path)
        self.store = open_chunk_store(self.path, self.partial, self.compression_level)  # by the suffix
        self.digest = run_digest(self.plan)
        self.layout = ChunkLayout.for_shape(self.plan.layout().shape,
                                            self.plan.chunk_size if chunk_size is None else int(chunk_size))
        self.done = np.zeros(self.layout.count, dtype=bool)
        self.previous_run_seconds = 0.0
        self.resuming = False
        if self.partial.exists():
            if resume:
                self._read_partial(chunk_size)
            elif not overwrite:
                raise ConfigError(str(self.partial), f"holds an unfinished run of this output; pass "
                                  f"{option('resume')} to finish it, or {option('overwrite')} "
                                  "to start over")
        if self.layout.count > MAX_CHUNKS:
            raise ConfigError("chunk_size", f"{chunk_size!r} cuts {self.plan.size:,} trajectories into "
                              f"{self.layout.count:,} chunks, more than {MAX_CHUNKS:,}; use larger chunks")

    def _read_partial(self, chunk_size) -> None:
        where = str(self.partial)
        record = self.store.read_partial()
        digest, axis, rows = record.digest, record.axis, record.rows
        if digest != self.digest:
            raise ConfigError(where, "was started by a different scene, sweep or rampwork version (or, "
                              "for a design, a numpy or scipy that draws other values); refusing to "
                              f"resume: pass {option('overwrite')} to start over")
        layout = ChunkLayout(self.layout.shape, axis, rows)
        if chunk_size is not None and layout != self.layout:
            raise ConfigError("chunk_size", f"{chunk_size} differs from the partial run's chunks "
                              f"({rows} along dimension {axis}); leave it unset to resume")
        self.layout = layout
        self.done = fit_done(record.done, layout.count)
        self.previous_run_seconds = record.run_seconds
        self.resuming = True

    @property
    def total_chunks(self) -> int:
        return self.layout.count

    @property
    def done_chunks(self) -> int:
        return int(self.done.sum())

    def _done_trajectories(self) -> int:
        return sum(stop - start for start, stop, _, _ in map(self.layout.piece, np.flatnonzero(self.done)))

    # --------------------------------------------------------------------------
    def run(self, progress=None) -> Path:
        """Run the chunks not yet done, write each as it finishes, finalise and
        rename. ``progress(done, total)`` (trajectories) is called once before
        the first chunk and after each. On any exception, Ctrl-C included, the
        partial file keeps every finished chunk. Returns the output path."""
        info = {}
        try:
            pending = [int(i) for i in np.flatnonzero(~self.done)]
            run_chunks = self._threaded if self.scheduler is None else self._distributed
            chunks = run_chunks(pending, info)  # compiled, or connected, before the file is touched
            try:
                self.store.open() if self.resuming else self._create()
                self._write(chunks, info, progress)
            finally:
                self.store.close()
        finally:
            if "close" in info:
                info["close"]()
        self.store.commit(self.overwrite)
        return self.path

    def _write(self, chunks, info: dict, progress) -> None:
        started = time.perf_counter()
        done = self._done_trajectories()
        if progress is not None:
            progress(done, self.plan.size)
        for index, results in _one_ahead(chunks):
            start, stop, where, shape = self.layout.piece(index)
            if results is not None:  # else written where it was computed
                self.store.write(index, where, shape, results)
            self.done[index] = True
            self.store.mark_done(index, self.done, self.previous_run_seconds + time.perf_counter() - started)
            done += stop - start
            if progress is not None:
                progress(done, self.plan.size)
        self._finalise(self.previous_run_seconds + time.perf_counter() - started, info)

    def _create(self):
        layout = self.plan.layout()
        # zero-stride stand-ins: the variables' values come chunk by chunk
        placeholders = {name: (layout.dims, np.broadcast_to(np.zeros((), self.plan.output_dtype(name)),
                                                            layout.shape), attrs)
                        for name, attrs in layout.attrs.items()}
        # no index: a design's `case` stand-in would be materialised as one
        coords = xr.Coordinates(layout.coords, indexes={}) if layout.drawn else layout.coords
        skeleton = xr.Dataset(placeholders, coords=coords)
        # a design's coordinates come with each chunk's results, as its outputs do;
        # one chunk of the file per chunk of the run: concurrent writers never share one
        deferred = tuple(layout.attrs) + layout.drawn
        chunks = {name: self.layout.chunksizes for name in deferred} if layout.shape else {}
        attrs = self.plan.attributes(0.0, 0.0, self.threads or 0, 0, entry="rampwork.run_to_file")
        attrs.update({DIGEST_ATTR: self.digest, LAYOUT_ATTR: np.array([self.layout.axis, self.layout.rows]),
                      RUN_TIME_ATTR: 0.0})
        self.store.create(skeleton, deferred, chunks, attrs, self.done)

    def _finalise(self, run_seconds: float, info: dict) -> None:
        # chunk by chunk: memory stays bounded
        steps = self.store.steps(self.layout.piece(index)[2] for index in range(self.layout.count))
        attrs = self.plan.attributes(info["compile_time_s"], run_seconds, info["threads"], steps,
                                     entry="rampwork.run_to_file",
                                     kernel_source=info.get("kernel_source"),
                                     kernel_tier=info.get("kernel_tier"))
        traces = None
        if self.plan.records:
            traces, attrs["trace_time_s"] = info["traces"]()
        if "scheduler" in info:
            attrs["scheduler"] = info["scheduler"]
        self.store.finalise(attrs, traces)

    # --------------------------------------------------------------------------
    def _threaded(self, pending, info: dict):
        """The pending chunks' results, in order, computed here; fills ``info``."""
        prepared = self.plan.prepare()
        info.update({"compile_time_s": prepared.compile_seconds, "threads": self.threads,
                     "kernel_source": prepared.kernel_source, "kernel_tier": prepared.tier,
                     "traces": prepared.traces})

        def chunks():
            with runner.using_threads(self.threads):
                for index in pending:
                    start, stop, _, _ = self.layout.piece(index)
                    yield index, prepared.run_chunk(start, stop, self.threads)

        return chunks()

    def _distributed(self, pending, info: dict):
        """The pending chunks' results as they arrive from the cluster, one
        task per chunk; fills ``info``."""
        from distributed import as_completed

        client, started = cluster.connect(self.scheduler)
        # the stored scene, its long axes shipped as arrays beside it (not as text)
        text = cluster.Shipped(run_digest(self.plan),
                               runner.scene_text(self.plan.scene, self.plan.sweep, stored=True),
                               {} if self.plan.sweep.design is not None else dict(self.plan.sweep.axes))
        info.update({"compile_time_s": 0.0, "threads": sum(client.nthreads().values()),
                     "scheduler": str(client.scheduler.address)})
        if started is not None:  # a local cluster we started: ours to close
            info["close"] = lambda: (client.close(), started.close())

        def traces():
            return client.submit(cluster.traces_task, text, pure=False).result()

        info["traces"] = traces

        def chunks():
            shipped = client.scatter(text, broadcast=True)
            # a few tasks per worker thread queued: workers stay busy and
            # finished results wait for the client no longer than that
            window = 2 * max(1, info["threads"])
            todo = iter(pending)
            # a store the workers write to gets each chunk from the worker that computed it
            writer = self.store.worker_writer() if self.store.writes_on_workers else None

            def submit(index):
                start, stop, where, shape = self.layout.piece(index)
                if writer is not None:
                    return client.submit(cluster.chunk_store_task, shipped, index, start, stop, writer, where,
                                         shape, pure=False)
                return client.submit(cluster.chunk_task, shipped, index, start, stop, pure=False)

            running = as_completed([submit(i) for i in itertools.islice(todo, window)])
            for future in running:
                index, results, compile_seconds = future.result()
                future.release()
                info["compile_time_s"] = max(info["compile_time_s"], compile_seconds)
                following = next(todo, None)
                if following is not None:
                    running.add(submit(following))
                yield index, results

        return chunks()


def _one_ahead(items):
    """Iterate ``items`` in a background thread, one item ahead: the next
    chunk is computed while this one is compressed and written (the kernel
    and the netCDF library both release the GIL). On exit, Ctrl-C included,
    the background thread finishes the item it is computing and stops."""
    ready = queue.Queue(maxsize=1)
    stop = threading.Event()

    def put(item) -> bool:
        while not stop.is_set():
            try:
                ready.put(item, timeout=0.1)
                return True
            except queue.Full:
                pass
        return False

    def produce():
        try:
            for item in items:
                if not put((True, item)):
                    return
            put((False, None))
        except BaseException as error:  # noqa: BLE001 - handed to the consumer
            put((False, error))
        finally:
            items.close()

    worker = threading.Thread(target=produce, name="rampwork-chunks", daemon=True)
    worker.start()
    try:
        while True:
            more, item = ready.get()
            if not more:
                if item is not None:
                    raise item
                return
            yield item
    finally:
        stop.set()
        worker.join()


# ------------------------------------------------------------------------------
def run_to_file(scene: Scene, sweep: Sweep | None, path: str | os.PathLike, *,
                chunk_size: int | None = None, threads: int | None = None, resume: bool = False,
                overwrite: bool = False, progress=None, scheduler=None, compression_level: int = 4) -> Path:
    """Run ``scene`` over ``sweep`` and write the results to the netCDF file
    ``path`` chunk by chunk, in bounded memory; the file reads back
    (:func:`rampwork.open_dataset`) equal, value for value, to
    :func:`rampwork.simulate`'s dataset. A ``path`` ending in ``.zarr`` is
    written as a Zarr store instead (the same variables and attributes;
    ``xarray.open_zarr`` reads it), each chunk where it is computed, on a
    Dask worker too; netCDF suffixes are ``.nc`` (the default format),
    ``.nc4``, ``.netcdf`` and ``.cdf``, and any other is refused.

    ``scene``: a ramp scene or a curve scene
    (:class:`~rampwork.curve_scene.CurveScene`, whose chunks run in the
    curve kernel's SIMD lanes over the threads, or on Dask workers).
    ``chunk_size``: trajectories per chunk at most (default
    ``runner.CHUNK_SIZE``, ``curve_chunks.CURVE_CHUNK_SIZE`` for a curve
    scene); a grid's chunk is a block of its arrays, whole
    along every dimension after the one it cuts, so it holds a multiple of
    those dimensions' size (``SweepToFile(...).layout.describe`` says how
    many); each finished chunk is on disk in ``.NAME.partial`` beside ``path`` until
    the run completes and the file is renamed to ``path``.
    ``resume``: finish the unfinished run in that partial file, running only
    the chunks it lacks; refused if it was started by another scene or sweep.
    ``overwrite``: replace ``path`` if it exists, and start over from an
    unfinished run left there.
    ``progress``: optional ``progress(done, total)``, in trajectories.
    ``scheduler``: run the chunks on a Dask cluster, one task per chunk: a
    scheduler address, ``"local"`` (start a local cluster, one worker per
    core) or a ``distributed.Client``; ``threads`` is then the workers'.
    ``compression_level``: zlib level 0..9 as in :func:`rampwork.write_netcdf`
    (Blosc-zstd's for Zarr; 0: none; compressing costs about as much as a
    cheap trajectory, see benchmarks/scaling.py; a resumed run keeps its file's).
    Returns ``path``.
    """
    job = SweepToFile(scene, sweep, path, chunk_size=chunk_size, threads=threads, resume=resume,
                      overwrite=overwrite, scheduler=scheduler, compression_level=compression_level)
    return job.run(progress)
