"""Shared test helpers.

Kernels are compiled per (ramp family, integrator, contact) and cached on disk
by numba; the physics tests reuse few of those combinations to keep the suite
fast (a fresh compile costs ~20 s, a cached load ~1 s).
"""

from __future__ import annotations

import pytest


@pytest.fixture(scope="session")
def reference():
    """The scipy reference solver module (skips where scipy is missing)."""
    pytest.importorskip("scipy")
    from rampwork import reference as module

    return module
