"""Bad input is refused before any work starts, with a ConfigError whose
message names the parameter (and, where there is one, the offending value).

None of these needs a compiled kernel: settings objects validate themselves,
and ``simulate`` checks scene, sweep and threads before it builds anything.
"""

from __future__ import annotations

import math
import re

import pytest

import rampwork as rw
from rampwork.errors import ConfigError

NAN, INF = math.nan, math.inf


def straight(**kwargs):
    return rw.Ramp.create("straight", slope=0.1, domain=(0.0, 1.0), **kwargs)


def scene(**kwargs):
    kwargs.setdefault("x0", 0.5)
    return rw.Scene(ramp=straight(), **kwargs)


def raises(names: str | tuple[str, ...], call, *value_texts: str):
    """``call()`` raises ConfigError; its message names every one of ``names``
    (as a word) and contains each of ``value_texts``."""
    with pytest.raises(ConfigError) as info:
        call()
    message = str(info.value)
    for name in (names,) if isinstance(names, str) else names:
        assert re.search(rf"\b{re.escape(name)}\b", message), (name, message)
    for text in value_texts:
        assert text in message, (text, message)
    return info.value


# ------------------------------------------------------------------------------
# friction
# ------------------------------------------------------------------------------
@pytest.mark.parametrize("kwargs, name", [
    (dict(mu_k=-0.1), "mu_k"),
    (dict(mu_k=0.1, mu_s=-0.2), "mu_s"),
])
def test_negative_friction(kwargs, name):
    raises(name, lambda: rw.Friction(**kwargs), "-0.")


@pytest.mark.parametrize("axis", ["mu", "mu_k", "mu_s"])
def test_negative_friction_axis(axis):
    raises(axis, lambda: rw.simulate(scene(friction=rw.Friction(0.0, 1.0)), rw.Sweep.grid(**{axis: [0.1, -0.25]})),
           "-0.25")


def test_static_below_kinetic():
    err = raises(("mu_s", "mu_k"), lambda: rw.Friction(mu_k=0.3, mu_s=0.2), "0.2", "0.3")
    assert err.where.endswith("mu_s")
    # a sweep whose cases put mu_s below mu_k
    raises(("mu_s", "mu_k"), lambda: rw.simulate(scene(), rw.Sweep.cases(mu_k=[0.1, 0.3], mu_s=[0.2, 0.2])))
    # a kinetic axis above the scene's static friction
    raises("mu_s", lambda: rw.simulate(scene(friction=rw.Friction(0.1, 0.2)), rw.Sweep.grid(mu_k=[0.1, 0.3])))
    # a static axis below the scene's kinetic friction
    raises("mu_s", lambda: rw.simulate(scene(friction=rw.Friction(0.3, 0.4)), rw.Sweep.grid(mu_s=[0.1, 0.5])))


# ------------------------------------------------------------------------------
# NaN and inf everywhere
# ------------------------------------------------------------------------------
@pytest.mark.parametrize("bad", [NAN, INF, -INF])
@pytest.mark.parametrize("name, build", [
    ("mu_k", lambda b: rw.Friction(mu_k=b)),
    ("mu_s", lambda b: rw.Friction(mu_k=0.1, mu_s=b)),
    ("dt", lambda b: rw.Integrator("rk4", dt=b)),
    ("x0", lambda b: scene(x0=b)),
    ("v0", lambda b: scene(v0=b)),
    ("m", lambda b: scene(m=b)),
    ("g", lambda b: scene(g=b)),
    ("t_max", lambda b: scene(t_max=b)),
    ("x0", lambda b: rw.Sweep.grid(x0=[0.5, b])),
    ("mu", lambda b: rw.Sweep.cases(mu=[b, 0.1])),
    ("slope", lambda b: rw.Sweep.grid(slope=[b])),
    ("slope", lambda b: rw.Ramp.create("straight", slope=b, domain=(0.0, 1.0))),
    ("curvature", lambda b: rw.Ramp.create("quadratic", curvature=b, domain=(0.0, 1.0))),
    ("radius", lambda b: rw.Ramp.create("circular_bowl", radius=b, domain=(-0.5, 0.5))),
    ("phase", lambda b: rw.Ramp.create("sine", amplitude=0.1, wavenumber=2.0, phase=b, domain=(0.0, 1.0))),
    ("domain", lambda b: rw.Ramp.create("straight", slope=0.1, domain=(0.0, b))),
    ("y_points", lambda b: rw.Ramp.create("spline", x_points=[0, 1, 2], y_points=[0.0, b, 1.0])),
])
def test_non_finite_values(name, build, bad):
    raises(name, lambda: build(bad))


# ------------------------------------------------------------------------------
# start values and the domain
# ------------------------------------------------------------------------------
def test_x0_outside_the_domain():
    raises("x0", lambda: rw.simulate(scene(x0=1.5)), "1.5")
    raises("x0", lambda: rw.simulate(scene(), rw.Sweep.grid(x0=[0.2, -0.75])), "-0.75")
    raises("x0", lambda: rw.simulate(scene(), rw.Sweep.cases(x0=[0.2, 2.5], v0=[0.0, 1.0])), "2.5")


def test_x0_missing():
    raises("x0", lambda: rw.simulate(rw.Scene(ramp=straight())))


# ------------------------------------------------------------------------------
# ramps
# ------------------------------------------------------------------------------
def test_unknown_family():
    raises("family", lambda: rw.Ramp.create("parabola", domain=(0.0, 1.0)), "parabola")


def test_unknown_ramp_parameter():
    raises("radius", lambda: rw.Ramp.create("quadratic", curvature=1.0, radius=2.0, domain=(0.0, 1.0)))


def test_missing_ramp_parameter():
    raises("curvature", lambda: rw.Ramp.create("quadratic", domain=(0.0, 1.0)))


def test_domain_reaching_a_vertical_tangent():
    raises("domain", lambda: rw.Ramp.create("circular_bowl", radius=1.0, domain=(-1.0, 0.5)))
    raises("domain", lambda: rw.Ramp.create("cycloid", radius=1.0, domain=(-1.0, 3.2)))


# ------------------------------------------------------------------------------
# integrator, scene, sweep, threads
# ------------------------------------------------------------------------------
@pytest.mark.parametrize("dt", [0.0, -1e-3])
def test_non_positive_dt(dt):
    raises("dt", lambda: rw.Integrator("rk4", dt=dt))


def test_unknown_method_and_contact():
    raises("method", lambda: rw.Integrator("rk45"), "rk45")
    raises("contact", lambda: scene(contact="glued"), "glued")


def test_too_many_steps_per_trajectory():
    raises("t_max", lambda: scene(integrator=rw.Integrator("rk4", 1e-12), t_max=1e3))


@pytest.mark.parametrize("axis", ["foo", "radius"])  # radius: an axis of another family
def test_unknown_sweep_axis(axis):
    raises(axis, lambda: rw.simulate(scene(), rw.Sweep.grid(**{axis: [0.1]})))


def test_mu_with_mu_k_axis():
    raises("mu", lambda: rw.Sweep.grid(mu=[0.1], mu_k=[0.1]))


def test_case_columns_of_different_lengths():
    raises("sweep", lambda: rw.Sweep.cases(x0=[0.1, 0.2], v0=[0.0]))


@pytest.mark.parametrize("threads", [0, -1, 1.5, True, "2"])
def test_bad_thread_count(threads):
    raises("threads", lambda: rw.simulate(scene(), threads=threads))


def test_sweep_too_big_for_memory():
    axis = [0.5] * 10_000
    raises("sweep", lambda: rw.simulate(scene(), rw.Sweep.grid(x0=axis, v0=axis, mu=axis)), "split")


def test_messages_show_plain_numbers():
    """Values appear as plain numbers, not as reprs of numpy scalars ('np.float64(...)')."""
    for call in (lambda: rw.simulate(scene(), rw.Sweep.grid(x0=[0.2, -0.75])),
                 lambda: rw.Sweep.grid(x0=[0.5, NAN]),
                 lambda: rw.simulate(scene(), rw.Sweep.cases(mu_k=[0.3], mu_s=[0.2]))):
        with pytest.raises(ConfigError) as info:
            call()
        assert "np." not in str(info.value), str(info.value)


def test_config_error_survives_pickling():
    """Errors raised on a Dask worker travel pickled to the client."""
    import pickle

    from rampwork.errors import ConfigError

    error = pickle.loads(pickle.dumps(ConfigError("integrator.dt", "must be > 0, got -1")))
    assert isinstance(error, ConfigError)
    assert (error.where, error.problem) == ("integrator.dt", "must be > 0, got -1")
    assert str(error) == "integrator.dt: must be > 0, got -1"


def test_record_index_beyond_the_sweep_is_refused_before_the_run(monkeypatch):
    from rampwork import kernels

    def no_kernel(*args):
        raise AssertionError("a kernel was built for a refused run")

    monkeypatch.setattr(kernels, "get_kernel", no_kernel)
    scene = rw.Scene(ramp=straight(), x0=0.5, record=rw.Record(indices=(0, 2)))
    with pytest.raises(ConfigError, match=r"record.indices\[1\].*beyond the sweep's 2 trajectories"):
        rw.simulate(scene, rw.Sweep.grid(v0=[0.0, 1.0]))
