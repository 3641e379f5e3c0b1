"""The family ``track``'s frame and point without data-dependent loops
(core/curve_track.py): the piece from a uniform table of cells where the
kernel gives no branch, the point from stored panel starts and a 3-node
Gauss-Legendre rule.  Against the `loop` family on random starts (the same
circle, its frame the same arithmetic), the closed forms of straights and
arcs, the Fresnel integrals and an independent quadrature of clothoids, and
the piece holding each point by a sorted search."""

import math

import numpy as np
import pytest
from scipy import special

from rampwork.curve_tracks import MAX_CELLS
from rampwork.curves import Curve, simulate_curve
from rampwork.errors import ConfigError

G = 9.81
#: outputs that only the dynamics set: bit for bit where the frames are
DYNAMICS = ("t_end", "p_end", "u_end", "W_friction", "displacement", "path_length",
            "curvature_mean", "nu_min", "p_lift_off", "n_reversals", "steps", "status")
#: outputs that read the point: to rounding
GEOMETRY = ("X_end", "Y_end", "W_energy", "path_length_X", "X_lift_off", "Y_lift_off")


def _random_starts(radius, n, seed):
    rng = np.random.default_rng(seed)
    s0 = rng.uniform(0.0, 2 * math.pi * radius, n)
    u0 = rng.uniform(-1.0, 1.0, n) * math.sqrt(6 * G * radius)
    u0[: n // 8] = 0.0  # starts at rest: held, sliding off or falling off
    mu_k = rng.uniform(0.0, 0.6, n)
    return s0, u0, mu_k, mu_k + rng.uniform(0.0, 0.3, n)


@pytest.mark.parametrize("method, radius", [
    ("rk4", 1.0), ("rk4", 0.5), pytest.param("dopri5", 1.0, marks=pytest.mark.slow)])
def test_a_one_piece_circle_track_is_the_loop_on_random_starts(method, radius):
    """Radius a power of two: the track's phase 0 + sigma (1/R + 0) and the
    loop's s / R round alike, so every step is the same; the point differs
    by rounding (the loop's closed form, the track's panels)."""
    s0, u0, mu_k, mu_s = _random_starts(radius, 400, seed=20)
    runs = [simulate_curve(curve, s0=s0, u0=u0, mu_k=mu_k, mu_s=mu_s, method=method, dt=2e-3,
                           rtol=1e-8, t_max=4.0)
            for curve in (Curve.track([[2 * math.pi * radius, 1 / radius, 1 / radius]]),
                          Curve.create("loop", radius=radius))]
    names = set(runs[1]["status_name"].tolist())
    assert {"stuck", "lifted_off", "exited"} <= names, names  # stops, falls and exits
    assert (runs[1]["n_reversals"] > 0).any()
    for name in DYNAMICS:
        np.testing.assert_array_equal(runs[0][name], runs[1][name], err_msg=name)
    # a few ulps of the loop's size (of g 2R for the energy; path_length_X sums a
    # difference of X per step, each with its rounding)
    ulps = 8 * np.finfo(float).eps * radius
    for name in GEOMETRY:
        bound = ulps * (G * 2 * radius if name == "W_energy" else 1.0) * (
            np.sqrt(runs[1]["steps"] + 1.0) if name == "path_length_X" else 1.0)
        a, b = runs[0][name], runs[1][name]
        assert ((np.abs(a - b) <= bound) | (np.isnan(a) & np.isnan(b))).all(), (
            name, np.nanmax(np.abs(a - b) / bound))


def _clothoid_reference(sigma, phi0, k0, c):
    """∫_0^sigma (cos, sin)(phi0 + t k0 + c t^2 / 2) dt: numpy's 20-node
    Gauss-Legendre rule on 64 equal panels (exact to rounding here)."""
    nodes, weights = np.polynomial.legendre.leggauss(20)
    edges = np.linspace(0.0, 1.0, 65)
    t = (0.5 * (edges[:-1] + edges[1:])[:, None] + 0.5 * np.diff(edges)[:, None] * nodes).ravel()
    w = np.tile(0.5 * weights / 64, 64)
    t = np.asarray(sigma)[:, None] * t
    angle = phi0 + t * (k0 + 0.5 * c * t)
    return sigma * (np.cos(angle) @ w), sigma * (np.sin(angle) @ w)


def test_the_points_of_straights_arcs_and_clothoids():
    a = 1.3  # a clothoid from curvature 0 to 2 / a^2, an arc of that, one unwinding past 0
    pieces = [[0.7, 0.0, 0.0], [2.0, 0.0, 2.0 / a ** 2], [1.5, 2.0 / a ** 2, 2.0 / a ** 2],
              [3.0, 2.0 / a ** 2, -0.4]]
    start = (0.3, -0.2, 0.25)
    track = Curve.track(pieces, start=start)
    ends = np.cumsum([0.0] + [piece[0] for piece in pieces])
    rng = np.random.default_rng(3)
    s = np.sort(np.concatenate([rng.uniform(0.0, ends[-1], 300), ends]))
    at = track.evaluate(s)
    # the straight: the start plus s along the start angle
    first = s <= ends[1]
    np.testing.assert_allclose(at["X"][first], start[0] + s[first] * math.cos(start[2]), rtol=0, atol=4e-16)
    np.testing.assert_allclose(at["Y"][first], start[1] + s[first] * math.sin(start[2]), rtol=0, atol=4e-16)
    # the first clothoid against the Fresnel integrals: X + i Y = e^{i phi} a sqrt(pi) (C + i S)
    base = track.evaluate([ends[1]])
    on = (s >= ends[1]) & (s <= ends[2])
    fresnel_s, fresnel_c = special.fresnel((s[on] - ends[1]) / (a * math.sqrt(math.pi)))
    scale = a * math.sqrt(math.pi)
    x, y = scale * fresnel_c, scale * fresnel_s
    rotate = np.exp(1j * start[2]) * (x + 1j * y)
    np.testing.assert_allclose(at["X"][on], base["X"][0] + rotate.real, rtol=0, atol=2e-15)
    np.testing.assert_allclose(at["Y"][on], base["Y"][0] + rotate.imag, rtol=0, atol=2e-15)
    # each piece from its start point against an independent quadrature of its own angle
    for k in (1, 2, 3):
        on = (s >= ends[k]) & (s <= ends[k + 1])
        here = track.evaluate([ends[k]])
        phi0 = math.atan2(here["sin_phi"][0], here["cos_phi"][0])
        k0, k1 = pieces[k][1], pieces[k][2]
        dx, dy = _clothoid_reference(s[on] - ends[k], phi0, k0, (k1 - k0) / pieces[k][0])
        np.testing.assert_allclose(at["X"][on], here["X"][0] + dx, rtol=0, atol=4e-15, err_msg=k)
        np.testing.assert_allclose(at["Y"][on], here["Y"][0] + dy, rtol=0, atol=4e-15, err_msg=k)
    # and the `clothoid` family (its Gauss-Legendre panels from the origin)
    spiral = Curve.create("clothoid", clothoid_parameter=a, length=2.0)
    sigma = np.linspace(0.0, 2.0, 101)
    alone = Curve.track([[2.0, 0.0, 2.0 / a ** 2]]).evaluate(sigma)
    reference = spiral.evaluate(sigma)
    for name in ("X", "Y", "sin_phi", "cos_phi", "kappa"):
        np.testing.assert_allclose(alone[name], reference[name], rtol=0, atol=2e-15, err_msg=name)


def test_the_piece_of_every_point_without_the_branch():
    """p3 = 0 (evaluate, a trajectory's start): the piece holding p, the one
    ahead at a joint, from the cells, on pieces of very different lengths."""
    lengths = np.array([0.013, 5.0, 0.02, 0.5, 3.0, 0.0101, 0.7])
    curvatures = np.arange(1.0, lengths.size + 1.0) / 10.0  # each piece's own (arcs)
    track = Curve.track([[length, kappa, kappa] for length, kappa in zip(lengths, curvatures)])
    joints = np.cumsum(lengths)[:-1]
    rng = np.random.default_rng(7)
    p = np.concatenate([joints, np.nextafter(joints, -np.inf), np.nextafter(joints, np.inf),
                        rng.uniform(0.0, lengths.sum(), 2000), [0.0, lengths.sum()]])
    piece = np.searchsorted(joints, p, side="right")  # the joints at or behind p
    np.testing.assert_array_equal(track.evaluate(p)["kappa"], curvatures[piece])
    # a population: each row's own pieces, the cells as fine as its shortest
    other = Curve.track([[[length, kappa, kappa] for length, kappa in zip(lengths, curvatures)],
                         [[20.0, 0.0, 0.0], [1.0, 0.5, 0.5]]], row=1)
    q = np.array([19.999, 20.0, 20.5, 21.0])
    np.testing.assert_array_equal(other.evaluate(q)["kappa"], [0.0, 0.5, 0.5, 0.5])


def test_a_piece_too_short_beside_the_longest_track_is_refused():
    short = 3.0 * 10.0 / MAX_CELLS / 2  # half the least length the cells allow on 10 m
    with pytest.raises(ConfigError, match="too short") as error:
        Curve.track([[5.0, 0.0, 0.0], [short, 0.1, 0.1], [5.0, 0.0, 0.0]])
    assert error.value.where == "curve.pieces"
    Curve.track([[5.0, 0.0, 0.0], [4 * short, 0.1, 0.1], [5.0, 0.0, 0.0]])  # allowed
