"""The curve kernel in SIMD lanes (core/curve_lanes.py) against its scalar reference.

The lane kernel takes clean steps for a block of lanes in one vector loop and
every other step (events, vertical tangents, rejections it cannot take) in
the scalar code, the adaptive pairs' events located in the vector loop
first; run with the vector loop off (``vector=False``) every step goes
through that scalar code alone.  Both must give the same bits, for every
method, on random scenes with stops, reversals, lift-offs, exits, contact
switches, joints and drag, whatever the thread count, tile size or order of
the trajectories.  (The physics itself is tested against closed forms in
tests/test_curves*.py, through the lane kernel.)
"""

from __future__ import annotations

import numpy as np
import pytest

import rampwork as rw
from rampwork.core import curve_lanes, status as st
from rampwork.core.curve_steppers import CURVE_STEPPERS
from rampwork.core.threads import max_threads, using_threads
from rampwork.curves import Curve, prepare_curve_run

METHODS = tuple(CURVE_STEPPERS)
N = 300


def _curves():
    theta = np.linspace(0.2, 5.5, 9)
    return {
        "loop": (Curve.create("loop", radius=1.0), {}),
        "quarter_pipe": (Curve.create("quarter_pipe", radius=1.0, flat_length=0.5), {}),
        "brachistochrone": (Curve.create("brachistochrone", radius=0.5), {}),
        "graph_sine": (Curve.from_ramp(rw.Ramp.create("sine", domain=(-1.0, 1.0), amplitude=0.1,
                                                      wavenumber=6.0, phase=0.3)), {}),
        "spline": (Curve.through_points(np.sin(theta), 1.0 - np.cos(theta)), {}),
    }


CURVES = _curves()


def _arguments(name, method, contact, seed):
    """Random starts (some on an end, some at rest), friction and air drag
    (both terms, zero in some trajectories)."""
    curve, _ = CURVES[name]
    lo, hi = (float(v[0]) for v in curve.domain())
    rng = np.random.default_rng(seed)
    s0 = rng.uniform(lo, hi, N)
    s0[:10] = lo
    if name == "brachistochrone":
        s0 = np.maximum(s0, 1e-3)  # no friction at the cusp itself (refused)
    u0 = rng.uniform(-6.0, 6.0, N)
    u0[::7] = 0.0  # at rest: the rest rule
    drag = rng.uniform(0.0, 0.3, (2, N)) * (rng.uniform(size=(2, N)) < 0.7)
    return dict(s0=s0, u0=u0, mu_k=rng.uniform(0.0, 0.4, N), method=method,
                dt=2e-3 if method != "dopri5" else 1e-3, t_max=2.0, rtol=1e-7, contact=contact,
                drag_linear=drag[0], drag_quadratic=drag[1])


def _run(name, args, *, vector=True, threads=1, order=None):
    curve, _ = CURVES[name]
    if order is not None:
        args = {k: (v[order] if isinstance(v, np.ndarray) else v) for k, v in args.items()}
    run = prepare_curve_run(curve, vector=vector, **args)
    with using_threads(threads):
        return run.run()


def _assert_same_bits(a, b, order=None):
    for key in a:
        left = a[key] if order is None else a[key][np.argsort(order)]
        assert left.dtype == b[key].dtype
        if left.dtype.kind == "f":
            same = left.view(np.int64) == b[key].view(np.int64)
            assert same.all(), (key, np.flatnonzero(~same)[:5], left[~same][:3], b[key][~same][:3])
        else:
            assert np.array_equal(left, b[key]), key


#: (family, method): every method on three families, the adaptive and RK4 on all; the
#: default suite runs every method on the loop and RK4 on a wrapped ramp (p = x, the
#: other frame), the slow suite the rest (each case compiles two kernel variants; the
#: lane loop is the same code for every family, whose frame it calls)
DEFAULT_CASES = {("graph_sine", "rk4")}
CASES = [pytest.param(name, method, marks=() if name == "loop" or (name, method) in DEFAULT_CASES
                      else pytest.mark.slow)
         for name, method in ([(name, method) for name in ("loop", "quarter_pipe", "graph_sine")
                               for method in METHODS]
                              + [(name, method) for name in ("brachistochrone", "spline")
                                 for method in ("rk4", "dopri5")])]


@pytest.mark.parametrize(("name", "method"), CASES)
def test_lanes_match_the_scalar_reference_bit_for_bit(name, method):
    args = _arguments(name, method, "one_sided", 1)
    reference = _run(name, args, vector=False)
    _assert_same_bits(_run(name, args), reference)
    seen = set(reference["status_name"].tolist())
    # the scenes reach the events the vector loop leaves to the scalar code
    assert "exited" in seen and ({"stuck", "lifted_off"} & seen), seen


@pytest.mark.parametrize("method", (pytest.param("euler", marks=pytest.mark.slow), "rk4",
                                    pytest.param("dopri5", marks=pytest.mark.slow)))
def test_lanes_match_the_scalar_reference_with_two_sided_contact(method):
    args = _arguments("loop", method, "two_sided", 2)
    reference = _run("loop", args, vector=False)
    _assert_same_bits(_run("loop", args), reference)
    assert (reference["n_reversals"] > 0).any()
    assert (reference["nu_min"] < 0).any()  # the contact switched sides


@pytest.mark.parametrize("method", ("rk4", "dopri5"))
def test_lanes_do_not_depend_on_threads_tiles_or_order(method, monkeypatch):
    # the loop: its kernels are the bit-for-bit tests' (one compilation for both)
    args = _arguments("loop", method, "one_sided", 3)
    reference = _run("loop", args)
    order = np.random.default_rng(5).permutation(N)
    _assert_same_bits(_run("loop", args, order=order), reference, order)
    _assert_same_bits(_run("loop", args, threads=2), reference)
    monkeypatch.setattr(curve_lanes, "tile_size", lambda n, threads: 37)  # tiles of odd sizes
    _assert_same_bits(_run("loop", args, threads=2), reference)
    assert len(set(reference["status_name"].tolist())) >= 2  # lanes finish at different steps


def test_lanes_take_events_of_every_kind():
    """The loop's run meets what the scalar code resolves: stops, reversals,
    lift-offs and exits (so the bit-for-bit test above covers them)."""
    args = _arguments("loop", "rk4", "one_sided", 1)
    out = _run("loop", args)
    names = set(out["status_name"].tolist())
    assert {"exited", "lifted_off", "stuck"} <= names, names
    assert (out["n_reversals"] > 0).any()


@pytest.mark.skipif(max_threads() < 2, reason="needs 2 threads")
def test_simulate_runs_curve_scenes_on_the_threads_asked_for():
    from rampwork.curve_scene import CurveScene

    scene = CurveScene(curve=Curve.create("loop", radius=1.0), s0=0.0, u0=7.0,
                       integrator=rw.Integrator("rk4", dt=1e-3))
    sweep = rw.Sweep.grid(u0=np.linspace(2.0, 9.0, 40), mu=[0.0, 0.1, 0.3])
    one = rw.simulate(scene, sweep, threads=1)
    two = rw.simulate(scene, sweep, threads=2)
    assert one.attrs["threads"] == 1 and two.attrs["threads"] == 2
    for name in one.data_vars:
        np.testing.assert_array_equal(one[name].values, two[name].values)
    codes = set(np.unique(one.status.values).tolist())
    assert {st.EXITED, st.LIFTED_OFF} <= codes, codes


def test_lanes_locate_an_event_as_the_scalar_locator_does():
    """curve_events.py: the bracket kept in lane fields, a trial per call
    (as the vector loop takes them), ends where the scalar loop ends, bit
    for bit, on adjacent step sizes: the lower clean, the upper not.  A toy
    step (a linear reversal u - a h and an end p_hi) stands in for a
    method's."""
    from rampwork.core import curve_events as ce
    from rampwork.core.curve_kernel import EV_HI, LANES, N_FIELDS
    from rampwork.core.jit import jit, specialise

    @jit
    def toy_step(p, u, q, d, sn, h, g, s0, s1, s2, s3, shared, b, c, p_lo, p_hi, joint, rtol,
                 atol, frame):
        p1, u1 = p + h * u, u - 3.0 * h
        clean = (d * u1 > 0.0) and (p1 <= p_hi)
        return p1, u1, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, clean, frame, False

    constants = {"JOINTS": 0, "try_step": toy_step}
    names = (("event_guess", ce._event_guess), ("event_trial", ce._event_trial),
             ("locate_event", ce._locate_event), ("lane_trial", ce._lane_trial))
    built = {}
    for name, template in names:
        built[name] = specialise(template, f"test_lane_events_{name}", dict(constants),
                                 cache=False)
        constants[name] = built[name]
    frame = (0.0, 1.0, 0.0, 1.0)
    shared = np.zeros(1)
    for p, u, p_hi in ((0.0, 2.0, 10.0), (0.0, 2.0, 0.5), (0.3, 1e-3, 10.0)):
        h = 2.0  # the reversal at h = u / 3, the end at (p_hi - p) / u
        step = toy_step(p, u, 0.0, 1.0, 1.0, h, 9.81, 0.0, 0.0, 0.0, 0.0, shared, 0.0, 0.0,
                        -10.0, p_hi, np.nan, 1e-6, 1e-6, frame)
        assert not step[8]
        hi, _ = built["locate_event"](p, u, 0.0, 1.0, 1.0, h, 9.81, 0.0, 0.0, 0.0, 0.0, shared,
                                      0.0, 0.0, -10.0, p_hi, np.nan, 1e-6, 1e-6, frame, step)
        lanes = np.full(N_FIELDS * LANES, 7.0)  # a lane's earlier values: overwritten
        closed = ce.lane_bracket(lanes, 0, False, True, step[8], h, step[0], step[1], step[7],
                                 p, u, 1.0)
        trials = 0
        while not closed:
            trial = built["lane_trial"](lanes, 0, True, h, p, 1.0, 1.0, -10.0, p_hi, np.nan)
            step = toy_step(p, u, 0.0, 1.0, 1.0, trial, 9.81, 0.0, 0.0, 0.0, 0.0, shared, 0.0,
                            0.0, -10.0, p_hi, np.nan, 1e-6, 1e-6, frame)
            closed = ce.lane_bracket(lanes, 0, True, False, step[8], trial, step[0], step[1],
                                     step[7], p, u, 1.0)
            trials += 1
        assert lanes[EV_HI * LANES] == hi
        assert 0 < trials < 40  # far fewer than bisection's ~50 on these
        below = np.nextafter(hi, 0.0)
        args = (9.81, 0.0, 0.0, 0.0, 0.0, shared, 0.0, 0.0, -10.0, p_hi, np.nan, 1e-6, 1e-6,
                frame)
        assert toy_step(p, u, 0.0, 1.0, 1.0, below, *args)[8]
        assert not toy_step(p, u, 0.0, 1.0, 1.0, hi, *args)[8]


@pytest.mark.parametrize("name", ["loop", "quarter_pipe", "graph_sine"])
def test_a_point_anywhere_family_has_its_point_everywhere(name):
    """The lane kernel evaluates a ``point_anywhere`` family's point at a step's
    unclamped end (core/curve_vector.py), beyond the curve's ends or NaN: it
    must return there, finite wherever p is, and X = p on a wrapped ramp."""
    curve = CURVES[name][0]
    assert curve.spec.point_anywhere
    p = np.array([-1e3, -2.0, 1e-300, 7.5, 1e3])
    values = curve.evaluate(np.append(p, np.nan))
    assert np.isfinite(values["X"][:-1]).all() and np.isfinite(values["Y"][:-1]).all()
    if name == "graph_sine":
        np.testing.assert_array_equal(values["X"][:-1], p)
    # not the clothoid: its point's panels loop on p
    assert not Curve.create("clothoid", clothoid_parameter=1.0, length=2.0).spec.point_anywhere


def test_a_helper_is_shared_by_kernels_whose_constants_it_reads_agree():
    """core/curve_lanes._helper: one link-only helper per template and the
    values of the constants its code reads; others do not split it."""
    from rampwork.core import curve_steppers as cs

    constants = {"FRICTION": True, "DRAG": False, "DRAG_LINEAR": False, "DRAG_QUADRATIC": False,
                 "ONE_SIDED": True, "curve_frame": None}
    first = curve_lanes._helper(cs._stage_from, "k1", "stage_from", constants, shared=True)
    again = curve_lanes._helper(cs._stage_from, "k2", "stage_from",
                                {**constants, "ONE_SIDED": False}, shared=True)
    other = curve_lanes._helper(cs._stage_from, "k3", "stage_from",
                                {**constants, "FRICTION": False}, shared=True)
    assert again is first and other is not first
    assert first.targetoptions["no_cpython_wrapper"] and first.targetoptions["_nrt"] is False
    alone = curve_lanes._helper(cs._stage_from, "k4", "stage_from", constants, shared=False)
    assert alone is not first
