"""Zarr stores (rampwork.run_to_file(..., "out.zarr"), `rampwork run -o out.zarr`,
rampwork.write_zarr): the same variables, attributes and values as the netCDF
file; each chunk written where it is computed, Dask workers included; a run
interrupted, or a writer killed part-way through a chunk, resumes (or is rerun)
to the same store, and no chunk is marked done before its data are written."""

import os
import signal
import subprocess
import sys

import numpy as np
import pytest
import xarray as xr

import rampwork as rw
from rampwork import io, runner, zarrstore
from rampwork.streaming import ChunkLayout, SweepToFile, partial_path
from test_streaming import GRID, _scene, _stop_after, assert_same_data, assert_same_file

zarr = pytest.importorskip("zarr")
pytest.importorskip("dask.array")

RANDOM = rw.Sweep.random(101, seed=3, x0=(-0.9, 0.9), mu=(0.0, 0.3))


def _store_listing(path):
    return sorted(os.path.relpath(os.path.join(folder, name), path)
                  for folder, _, files in os.walk(path) for name in files)


def _done_record(partial):
    return np.asarray(zarr.open_array(str(partial / zarrstore.DONE_ARRAY), mode="r")[:]) >= 0


# ------------------------------------------------------------------------------
# the store holds what the netCDF file holds
# ------------------------------------------------------------------------------
@pytest.mark.parametrize("sweep, chunk_size", [(GRID, 7), (GRID, 2), (RANDOM, 16), (rw.Sweep.single(), None)])
def test_store_equals_the_netcdf_file_bit_for_bit(tmp_path, sweep, chunk_size):
    scene = _scene(record=rw.Record(count=3, every=50))
    netcdf = rw.open_dataset(rw.run_to_file(scene, sweep, tmp_path / "out.nc", chunk_size=chunk_size))
    path = rw.run_to_file(scene, sweep, tmp_path / "out.zarr", chunk_size=chunk_size)
    assert path == tmp_path / "out.zarr" and path.is_dir()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.nc", "out.zarr"]  # no partial left
    store = rw.open_dataset(path)
    assert_same_file(netcdf, store)  # variables, dims, dtypes, values, attributes
    assert store.attrs["trajectory_steps"] == netcdf.attrs["trajectory_steps"]
    assert store.attrs["history"].endswith(netcdf.attrs["history"].split(": ", 1)[1])
    assert zarrstore.DONE_ARRAY not in store.variables and not any(
        key.startswith("rampwork_partial") or key == "rampwork_chunks_done" for key in store.attrs)
    assert not any(".partial" in name for name in _store_listing(path))  # no temporary objects

    lazily = xr.open_zarr(path)  # plain xarray, consolidated metadata
    assert lazily.attrs["rampwork_scene"] == netcdf.attrs["rampwork_scene"]
    assert lazily.attrs["source"].startswith("rampwork ")
    assert lazily["status"].attrs["flag_meanings"] == netcdf["status"].attrs["flag_meanings"]
    assert list(lazily["status"].attrs["flag_values"]) == list(netcdf["status"].attrs["flag_values"])
    assert lazily["W_excess"].attrs["units"] == "J"
    assert np.isnan(lazily["t_end"].encoding["_FillValue"])  # floats: NaN is missing
    assert "_FillValue" not in lazily["steps"].encoding or lazily["steps"].encoding["_FillValue"] is None
    if sweep.axes:
        # one Zarr chunk per chunk of the run: concurrent writers never share one
        layout = ChunkLayout.for_shape(runner.dataset_layout(runner.plan_run(scene, sweep)).shape,
                                       chunk_size)
        assert lazily["t_end"].encoding["chunks"] == layout.chunksizes
        assert zarr.open_array(str(path / "status"), mode="r").chunks == layout.chunksizes


def test_write_zarr_mirrors_write_netcdf(tmp_path):
    scene = _scene(record=rw.Record(count=2, every=40))
    dataset = rw.simulate(scene, GRID)
    rw.write_netcdf(dataset, tmp_path / "a.nc")
    assert rw.write_zarr(dataset, tmp_path / "a.zarr") == tmp_path / "a.zarr"
    assert_same_file(rw.open_dataset(tmp_path / "a.nc"), rw.open_dataset(tmp_path / "a.zarr"))
    assert_same_data(dataset, xr.open_zarr(tmp_path / "a.zarr").load())

    # replaced only when asked, and never a directory that is not a Zarr store
    with pytest.raises(rw.ConfigError, match="exists; pass overwrite=True"):
        rw.write_zarr(dataset, tmp_path / "a.zarr")
    other = rw.simulate(scene, rw.Sweep.grid(mu=[0.1, 0.2]))
    rw.write_zarr(other, tmp_path / "a.zarr", overwrite=True, compression_level=0)
    assert_same_data(other, rw.open_dataset(tmp_path / "a.zarr"))
    precious = tmp_path / "precious.zarr"
    precious.mkdir()
    (precious / "notes.txt").write_text("mine")
    with pytest.raises(rw.ConfigError, match="not a Zarr store; refusing to replace it"):
        rw.write_zarr(dataset, precious, overwrite=True)
    assert (precious / "notes.txt").read_text() == "mine"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.nc", "a.zarr", "precious.zarr"]


@pytest.mark.parametrize("name", ["out.txt", "out", "out.zarr.tmp", "out.h5"])
def test_an_unknown_suffix_is_refused_before_any_work(tmp_path, name, monkeypatch):
    monkeypatch.setattr(runner, "prepare", lambda *a, **k: pytest.fail("work started"))
    with pytest.raises(rw.ConfigError) as error:
        rw.run_to_file(_scene(), GRID, tmp_path / name)
    assert error.value.where == str(tmp_path / name)
    assert ".nc" in error.value.problem and ".zarr" in error.value.problem and "\n" not in str(error.value)
    assert list(tmp_path.iterdir()) == []
    assert io.output_format(tmp_path / "x.NC") == "netcdf" and io.output_format("y.Zarr") == "zarr"


def test_cli_refuses_an_unknown_suffix_and_missing_zarr_with_one_line(tmp_path, capsys, monkeypatch):
    from rampwork.cli import example_text, main

    scene = tmp_path / "straight.toml"
    scene.write_text(example_text("straight"), encoding="utf-8")
    monkeypatch.setattr(runner, "prepare", lambda *a, **k: pytest.fail("work started"))
    assert main(["run", str(scene), "-o", str(tmp_path / "out.csv")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"rampwork: error: {tmp_path / 'out.csv'}: suffix '.csv'") and "\n" not in err
    assert ".zarr" in err and ".nc" in err
    monkeypatch.setitem(sys.modules, "zarr", None)  # as if zarr were not installed
    assert main(["run", str(scene), "-o", str(tmp_path / "out.zarr")]) == 2
    err = capsys.readouterr().err.strip()
    assert "pip install 'rampwork[zarr]'" in err and "\n" not in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["straight.toml"]


# ------------------------------------------------------------------------------
# interruption and resume
# ------------------------------------------------------------------------------
def test_an_interrupted_store_resumes_bit_for_bit(tmp_path, monkeypatch):
    scene = _scene()
    path = tmp_path / "out.zarr"
    with pytest.raises(KeyboardInterrupt):
        rw.run_to_file(scene, GRID, path, chunk_size=7, progress=_stop_after(3))
    partial = partial_path(path)
    assert not path.exists() and partial.is_dir()
    assert np.flatnonzero(_done_record(partial)).tolist() == [0, 1, 2]
    job = SweepToFile(scene, GRID, path, resume=True)
    assert job.resuming and job.done_chunks == 3 and job.total_chunks == 20

    ran = []
    run_chunk = runner.run_chunk
    monkeypatch.setattr(runner, "run_chunk", lambda prepared, start, stop, *a, **k:
                        ran.append(start) or run_chunk(prepared, start, stop, *a, **k))
    job.run()
    assert len(ran) == 17 and 0 not in ran  # the three chunks marked done were not run again
    assert not partial.exists()
    whole = rw.run_to_file(scene, GRID, tmp_path / "whole.nc", chunk_size=7)
    assert_same_file(rw.open_dataset(whole), rw.open_dataset(path))

    # a resume of another sweep is refused, and an unfinished run is not silently lost
    with pytest.raises(KeyboardInterrupt):
        rw.run_to_file(scene, GRID, tmp_path / "again.zarr", chunk_size=7, progress=_stop_after(1))
    with pytest.raises(rw.ConfigError, match="holds an unfinished run"):
        rw.run_to_file(scene, GRID, tmp_path / "again.zarr")
    with pytest.raises(rw.ConfigError, match="different scene, sweep or rampwork version"):
        rw.run_to_file(_scene(t_max=6.0), GRID, tmp_path / "again.zarr", resume=True)


KILL_SCENE = """\
title = "quadratic bowl"
t_max = 5.0
[ramp]
family = "quadratic"
curvature = 1.0
domain = [-1.0, 1.0]
[friction]
mu_k = 0.1
mu_s = 0.2
[sweep]
kind = "grid"
[sweep.axes]
mu = [0.05, 0.1, 0.2, 0.3]
x0 = { linspace = [-0.9, 0.2, 8] }
"""


def _rampwork(*args):
    return [sys.executable, "-m", "rampwork", *map(str, args)]


def test_a_writer_killed_inside_a_chunk_leaves_it_unmarked_and_resume_completes(tmp_path):
    """SIGKILL after the first variable of chunk 5 is written: chunks 0..4
    are marked done and hold their values, chunk 5 is written in part and
    not marked; the resumed store equals an uninterrupted one."""
    from rampwork.scenefile import parse_scene

    scene_path = tmp_path / "bowl.toml"
    scene_path.write_text(KILL_SCENE, encoding="utf-8")
    path = tmp_path / "out.zarr"
    sentinel = tmp_path / "killed"
    env = dict(os.environ, **{zarrstore.KILL_ENV: f"5:{sentinel}"})
    run = subprocess.run(_rampwork("run", scene_path, "-o", path, "-q", "--chunk-size", 4),
                         capture_output=True, text=True, timeout=600, env=env)
    assert run.returncode == -signal.SIGKILL, run.stderr
    assert sentinel.exists() and not path.exists()
    partial = partial_path(path)
    done = _done_record(partial)
    assert np.flatnonzero(done).tolist() == [0, 1, 2, 3, 4]  # 8 chunks of 4 x0, in order

    scene, sweep = parse_scene(KILL_SCENE)
    reference = rw.open_dataset(rw.run_to_file(scene, sweep, tmp_path / "whole.nc", chunk_size=4))
    layout = ChunkLayout.for_shape(reference["status"].shape, 4)
    written = {name: zarr.open_array(str(partial / name), mode="r") for name in ("status", "t_end")}
    for index in range(layout.count):
        _, _, where, _ = layout.piece(index)
        if done[index]:  # a chunk marked done holds all its values
            for name, array in written.items():
                assert np.array_equal(array[where], reference[name].values[where], equal_nan=True)
    _, _, where, _ = layout.piece(5)
    assert np.array_equal(written["status"][where], reference["status"].values[where])  # written...
    assert np.isnan(written["t_end"][where]).all()  # ...in part: killed before the second variable

    resumed = subprocess.run(_rampwork("run", scene_path, "-o", path, "--resume"),
                             capture_output=True, text=True, timeout=600)
    assert resumed.returncode == 0, resumed.stderr
    assert "resuming     5 of 8 chunks done" in resumed.stdout
    assert not partial.exists()
    assert_same_file(reference, rw.open_dataset(path))
    assert not any(".partial" in name for name in _store_listing(path))

    info = subprocess.run(_rampwork("info", path, "--no-scene"), capture_output=True, text=True, timeout=120)
    assert info.returncode == 0, info.stderr
    status = next(line for line in info.stdout.splitlines() if line.startswith("status"))
    assert sum(int(count.rstrip(",")) for count in status.split()[2::2]) == 32  # "status  stuck 20, exited 12"
    assert "W_excess" in info.stdout and str(path) in info.stdout


# ------------------------------------------------------------------------------
# Dask: each worker writes the chunks it computes
# ------------------------------------------------------------------------------
def test_dask_workers_write_their_chunks_themselves(tmp_path, monkeypatch):
    distributed = pytest.importorskip("distributed")
    scene = _scene(record=rw.Record(count=2, every=40))
    threaded = rw.run_to_file(scene, GRID, tmp_path / "threads.nc", chunk_size=7)
    # nothing reaches the client's writer: the workers write
    monkeypatch.setattr(zarrstore.ZarrChunkStore, "write",
                        lambda *a, **k: pytest.fail("a chunk was written by the client"))
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        seen = []
        path = rw.run_to_file(scene, GRID, tmp_path / "dask.zarr", chunk_size=7, scheduler=client,
                              progress=lambda done, total: seen.append(done))
    on_dask = rw.open_dataset(path)
    assert_same_file(rw.open_dataset(threaded), on_dask)
    assert on_dask.attrs["scheduler"].startswith("inproc://")
    assert seen[0] == 0 and seen[-1] == GRID.size and len(seen) == 1 + 20


def _process_cluster(distributed):
    return distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                    dashboard_address=None)


@pytest.mark.slow
def test_two_worker_processes_write_the_same_store_as_threads(tmp_path):
    distributed = pytest.importorskip("distributed")
    scene = _scene(record=rw.Record(count=2, every=40))
    threaded = rw.open_dataset(rw.run_to_file(scene, GRID, tmp_path / "threads.nc", chunk_size=7))
    with _process_cluster(distributed) as cluster, distributed.Client(cluster) as client:
        path = rw.run_to_file(scene, GRID, tmp_path / "dask.zarr", chunk_size=7, scheduler=client)
    on_dask = rw.open_dataset(path)
    assert_same_file(threaded, on_dask)
    assert on_dask.attrs["scheduler"].startswith("tcp://127.0.0.1")


@pytest.mark.slow
def test_a_worker_killed_while_writing_its_chunk_is_rerun_to_the_same_store(tmp_path, monkeypatch):
    """A worker process SIGKILLs itself inside chunk 3, after its first
    variable: Dask reruns the task on a worker that lives, and the store
    equals the threaded run's netCDF file."""
    distributed = pytest.importorskip("distributed")
    scene = _scene()
    threaded = rw.open_dataset(rw.run_to_file(scene, GRID, tmp_path / "threads.nc", chunk_size=7))
    sentinel = tmp_path / "killed"
    monkeypatch.setenv(zarrstore.KILL_ENV, f"3:{sentinel}")  # the worker processes inherit it
    with _process_cluster(distributed) as cluster, distributed.Client(cluster) as client:
        pids = set(client.run(os.getpid).values())
        path = rw.run_to_file(scene, GRID, tmp_path / "dask.zarr", chunk_size=7, scheduler=client)
        assert pids - set(client.run(os.getpid).values())  # a worker process died (and was restarted)
    assert sentinel.exists()
    assert_same_file(threaded, rw.open_dataset(path))
    assert not any(".partial" in name for name in _store_listing(path))
