"""Recorded trajectories of curve scenes (``[record]``, docs/physics.md §5.2):
a trace ends exactly where the batch's outputs say, keeps the energy balance
along the way to the method's accuracy, follows the frictionless loop's
closed form u²(s), and is the same in a chunked file as in one call."""

from __future__ import annotations

import numpy as np
import pytest

import rampwork as rw
from rampwork import schema
from rampwork.core import status as st
from rampwork.curve_scene import CurveScene
from rampwork.curves import Curve
from rampwork.errors import ConfigError
from rampwork.scenefile import dump_scene, parse_scene

G = 9.81
ENDS = {"t_end": "trace_t", "s_end": "trace_s", "u_end": "trace_u", "X_end": "trace_X",
        "Y_end": "trace_Y", "W_friction": "trace_W_friction"}


def _scene(method="rk4", record=None, **changes):
    adaptive = {"rtol": 1e-9} if method in ("dopri5", "dop853") else {"dt": 1e-3}
    scene = CurveScene(curve=Curve.create("loop", radius=1.0), s0=0.0, u0=7.0,
                       friction=rw.Friction(0.1, 0.2), integrator=rw.Integrator(method, **adaptive),
                       t_max=4.0, record=record or rw.Record(count=5, every=3))
    return scene.replace(**changes)


def _last(ds, name, k):
    return ds[name].values[k, int(ds.trace_length[k]) - 1]


def _assert_ends_match(ds):
    for k, j in enumerate(ds.traced_index.values):
        for output, trace in ENDS.items():
            expected = ds[output].values.ravel()[j]
            assert _last(ds, trace, k) == expected or (np.isnan(expected) and np.isnan(_last(ds, trace, k))), \
                (output, int(j))
        if "W_drag" in ds:
            assert _last(ds, "trace_W_drag", k) == ds["W_drag"].values.ravel()[j]
        assert np.isnan(ds.trace_t.values[k, int(ds.trace_length[k]):]).all()


# a grid with lift-offs, exits, reversals and stops (mu = 0.4 stops low on the loop)
GRID = rw.Sweep.grid(u0=[2.0, 3.0, 6.5, 7.5, 9.0], mu=[0.0, 0.1, 0.4])


# every method but semi-implicit Euler one-sided, RK4 two-sided in the default
# suite; the other cases (a kernel and a trace variant each) in the slow suite
@pytest.mark.parametrize("method, contact", [
    *((method, "one_sided") for method in ("euler", "rk4", "dopri5", "dop853")),
    ("rk4", "two_sided"),
    pytest.param("semi_implicit_euler", "one_sided", marks=pytest.mark.slow),
    *(pytest.param(method, "two_sided", marks=pytest.mark.slow)
      for method in ("euler", "semi_implicit_euler", "dopri5", "dop853"))])
def test_a_trace_ends_where_the_outputs_say_bit_for_bit(method, contact):
    scene = _scene(method, rw.Record(count=GRID.size, every=7), contact=contact)
    ds = rw.simulate(scene, GRID)
    statuses = set(ds.status.values.ravel().tolist())
    assert len(statuses) >= 2  # several kinds of ends among the traced ones
    assert ds.sizes["traced"] == GRID.size
    _assert_ends_match(ds)
    # every trace starts at the start, in time order, on the curve
    assert (ds.trace_t.values[:, 0] == 0.0).all() and (ds.trace_s.values[:, 0] == 0.0).all()
    assert np.array_equal(ds.traced_u0.values, ds.u0.values[ds.traced_index.values // 3])
    for k in range(ds.sizes["traced"]):
        t = ds.trace_t.values[k, :int(ds.trace_length[k])]
        assert (np.diff(t) >= 0.0).all()


def test_a_trace_with_drag_ends_on_the_outputs_and_records_drag_work():
    scene = _scene("dopri5", drag=rw.Drag(0.05, 0.02))
    ds = rw.simulate(scene, GRID)
    assert "trace_W_drag" in ds
    _assert_ends_match(ds)
    without = rw.simulate(_scene("dopri5"), GRID)
    assert "trace_W_drag" not in without


def _energy_drift(ds, m=1.0):
    """The largest change of g Y + u²/2 + (W_f + W_d)/m along each trace."""
    energy = G * ds.trace_Y + 0.5 * ds.trace_u ** 2 + ds.trace_W_friction / m
    if "trace_W_drag" in ds:
        energy = energy + ds.trace_W_drag / m
    return float((energy.max("sample") - energy.min("sample")).max())


@pytest.mark.parametrize("method, settings, bound", [
    ("rk4", {"dt": 1e-3}, 1e-9),
    ("dopri5", {"rtol": 1e-10}, 1e-7),
    ("dop853", {"rtol": 1e-10}, 1e-7),
])
def test_energy_balance_holds_along_the_trace(method, settings, bound):
    sweep = rw.Sweep.grid(u0=[6.5, 7.5], mu=[0.1, 0.3])
    scene = _scene(method, rw.Record(count=4), integrator=rw.Integrator(method, **settings),
                   drag=rw.Drag(0.0, 0.03), m=2.0)
    ds = rw.simulate(scene, sweep)
    assert float(ds.trace_W_friction.max()) > 1.0  # friction did work
    assert _energy_drift(ds, m=2.0) < bound


@pytest.mark.parametrize("method", ["euler", pytest.param("semi_implicit_euler", marks=pytest.mark.slow)])
def test_energy_drift_of_the_first_order_methods_halves_with_the_step(method):
    sweep = rw.Sweep.grid(u0=[7.5], mu=[0.1])
    drifts = [_energy_drift(rw.simulate(_scene(method, rw.Record(count=1),
                                               integrator=rw.Integrator(method, dt=dt)), sweep))
              for dt in (2e-4, 1e-4)]
    assert 1.7 < drifts[0] / drifts[1] < 2.3, drifts


@pytest.mark.parametrize("method, settings, bound", [
    ("rk4", {"dt": 1e-3}, 1e-10),
    ("dopri5", {"rtol": 1e-10}, 1e-7),
])
def test_frictionless_loop_trace_follows_the_closed_form(method, settings, bound):
    radius = 1.3
    u0 = np.array([6.5, 8.5])  # lifts off (u0² < 5 g R); goes round and out
    scene = _scene(method, rw.Record(count=2), curve=Curve.create("loop", radius=radius),
                   friction=rw.Friction(0.0), integrator=rw.Integrator(method, **settings))
    ds = rw.simulate(scene, rw.Sweep.grid(u0=u0))
    assert set(ds.status.values.tolist()) == {st.LIFTED_OFF, st.EXITED}
    for k in range(2):
        n = int(ds.trace_length[k])
        s = ds.trace_s.values[k, :n]
        u = ds.trace_u.values[k, :n]
        exact = u0[k] ** 2 - 2 * G * radius * (1 - np.cos(s / radius))
        assert np.max(np.abs(u ** 2 - exact)) < bound * u0[k] ** 2
        # the point is the circle's; the normal force m (u²/R + g cos(s/R))
        assert np.allclose(ds.trace_X.values[k, :n], radius * np.sin(s / radius), atol=1e-13)
        nu = u ** 2 / radius + G * np.cos(s / radius)
        assert np.allclose(ds.trace_nu.values[k, :n], nu, atol=1e-9)
        assert n == int(ds.steps[k]) + 1  # the start and every step (every = 1)


def test_record_samples_every_so_many_steps_and_the_end():
    sweep = rw.Sweep.grid(u0=[7.5])
    every = rw.simulate(_scene(record=rw.Record(count=1, every=1)), sweep)
    sparse = rw.simulate(_scene(record=rw.Record(count=1, every=10)), sweep)
    capped = rw.simulate(_scene(record=rw.Record(count=1, every=1, max_samples=5)), sweep)
    n_every, n_sparse = int(every.trace_length[0]), int(sparse.trace_length[0])
    steps = int(every.steps[0])
    assert n_every == steps + 1  # the start and every step (the last one the end)
    assert steps // 10 + 1 <= n_sparse <= steps // 10 + 3
    # the samples of every 10th step are those of every step, bit for bit
    picked = every.trace_t.values[0, 10:n_every - 1:10]
    assert np.array_equal(sparse.trace_t.values[0, 1:1 + picked.size], picked)
    assert int(capped.trace_length[0]) == 5
    _assert_ends_match(capped)


def test_chunked_file_has_the_one_call_traces(tmp_path):
    scene = _scene("dopri5", rw.Record(indices=(0, 4, 7, 13)))
    expected = rw.simulate(scene, GRID)
    path = rw.run_to_file(scene, GRID, tmp_path / "out.nc", chunk_size=4)
    actual = rw.open_dataset(path)
    for name in schema.curve_trace_names() + ("traced_index", "trace_length", "traced_u0",
                                              "traced_mu"):
        assert np.array_equal(actual[name].values, expected[name].values, equal_nan=True), name
        assert actual[name].attrs["units"] == expected[name].attrs["units"]
    assert "trace_time_s" in actual.attrs


def test_a_scene_file_with_record_reads_back_and_checks_indices():
    scene = _scene(record=rw.Record(count=0, indices=(1, 3), every=2))
    sweep = rw.Sweep.grid(u0=[6.0, 7.0, 8.0, 9.0])
    text = dump_scene(scene, sweep)
    assert "[record]" in text
    again, sweep_again = parse_scene(text, "scene.toml")
    assert again == scene and sweep_again == sweep
    with pytest.raises(ConfigError, match=r"record\.indices\[1\]"):
        parse_scene(text.replace("indices = [1, 3]", "indices = [1, 4]"), "scene.toml")
    with pytest.raises(ConfigError, match=r"\[record\] unknown key 'rate'"):
        parse_scene(text.replace("every = 2", "rate = 2"), "scene.toml")
    # no [record] table: none written, none recorded
    plain = _scene(record=rw.Record())
    assert "[record]" not in dump_scene(plain, sweep)
    assert "traced" not in rw.simulate(plain, sweep).dims
