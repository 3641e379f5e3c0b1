"""Curve scenes written chunk by chunk (rampwork.run_to_file, `rampwork run`,
docs/physics.md §5): the netCDF file and the Zarr store equal
rampwork.simulate's dataset bit for bit, an interrupted run resumes to the
same data without recomputing its finished chunks, and a Dask cluster
writes the same file.  The ramp scenes' tests of the same machinery are in
test_streaming.py and test_zarr.py; these follow them."""

from __future__ import annotations

import numpy as np
import pytest

import rampwork as rw
from rampwork import curve_chunks, streaming
from rampwork.cli import main
from rampwork.curve_scene import CurveScene
from rampwork.curves import Curve
from rampwork.streaming import partial_path

from test_streaming import _stop_after, assert_same_data, assert_same_file


def _scene(method="dopri5", **changes):
    adaptive = {"rtol": 1e-8} if method in ("dopri5", "dop853") else {"dt": 1e-3}
    scene = CurveScene(curve=Curve.create("loop", radius=1.0), s0=0.0, u0=7.0,
                       friction=rw.Friction(0.1, 0.2),
                       integrator=rw.Integrator(method, **adaptive), t_max=5.0)
    return scene.replace(**changes)


#: 36 trajectories: lift-offs, exits, reversals; the mu = 0 rows are chunks of
#: their own at chunk_size 4, run on the whole sweep's kernel (with friction)
GRID = rw.Sweep.grid(radius=[0.8, 1.0, 1.2], mu=[0.0, 0.1, 0.3], u0=[3.0, 6.5, 7.5, 9.0])


@pytest.mark.parametrize("sweep, chunk_size", [
    (GRID, None),  # one chunk
    (GRID, 4),     # one u0 row at a time
    (GRID, 3),     # smaller than a row: cut along u0
    (GRID, 10),    # two mu rows, a short last chunk
    (rw.Sweep.cases(u0=np.linspace(2.0, 9.0, 11), s0=np.linspace(0.0, 1.0, 11)), 4),
    (rw.Sweep.random(23, seed=3, u0=(2.0, 9.0), mu=(0.0, 0.3)), 5),  # drawn chunk by chunk
    (rw.Sweep.single(), 5),
])
@pytest.mark.parametrize("suffix", [".nc", ".zarr"])
def test_chunked_file_equals_simulate_bit_for_bit(tmp_path, sweep, chunk_size, suffix):
    pytest.importorskip("zarr") if suffix == ".zarr" else None
    scene = _scene()
    expected = rw.simulate(scene, sweep)
    path = rw.run_to_file(scene, sweep, tmp_path / f"out{suffix}", chunk_size=chunk_size)
    actual = rw.open_dataset(path)
    assert_same_file(expected, actual)
    assert actual.attrs["trajectory_steps"] == expected.attrs["trajectory_steps"]
    assert actual.attrs["history"].split(": ", 1)[1].startswith("rampwork.run_to_file")
    assert [p.name for p in tmp_path.iterdir()] == [f"out{suffix}"]  # no partial left


def test_every_chunk_runs_on_the_whole_sweeps_kernel(tmp_path):
    """A chunk whose trajectories all have mu = 0 (and drag 0) still runs the
    kernel with friction and drag that the sweep needs, and gives what those
    trajectories give alone (dop853's error norm counts a work integral only
    for a trajectory that has it)."""
    scene = _scene("dop853", drag=rw.Drag(linear=0.0))
    sweep = rw.Sweep.grid(mu=[0.0, 0.2], drag_linear=[0.0, 0.1], u0=[6.5, 7.5, 9.0])
    run = curve_chunks.CurveSweepRun(scene, sweep)
    assert run.chunk(0, 3)[0].kernel is run.kernel
    # alone: a sweep of its own, on the kernel auto picks (the tiers' equality
    # is tests/test_curve_tiers.py's)
    frictionless = rw.simulate(scene, rw.Sweep.grid(mu=[0.0], drag_linear=[0.0], u0=[6.5, 7.5, 9.0]))
    chunk = run.compute(0, 3)  # mu = 0, drag 0
    expected = rw.simulate(scene, sweep)
    assert np.array_equal(chunk["t_end"], expected.t_end.values[0, 0])
    for name in ("t_end", "u_end", "W_friction", "steps"):
        assert np.array_equal(chunk[name], frictionless[name].values.ravel()), name
    path = rw.run_to_file(scene, sweep, tmp_path / "out.nc", chunk_size=3)
    assert_same_file(expected, rw.open_dataset(path))


@pytest.mark.parametrize("suffix", [".nc", ".zarr"])
def test_an_interrupted_curve_run_resumes_to_the_same_data(tmp_path, monkeypatch, suffix):
    pytest.importorskip("zarr") if suffix == ".zarr" else None
    scene = _scene("dop853")
    path = tmp_path / f"out{suffix}"
    with pytest.raises(KeyboardInterrupt):
        rw.run_to_file(scene, GRID, path, chunk_size=4, progress=_stop_after(3))
    assert not path.exists() and partial_path(path).exists()
    job = streaming.SweepToFile(scene, GRID, path, resume=True)
    assert job.resuming and job.done_chunks == 3 and job.total_chunks == 9

    ran = []
    compute = curve_chunks.CurveSweepRun.compute
    monkeypatch.setattr(curve_chunks.CurveSweepRun, "compute",
                        lambda self, start, stop: ran.append(start) or compute(self, start, stop))
    job.run()
    assert len(ran) == 6 and 0 not in ran  # the three finished chunks were not run again
    assert not partial_path(path).exists()
    assert_same_data(rw.simulate(scene, GRID), rw.open_dataset(path))
    # another scene does not resume this one's partial run
    with pytest.raises(KeyboardInterrupt):
        rw.run_to_file(scene, GRID, tmp_path / f"again{suffix}", chunk_size=4, progress=_stop_after(1))
    with pytest.raises(rw.ConfigError, match="different scene, sweep or rampwork version"):
        rw.run_to_file(scene.replace(t_max=6.0), GRID, tmp_path / f"again{suffix}", resume=True)


@pytest.mark.parametrize("suffix", [".nc", ".zarr"])
def test_dask_cluster_writes_the_same_curve_file_as_one_process(tmp_path, suffix):
    distributed = pytest.importorskip("distributed")
    pytest.importorskip("zarr") if suffix == ".zarr" else None
    scene = _scene()
    threaded = rw.run_to_file(scene, GRID, tmp_path / f"threads{suffix}", chunk_size=4)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        seen = []
        path = rw.run_to_file(scene, GRID, tmp_path / f"dask{suffix}", chunk_size=4,
                              scheduler=client, progress=lambda done, total: seen.append(done))
    on_dask = rw.open_dataset(path)
    assert_same_file(rw.open_dataset(threaded), on_dask)
    assert_same_data(rw.simulate(scene, GRID), on_dask)
    assert on_dask.attrs["scheduler"].startswith("inproc://")
    assert seen[0] == 0 and seen[-1] == GRID.size and len(seen) == 1 + 9


def test_cli_ctrl_c_and_resume_of_a_curve_scene(tmp_path, capsys, monkeypatch):
    from rampwork import cli
    from rampwork.scenefile import load_scene

    scene = tmp_path / "loop.toml"
    scene.write_text(cli.example_text("loop"), encoding="utf-8")
    output = tmp_path / "out.nc"
    calls = []
    compute = curve_chunks.CurveSweepRun.compute

    def interrupted(self, start, stop):
        calls.append(1)
        if len(calls) == 3:
            raise KeyboardInterrupt
        return compute(self, start, stop)

    monkeypatch.setattr(curve_chunks.CurveSweepRun, "compute", interrupted)
    assert main(["run", str(scene), "-o", str(output), "--chunk-size", "2"]) == 130
    err = capsys.readouterr().err
    assert "chunks are saved" in err and "--resume" in err
    assert not output.exists() and partial_path(output).exists()
    monkeypatch.setattr(curve_chunks.CurveSweepRun, "compute", compute)
    assert main(["run", str(scene), "-o", str(output), "--resume"]) == 0
    out = capsys.readouterr().out
    assert "resuming     2 of" in out and "loop curve" in out
    assert_same_data(rw.simulate(*load_scene(scene)), rw.open_dataset(output))
