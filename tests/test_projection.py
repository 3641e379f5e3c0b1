"""The adaptive pairs' projection onto the energy balance (docs/physics.md 1.6).

Expected values come from the independent scipy reference
(:mod:`rampwork.reference`) and from the energy balance itself; runs without
the projection are compared with runs with it only where the contract says
how they relate (energy_balance_error, to first order).
"""

from __future__ import annotations

import numpy as np
import pytest

import rampwork as rw
from rampwork import scenefile
from rampwork.core.status import STUCK
from rampwork.errors import ConfigError

PAIRS = ("dopri5", "dop853")
EPS = np.finfo(float).eps
#: y = x^2 / 2 on [-1, 1] from rest at x0 = 0.8 with mu = 0.02: 17 reversals
#: before it sticks, 200-1,800 steps, where the energy each step loses or
#: gains adds up
BOWL = rw.Ramp.create("quadratic", curvature=1.0, domain=(-1.0, 1.0))
MU = 0.02


def bowl_scene(method, rtol, atol, **kwargs):
    return rw.Scene(ramp=BOWL, x0=0.8, friction=rw.Friction(MU),
                    integrator=rw.Integrator(method, rtol=rtol, atol=atol, **kwargs))


@pytest.fixture(scope="module")
def long_reference(reference):
    ref = reference.reference_trajectory(bowl_scene("dopri5", 1e-9, 1e-9), mu_k=MU, mu_s=MU,
                                         rtol=3e-14, atol=3e-14)
    assert ref["status"] == STUCK and ref["n_reversals"] >= 15, ref["events"]
    return ref


@pytest.mark.parametrize("method", PAIRS)
@pytest.mark.parametrize("rtol, atol", [(1e-9, 1e-9), (1e-10, 1e-14)])
def test_projection_removes_the_error_that_adds_up(method, rtol, atol, long_reference):
    """On a long, slowly damped trajectory the unprojected pairs' W is off by
    the energy they lost or gained (measured: 20-50 rtol W for dopri5, 1-3
    for dop853); projected, by at most rtol W (measured 0.0001-0.13), at
    least ten times less."""
    w_ref = long_reference["W_friction"]
    on = rw.simulate(bowl_scene(method, rtol, atol))
    off = rw.simulate(bowl_scene(method, rtol, atol, project_energy=False))
    for ds in (on, off):
        assert int(ds.status) == STUCK and int(ds.n_reversals) == long_reference["n_reversals"]
    error_on = abs(float(on.W_friction) - w_ref)
    error_off = abs(float(off.W_friction) - w_ref)
    assert error_on <= rtol * w_ref, (error_on, error_off)
    assert error_on * 10.0 <= error_off, (error_on, error_off)


@pytest.mark.parametrize("method", PAIRS)
def test_energy_balance_error_keeps_its_meaning(method):
    """Projected, the balance W_friction - W_energy holds to rounding, and
    energy_balance_error reports the residuals the projection removed: the
    balance error of the unprojected run, to first order (measured within
    1 %).  Unprojected, it is W_friction - W_energy exactly."""
    on = rw.simulate(bowl_scene(method, 1e-9, 1e-9))
    off = rw.simulate(bowl_scene(method, 1e-9, 1e-9, project_energy=False))
    w = float(on.W_friction)
    assert abs(w - float(on.W_energy)) <= 100 * EPS * w
    balance_off = float(off.energy_balance_error)
    assert balance_off == float(off.W_friction) - float(off.W_energy)
    assert abs(balance_off) > 1e-3 * 1e-9 * w  # a drift worth estimating
    assert abs(float(on.energy_balance_error) - balance_off) <= 0.05 * abs(balance_off)


def test_projection_is_on_by_default_and_named_in_the_kernel_effects():
    assert rw.Integrator("dopri5").project_energy and rw.Integrator("dop853").project_energy
    on = rw.simulate(bowl_scene("dop853", 1e-8, 1e-8))
    off = rw.simulate(bowl_scene("dop853", 1e-8, 1e-8, project_energy=False))
    assert "energy projection" in on.attrs["kernel_effects"]
    assert "energy projection" not in off.attrs["kernel_effects"]
    assert "no energy projection" in rw.Integrator("dop853", project_energy=False).describe()


@pytest.mark.parametrize("kwargs", [
    dict(method="rk4", project_energy=False),
    dict(method="euler", dt=1e-3, project_energy=False),
    dict(method="dopri5", project_energy=1),
    dict(method="dop853", project_energy="no"),
])
def test_project_energy_setting_is_checked(kwargs):
    with pytest.raises(ConfigError) as info:
        rw.Integrator(**kwargs)
    assert info.value.where == "integrator.project_energy"


def test_scene_file_round_trips_project_energy():
    text = """
[ramp]
family = "quadratic"
curvature = 1.0
domain = [-1.0, 1.0]

[integrator]
method = "dop853"
rtol = 1e-9
project_energy = false
"""
    scene, _ = scenefile.parse_scene(text)
    assert scene.integrator.project_energy is False
    again, _ = scenefile.parse_scene(scenefile.dump_scene(scene))
    assert again.integrator == scene.integrator
    default, _ = scenefile.parse_scene(text.replace("project_energy = false\n", ""))
    assert default.integrator.project_energy is True
    assert "project_energy =" not in scenefile.dump_scene(default)
    with pytest.raises(ConfigError) as info:
        scenefile.parse_scene(text.replace("project_energy = false", "project_energy = 0"))
    assert "integrator.project_energy" in str(info.value)
