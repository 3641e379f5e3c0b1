"""g and the ramp parameters of a lane, for the lane kernels' templates.

Where every trajectory of a run shares them (kernels built with
``uniform_parameters``), they are the run's settings, read once per block and
held in registers, instead of five more lane loads per step.  Templates:
``LANES`` and ``UNIFORM_PARAMETERS`` are bound per scene by
``kernel.build_kernel``.
"""

from __future__ import annotations

from .layout import G, P0, P1, P2, P3, SET_G, SET_P0, SET_P1, SET_P2, SET_P3

# bound per scene by kernel.build_kernel
LANES = 64
UNIFORM_PARAMETERS = False


def _uniform_parameters(settings):
    """(g, p0, p1, p2, p3) of the run where it shares them; zeros (unused)
    otherwise."""
    if UNIFORM_PARAMETERS:
        return (settings[SET_G], settings[SET_P0], settings[SET_P1], settings[SET_P2],
                settings[SET_P3])
    return (0.0, 0.0, 0.0, 0.0, 0.0)


def _lane_parameters(lanes, i, uniform):
    """(g, p0, p1, p2, p3) of lane i: ``uniform`` (from
    :func:`_uniform_parameters`) where the run shares them."""
    if UNIFORM_PARAMETERS:
        return uniform
    return (lanes[G * LANES + i], lanes[P0 * LANES + i], lanes[P1 * LANES + i],
            lanes[P2 * LANES + i], lanes[P3 * LANES + i])
