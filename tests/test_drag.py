"""Air drag along the path (``Scene.drag``): closed forms, convergence order,
energy balance with friction, the scipy reference, compile-time pruning, and
bad input.

The drag force is tangential, m (b s' + c s'^2) against the motion, s' the
speed along the path.  Projected on the tangent (1, f') it adds
a_drag = -b v - d c v^2 sqrt(1 + f'^2) to dv/dt; its power per unit mass is
b v^2 (1 + f'^2) + d c v^3 (1 + f'^2)^(3/2) (d = sign(v)).  On a flat
frictionless ramp that gives the closed forms used below:

* linear:    v = v0 e^(-b t),         x = x0 + (v0 / b) (1 - e^(-b t))
* quadratic: v = v0 / (1 + c v0 t),   x = x0 + ln(1 + c v0 t) / c
* both:      W_drag / m = (v0^2 - v^2) / 2.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import rampwork as rw
from rampwork import runner
from rampwork.cli import main
from rampwork.core import kernel as K
from rampwork.core.status import TIMEOUT
from rampwork.core.variant import KernelVariant
from rampwork.errors import ConfigError
from rampwork.scenefile import dump_scene, parse_scene

FLAT = rw.Ramp.create("straight", slope=0.0, domain=(-100.0, 100.0))
V0 = 2.0
T_MAX = 1.5
B = 0.7  # 1/s
C = 0.4  # 1/m
BOWL = rw.Ramp.create("quadratic", curvature=2.0, domain=(-1.0, 1.0))


def closed_form(kind: str, v0: float, t: float) -> tuple[float, float, float]:
    """(x - x0, v, W_drag / m) at time t on the flat frictionless ramp."""
    if kind == "linear":
        v = v0 * math.exp(-B * t)
        x = v0 / B * -math.expm1(-B * t)
    else:
        speed = abs(v0)
        v = v0 / (1.0 + C * speed * t)
        x = math.copysign(math.log1p(C * speed * t) / C, v0)
    return x, v, 0.5 * (v0 * v0 - v * v)


def flat_scene(kind: str, integrator: rw.Integrator, v0: float = V0, m: float = 1.0) -> rw.Scene:
    drag = rw.Drag(linear=B) if kind == "linear" else rw.Drag(quadratic=C)
    return rw.Scene(ramp=FLAT, integrator=integrator, x0=0.0, v0=v0, m=m, t_max=T_MAX, drag=drag)


def one(ds, name):
    return float(ds[name].values)


# ----------------------------------------------------------------------------
# closed forms on a flat frictionless ramp
# ----------------------------------------------------------------------------
@pytest.mark.parametrize("kind", ["linear", "quadratic"])
@pytest.mark.parametrize("method, settings, tolerance", [
    ("rk4", dict(dt=1e-3), 1e-12),
    ("dopri5", dict(rtol=1e-12, atol=1e-12), 1e-10),
    ("dop853", dict(rtol=1e-13, atol=1e-13), 1e-11),
])
def test_closed_forms(kind, method, settings, tolerance):
    ds = rw.simulate(flat_scene(kind, rw.Integrator(method, **settings), m=2.0), threads=1)
    x, v, w = closed_form(kind, V0, T_MAX)
    assert one(ds, "status") == TIMEOUT and one(ds, "t_end") == T_MAX
    assert one(ds, "x_end") == pytest.approx(x, abs=tolerance)
    assert one(ds, "v_end") == pytest.approx(v, abs=tolerance)
    assert one(ds, "W_drag") == pytest.approx(2.0 * w, abs=tolerance)
    assert one(ds, "W_friction") == 0.0
    assert one(ds, "W_energy") == pytest.approx(2.0 * w, abs=tolerance)
    assert abs(one(ds, "energy_balance_error")) < tolerance


@pytest.mark.parametrize("kind", ["linear", "quadratic"])
def test_closed_forms_moving_left(kind):
    """d = -1: the quadratic term keeps its sign through d c v^2."""
    ds = rw.simulate(flat_scene(kind, rw.Integrator("rk4", dt=1e-3), v0=-V0), threads=1)
    x, v, w = closed_form(kind, -V0, T_MAX)
    assert one(ds, "x_end") == pytest.approx(x, abs=1e-12)
    assert one(ds, "v_end") == pytest.approx(v, abs=1e-12)
    assert one(ds, "W_drag") == pytest.approx(w, abs=1e-12)


@pytest.mark.parametrize("method, order, dts", [
    ("euler", 1, (1e-2, 5e-3, 2.5e-3, 1.25e-3)),
    ("rk4", 4, (0.1, 0.05, 0.025, 0.0125)),
])
def test_convergence_order(method, order, dts):
    """The error of x and of the drag work at t_max falls as dt^order."""
    x, v, w = closed_form("quadratic", V0, T_MAX)
    errors_x, errors_w = [], []
    for dt in dts:
        ds = rw.simulate(flat_scene("quadratic", rw.Integrator(method, dt=dt)), threads=1)
        errors_x.append(abs(one(ds, "x_end") - x))
        errors_w.append(abs(one(ds, "W_drag") - w))
    for errors in (errors_x, errors_w):
        slope = np.polyfit(np.log(dts), np.log(errors), 1)[0]
        assert slope == pytest.approx(order, abs=0.15), errors


# ----------------------------------------------------------------------------
# energy balance with friction and both kinds of drag, reversals on a bowl
# ----------------------------------------------------------------------------
BOWL_SWEEP = rw.Sweep.random(24, seed=5, x0=(-0.95, 0.95), v0=(-2.5, 2.5), mu=(0.1, 0.3),
                             drag_linear=(0.0, 1.0), drag_quadratic=(0.0, 1.5))


def bowl_scene(integrator, **kwargs) -> rw.Scene:
    return rw.Scene(ramp=BOWL, friction=rw.Friction(0.2), integrator=integrator, x0=0.0,
                    t_max=30.0, drag=rw.Drag(0.3, 0.5), **kwargs)


@pytest.mark.parametrize("method, settings, tolerance", [
    ("euler", dict(dt=1e-4), 2e-3),
    ("semi_implicit_euler", dict(dt=1e-4), 2e-3),
    ("rk4", dict(dt=1e-3), 1e-9),
    ("dopri5", dict(rtol=1e-10, atol=1e-12), 1e-8),
    ("dop853", dict(rtol=1e-12, atol=1e-14), 1e-11),
])
def test_energy_balance_with_friction_and_drag(method, settings, tolerance):
    """W_friction + W_drag equals the mechanical energy lost, to the method's
    accuracy (relative to the energy lost), on trajectories with reversals.
    The adaptive pairs project every step onto that balance
    (docs/physics.md 1.6): their energy_balance_error, the residuals removed
    plus what is left, must be within the same accuracy, and without the
    projection it is W_friction + W_drag - W_energy as for fixed steps."""
    ds = rw.simulate(bowl_scene(rw.Integrator(method, **settings)), BOWL_SWEEP, threads=1)
    runs = [ds]
    if method in ("dopri5", "dop853"):
        runs.append(rw.simulate(bowl_scene(rw.Integrator(method, project_energy=False, **settings)),
                                BOWL_SWEEP, threads=1))
    for k, run in enumerate(runs):
        w_f, w_d, w_e = run.W_friction.values, run.W_drag.values, run.W_energy.values
        assert run.n_reversals.values.max() >= 2 and (run.n_reversals.values > 0).mean() > 0.5
        assert (w_f > 0).all() and (w_d > 0).all() and (w_e > 0).all()
        error = w_f + w_d - w_e
        assert np.abs(error / w_e).max() < tolerance
        assert np.abs(run.energy_balance_error.values / w_e).max() < tolerance
        if k == len(runs) - 1:  # not projected
            assert np.allclose(run.energy_balance_error.values, error, rtol=1e-12, atol=1e-15)
        else:  # projected: the balance holds far below the method's accuracy
            assert np.abs(error / w_e).max() < 1e-3 * tolerance
    assert "W_friction + W_drag - W_energy" in ds.energy_balance_error.attrs["comment"]


# ----------------------------------------------------------------------------
# against the scipy reference
# ----------------------------------------------------------------------------
# stops after 1-3 reversals, exits, and one trajectory without drag
REFERENCE_CASES = rw.Sweep.cases(x0=[-0.9, 0.5, 0.0, 0.8, -0.3, 0.95, 0.6],
                                 v0=[0.0, -2.0, 3.0, 2.5, -4.0, 1.0, 5.0],
                                 mu=[0.1, 0.2, 0.3, 0.1, 0.15, 0.25, 0.1],
                                 drag_linear=[0.3, 0.0, 0.8, 0.2, 0.1, 0.5, 0.0],
                                 drag_quadratic=[0.5, 1.2, 0.0, 0.1, 0.2, 0.3, 0.0])


def _reference_check(reference, scene, sweep, tolerance):
    ds = rw.simulate(scene, sweep, threads=1)
    ref = reference.reference_sweep(scene, sweep, rtol=1e-13, atol=1e-13)
    assert (ds.status.values == ref["status"]).all()
    for name in ("x_end", "v_end", "W_friction", "W_drag", "t_end"):
        np.testing.assert_allclose(ds[name].values, ref[name], rtol=0, atol=tolerance, err_msg=name)
    return ds


@pytest.mark.parametrize("method, settings, tolerance", [
    ("rk4", dict(dt=1e-3), 1e-8),
    ("dopri5", dict(rtol=1e-12, atol=1e-12), 1e-8),
    ("dop853", dict(rtol=1e-13, atol=1e-13), 1e-9),
])
def test_reference_on_a_bowl(reference, method, settings, tolerance):
    """Stops, reversals and exits with both kinds of drag and friction."""
    ds = _reference_check(reference, bowl_scene(rw.Integrator(method, **settings)),
                          REFERENCE_CASES, tolerance)
    assert set(ds.status.values.tolist()) == {1, 2} and ds.n_reversals.values.max() == 3


@pytest.mark.parametrize("method", ["dopri5", pytest.param("dop853", marks=pytest.mark.slow)])
def test_reference_lift_off_on_a_dome(reference, method):
    """The drag work at a lift-off located on the pair's dense output."""
    scene = rw.Scene(ramp=rw.Ramp.create("circular_dome", radius=1.0, domain=(-0.9, 0.9)),
                     friction=rw.Friction(0.1), integrator=rw.Integrator(method, rtol=1e-12),
                     x0=-0.3, t_max=10.0, drag=rw.Drag(0.4, 0.6))
    sweep = rw.Sweep.cases(v0=[0.8, 1.5, 2.5, 3.5, -1.0])
    ds = _reference_check(reference, scene, sweep, 1e-8)
    assert (ds.status.values == 3).sum() >= 3  # lifted off
    np.testing.assert_allclose(ds.x_lift_off.values,
                               reference.reference_sweep(scene, sweep, rtol=1e-13,
                                                         atol=1e-13)["x_lift_off"],
                               atol=1e-8)


# ----------------------------------------------------------------------------
# pruning: without drag, the arithmetic of a build without the feature
# ----------------------------------------------------------------------------
def _raw(scene, sweep, **drag_flags):
    """The kernel's raw outputs for a plan, from a kernel built with drag_flags."""
    plan = runner.plan_run(scene, sweep)
    spec = scene.ramp.spec
    variant = KernelVariant(spec.key, scene.integrator.method,
                            one_sided=scene.contact == "one_sided",
                            check_contact=plan.variant.check_contact,
                            carry_slope=plan.variant.carry_slope, **drag_flags)
    run_batch, _ = K.build_kernel(variant, spec.height, spec.slope_curvature)
    out = np.zeros((K.N_OUTPUTS, plan.size))
    run_batch(runner.chunk_inputs(plan, 0, plan.size), runner._settings(scene), out,
              scene.ramp.shared_array(), 64)
    return out


NO_DRAG_SWEEP = rw.Sweep.random(24, seed=5, x0=(-0.95, 0.95), v0=(-2.5, 2.5), mu=(0.1, 0.3))


# semi-implicit Euler (two kernels of its own) in the slow suite
@pytest.mark.parametrize("method, settings", [
    ("euler", dict(dt=1e-3)), ("rk4", dict(dt=1e-3)),
    pytest.param("semi_implicit_euler", dict(dt=1e-3), marks=pytest.mark.slow)])
def test_zero_drag_is_bit_identical_for_fixed_steps(method, settings):
    """A kernel built with both drag terms but given b = c = 0 does the same
    arithmetic where it matters: the drag rate is exactly 0, fma(-0, v, a) is
    a, and the added tests (drag work >= 0) always hold.  So its results
    equal those of the kernel without drag bit for bit (and that kernel is
    the one build_kernel makes by default, as before drag existed)."""
    scene = bowl_scene(rw.Integrator(method, **settings)).replace(drag=rw.Drag())
    plain = _raw(scene, NO_DRAG_SWEEP)
    off = _raw(scene, NO_DRAG_SWEEP, drag_linear=False, drag_quadratic=False)
    on = _raw(scene, NO_DRAG_SWEEP, drag_linear=True, drag_quadratic=True)
    assert np.array_equal(plain, off, equal_nan=True)
    assert np.array_equal(on, off, equal_nan=True)
    assert (on[K.OUT_DRAG_WORK] == 0.0).all()
    assert on[K.OUT_NREV].max() >= 3


def test_zero_drag_is_bit_identical_for_an_euler_exit():
    """A trajectory that leaves the bowl: explicit Euler locates its events in
    closed form with drag compiled in too (the drag rate is the step start's),
    so zero drag ends on the same bits as no drag (it used to root-find the
    exit with drag on and end a few ulps apart)."""
    scene = bowl_scene(rw.Integrator("euler", dt=1e-3)).replace(drag=rw.Drag())
    sweep = rw.Sweep.cases(x0=[0.6794002416175917], v0=[2.1254605859868407], mu=[0.1842743345913863])
    off = _raw(scene, sweep, drag_linear=False, drag_quadratic=False)
    on = _raw(scene, sweep, drag_linear=True, drag_quadratic=True)
    assert on[K.OUT_STATUS, 0] == 2  # exited
    assert np.array_equal(on, off, equal_nan=True)


@pytest.mark.parametrize("method", ["dopri5", pytest.param("dop853", marks=pytest.mark.slow)])
def test_zero_drag_adaptive_agrees_within_tolerance(method):
    """Adaptive pairs with the drag terms compiled in but b = c = 0: the drag
    work is exactly 0, but the error norm is the RMS over five components
    instead of four (the fifth 0), so step sizes and hence results differ
    within the tolerance, not bit for bit."""
    scene = bowl_scene(rw.Integrator(method, rtol=1e-10, atol=1e-12)).replace(drag=rw.Drag())
    off = _raw(scene, NO_DRAG_SWEEP)
    on = _raw(scene, NO_DRAG_SWEEP, drag_linear=True, drag_quadratic=True)
    assert (on[K.OUT_DRAG_WORK] == 0.0).all() and (off[K.OUT_DRAG_WORK] == 0.0).all()
    assert np.array_equal(on[K.OUT_STATUS], off[K.OUT_STATUS])
    assert np.array_equal(on[K.OUT_NREV], off[K.OUT_NREV])
    for row in (K.OUT_X, K.OUT_V, K.OUT_WORK, K.OUT_T):
        np.testing.assert_allclose(on[row], off[row], rtol=0, atol=1e-7)


def test_scene_without_drag_has_no_drag_output():
    scene = bowl_scene(rw.Integrator("rk4", dt=1e-3)).replace(drag=rw.Drag())
    plan = runner.plan_run(scene, NO_DRAG_SWEEP)
    assert not plan.variant.drag_linear and not plan.variant.drag_quadratic
    ds = rw.simulate(scene, NO_DRAG_SWEEP, threads=1)
    assert "W_drag" not in ds and "drag_linear" not in ds.attrs
    assert "[drag]" not in ds.attrs["rampwork_scene"]
    np.testing.assert_array_equal(ds.energy_balance_error.values,
                                  ds.W_friction.values - ds.W_energy.values)
    raw = _raw(scene, NO_DRAG_SWEEP)
    np.testing.assert_array_equal(ds.x_end.values, raw[K.OUT_X])
    np.testing.assert_array_equal(ds.W_friction.values, raw[K.OUT_WORK] * scene.m)


def test_flags_follow_the_run():
    """Only the terms some trajectory has are compiled in."""
    scene = bowl_scene(rw.Integrator("rk4"))
    plan = runner.plan_run(scene.replace(drag=rw.Drag(linear=0.5)))
    assert plan.variant.drag_linear and not plan.variant.drag_quadratic
    plan = runner.plan_run(scene.replace(drag=rw.Drag()),
                           rw.Sweep.grid(drag_quadratic=[0.0, 0.2]))
    assert plan.variant.drag_quadratic and not plan.variant.drag_linear
    plan = runner.plan_run(scene.replace(drag=rw.Drag(0.0, 0.3)),
                           rw.Sweep.grid(drag_quadratic=[0.0]))
    assert not plan.variant.drag


# ----------------------------------------------------------------------------
# the dataset and the scene file
# ----------------------------------------------------------------------------
def test_dataset_variables_and_attributes():
    scene = flat_scene("linear", rw.Integrator("rk4", dt=1e-3))
    ds = rw.simulate(scene, rw.Sweep.grid(drag_linear=[B, 2 * B]), threads=1)
    attrs = ds.W_drag.attrs
    assert attrs["units"] == "J" and attrs["long_name"] == "work against air drag"
    assert ds.drag_linear.attrs["units"] == "s-1"
    assert ds.W_energy.attrs["long_name"] == "mechanical energy lost"
    assert ds.attrs["drag_linear"] == B and ds.attrs["drag_quadratic"] == 0.0
    again, sweep = parse_scene(ds.attrs["rampwork_scene"])
    assert again.drag == scene.drag and sweep.names == ("drag_linear",)
    assert ds.W_drag.values[1] > ds.W_drag.values[0] > 0


def test_netcdf_file_written_chunk_by_chunk(tmp_path):
    """A streamed file holds W_drag and the scene with its drag, and reads
    back equal to the in-memory run."""
    scene = flat_scene("linear", rw.Integrator("rk4", dt=1e-3))
    sweep = rw.Sweep.grid(drag_linear=[0.1, B, 1.5], v0=[1.0, -2.0])
    path = rw.run_to_file(scene, sweep, tmp_path / "drag.nc", chunk_size=2, threads=1)
    stored = rw.open_dataset(path)
    memory = rw.simulate(scene, sweep, threads=1)
    np.testing.assert_array_equal(stored.W_drag.values, memory.W_drag.values)
    np.testing.assert_array_equal(stored.energy_balance_error.values,
                                  memory.energy_balance_error.values)
    assert stored.W_drag.attrs["units"] == "J" and stored.drag_linear.attrs["units"] == "s-1"
    assert parse_scene(stored.attrs["rampwork_scene"]) == (scene, sweep)


def test_scene_file_round_trip():
    scene = flat_scene("quadratic", rw.Integrator("dopri5", rtol=1e-9)).replace(
        drag=rw.Drag(0.25, 0.125))
    sweep = rw.Sweep.cases(drag_linear=[0.0, 0.5], drag_quadratic=[1.0, 0.0])
    text = dump_scene(scene, sweep)
    assert "[drag]\nlinear = 0.25\nquadratic = 0.125" in text
    assert parse_scene(text) == (scene, sweep)
    assert "[drag]" not in dump_scene(scene.replace(drag=rw.Drag()))


# ----------------------------------------------------------------------------
# bad input
# ----------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["linear", "quadratic"])
@pytest.mark.parametrize("value", [-1.0, math.nan, math.inf, -math.inf, "0.1", True])
def test_bad_coefficients(name, value):
    with pytest.raises(ConfigError) as error:
        rw.Drag(**{name: value})
    assert error.value.where == f"drag.{name}"


def test_bad_drag_field_and_sweep_axis():
    with pytest.raises(ConfigError) as error:
        rw.Scene(ramp=FLAT, x0=0.0, drag=0.5)
    assert error.value.where == "drag"
    with pytest.raises(ConfigError) as error:
        runner.plan_run(rw.Scene(ramp=FLAT, x0=0.0), rw.Sweep.grid(drag_quadratic=[0.1, -0.1]))
    assert error.value.where == "sweep.drag_quadratic"


def _scene_file(tmp_path, drag_table: str):
    path = tmp_path / "drag.toml"
    path.write_text('x0 = 0.0\nv0 = 1.0\nt_max = 1.0\n[ramp]\nfamily = "straight"\nslope = 0.0\n'
                    f'domain = [-10.0, 10.0]\n[drag]\n{drag_table}\n', encoding="utf-8")
    return path


def _error_line(capsys) -> str:
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("rampwork: error: "), err
    return lines[0]


@pytest.mark.parametrize("table, expected", [
    ("linear = -1", "drag.linear"),
    ("quadratic = nan", "drag.quadratic"),
    ("cubic = 1.0", "[drag] unknown key 'cubic'"),
])
def test_bad_scene_file_exits_2(tmp_path, capsys, table, expected):
    path = _scene_file(tmp_path, table)
    assert main(["check", str(path)]) == 2
    line = _error_line(capsys)
    assert expected in line and str(path) in line


def test_scene_file_check_prints_drag(tmp_path, capsys):
    path = _scene_file(tmp_path, "linear = 0.5\nquadratic = 0.25")
    assert main(["check", str(path)]) == 0
    assert "linear = 0.5 s-1, quadratic = 0.25 m-1" in capsys.readouterr().out
