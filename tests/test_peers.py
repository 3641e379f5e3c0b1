"""The peers of benchmarks/accuracy_cost.py --peers (heyoka, CyRK) integrate
rampwork's physics: on a few starts of each ramp family they end with the
status, the reversals and the friction work of the independent reference
(rampwork.reference, scipy DOP853 with events), to their tolerance.  Skipped
where the optional 'bench' extra is not installed."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("scipy")
ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))
peers = pytest.importorskip("peers")

import rampwork as rw  # noqa: E402
from rampwork import reference  # noqa: E402

#: (family, params, domain, starts (x0, v0, mu)): sticking after swings, exits at
#: either end, starts from rest (sliding off or held), lift-off over a crest
CASES = [
    ("quadratic", {"curvature": 1.0, "slope": 0.0, "height": 0.0}, (-1.0, 1.0),
     [(0.5, 0.0, 0.1), (0.9, 3.0, 0.05), (-0.3, -1.0, 0.3), (0.0, 5.0, 0.02), (0.95, 0.0, 0.5),
      (0.2, 0.0, 0.3), (-0.6, 4.0, 0.04)]),
    ("circular_dome", {"radius": 1.0, "x_centre": 0.0, "y_centre": 0.0}, (-0.95, 0.95),
     [(0.0, 1.5, 0.05), (0.1, 0.5, 0.3), (-0.1, -1.0, 0.2)]),
    ("circular_bowl", {"radius": 1.0, "x_centre": 0.0, "y_bottom": 0.0}, (-0.95, 0.95),
     [(0.8, 0.2, 0.08), (0.6, -0.4, 0.05)]),
    ("sine", {"mean_slope": -0.2, "amplitude": 0.05, "wavenumber": 2.0 * math.pi, "phase": 0.0}, (-2.0, 2.0),
     [(-1.5, 1.0, 0.1), (-1.7, 0.2, 0.3), (-1.3, 1.4, 0.06)]),
]
T_MAX = 60.0


def _reference(family, params, domain, starts):
    ramp = rw.Ramp.create(family, domain=domain, **params)
    scene = rw.Scene(ramp=ramp, friction=rw.Friction(mu_k=0.1), t_max=T_MAX)
    out = []
    for x0, v0, mu in starts:
        out.append(reference.reference_trajectory(scene, x0=x0, v0=v0, mu_k=mu, mu_s=mu, rtol=1e-13, atol=1e-15))
    return out


def _check(result, ref_runs, rel):
    for j, ref in enumerate(ref_runs):
        assert result["status"][j] == ref["status"], (j, result["status"][j], ref["status"])
        assert result["n_reversals"][j] == ref["n_reversals"], j
        scale = max(abs(ref["W_friction"]), 1e-9)
        assert abs(result["W_friction"][j] - ref["W_friction"]) <= rel * scale, (j, result["W_friction"][j], ref)
        assert abs(result["t_end"][j] - ref["t_end"]) <= 1e3 * rel * max(ref["t_end"], 1.0), j
        assert abs(result["x_end"][j] - ref["x_end"]) <= 1e3 * rel, j


def _task(family, params, domain, starts):
    key = peers.ramp_key(family, params, domain, 9.81, T_MAX)
    x0, v0, mu = (np.array(c, float) for c in zip(*starts))
    return key, x0, v0, mu


@pytest.mark.parametrize("family, params, domain, starts", CASES, ids=[c[0] for c in CASES])
def test_heyoka_matches_the_reference(family, params, domain, starts):
    pytest.importorskip("heyoka")
    key, x0, v0, mu = _task(family, params, domain, starts)
    result = peers.heyoka_chunk((key, 1e-12, x0, v0, mu, mu))
    _check(result, _reference(family, params, domain, starts), rel=1e-9)


@pytest.mark.parametrize("family, params, domain, starts", CASES, ids=[c[0] for c in CASES])
def test_cyrk_matches_the_reference(family, params, domain, starts):
    pytest.importorskip("CyRK")
    key, x0, v0, mu = _task(family, params, domain, starts)
    refs = _reference(family, params, domain, starts)
    _check(peers.cyrk_chunk((key, "DOP853", 1e-11, x0, v0, mu, mu)), refs, rel=1e-7)
    module, why = peers.build_cyrk()
    if module is None:
        pytest.skip(why)
    _check(peers.cyrk_compiled_chunk((key, "DOP853", 1e-11, x0, v0, mu, mu)), refs, rel=1e-7)


def test_heyoka_lanes_refilled_as_trajectories_end():
    """More starts than SIMD lanes, in an order that ends trajectories at
    different times: each result is that of the start integrated alone."""
    pytest.importorskip("heyoka")
    family, params, domain, starts = CASES[0]
    key, x0, v0, mu = _task(family, params, domain, starts * 3)
    together = peers.heyoka_chunk((key, 1e-10, x0, v0, mu, mu))
    for j in range(x0.size):
        alone = peers.heyoka_chunk((key, 1e-10, x0[j:j + 1], v0[j:j + 1], mu[j:j + 1], mu[j:j + 1]))
        assert alone["status"][0] == together["status"][j]
        assert alone["W_friction"][0] == pytest.approx(together["W_friction"][j], rel=1e-12, abs=1e-15)
