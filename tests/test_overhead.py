"""Issue 19 item 1: the per-call cost of rampwork.simulate does not grow with
the sweep outside the kernel.  A cases sweep (and a long explicit grid axis)
is stored with its dataset by reference to the dataset's coordinates, not as
text; the stored scene re-runs from the dataset; the resume digest still sees
every value."""

from __future__ import annotations

import numpy as np
import pytest

import rampwork as rw
from rampwork import runner, streaming
from rampwork.errors import ConfigError
from rampwork.scenefile import INLINE_VALUES, dump_scene, parse_scene, scene_from_dataset


def _scene(**changes):
    scene = rw.Scene(ramp=rw.Ramp.create("quadratic", curvature=1.0, domain=(-1.0, 1.0)),
                     friction=rw.Friction(0.2), x0=-0.9, t_max=2.0,
                     integrator=rw.Integrator("rk4", dt=1e-2))
    return scene.replace(**changes)


def _cases(n, seed=0):
    rng = np.random.default_rng(seed)
    return rw.Sweep.cases(mu=rng.uniform(0.01, 0.4, n), x0=rng.uniform(-0.9, 0.9, n),
                          v0=rng.uniform(-2.0, 2.0, n))


def test_stored_scene_of_cases_has_a_size_independent_of_n():
    scene = _scene()
    sizes = {}
    for n in (INLINE_VALUES + 1, 1000, 20000):
        ds = rw.simulate(scene, _cases(n), threads=1)
        text = ds.attrs["rampwork_scene"]
        sizes[n] = len(text.replace(f"num = {n} ", "num = N "))  # n is written only as num
        assert f'mu = {{ coordinate = "mu", num = {n} }}' in text
    assert len(set(sizes.values())) == 1, sizes
    assert max(sizes.values()) < 1500


def test_short_lists_stay_inline():
    sweep = rw.Sweep.cases(mu=[0.1, 0.2, 0.3], x0=[-0.5, 0.1, 0.7])
    ds = rw.simulate(_scene(), sweep, threads=1)
    assert "coordinate" not in ds.attrs["rampwork_scene"]
    assert parse_scene(ds.attrs["rampwork_scene"]) == (_scene(), sweep)


@pytest.mark.parametrize("method", ["rk4", "dopri5"])
def test_stored_cases_rerun_from_the_dataset(tmp_path, method):
    integrator = rw.Integrator(method, dt=1e-2) if method == "rk4" else rw.Integrator(method, rtol=1e-7)
    scene, sweep = _scene(integrator=integrator), _cases(500, seed=3)
    ds = rw.simulate(scene, sweep, threads=1)
    stored = rw.open_dataset(rw.write_netcdf(ds, tmp_path / "cases.nc"))
    scene2, sweep2 = rw.scene_from_dataset(stored)
    assert scene2 == scene and sweep2 == sweep
    again = rw.simulate(scene2, sweep2, threads=1)
    for name in ("status", "x_end", "t_end", "W_friction", "steps"):
        assert np.array_equal(again[name].values, ds[name].values, equal_nan=True), name


def test_long_explicit_grid_axis_is_stored_by_reference_and_reruns():
    mu = np.sort(np.random.default_rng(1).uniform(0.01, 0.4, 100))
    sweep = rw.Sweep.grid(mu=mu, v0=[-1.0, 0.5])
    ds = rw.simulate(_scene(), sweep, threads=1)
    text = ds.attrs["rampwork_scene"]
    assert 'mu = { coordinate = "mu", num = 100 }' in text and "v0 = [-1.0, 0.5]" in text
    scene2, sweep2 = scene_from_dataset(ds)
    assert sweep2 == sweep
    again = rw.simulate(scene2, sweep2, threads=1)
    assert np.array_equal(again.W_friction.values, ds.W_friction.values)


def test_an_evenly_spaced_axis_stays_a_linspace():
    sweep = rw.Sweep.grid(mu=np.linspace(0.01, 0.4, 1000))
    text = dump_scene(_scene(), sweep, stored=True)
    assert "linspace = [0.01, 0.4, 1000]" in text and "coordinate" not in text


def test_a_reference_without_its_dataset_is_refused_clearly():
    text = dump_scene(_scene(), _cases(200), stored=True)
    with pytest.raises(ConfigError, match="scene_from_dataset"):
        parse_scene(text)
    # the full text (what a distributed worker gets) still lists every value
    assert parse_scene(dump_scene(_scene(), _cases(200)))[1] == _cases(200)


def test_a_reference_checks_the_coordinate():
    text = dump_scene(_scene(), _cases(200), stored=True)
    sweep = _cases(200)
    coords = {name: values for name, values in sweep.axes}
    with pytest.raises(ConfigError, match="shape"):
        parse_scene(text, coordinates={**coords, "mu": coords["mu"][:199]})
    with pytest.raises(ConfigError, match="NaN"):
        parse_scene(text, coordinates={**coords, "x0": np.full(200, np.nan)})
    with pytest.raises(ConfigError, match="no coordinate 'v0'"):
        parse_scene(text, coordinates={"mu": coords["mu"], "x0": coords["x0"]})
    assert parse_scene(text, coordinates=coords)[1] == sweep


def test_digest_changes_when_one_case_value_changes():
    scene = _scene()
    sweep = _cases(1000)
    base = streaming.run_digest(runner.plan_run(scene, sweep))
    assert streaming.run_digest(runner.plan_run(scene, _cases(1000))) == base
    columns = {name: np.array(values) for name, values in sweep.axes}
    columns["v0"][567] = np.nextafter(columns["v0"][567], np.inf)  # one bit of one value
    changed = streaming.run_digest(runner.plan_run(scene, rw.Sweep.cases(**columns)))
    assert changed != base
    # the stored texts are equal: the values' bytes make the difference
    assert (runner.scene_text(scene, sweep, stored=True)
            == runner.scene_text(scene, rw.Sweep.cases(**columns), stored=True))


def test_info_prints_the_sweep_of_a_stored_cases_run(tmp_path, capsys):
    from rampwork.cli import main

    path = rw.write_netcdf(rw.simulate(_scene(), _cases(300), threads=1), tmp_path / "c.nc")
    assert main(["info", str(path)]) == 0
    out = capsys.readouterr().out
    assert "cases: 300 x (mu, x0, v0)" in out and 'coordinate = "mu", num = 300' in out


def test_sweep_holds_read_only_copies_and_compares_by_value():
    mu = np.array([0.1, 0.2, 0.3])
    sweep = rw.Sweep.cases(mu=mu, x0=[0.0, 0.1, 0.2])
    mu[0] = 0.9  # the caller's array changes; the sweep's does not
    values = dict(sweep.axes)["mu"]
    assert isinstance(values, np.ndarray) and values.dtype == np.float64
    assert not values.flags.writeable and values[0] == 0.1
    same = rw.Sweep.cases(mu=(0.1, 0.2, 0.3), x0=np.array([0.0, 0.1, 0.2]))
    assert sweep == same and hash(sweep) == hash(same)
    assert sweep != rw.Sweep.cases(mu=[0.1, 0.2, 0.3], x0=[0.0, 0.1, 0.25])
    assert sweep != rw.Sweep.grid(mu=[0.1, 0.2, 0.3], x0=[0.0, 0.1, 0.2])
    assert sweep != rw.Sweep.cases(x0=[0.0, 0.1, 0.2], mu=[0.1, 0.2, 0.3])  # the axes' order counts


def test_rampwork_run_reruns_a_dataset_with_cases(tmp_path, capsys):
    from rampwork.cli import main

    first = rw.write_netcdf(rw.simulate(_scene(), _cases(200, seed=5), threads=1), tmp_path / "first.nc")
    assert main(["check", str(first)]) == 0
    again = tmp_path / "again.nc"
    assert main(["run", str(first), "-o", str(again), "--quiet"]) == 0
    a, b = rw.open_dataset(first), rw.open_dataset(again)
    assert np.array_equal(a.mu.values, b.mu.values) and np.array_equal(a.v0.values, b.v0.values)
    for name in ("status", "x_end", "W_friction"):
        assert np.array_equal(a[name].values, b[name].values), name
    # an override applies to the stored scene as to a file
    changed = tmp_path / "changed.nc"
    assert main(["run", str(first), "-o", str(changed), "--quiet", "--set", "m=2"]) == 0
    c = rw.open_dataset(changed)
    assert rw.scene_from_dataset(c)[0].m == 2.0
    np.testing.assert_allclose(c.W_friction.values, 2 * a.W_friction.values, rtol=1e-12, atol=1e-15)


def test_a_cases_sweep_on_dask_workers_writes_the_same_file(tmp_path):
    """Workers get the stored scene and the case arrays (not the values as
    text) and compute what threads compute."""
    distributed = pytest.importorskip("distributed")
    scene, sweep = _scene(), _cases(300, seed=7)
    threaded = rw.open_dataset(rw.run_to_file(scene, sweep, tmp_path / "threads.nc", chunk_size=64))
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster, distributed.Client(cluster) as client:
        on_dask = rw.open_dataset(rw.run_to_file(scene, sweep, tmp_path / "dask.nc", chunk_size=64,
                                                 scheduler=client))
    assert 'coordinate = "mu", num = 300' in on_dask.attrs["rampwork_scene"]
    for name in ("mu", "x0", "v0", "status", "x_end", "W_friction", "steps"):
        assert np.array_equal(on_dask[name].values, threaded[name].values), name
