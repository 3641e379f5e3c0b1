"""Curve scenes through the one entry point (docs/physics.md §5): scene files
with a ``[curve]`` table, ``rampwork.simulate`` datasets, the CLI, and the
horizontal-path baseline and mean curvature against closed forms."""

from __future__ import annotations

import math

import numpy as np
import pytest

import rampwork as rw
from rampwork.core.threads import max_threads
from rampwork import cli, schema
from rampwork.cli import main
from rampwork.curve_scene import CurveScene
from rampwork.curves import Curve, simulate_curve
from rampwork.errors import ConfigError
from rampwork.scenefile import dump_scene, parse_scene, scene_from_dataset

G = 9.81
CURVE_EXAMPLES = ("loop", "quarter_pipe", "brachistochrone", "track")

LOOP = """\
title = "loop"
s0 = 0.0
u0 = 7.0
[curve]
family = "loop"
radius = 1.0
[friction]
mu_k = 0.0
"""


def parse(text: str):
    return parse_scene(text, "scene.toml")


# ------------------------------------------------------------------------------
# scene files
# ------------------------------------------------------------------------------
@pytest.mark.parametrize("name", CURVE_EXAMPLES)
def test_curve_examples_parse_and_round_trip(name):
    scene, sweep = parse(cli.example_text(name))
    assert isinstance(scene, CurveScene) and scene.curve.family == name
    assert 1 < sweep.size <= 1000
    text = dump_scene(scene, sweep)
    assert parse(text) == (scene, sweep)
    assert dump_scene(*parse(text)) == text


def test_loop_track_scene_runs_and_reads_back():
    text = LOOP.replace('family = "loop"\nradius = 1.0', 'family = "loop_track"\nradius = 1.0\nblend_length = 0.5')
    scene, sweep = parse(text + "[sweep.axes]\nu0 = [6.0, 8.0]\n")
    dataset = rw.simulate(scene, sweep)
    codes = {name: code for code, name, _ in rw.STATUS_TABLE}
    # without friction the loop is cleared iff u0^2 >= 5 g R (the blends change that by ~1e-3)
    assert list(dataset["status"].values) == [codes["lifted_off"], codes["exited"]]
    again, sweep_again = scene_from_dataset(dataset)
    assert again == scene and sweep_again == sweep


SPLINE = """\
title = "spline through a circle's points"
s0 = 0.0
u0 = 9.0
[curve]
family = "spline"
x_points = [0.0, 0.7071067811865476, 1.0, 0.7071067811865476, 0.0, -0.7071067811865476]
y_points = [0.0, 0.2928932188134524, 1.0, 1.7071067811865475, 2.0, 1.7071067811865475]
end = "clamped"
end_tangents = [[1.0, 0.0], [-1.0, -1.0]]
[sweep.axes]
mu = [0.0, 0.1]
"""


def test_a_spline_through_points_reads_back_from_its_file_and_dataset():
    scene, sweep = parse(SPLINE)
    assert scene.curve.family == "spline" and scene.curve.points[2] == "clamped"
    text = dump_scene(scene, sweep)
    assert parse(text) == (scene, sweep) and dump_scene(*parse(text)) == text
    dataset = rw.simulate(scene, sweep)
    assert dataset.sizes["mu"] == 2
    again = scene_from_dataset(dataset)
    assert again == (scene, sweep)
    # the same spline built in Python runs the same trajectories
    direct = simulate_curve(Curve.through_points(
        scene.curve.points[0], scene.curve.points[1], end="clamped", end_tangents=[[1.0, 0.0], [-1.0, -1.0]]),
        s0=0.0, u0=9.0, mu_k=np.array([0.0, 0.1]), method="rk4", dt=1e-3, t_max=scene.t_max)
    np.testing.assert_array_equal(dataset["s_end"].values, direct["p_end"])


@pytest.mark.parametrize("change, where", [
    ('x_points = [0.0, 1.0]\ny_points = [0.0, 1.0]', "curve.x_points"),
    ('x_points = [0.0, 1.0, 2.0]\ny_points = [0.0, 1.0, 0.0]\nend = "cubic"', "curve.end"),
    ('x_points = [0.0, 1.0, 2.0]\ny_points = [0.0, 1.0, 0.0]\nradius = 1.0', "curve"),
])
def test_spline_scene_errors_name_the_key(change, where):
    text = f'u0 = 1.0\n[curve]\nfamily = "spline"\n{change}\n'
    with pytest.raises(ConfigError, match=f"{where}"):
        parse(text)


def test_curve_examples_are_listed(capsys):
    assert main(["example"]) == 0
    out = capsys.readouterr().out
    assert all(name in out for name in CURVE_EXAMPLES) and "straight" in out


@pytest.mark.parametrize("change, where, words", [
    ('[ramp]\nfamily = "straight"\nslope = -0.1\ndomain = [0.0, 1.0]\n', "curve", "exactly one"),
    ("x0 = 0.1\n", "x0", "s0"),
    ("diagnostics = [\"x_lift_off_paper\"]\n", "diagnostics", "diagnostics"),
])
def test_a_curve_scene_refuses_what_is_for_ramps(change, where, words):
    text = (change + LOOP) if not change.startswith("[") else (LOOP + change)
    with pytest.raises(ConfigError) as error:
        parse(text)
    assert where in error.value.where + error.value.problem and words in str(error.value)


@pytest.mark.parametrize("old, new, where", [
    ('family = "loop"', 'family = "helix"', "curve.family"),
    ("radius = 1.0", "radius = -1.0", "curve.radius"),
    ("radius = 1.0", "radius = 1.0\nslope = 2.0", "curve"),
    ("radius = 1.0", 'radius = 1.0\nside = "up"', "curve.side"),
    ("radius = 1.0", "radius = 1.0\nexit_angle = 7.0", "curve.exit_angle"),
    ("s0 = 0.0", "s0 = 7.0", "s0"),
    ("s0 = 0.0", "", "s0"),
    ("mu_k = 0.0", "mu_k = 0.0\n[integrator]\nmethod = \"leapfrog\"", "integrator.method"),
    ("mu_k = 0.0", "mu_k = 0.0\n[sweep.axes]\nx0 = [0.1]", "sweep"),
])
def test_curve_scene_errors_name_the_key(old, new, where):
    with pytest.raises(ConfigError) as error:
        parse(LOOP.replace(old, new))
    assert error.value.where.startswith("scene.toml")
    assert where in str(error.value)


def test_swept_mu_s_below_mu_k_is_refused_before_any_work(monkeypatch):
    from rampwork.curves import CurveRun

    monkeypatch.setattr(CurveRun, "compile", lambda self: pytest.fail("compiled"))
    scene, sweep = parse(LOOP + "[sweep.axes]\nmu_k = [0.1, 0.3]\nmu_s = [0.2]\n")
    with pytest.raises(ConfigError, match="mu_s"):
        rw.simulate(scene, sweep)


def test_contact_is_given_once():
    text = LOOP.replace("radius = 1.0", 'radius = 1.0\ncontact = "two_sided"')
    assert parse(text)[0].contact == "two_sided"
    with pytest.raises(ConfigError, match="given twice"):
        parse('contact = "two_sided"\n' + text)


# ------------------------------------------------------------------------------
# the dataset contract
# ------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def loop_dataset():
    scene, sweep = parse(cli.example_text("loop"))
    return scene, sweep, rw.simulate(scene, sweep)


def test_dataset_has_the_registry_names_units_and_flags(loop_dataset):
    scene, sweep, ds = loop_dataset
    assert ds.status.dims == ("radius", "mu") and ds.status.shape == (7, 3)
    assert tuple(ds.data_vars) == schema.curve_output_names()
    for name in ds.data_vars:
        spec = schema.CURVE_OUTPUTS[name]
        assert ds[name].attrs["units"] == spec.units and ds[name].attrs["long_name"] == spec.long_name
        assert ds[name].dtype == spec.np_dtype
    assert ds.radius.attrs["units"] == "m" and ds.mu.attrs["long_name"] == "friction coefficient"
    np.testing.assert_array_equal(ds.status.attrs["flag_values"], schema.STATUS_FLAG_VALUES)
    assert ds.attrs["Conventions"] == schema.CONVENTIONS
    assert "rampwork.simulate" in ds.attrs["history"] and ds.attrs["curve_family"] == "loop"
    assert ds.attrs["compile_time_s"] >= 0 and ds.attrs["run_time_s"] >= 0
    assert scene_from_dataset(ds) == (scene, sweep)


def test_dataset_values_are_the_direct_runs(loop_dataset):
    """The sweep's labels select the right trajectories: each equals a direct
    simulate_curve run of its own values, bit for bit."""
    _, _, ds = loop_dataset
    for radius, mu in ((0.6, 0.0), (1.0, 0.05), (1.2, 0.1)):
        one = ds.sel(radius=radius, mu=mu)
        out = simulate_curve(Curve.create("loop", radius=radius), s0=0.0, u0=7.0, mu_k=mu,
                             method="rk4", dt=1e-3, t_max=5.0)
        for name in ("t_end", "u_end", "W_friction", "nu_min", "path_length_X"):
            assert one[name].item() == out[name][()], name
        assert one.s_end.item() == out["p_end"][()]


def test_loop_example_clears_iff_five_g_r_without_friction(loop_dataset):
    _, _, ds = loop_dataset
    cleared = ds.status.sel(mu=0.0).values == rw.STATUS_TABLE[2][0]
    expected = 7.0 ** 2 >= 5 * G * ds.radius.values
    np.testing.assert_array_equal(cleared, expected)
    lifted = ds.sel(mu=0.0).where(~expected)
    # where it leaves: nu = 0 with u^2 = u0^2 - 2 g R (1 - cos theta) -> cos theta = (2 g R - u0^2) / (3 g R)
    radius = ds.radius.values
    theta = np.arccos(np.clip((2 * G * radius - 49.0) / (3 * G * radius), -1, 1))
    np.testing.assert_allclose(lifted.s_lift_off.values[~expected], (radius * theta)[~expected],
                               atol=1e-9)


def test_cases_and_designs_give_a_case_dimension():
    scene = CurveScene(curve=Curve.create("loop", radius=1.0), s0=0.0, t_max=2.0)
    ds = rw.simulate(scene, rw.Sweep.cases(u0=[6.0, 7.5], radius=[1.0, 0.9]))
    assert ds.status.dims == ("case",) and list(ds.u0.values) == [6.0, 7.5]
    assert list(ds.case.values) == [0, 1]
    design = rw.simulate(scene, rw.Sweep.random(5, seed=3, u0=(5.0, 8.0)))
    assert design.status.dims == ("case",) and design.u0.size == 5
    assert ((design.u0 >= 5.0) & (design.u0 <= 8.0)).all()


def test_air_drag_adds_its_work():
    scene = CurveScene(curve=Curve.create("loop", radius=1.0), s0=0.0, u0=8.0, t_max=2.0,
                       drag=rw.Drag(linear=0.1))
    ds = rw.simulate(scene)
    assert "W_drag" in ds and ds.W_drag.item() > 0
    assert abs(ds.energy_balance_error.item()) < 1e-9
    assert "W_drag" not in rw.simulate(scene.replace(drag=rw.Drag()))


# ------------------------------------------------------------------------------
# the horizontal-path baseline and the mean curvature against closed forms
# ------------------------------------------------------------------------------
def _arc_speed_squared(phi, phi0, w0, mu, radius):
    """u^2 on a circular arc (inside, moving up, counter-clockwise) with
    friction: d(u^2)/dphi = -2 mu u^2 - 2 g R (sin phi + mu cos phi)."""
    a = 2 * mu

    def primitive(psi):
        return math.exp(a * (psi - phi0)) * ((a * math.sin(psi) - math.cos(psi))
                                             + mu * (a * math.cos(psi) + math.sin(psi))) / (1 + a * a)

    return math.exp(-a * (phi - phi0)) * (w0 - 2 * G * radius * (primitive(phi) - primitive(phi0)))


@pytest.mark.parametrize("method, tol", [("rk4", 1e-9), ("dopri5", 1e-7), ("dop853", 1e-7)])
def test_circular_arc_with_friction_path_baseline_and_curvature(method, tol):
    """An arc from -0.5 rad to 2.5 rad: X = R sin theta turns back at the
    vertical tangent theta = pi/2, so ∫|dX| = R (1 - sin(-0.5)) + R (1 - sin 2.5),
    and the mean curvature is 1/R."""
    radius, mu, u0, m = 0.8, 0.2, 10.0, 2.0
    scene = CurveScene(curve=Curve.create("loop", radius=radius, entry_angle=-0.5, exit_angle=2.5),
                       s0=-0.5 * radius, u0=u0, m=m, friction=rw.Friction(mu),
                       integrator=rw.Integrator(method, 1e-3, **({"rtol": 1e-11} if method in ("dopri5", "dop853") else {})))
    ds = rw.simulate(scene)
    assert ds.status.item() == 2
    path_x = radius * (2.0 - math.sin(-0.5) - math.sin(2.5))
    assert ds.path_length_X.item() == pytest.approx(path_x, rel=1e-14)
    assert ds.W_path.item() == pytest.approx(mu * m * G * path_x, rel=1e-14)
    u_end = math.sqrt(_arc_speed_squared(2.5, -0.5, u0 * u0, mu, radius))
    work = m * (0.5 * u0 ** 2 - 0.5 * u_end ** 2 - G * radius * (math.cos(-0.5) - math.cos(2.5)))
    assert ds.W_friction.item() == pytest.approx(work, rel=tol)
    assert ds.W_excess.item() == pytest.approx(work - mu * m * G * path_x, rel=10 * tol)
    assert ds.curvature_mean.item() == pytest.approx(1.0 / radius, rel=1e-12)
    assert ds.path_length.item() == pytest.approx(3.0 * radius, rel=tol)


def test_a_full_loop_travels_four_radii_horizontally():
    radius = 0.7
    scene = CurveScene(curve=Curve.create("loop", radius=radius), s0=0.0, u0=8.0)
    ds = rw.simulate(scene)
    assert ds.status.item() == 2
    assert ds.path_length_X.item() == pytest.approx(4 * radius, rel=1e-14)
    assert ds.X_end.item() == pytest.approx(0.0, abs=1e-14) and ds.W_path.item() == 0.0


@pytest.mark.parametrize("ramp", [
    rw.Ramp.create("quadratic", curvature=1.5, slope=-0.5, domain=(-1.5, 1.5)),
    rw.Ramp.create("sine", amplitude=0.2, wavenumber=4.0, domain=(-1.5, 1.5)),
    rw.Ramp.create("circular_dome", radius=1.0, domain=(-0.9, 0.9)),
], ids=lambda r: r.family)
def test_wrapped_ramp_baseline_is_the_ramp_kernels(ramp):
    """A y = f(x) ramp as a curve: ∫|dX| is the ramp kernel's horizontal
    path (its W_path), reversals included; and where the block moves one
    way, the mean curvature is the net turning over the arc length,
    (atan f'(x_end) - atan f'(x0)) / ∫|ds|."""
    rng = np.random.default_rng(3)
    n = 24
    lo, hi = ramp.domain
    mu = rng.uniform(0, 0.4, n)
    x0 = rng.uniform(0.9 * lo, 0.9 * hi, n)
    v0 = rng.uniform(-2, 2, n)
    scene = rw.Scene(ramp=ramp, integrator=rw.Integrator("rk4", dt=1e-3, closed_form=False), t_max=5.0)
    ds = rw.simulate(scene, rw.Sweep.cases(mu=mu, x0=x0, v0=v0))
    _, fp0, _ = ramp.evaluate(x0)
    out = simulate_curve(Curve.from_ramp(ramp), s0=x0, u0=v0 * np.sqrt(1 + fp0 ** 2), mu_k=mu,
                         method="rk4", dt=1e-3, t_max=5.0)
    np.testing.assert_array_equal(out["status"], ds.status.values)
    np.testing.assert_allclose(out["path_length_X"], ds.path_length_x.values, atol=1e-8)
    np.testing.assert_allclose(mu * G * out["path_length_X"], ds.W_path.values, atol=1e-8)
    one_way = (out["n_reversals"] == 0) & (out["path_length"] > 0)
    assert one_way.sum() >= 3
    _, fp_end, _ = ramp.evaluate(out["p_end"])
    direction = np.sign(v0 + (v0 == 0) * -fp0)
    turning = direction * (np.arctan(fp_end) - np.arctan(fp0))
    np.testing.assert_allclose(out["curvature_mean"][one_way],
                               turning[one_way] / out["path_length"][one_way], rtol=1e-7, atol=1e-9)


# ------------------------------------------------------------------------------
# the command line
# ------------------------------------------------------------------------------
def _example_file(tmp_path, name):
    path = tmp_path / f"{name}.toml"
    path.write_text(cli.example_text(name), encoding="utf-8")
    return path


def test_cli_runs_a_curve_scene_to_netcdf(tmp_path, capsys):
    scene_path = _example_file(tmp_path, "brachistochrone")
    output = tmp_path / "out.nc"
    assert main(["run", str(scene_path), "-o", str(output)]) == 0
    out = capsys.readouterr().out
    assert "compile time" in out and "exited 5" in out
    ds = rw.open_dataset(output)
    assert ds.status.dims == ("mu",) and (ds.status.values == 2).all()
    # the cycloid's bottom: from s0 just below the cusp without friction, close to pi sqrt(r/g)
    assert ds.t_end.sel(mu=0.0).item() == pytest.approx(math.pi * math.sqrt(0.5 / G), rel=1e-2)
    assert (np.diff(ds.t_end.values) > 0).all()  # friction slows it down
    again = tmp_path / "again.nc"
    assert main(["run", str(output), "-o", str(again), "--set", "curve.radius=0.25"]) == 0
    assert rw.open_dataset(again).attrs["curve_radius"] == 0.25


def test_cli_check_and_refusals(tmp_path, capsys):
    scene_path = _example_file(tmp_path, "quarter_pipe")
    assert main(["check", str(scene_path)]) == 0
    assert "quarter_pipe" in capsys.readouterr().out
    # curve scenes run on threads (SIMD lanes over tiles): the same bits as one thread
    outputs = []
    for threads in ("1", str(min(2, max_threads()))):
        outputs.append(tmp_path / f"threads{threads}.nc")
        assert main(["run", str(scene_path), "-o", str(outputs[-1]), "--threads", threads,
                     "--quiet"]) == 0
    one, more = (rw.open_dataset(path) for path in outputs)
    for name in one.data_vars:
        np.testing.assert_array_equal(one[name].values, more[name].values, err_msg=name)
    assert main(["run", str(scene_path), "-o", str(tmp_path / "x.nc"), "--threads", "0"]) == 2
    assert "threads" in capsys.readouterr().err
    bad = tmp_path / "bad.toml"
    bad.write_text(cli.example_text("loop").replace("radius = 1.0 ", "radius = -1.0 "), encoding="utf-8")
    assert main(["check", str(bad)]) == 2
    assert "curve.radius" in capsys.readouterr().err
    assert not (tmp_path / "x.nc").exists()
