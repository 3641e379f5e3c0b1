"""Sweeps of single spline coordinates by name (docs/physics.md §5.2): a
spline through n points takes x0 .. x{n-1} and y0 .. y{n-1} as sweep axes;
each value gives one spline of a population run through ``row`` (the spline
kernel compiled once, as tests/test_curves_spline_sweep.py's), bit for bit
the splines built by hand; values that break the spline are refused by name."""

import math

import numpy as np
import pytest

import rampwork as rw
from rampwork.curves import Curve, simulate_curve
from rampwork.errors import ConfigError
from rampwork.scenefile import dump_scene, parse_scene

THETA = np.linspace(0.0, 1.5 * math.pi, 9)
X = np.sin(THETA)
Y = 1.0 - np.cos(THETA)
OUTPUTS = ("t_end", "p_end", "u_end", "X_end", "Y_end", "W_friction", "nu_min", "path_length_X",
           "p_lift_off", "steps", "status")


def _equal(a, b):
    return a == b or (np.isnan(a) and np.isnan(b))


def test_a_swept_coordinate_equals_the_splines_built_by_hand_bit_for_bit():
    heights = np.array([Y[2], 1.1 * Y[2], 0.8 * Y[2], 1.25 * Y[2]])
    u0 = np.array([8.0, 3.0, 9.0])  # lift-offs; back down and out at the start
    swept = simulate_curve(Curve.through_points(X, Y), s0=0.0, u0=u0[:, None], mu_k=0.1,
                           y2=heights[None, :], method="rk4", dt=1e-3)
    assert swept["t_end"].shape == (3, 4)
    assert len(set(swept["status_name"].ravel().tolist())) >= 2
    rows = np.tile(Y, (heights.size, 1))
    rows[:, 2] = heights
    by_hand = simulate_curve(Curve.through_points(X, rows), s0=0.0, u0=u0[:, None], mu_k=0.1,
                             row=np.arange(heights.size)[None, :], method="rk4", dt=1e-3)
    for name in OUTPUTS:
        np.testing.assert_array_equal(swept[name], by_hand[name], err_msg=name)
    # two coordinates of one point, on a population's second row
    xs = np.stack([X, 1.1 * X])
    both = simulate_curve(Curve.through_points(xs, Y, row=1), s0=0.0, u0=8.0, mu_k=0.1,
                          x3=[1.05, 1.15], y3=[1.2, 1.1], method="rk4", dt=1e-3)
    for k, (x3, y3) in enumerate(((1.05, 1.2), (1.15, 1.1))):
        x, y = 1.1 * X, Y.copy()
        x[3], y[3] = x3, y3
        alone = simulate_curve(Curve.through_points(x, y), s0=0.0, u0=8.0, mu_k=0.1,
                               method="rk4", dt=1e-3)
        for name in OUTPUTS:
            assert _equal(both[name][k], alone[name]), (name, k)


@pytest.mark.parametrize("sweep, where, words", [
    ({"y9": [1.0]}, "curve.y9", "9 points"),
    ({"z2": [1.0]}, "curve.z2", "x0 .. x8"),
    ({"y2": [0.6, math.nan]}, "curve.y2", "finite"),
    ({"x2": 0.4, "y2": [0.6, 2.5]}, "curve.x2", "x2 = 0.4, y2 = 2.5.*crosses itself"),
    ({"x2": [X[3]], "y2": [Y[3]]}, "curve.x2", "distinct"),
    ({"x2": [0.5, -1.8], "y2": 0.3}, "curve.x2", "x2 = -1.8, y2 = 0.3.*not regular"),
])
def test_coordinates_that_break_the_spline_are_refused_by_name(sweep, where, words):
    with pytest.raises(ConfigError, match=words) as error:
        simulate_curve(Curve.through_points(X, Y), s0=0.0, u0=8.0, mu_k=0.1, **sweep)
    assert error.value.where == where


SCENE = f"""\
title = "a spline's third point, swept"
s0 = 0.0
u0 = 8.0
[curve]
family = "spline"
x_points = {X.tolist()}
y_points = {Y.tolist()}
[friction]
mu_k = 0.1
mu_s = 0.1
[sweep.axes]
y2 = [0.55, 0.65, 0.75]
"""


def test_a_scene_sweeps_a_coordinate_by_name():
    scene, sweep = parse_scene(SCENE)
    assert "y2" in scene.axis_names and sweep.names == ("y2",)
    dataset = rw.simulate(scene, sweep)
    assert dataset["y2"].attrs["units"] == "m" and dataset.sizes["y2"] == 3
    direct = simulate_curve(Curve.through_points(X, Y), s0=0.0, u0=8.0, mu_k=0.1,
                            y2=[0.55, 0.65, 0.75], method="rk4", dt=1e-3, t_max=scene.t_max)
    np.testing.assert_array_equal(dataset["s_end"].values, direct["p_end"])
    assert parse_scene(dump_scene(scene, sweep)) == (scene, sweep)


def test_the_command_line_sweeps_and_sets_a_coordinate(tmp_path, capsys):
    from rampwork.cli import main

    path = tmp_path / "spline.toml"
    path.write_text(SCENE, encoding="utf-8")
    output = tmp_path / "out.nc"
    assert main(["run", str(path), "-o", str(output), "--set", "sweep.axes.y2=[0.6, 0.7]"]) == 0
    swept = rw.open_dataset(output)
    assert swept["y2"].values.tolist() == [0.6, 0.7]
    # [curve] y2 = 0.7 (here through --set): that point moved, no sweep
    again = tmp_path / "again.nc"
    assert main(["run", str(path), "-o", str(again), "--set", "sweep.axes={}",
                 "--set", "curve.y2=0.7"]) == 0
    fixed = rw.open_dataset(again)
    assert fixed["s_end"].item() == swept["s_end"].sel(y2=0.7).item()
    with pytest.raises(ConfigError, match="curve.y9"):
        parse_scene(SCENE.replace("[friction]", "y9 = 1.0\n[friction]"))
