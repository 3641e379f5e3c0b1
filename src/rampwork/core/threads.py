"""Work items spread over worker threads.

The jitted kernels release the GIL (``nogil``), so plain Python threads run
them side by side.  Why not numba's ``prange``: a parallel function goes
through numba's parfor pipeline, whose gufunc and its two wrappers link,
optimise and emit the whole kernel's code three more times: about 1.2 s of
LLVM per kernel variant, a sixth of a cold compile (measured on 2 cores),
where a thread pool costs a few microseconds per work item.

Items are handed out one at a time (dynamic scheduling): a tile whose
trajectories stick at once and one whose trajectories run to t_max take very
different times.  The calling thread works too, so one thread needs no pool.
"""

from __future__ import annotations

import concurrent.futures
import contextlib
import itertools
import threading

import numba

_pool: concurrent.futures.ThreadPoolExecutor | None = None
_pool_lock = threading.Lock()
_threads: int | None = None  # set by using_threads; None: every thread allowed


def max_threads() -> int:
    """The most threads a run may use (numba's NUMBA_NUM_THREADS: the CPUs
    unless the environment says otherwise)."""
    return numba.config.NUMBA_NUM_THREADS


def current_threads() -> int:
    return _threads if _threads is not None else max_threads()


@contextlib.contextmanager
def using_threads(threads: int):
    """Run work items on ``threads`` threads inside the block (restored after)."""
    global _threads
    previous = _threads
    _threads = int(threads)
    try:
        yield
    finally:
        _threads = previous


def _worker_pool() -> concurrent.futures.ThreadPoolExecutor:
    global _pool
    with _pool_lock:
        if _pool is None:
            _pool = concurrent.futures.ThreadPoolExecutor(
                max_workers=max(max_threads() - 1, 1), thread_name_prefix="rampwork")
        return _pool


def run_items(function, n_items: int, *args) -> None:
    """``function(first, stop, *args)`` for work items 0 .. n_items - 1, one
    item per call, spread over :func:`current_threads` threads.  An exception
    in any thread (or Ctrl-C in the caller) stops handing out items and is
    raised here once the items under way are done."""
    threads = min(current_threads(), n_items)
    if threads <= 1:
        function(0, n_items, *args)
        return
    items = itertools.count()  # next() is atomic under the GIL
    stop = threading.Event()

    def work():
        for item in items:
            if item >= n_items or stop.is_set():
                return
            function(item, item + 1, *args)

    helpers = [_worker_pool().submit(work) for _ in range(threads - 1)]
    try:
        work()
        for helper in helpers:
            helper.result()
    except BaseException:
        stop.set()
        concurrent.futures.wait(helpers)
        raise


class TiledKernel:
    """``run_batch(inputs, settings, outputs, shared, tile_size)``: a batch's
    tiles of ``tile_size`` trajectories spread over threads, each run by the
    jitted ``run_tiles(first_tile, stop_tile, tile_size, inputs, settings,
    outputs, shared)``."""

    def __init__(self, run_tiles):
        self.run_tiles = run_tiles

    def __call__(self, inputs, settings, outputs, shared, tile_size):
        n_tiles = -(-inputs.shape[1] // tile_size)
        run_items(self.run_tiles, n_tiles, tile_size, inputs, settings, outputs, shared)

    @property
    def _cache(self):
        """numba's cache of the jitted function (see ``jit.disk_cached``)."""
        return self.run_tiles._cache

    @property
    def stats(self):
        """The jitted function's cache statistics (numba's ``stats``)."""
        return self.run_tiles.stats
