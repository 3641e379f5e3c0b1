"""Sweeps written chunk by chunk (rampwork.run_to_file, `rampwork run`): the
file equals simulate()'s dataset bit for bit, a killed run resumes to the same
file, memory stays bounded, and a Dask cluster gives the same results."""

import os
import re
import signal
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest

import rampwork as rw
from rampwork import runner, schema, streaming
from rampwork.streaming import ChunkLayout, partial_path

# the test reads a partial file while another process writes it
os.environ.setdefault("HDF5_USE_FILE_LOCKING", "FALSE")

#: global attributes that differ between two runs of the same sweep
#: attributes of how a run went (its kernel's tier and source too), not of its data
RUN_ATTRS = {"history", "compile_time_s", "run_time_s", "trace_time_s", "threads", "scheduler",
             "kernel_source", "kernel_tier"}


def _scene(**changes):
    scene = rw.Scene(ramp=rw.Ramp.create("quadratic", curvature=1.0, domain=(-1.0, 1.0)),
                     friction=rw.Friction(0.1, 0.2), x0=-0.9, t_max=5.0)
    return scene.replace(**changes)


GRID = rw.Sweep.grid(mu=np.linspace(0.05, 0.4, 5), v0=np.linspace(-1.0, 1.5, 7), x0=[-0.9, -0.5, 0.2])


def assert_same_data(expected, actual):
    """Every variable and coordinate equal bit for bit, with the same dims
    and attributes."""
    assert set(actual.variables) == set(expected.variables)
    assert set(actual.coords) == set(expected.coords)
    for name in expected.variables:
        want, got = expected[name], actual[name]
        assert got.dims == want.dims, name
        assert got.dtype == want.dtype, name
        assert np.array_equal(got.values, want.values, equal_nan=True), name
        assert set(got.attrs) == set(want.attrs), name
        for key, value in want.attrs.items():
            assert np.array_equal(np.asarray(got.attrs[key]), np.asarray(value)), (name, key)


def assert_same_file(expected, actual):
    assert_same_data(expected, actual)
    keys = set(expected.attrs) - RUN_ATTRS
    assert keys == set(actual.attrs) - RUN_ATTRS
    for key in keys:
        assert np.array_equal(np.asarray(actual.attrs[key]), np.asarray(expected.attrs[key])), key


def _stop_after(chunks):
    """A progress callback that interrupts the run after ``chunks`` chunks."""
    calls = []

    def progress(done, total):
        calls.append(done)
        if len(calls) > chunks:  # the first call comes before any chunk
            raise KeyboardInterrupt

    return progress


# ------------------------------------------------------------------------------
# the file equals the in-memory dataset
# ------------------------------------------------------------------------------
@pytest.mark.parametrize("sweep, chunk_size", [
    (GRID, None),   # one chunk
    (GRID, 7),      # two v0 rows (of 3 x0) at a time
    (GRID, 2),      # smaller than a row: cut along x0
    (GRID, 40),     # several mu rows at a time, a short last chunk
    (rw.Sweep.random(101, seed=3, x0=(-0.9, 0.9), mu=(0.0, 0.3)), 16),
    (rw.Sweep.single(), 5),
])
def test_file_equals_simulate_bit_for_bit(tmp_path, sweep, chunk_size):
    scene = _scene(record=rw.Record(count=3, every=50))
    expected = rw.simulate(scene, sweep)
    path = rw.run_to_file(scene, sweep, tmp_path / "out.nc", chunk_size=chunk_size)
    actual = rw.open_dataset(path)
    assert_same_file(expected, actual)
    assert actual.attrs["trajectory_steps"] == expected.attrs["trajectory_steps"]
    assert not partial_path(path).exists()
    assert [p.name for p in tmp_path.iterdir()] == ["out.nc"]  # no temporary files left


@pytest.mark.parametrize("shape", [(), (7,), (5, 3), (4, 6, 5), (3, 1000), (2, 1, 3)])
@pytest.mark.parametrize("target", [1, 4, 7, 13, 1000, 10**6])
def test_chunks_are_contiguous_hyperslabs_covering_each_trajectory_once(shape, target):
    layout = ChunkLayout.for_shape(shape, target)
    flat = np.arange(int(np.prod(shape))).reshape(shape)
    covered = []
    for index in range(layout.count):
        start, stop, where, piece_shape = layout.piece(index)
        assert np.array_equal(flat[where].ravel(), np.arange(start, stop))
        assert flat[where].shape == piece_shape
        inner = int(np.prod(shape[layout.axis + 1:])) if shape else 1
        assert stop - start <= max(target, inner)
        covered.extend(range(start, stop))
    assert covered == list(range(flat.size))  # in order, each once
    if shape:
        assert all(c <= s for c, s in zip(layout.chunksizes, shape))


# ------------------------------------------------------------------------------
# interruption and resume
# ------------------------------------------------------------------------------
def test_interrupted_run_resumes_without_recomputing(tmp_path, monkeypatch):
    scene = _scene()
    path = tmp_path / "out.nc"
    with pytest.raises(KeyboardInterrupt):
        rw.run_to_file(scene, GRID, path, chunk_size=7, progress=_stop_after(3))
    assert not path.exists()
    partial = partial_path(path)
    job = streaming.SweepToFile(scene, GRID, path, resume=True)
    assert job.resuming and job.done_chunks == 3 and job.total_chunks == 20  # 5 mu x 4 pieces of v0

    ran = []
    run_chunk = runner.run_chunk
    monkeypatch.setattr(runner, "run_chunk", lambda prepared, start, stop, *a, **k:
                        ran.append(start) or run_chunk(prepared, start, stop, *a, **k))
    job.run()
    assert len(ran) == 17 and 0 not in ran  # the three finished chunks were not run again
    assert not partial.exists()
    assert_same_data(rw.simulate(scene, GRID), rw.open_dataset(path))


def test_resume_refuses_another_scene_or_sweep_or_chunking(tmp_path):
    scene = _scene()
    path = tmp_path / "out.nc"
    with pytest.raises(KeyboardInterrupt):
        rw.run_to_file(scene, GRID, path, chunk_size=7, progress=_stop_after(1))
    partial = partial_path(path)
    before = partial.read_bytes()
    other_sweep = rw.Sweep.grid(mu=np.linspace(0.05, 0.4, 5), v0=np.linspace(-1.0, 1.5, 7), x0=[-0.9, -0.5, 0.3])
    for other_scene, sweep in ((scene, other_sweep), (_scene(t_max=6.0), GRID),
                               (_scene(integrator=rw.Integrator("rk4", dt=2e-3)), GRID)):
        with pytest.raises(rw.ConfigError, match="different scene, sweep or rampwork version") as error:
            rw.run_to_file(other_scene, sweep, path, resume=True)
        assert str(partial) in str(error.value) and "\n" not in str(error.value)
    with pytest.raises(rw.ConfigError, match="chunk_size: 9 differs"):  # 3 v0 rows, not 2
        rw.run_to_file(scene, GRID, path, resume=True, chunk_size=9)
    assert partial.read_bytes() == before and not path.exists()  # nothing touched


def test_a_damaged_partial_file_is_refused_with_one_line(tmp_path):
    path = tmp_path / "out.nc"
    partial_path(path).write_bytes(b"not netCDF")
    with pytest.raises(rw.ConfigError, match="cannot be resumed") as error:
        rw.run_to_file(_scene(), GRID, path, resume=True)
    assert "\n" not in str(error.value)


def test_overwrite_rules(tmp_path):
    scene = _scene()
    sweep = rw.Sweep.grid(mu=[0.1, 0.2, 0.3])
    path = tmp_path / "out.nc"
    partial = partial_path(path)
    path.write_bytes(b"old")
    # an existing file is refused before any work, and left alone
    with pytest.raises(rw.ConfigError, match="exists; pass overwrite=True"):
        rw.run_to_file(scene, sweep, path)
    with pytest.raises(rw.ConfigError, match="exists; pass overwrite=True"):
        rw.run_to_file(scene, sweep, path, resume=True)
    assert path.read_bytes() == b"old" and not partial.exists()

    # an interrupted overwrite leaves the old file in place until the new one is complete
    with pytest.raises(KeyboardInterrupt):
        rw.run_to_file(scene, sweep, path, overwrite=True, chunk_size=1, progress=_stop_after(1))
    assert path.read_bytes() == b"old" and partial.exists()
    # an unfinished run is neither lost nor silently continued
    path.unlink()
    with pytest.raises(rw.ConfigError, match="holds an unfinished run") as error:
        rw.run_to_file(scene, sweep, path)
    # the API's words (the command line says --resume, --overwrite: test_findings.py)
    assert "resume=True" in str(error.value) and "overwrite=True" in str(error.value)
    # overwrite starts over (a different sweep is fine then)
    other = rw.Sweep.grid(mu=[0.15, 0.25])
    rw.run_to_file(scene, other, path, overwrite=True, chunk_size=1)
    assert_same_data(rw.simulate(scene, other), rw.open_dataset(path))
    assert not partial.exists()

    # resume without a partial file is an ordinary run
    fresh = tmp_path / "fresh.nc"
    rw.run_to_file(scene, sweep, fresh, resume=True)
    assert_same_data(rw.simulate(scene, sweep), rw.open_dataset(fresh))


@pytest.mark.parametrize("kwargs, where", [
    ({"chunk_size": 0}, "chunk_size"),
    ({"chunk_size": 2.5}, "chunk_size"),
    ({"chunk_size": True}, "chunk_size"),
    ({"threads": 0}, "threads"),
    ({"compression_level": 10}, "compression_level"),
    ({"scheduler": 17}, "scheduler"),
    ({"scheduler": "local", "threads": 1}, "threads"),
])
def test_bad_arguments_are_refused_before_any_work(tmp_path, kwargs, where):
    if "scheduler" in kwargs:
        pytest.importorskip("distributed")
    with pytest.raises(rw.ConfigError) as error:
        rw.run_to_file(_scene(), GRID, tmp_path / "out.nc", **kwargs)
    assert error.value.where == where and "\n" not in str(error.value)
    assert list(tmp_path.iterdir()) == []


# ------------------------------------------------------------------------------
# a real process killed part-way, resumed from the command line
# ------------------------------------------------------------------------------
KILL_SCENE = """\
title = "Block in a circular bowl, many starts"
t_max = 30.0
[ramp]
family = "circular_bowl"
radius = 1.0
domain = [-0.95, 0.95]
[friction]
mu_k = 0.05
mu_s = 0.15
[sweep]
kind = "grid"
[sweep.axes]
x0 = { linspace = [-0.85, -0.3, 16000] }
"""


def _chunks_done(partial):
    import netCDF4

    with netCDF4.Dataset(partial, "r") as nc:
        return int(np.unpackbits(np.atleast_1d(nc.getncattr(streaming.DONE_ATTR))).sum())


def _chunks_done_yet(partial):
    try:
        return _chunks_done(partial)
    except (OSError, AttributeError, RuntimeError):  # not there yet, or being written
        return 0


def _rampwork(*args):
    return [sys.executable, "-m", "rampwork", *map(str, args)]


def test_a_killed_run_resumes_to_an_identical_file(tmp_path):
    scene_path = tmp_path / "bowl.toml"
    scene_path.write_text(KILL_SCENE, encoding="utf-8")
    path = tmp_path / "out.nc"
    partial = partial_path(path)
    process = subprocess.Popen(_rampwork("run", scene_path, "-o", path, "-q", "--chunk-size", 400),
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    try:
        deadline = time.monotonic() + 600  # a cold numba cache on a busy machine compiles slowly
        while _chunks_done_yet(partial) < 2 and process.poll() is None and time.monotonic() < deadline:
            time.sleep(0.05)
        assert process.poll() is None, f"the run ended before it could be killed: {process.communicate()}"
        assert time.monotonic() < deadline, "no two chunks finished in time"
        process.send_signal(signal.SIGKILL)
    finally:
        process.kill()
        process.wait()
    assert process.returncode == -signal.SIGKILL
    assert not path.exists()
    done = _chunks_done(partial)
    assert 2 <= done < 40

    resumed = subprocess.run(_rampwork("run", scene_path, "-o", path, "--resume"),
                             capture_output=True, text=True, timeout=300)
    assert resumed.returncode == 0, resumed.stderr
    line = next(line for line in resumed.stdout.splitlines() if line.startswith("resuming"))
    assert int(line.split()[1]) >= done and line.split()[3] == "40"
    assert not partial.exists()

    from rampwork.scenefile import parse_scene

    scene, sweep = parse_scene(KILL_SCENE)
    whole = rw.run_to_file(scene, sweep, tmp_path / "whole.nc", chunk_size=400)
    assert_same_file(rw.open_dataset(whole), rw.open_dataset(path))


def test_sigterm_keeps_the_finished_chunks_and_says_how_to_resume(tmp_path):
    """SIGTERM, which batch schedulers send, is handled like Ctrl-C: the
    finished chunks stay in the partial file, the resume hint is printed, and
    the exit status is the shell's for SIGTERM (143)."""
    scene_path = tmp_path / "bowl.toml"
    scene_path.write_text(KILL_SCENE, encoding="utf-8")
    path = tmp_path / "out.nc"
    partial = partial_path(path)
    process = subprocess.Popen(_rampwork("run", scene_path, "-o", path, "-q", "--chunk-size", 400),
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 600
        while _chunks_done_yet(partial) < 2 and process.poll() is None and time.monotonic() < deadline:
            time.sleep(0.05)
        assert process.poll() is None, f"the run ended before it could be stopped: {process.communicate()}"
        process.send_signal(signal.SIGTERM)
        _, err = process.communicate(timeout=120)
    finally:
        process.kill()
        process.wait()
    assert process.returncode == 143, err
    lines = err.strip().splitlines()
    assert re.fullmatch(rf"rampwork: note: (\d+) of 40 chunks are saved in {re.escape(str(partial))}; "
                        r"run the same command with --resume to finish", lines[-2]), err
    assert lines[-1] == "rampwork: error: terminated (SIGTERM)" and "Traceback" not in err
    assert not path.exists() and 2 <= _chunks_done(partial) < 40
    resumed = subprocess.run(_rampwork("run", scene_path, "-o", path, "--resume", "-q"),
                             capture_output=True, text=True, timeout=300)
    assert resumed.returncode == 0, resumed.stderr
    assert rw.open_dataset(path).status.size == 16000 and not partial.exists()


# ------------------------------------------------------------------------------
# memory
# ------------------------------------------------------------------------------
MEMORY_SCRIPT = """\
import resource, sys
import numpy as np
import rampwork as rw

def peak():
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024  # bytes (Linux: KiB)

scene = rw.Scene(ramp=rw.Ramp.create("quadratic", curvature=1.0, domain=(-1.0, 1.0)),
                 friction=rw.Friction(0.3, 0.3), x0=-0.9, t_max=5.0,
                 integrator=rw.Integrator("euler", dt=1e-2))
sweep = rw.Sweep.grid(mu=[0.2, 0.25, 0.3, 0.35], v0=[0.0, 0.5, 1.0, 1.5, 2.0], x0=np.linspace(-0.9, -0.85, 50000))
rw.run_to_file(scene, rw.Sweep.grid(mu=[0.2]), sys.argv[1] + ".warm.nc")  # compile, load netCDF
before = peak()
rw.run_to_file(scene, sweep, sys.argv[1], chunk_size=10000)
print(sweep.size, before, peak())
"""


@pytest.mark.slow
def test_a_million_trajectories_in_bounded_memory(tmp_path):
    path = tmp_path / "million.nc"
    out = subprocess.run([sys.executable, "-c", MEMORY_SCRIPT, str(path)], capture_output=True,
                         text=True, timeout=900)
    assert out.returncode == 0, out.stderr
    size, before, after = map(int, out.stdout.split())
    assert size == 10**6
    dataset = rw.open_dataset(path)
    assert dataset.status.size == size and (dataset.status.values > 0).all()
    in_memory = sum(dataset[name].nbytes for name in schema.output_names(False))
    growth = after - before
    print(f"\n{size:,} trajectories, {in_memory / 2**20:.0f} MiB of results; "
          f"peak RSS {before / 2**20:.0f} MiB before the run, {after / 2**20:.0f} MiB after "
          f"(growth {growth / 2**20:.1f} MiB)")
    assert growth < in_memory / 5  # about three chunks in flight: the one computed, queued, written


# ------------------------------------------------------------------------------
# Dask
# ------------------------------------------------------------------------------
def test_dask_cluster_writes_the_same_file_as_threads(tmp_path):
    distributed = pytest.importorskip("distributed")
    scene = _scene(record=rw.Record(count=2, every=40))
    threaded = rw.run_to_file(scene, GRID, tmp_path / "threads.nc", chunk_size=7)
    # in-process workers (inproc:// transport): nothing leaves the machine
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        seen = []
        path = rw.run_to_file(scene, GRID, tmp_path / "dask.nc", chunk_size=7, scheduler=client,
                              progress=lambda done, total: seen.append(done))
        assert client.status == "running"  # a client we were given is left open
    on_dask = rw.open_dataset(path)
    assert_same_file(rw.open_dataset(threaded), on_dask)
    assert on_dask.attrs["scheduler"].startswith("inproc://")
    assert seen[0] == 0 and seen[-1] == GRID.size and len(seen) == 1 + 20  # before and after each chunk


# ------------------------------------------------------------------------------
# the command line: progress, Ctrl-C, resume, a local cluster
# ------------------------------------------------------------------------------
def _cli_scene(tmp_path):
    from rampwork import cli

    path = tmp_path / "straight.toml"
    path.write_text(cli.example_text("straight"), encoding="utf-8")
    return path


def test_cli_progress_bar_on_request(tmp_path, capsys):
    from rampwork.cli import main

    scene = _cli_scene(tmp_path)
    assert main(["run", str(scene), "-o", str(tmp_path / "out.nc"), "--progress", "--chunk-size", "4"]) == 0
    err = capsys.readouterr().err.splitlines()
    # not a terminal: whole lines, the first before any chunk, the last at 100 %
    assert err[0].startswith("[") and " 0%" in err[0] and "trajectories" in err[0]
    assert err[-1].startswith("[" + "#" * 24 + "] 100%") and "/s" in err[-1] and "0:00 left" in err[-1]
    assert main(["run", str(scene), "-o", str(tmp_path / "quiet.nc"), "--chunk-size", "4"]) == 0
    assert capsys.readouterr().err == ""  # not a terminal, not asked: no progress


def test_cli_ctrl_c_keeps_finished_chunks_and_resume_finishes(tmp_path, capsys, monkeypatch):
    from rampwork.cli import main

    scene = _cli_scene(tmp_path)
    output = tmp_path / "out.nc"
    calls = []
    run_chunk = runner.run_chunk

    def interrupted(*args, **kwargs):
        calls.append(1)
        if len(calls) == 3:
            raise KeyboardInterrupt
        return run_chunk(*args, **kwargs)

    monkeypatch.setattr(runner, "run_chunk", interrupted)
    assert main(["run", str(scene), "-o", str(output), "--chunk-size", "4"]) == 130
    err = capsys.readouterr().err
    assert "2 of 3 chunks are saved" in err and "--resume" in err and err.strip().endswith("interrupted")
    assert not output.exists() and partial_path(output).exists()

    assert main(["run", str(scene), "-o", str(output), "--chunk-size", "4"]) == 2  # no silent restart
    assert "--resume" in capsys.readouterr().err
    monkeypatch.setattr(runner, "run_chunk", run_chunk)
    assert main(["run", str(scene), "-o", str(output), "--resume"]) == 0
    out = capsys.readouterr().out
    assert "resuming     2 of 3 chunks done" in out and "trajectories  12" in out
    from rampwork.scenefile import load_scene

    assert_same_data(rw.simulate(*load_scene(scene)), rw.open_dataset(output))


def test_cli_resume_of_another_scene_is_refused(tmp_path, capsys, monkeypatch):
    from rampwork.cli import main

    scene = _cli_scene(tmp_path)
    output = tmp_path / "out.nc"
    monkeypatch.setattr(runner, "run_chunk", lambda *a, **k: (_ for _ in ()).throw(KeyboardInterrupt))
    assert main(["run", str(scene), "-o", str(output), "--chunk-size", "4"]) == 130
    capsys.readouterr()
    assert main(["run", str(scene), "-o", str(output), "--resume", "--set", "t_max=7"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"rampwork: error: {partial_path(output)}: was started by a different scene")
    assert "\n" not in err


@pytest.mark.slow
def test_cli_local_dask_cluster(tmp_path):
    pytest.importorskip("distributed")
    scene = _cli_scene(tmp_path)
    output = tmp_path / "dask.nc"
    run = subprocess.run(_rampwork("run", scene, "-o", output, "--scheduler", "local", "--chunk-size", 5),
                         capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    from rampwork.scenefile import load_scene

    on_dask = rw.open_dataset(output)
    assert on_dask.attrs["scheduler"].startswith("tcp://127.0.0.1")
    assert_same_data(rw.simulate(*load_scene(scene)), on_dask)
