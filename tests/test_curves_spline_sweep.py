"""Sweeps over a spline's points (docs/physics.md §5.2): a population of
splines, one per row of the points, runs in one call, each trajectory bit for
bit its spline's own run; each spline is checked, an error names its row;
splines through points of circles approach the circle's closed form with
friction (the linear ODE in u²)."""

import math

import numpy as np
import pytest

import rampwork as rw
from rampwork.curves import Curve, simulate_curve
from rampwork.errors import ConfigError
from rampwork.scenefile import dump_scene, parse_scene

G = 9.81
TURN = 1.5 * math.pi  # three quarters of a circle from its bottom, past two vertical tangents
OUTPUTS = ("t_end", "p_end", "u_end", "X_end", "Y_end", "W_friction", "nu_min", "path_length_X",
           "steps", "status")


def _circle_points(radius, points):
    theta = np.linspace(0.0, TURN, points)
    return radius * np.sin(theta), radius * (1.0 - np.cos(theta))


def _clamped(radius_rows, points):
    xs, ys = zip(*(_circle_points(r, points) for r in radius_rows))
    tangents = ((1.0, 0.0), (math.cos(TURN), math.sin(TURN)))
    return np.array(xs), np.array(ys), tangents


def _circle_u2(theta, w0, mu, radius):
    """u² after turning theta inside a circle with friction, from u² = w0."""
    a = 2.0 * mu
    e = np.exp(a * theta)
    sin_part = (e * (a * np.sin(theta) - np.cos(theta)) + 1.0) / (a * a + 1.0)
    cos_part = (e * (a * np.cos(theta) + np.sin(theta)) - a) / (a * a + 1.0)
    return (w0 - 2.0 * G * radius * (sin_part + mu * cos_part)) / e


@pytest.mark.parametrize("method", ["rk4", "dopri5"])
def test_a_sweep_over_splines_equals_each_splines_own_run_bit_for_bit(method):
    theta = np.linspace(0.0, TURN, 17)
    x = np.sin(theta)
    # y rows over one x row: bent, stretched, with a bump (stops, lift-offs, exits)
    ys = np.stack([1 - np.cos(theta), 1.3 * (1 - np.cos(theta)),
                   (1 - np.cos(theta)) + 0.1 * np.sin(3 * theta), 0.7 * (1 - np.cos(theta))])
    population = Curve.through_points(x, ys)
    rows = np.array([0, 1, 2, 3, 2, 0, 1, 3])
    u0 = np.array([8.0, 8.0, 7.0, 3.0, 9.0, 4.0, 9.5, 8.5])
    together = simulate_curve(population, s0=0.0, u0=u0, mu_k=0.1, row=rows, method=method,
                              dt=1e-3, rtol=1e-8)
    assert len(set(together["status_name"].tolist())) >= 2
    for k in range(rows.size):
        alone = simulate_curve(Curve.through_points(x, ys[rows[k]]), s0=0.0, u0=u0[k], mu_k=0.1,
                               method=method, dt=1e-3, rtol=1e-8)
        for name in OUTPUTS:
            assert together[name][k] == alone[name] or (
                np.isnan(together[name][k]) and np.isnan(alone[name])), (name, k)
    # x and y both per row; a population's curve picks its row
    xs = np.stack([x, 1.1 * x])
    second = Curve.through_points(xs, ys[:2], row=1)
    direct = simulate_curve(Curve.through_points(1.1 * x, ys[1]), s0=0.5, u0=8.0, method=method,
                            rtol=1e-8)
    picked = simulate_curve(second, s0=0.5, u0=8.0, method=method, rtol=1e-8)
    assert picked["u_end"] == direct["u_end"] and picked["t_end"] == direct["t_end"]


def test_splines_through_circles_approach_the_circles_closed_form():
    radii = np.array([0.8, 1.0, 1.5])
    u0, mu = 12.0, 0.15  # in contact all the way round on every circle
    errors = []
    for points in (13, 25, 49):
        xs, ys, tangents = _clamped(radii, points)
        population = Curve.through_points(xs, ys, end="clamped", end_tangents=tangents)
        out = simulate_curve(population, s0=0.0, u0=u0, mu_k=mu, row=[0, 1, 2], method="dopri5",
                             rtol=1e-11)
        assert (out["status_name"] == "exited").all() and (out["nu_min"] > 0).all()
        np.testing.assert_allclose(out["X_end"], -radii, rtol=1e-12)
        exact = np.sqrt(_circle_u2(TURN, u0 * u0, mu, radii))
        errors.append(np.abs(out["u_end"] - exact) / exact)
    errors = np.array(errors)
    assert errors[-1].max() < 5e-8  # measured 1.6e-8 to 2.8e-8 with 49 points
    # fourth order in the points' spacing (measured 3.95-4.0), though the
    # curvature the friction sees converges at second order only
    assert (np.log2(errors[:-1] / errors[1:]) > 3.5).all(), errors


def test_each_spline_is_checked_and_an_error_names_its_row():
    x = [0.0, 1.0, 2.0, 3.0]
    with pytest.raises(ConfigError, match=r"spline 1 \(row 1 of the points\).*regular"):
        Curve.through_points([[0.0, 1.0, 2.0], [0.0, 1.0, 0.0]], [[0.0, 0.5, 0.0], [0.0, 0.0, 0.001]])
    theta = np.linspace(0, 1.9 * math.pi, 30)
    with pytest.raises(ConfigError, match=r"spline 2 .*crosses itself"):
        Curve.through_points([np.cos(theta), 2 * np.cos(theta), np.sin(2 * theta)],
                             [np.sin(theta), np.sin(theta), np.sin(theta)])
    with pytest.raises(ConfigError, match=r"spline 0 .*distinct"):
        Curve.through_points([[0.0, 1.0, 0.0, 1.0], x], [[0.0, 1.0, 0.0, 1.0], [0.0, 0.1, 0.2, 0.3]])
    with pytest.raises(ConfigError, match="curve.y_points"):
        Curve.through_points(x, [[0.0, 1.0, 0.0]])  # 3 values for 4 points
    population = Curve.through_points(x, [[0.0, 0.1, 0.2, 0.3], [0.0, -0.1, -0.2, -0.3]])
    for bad in (2, -1, 0.5):
        with pytest.raises(ConfigError, match="curve.row"):
            simulate_curve(population, s0=0.0, u0=1.0, row=[0, bad])
    with pytest.raises(ConfigError, match="s0"):  # off the shorter spline of the two
        simulate_curve(Curve.through_points(x, [[0.0, 0.1, 0.2, 0.3], [0.0, 2.0, 4.0, 6.0]]),
                       s0=5.0, u0=1.0, row=[0, 1])


SPLINES = """\
title = "two splines"
s0 = 0.0
u0 = 8.0
t_max = 3.0
[curve]
family = "spline"
x_points = [0.0, 1.0, 1.8, 2.2]
y_points = [[0.0, 0.2, 0.8, 1.6], [0.0, 0.3, 1.0, 2.0]]
[friction]
mu_k = 0.1
[sweep.axes]
row = [0, 1]
u0 = [6.0, 8.0]
"""


def test_a_scene_file_sweeps_a_population_of_splines():
    scene, sweep = parse_scene(SPLINES, "scene.toml")
    text = dump_scene(scene, sweep)
    assert parse_scene(text, "scene.toml") == (scene, sweep)
    ds = rw.simulate(scene, sweep)
    assert ds.sizes == {"row": 2, "u0": 2}
    for k, y in enumerate(([0.0, 0.2, 0.8, 1.6], [0.0, 0.3, 1.0, 2.0])):
        alone = simulate_curve(Curve.through_points([0.0, 1.0, 1.8, 2.2], y), s0=0.0,
                               u0=[6.0, 8.0], mu_k=0.1, t_max=3.0)
        np.testing.assert_array_equal(ds["s_end"].values[k], alone["p_end"])
        np.testing.assert_array_equal(ds["t_end"].values[k], alone["t_end"])
    with pytest.raises(ConfigError, match="curve.row"):  # checked before any work
        rw.simulate(*parse_scene(SPLINES.replace("row = [0, 1]", "row = [0, 2]"), "scene.toml"))
