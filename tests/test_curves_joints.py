"""Curves with any number of joints (docs/physics.md §5.1): the family
``track`` (straights, arcs and clothoids in a chain) runs in the kernel's
MANY_JOINTS mode, every piece's start an exact event.  Checked against
energy conservation at mu = 0 across every joint, the frictionless loop's
clearing condition u0^2 + 2 g h >= 5 g R (h: the sloped in-run's drop to the
circle's bottom), the recorded steps ending on each joint to an ulp, and a
population mixing joint counts against its tracks run alone, bit for bit.
The default suite compiles one kernel (rk4, frictionless, many joints) and
the JOINTS = 0 one; the pairs and the scalar reference are in the slow suite."""

import math

import numpy as np
import pytest

from rampwork.curves import Curve, loop_track_pieces, prepare_curve_run, simulate_curve
from rampwork.curve_tracks import check_joints
from rampwork.errors import ConfigError

G = 9.81
RADIUS = 1.0
SLOPE = 0.3
OUTPUTS = ("t_end", "p_end", "u_end", "X_end", "Y_end", "W_energy", "nu_min", "path_length_X",
           "curvature_mean", "p_lift_off", "steps", "status")


def _kicker_track(slope=SLOPE, radius=RADIUS):
    """The sloped loop, then a flat, an arc curving up (radius 2) and a flat:
    five pieces, four curvature jumps."""
    pieces, start = loop_track_pieces(radius, slope, 1.0)
    return pieces[:-1] + [[1.0, 0.0, 0.0], [0.6, 0.5, 0.5], [0.5, 0.0, 0.0]], start


def _energy(out):
    return 0.5 * out["u_end"] ** 2 + G * out["Y_end"]


def test_the_sloped_loop_clears_iff_u0_squared_reaches_5gR_less_its_drop():
    for slope in (0.0, SLOPE, 0.8):
        pieces, start = loop_track_pieces(RADIUS, slope, 1.0)
        drop = start[1]  # the start's height over the circle's bottom
        assert drop == pytest.approx(math.sin(slope) + RADIUS * (1 - math.cos(slope)), abs=1e-15)
        critical = math.sqrt(5 * G * RADIUS - 2 * G * drop)
        track = Curve.track(pieces, start=start)
        out = simulate_curve(track, s0=0.0, u0=critical * np.array([0.99, 1.01]), method="rk4",
                             dt=1e-3)
        assert out["status_name"].tolist() == ["lifted_off", "exited"], slope
        # the slow one leaves in the upper half of the circle, past the in-run
        assert pieces[0][0] < out["p_lift_off"][0] < pieces[0][0] + pieces[1][0]
        assert out["Y_lift_off"][0] > RADIUS


def test_energy_is_conserved_across_every_joint_to_rounding():
    pieces, start = _kicker_track()
    track = Curve.track(pieces, start=start)
    errors = []
    for dt in (4e-3, 2e-3, 1e-3):
        out = simulate_curve(track, s0=0.0, u0=7.0, method="rk4", dt=dt)
        assert out["status_name"] == "exited" and out["W_friction"] == 0.0
        errors.append(abs(float(out["energy_balance_error"])))
    # fourth order across the joints (a step across a curvature jump would be first order)
    assert errors[0] / errors[1] > 8 and errors[1] / errors[2] > 8, errors
    fine = prepare_curve_run(track, s0=0.0, u0=7.0, method="rk4", dt=1e-4)
    out = fine.run()
    e0 = 0.5 * 7.0 ** 2 + G * start[1]
    assert abs(float(out["energy_balance_error"])) <= 100 * np.finfo(float).eps * e0 * math.sqrt(
        float(out["steps"]))
    # every sample, the joints' steps among them
    trace = fine.trace(0, every=1000)
    energy = 0.5 * trace[2] ** 2 + G * trace[4]
    assert np.abs(energy - e0).max() < 1e-10 * e0


def test_every_joint_ends_a_step_within_an_ulp_both_ways():
    pieces, start = _kicker_track()
    track = Curve.track(pieces, start=start)
    joints = np.cumsum([piece[0] for piece in pieces])[:-1]
    assert joints.size == 4
    # forwards through all four; backwards from the kicker's end through two, into the loop
    for u0, passed in ((7.0, joints), (-3.0, joints[-2:])):
        s0 = 0.0 if u0 > 0 else float(joints[-1] + 0.3)
        run = prepare_curve_run(track, s0=s0, u0=u0, method="rk4", dt=1e-3)
        trace = run.trace(0, every=10 ** 9)  # the start, the event steps, the end
        for joint in passed:
            nearest = trace[1][np.argmin(np.abs(trace[1] - joint))]
            assert abs(nearest - joint) <= np.spacing(joint), (u0, joint, nearest - joint)
            # just past it, in the direction of travel
            assert (nearest - joint) * u0 > 0


def test_a_population_mixing_joint_counts_equals_its_tracks_alone_bit_for_bit():
    loop, start = loop_track_pieces(RADIUS, SLOPE, 1.0)
    kicker, _ = _kicker_track()
    population = [[[3.0, 0.0, 0.0]], loop, kicker, [[1.0, 0.0, 0.0], [2.0, -0.2, 0.3]]]
    starts = [(0.0, 0.5, -0.2), start, start, (0.0, 0.0, 0.1)]
    tracks = Curve.track(population, start=starts)
    rows = np.array([2, 0, 1, 3, 2, 1, 0, 3, 2])
    u0 = np.array([7.0, 1.0, 6.4, 2.0, 6.0, 7.5, -0.5, 4.0, 3.0])
    s0 = np.array([0.0, 1.5, 0.0, 0.0, 0.0, 0.0, 2.0, 0.5, 8.0])
    together = simulate_curve(tracks, s0=s0, u0=u0, row=rows, method="rk4", dt=1e-3)
    assert {"exited", "lifted_off"} <= set(together["status_name"].tolist())
    for k in range(rows.size):
        alone = simulate_curve(Curve.track(population[rows[k]], start=starts[rows[k]]),
                               s0=s0[k], u0=u0[k], method="rk4", dt=1e-3)
        for name in OUTPUTS:
            assert together[name][k] == alone[name] or (
                np.isnan(together[name][k]) and np.isnan(alone[name])), (name, k)


@pytest.mark.parametrize("pieces, start, where, words", [
    ([[1.0, 0.0, 0.0], [0.0, 1.0, 1.0]], (0, 0, 0), "curve.pieces", "length must be > 0"),
    ([[1.0, 0.0, 0.0], [-1.0, 1.0, 1.0]], (0, 0, 0), "curve.pieces", "length must be > 0"),
    ([[1.0, 0.0, math.nan]], (0, 0, 0), "curve.pieces", "finite"),
    ([1.0, 0.0, 0.0], (0, 0, 0), "curve.pieces", "expected a list"),
    ([[1.0, 0.0, 0.0]], (0, 0), "curve.start", "X, Y, angle"),
])
def test_track_errors_name_the_key(pieces, start, where, words):
    with pytest.raises(ConfigError, match=words) as error:
        Curve.track(pieces, start=start)
    assert error.value.where == where


def test_joints_unsorted_or_off_the_domain_are_refused():
    assert check_joints([0.5, 1.0, 2.0], 0.0, 3.0).tolist() == [0.5, 1.0, 2.0]
    for joints, words in (([1.0, 0.5], "strictly increasing"), ([1.0, 1.0], "strictly increasing"),
                          ([0.0, 1.0], "inside"), ([1.0, 3.5], "inside"), ([math.nan], "finite")):
        with pytest.raises(ConfigError, match=words):
            check_joints(joints, 0.0, 3.0)
    with pytest.raises(ConfigError, match="in_run_slope"):
        loop_track_pieces(1.0, -0.1)
    with pytest.raises(ConfigError, match="in_run_slope"):
        loop_track_pieces(1.0, 2.0)
    with pytest.raises(ConfigError, match="blend_length"):
        loop_track_pieces(1.0, 0.0, 1.0, 7.0)
    tracks = Curve.track([[[1.0, 0.0, 0.0]], [[2.0, 0.0, 0.0]]])
    with pytest.raises(ConfigError, match=r"\[0, 2\)"):
        simulate_curve(tracks, s0=0.0, u0=1.0, row=[0, 2])
    with pytest.raises(ConfigError, match="s0"):
        simulate_curve(tracks, s0=1.5, u0=1.0, row=[0, 1])


@pytest.mark.slow
@pytest.mark.parametrize("method, rtol", [("dopri5", 1e-7), ("dop853", 1e-8)])
def test_the_pairs_conserve_energy_across_every_joint_within_10x_rtol(method, rtol):
    pieces, start = _kicker_track()
    blended, _ = loop_track_pieces(RADIUS, SLOPE, 1.0, blend_length=0.5)
    for track_pieces in (pieces, blended):
        out = simulate_curve(Curve.track(track_pieces, start=start), s0=0.0, u0=7.5,
                             method=method, rtol=rtol, dt=1e-3)
        assert out["status_name"] == "exited"
        e0 = 0.5 * 7.5 ** 2 + G * start[1]
        assert abs(float(out["energy_balance_error"])) <= 10 * rtol * e0


@pytest.mark.slow
@pytest.mark.parametrize("method", ["euler", "rk4", "dopri5"])
def test_many_joints_give_the_scalar_kernels_bits_with_friction(method):
    loop, start = loop_track_pieces(RADIUS, SLOPE, 1.0, blend_length=0.4)
    kicker, _ = _kicker_track()
    tracks = Curve.track([loop, kicker, [[2.0, 0.0, 0.0]]], start=start)
    rows = np.tile([0, 1, 2], 70)
    u0 = np.linspace(-2.0, 9.0, rows.size)
    s0 = np.where(u0 < 0, 8.5, 0.0) * (rows != 2)
    runs = [prepare_curve_run(tracks, s0=s0, u0=u0, row=rows, mu_k=0.1, method=method, dt=1e-3,
                              vector=vector).run() for vector in (True, False)]
    for name in OUTPUTS:
        np.testing.assert_array_equal(runs[0][name], runs[1][name], err_msg=name)


def test_the_sloped_loop_example_reads_back_and_runs_as_in_python():
    import rampwork as rw
    from rampwork.cli import example_text
    from rampwork.scenefile import dump_scene, parse_scene

    scene, _ = parse_scene(example_text("track"))
    sweep = rw.Sweep.grid(u0=[6.3, 6.6, 7.0])  # frictionless: the kernel compiled above
    assert parse_scene(dump_scene(scene, sweep)) == (scene, sweep)
    dataset = rw.simulate(scene, sweep)
    pieces, start = _kicker_track()
    direct = simulate_curve(Curve.track(pieces, start=start), s0=0.0, u0=[6.3, 6.6, 7.0],
                            method="rk4", dt=1e-3, t_max=scene.t_max)
    np.testing.assert_array_equal(dataset["s_end"].values, direct["p_end"])
    # below 6.51 m/s it falls inside the loop; above, it clears the loop (and the kicker)
    assert direct["status_name"].tolist() == ["lifted_off", "exited", "exited"]
    # a population (one list of pieces per track) writes and reads back too
    population = scene.replace(curve=Curve.track([pieces, pieces[:2]], start=[start, start],
                                                 row=1))
    assert parse_scene(dump_scene(population, sweep)) == (population, sweep)


def test_a_chunked_track_sweep_equals_the_one_call_run(tmp_path):
    """Chunks run on the whole sweep's kernel (MANY_JOINTS here), also a
    chunk whose tracks have no joint."""
    import rampwork as rw
    from rampwork.curve_scene import CurveScene

    loop, start = loop_track_pieces(RADIUS, SLOPE, 1.0)
    tracks = Curve.track([[[3.0, 0.0, 0.0]], loop], start=[(0.0, 0.5, -0.2), start])
    scene = CurveScene(curve=tracks, s0=0.0, t_max=5.0)
    sweep = rw.Sweep.grid(row=[0.0, 1.0], u0=[1.0, 6.4, 7.0])
    whole = rw.simulate(scene, sweep)
    path = tmp_path / "chunks.nc"
    rw.run_to_file(scene, sweep, path, chunk_size=3)
    chunked = rw.open_dataset(path)
    for name in ("s_end", "t_end", "u_end", "status"):
        np.testing.assert_array_equal(chunked[name].values, whole[name].values, err_msg=name)
