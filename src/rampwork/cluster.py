"""Sweeps on a Dask cluster: the ``scheduler`` argument of
:func:`rampwork.run_to_file`, and the tasks the workers run (each rebuilds
the run from the scene's stored text, prepares it once, and computes, or
computes and writes, one chunk per task)."""

from __future__ import annotations

import os
import threading
from dataclasses import dataclass

from . import runner
from .errors import ConfigError
from .sweepruns import PreparedSweep, SweepRun, sweep_run


def check_scheduler(scheduler, plan: SweepRun):
    if scheduler is None:
        return None
    try:
        from distributed import Client
    except ImportError:
        raise ConfigError("scheduler", "needs dask.distributed: pip install 'rampwork[cluster]'") from None
    if not isinstance(scheduler, (str, Client)) or (isinstance(scheduler, str) and not scheduler.strip()):
        raise ConfigError("scheduler", f"expected 'local', a scheduler address such as "
                          f"tcp://host:8786, or a distributed.Client; got {scheduler!r}")
    plan.check_shippable()
    return scheduler


def connect(scheduler):
    """(client, cluster): the cluster is ours to close when we started it."""
    from distributed import Client, LocalCluster

    if isinstance(scheduler, Client):
        return scheduler, None
    if scheduler == "local":
        cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1
        cluster = LocalCluster(n_workers=cores, threads_per_worker=1, processes=True,
                               dashboard_address=None)
        return Client(cluster), cluster
    try:
        return Client(scheduler, timeout="10s"), None
    except (OSError, TimeoutError, ValueError) as error:
        raise ConfigError("scheduler", f"cannot connect to {scheduler!r}: "
                          f"{' '.join(str(error).split())}") from None


@dataclass(frozen=True, eq=False)
class Shipped:
    """What a worker rebuilds a run from: the stored scene text, the sweep's
    axes as arrays (which the text may only refer to) and the run's digest."""

    digest: str
    text: str
    coordinates: dict


#: on a worker: prepared runs by their digest, and one kernel call at a
#: time (a worker's threads share the kernels' thread pool)
_WORKER_RUNS: dict[str, PreparedSweep] = {}
_WORKER_LOCK = threading.Lock()


def _worker_prepared(shipped: Shipped) -> tuple[PreparedSweep, float]:
    from .scenefile import parse_scene

    key = shipped.digest
    if key in _WORKER_RUNS:
        return _WORKER_RUNS[key], 0.0
    scene, sweep = parse_scene(shipped.text, "scene shipped to a worker", shipped.coordinates)
    prepared = sweep_run(scene, sweep).prepare("specialised")  # as the file says
    _WORKER_RUNS[key] = prepared
    return prepared, prepared.compile_seconds


def _worker_threads() -> int:
    import numba
    from distributed import get_worker

    worker = get_worker()
    threads = getattr(getattr(worker, "state", None), "nthreads", None) or getattr(worker, "nthreads", 1)
    return max(1, min(int(threads), numba.config.NUMBA_NUM_THREADS))


def chunk_task(text: Shipped, index: int, start: int, stop: int):
    with _WORKER_LOCK:
        prepared, compile_seconds = _worker_prepared(text)
        threads = _worker_threads()
        with runner.using_threads(threads):
            return index, prepared.run_chunk(start, stop, threads), compile_seconds


def chunk_store_task(text: Shipped, index: int, start: int, stop: int, writer, where, shape):
    """A chunk computed and written on the worker: only its index goes back."""
    index, results, compile_seconds = chunk_task(text, index, start, stop)
    writer.write(index, where, shape, results)
    return index, None, compile_seconds


def traces_task(text: Shipped):
    with _WORKER_LOCK:
        prepared, _ = _worker_prepared(text)
        return prepared.traces()
