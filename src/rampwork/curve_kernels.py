"""The compiled curve kernels, built once per process, and their two tiers
(docs/guide/compilation.md): which kernel runs a curve sweep."""

from __future__ import annotations

from . import validate
from .core import curve_lanes
from .curve_families import CurveFamily

_KERNELS: dict = {}

#: the largest sweep that ``kernel="auto"`` runs on a curve's general kernel
#: (every effect compiled in) while the specialised one is not compiled: a
#: few seconds of work at most, where a compilation costs 5-25 s
GENERAL_MAX_CASES = 1 << 15


def curve_tier(spec: CurveFamily, method: str, kernel: str | None, n: int, *, one_sided: bool,
               friction: bool, drag_linear: bool, drag_quadratic: bool, joints: int,
               vector: bool = True) -> str:
    """``"general"`` or ``"specialised"``: which curve kernel runs ``n``
    trajectories (``kernel``: a tier of :data:`rampwork.validate.KERNEL_TIERS`, None
    for ``RAMPWORK_KERNEL``'s or ``"auto"``).  A curve's general kernel is
    its family's and method's (and contact's and joint count's) with
    friction and both drag terms compiled in: zero coefficients make them
    exact no-ops, so it gives the specialised kernel's results bit for bit
    (tests/test_curve_tiers.py), and a scene that adds friction or drag
    compiles nothing new.  ``auto``: the specialised kernel where it is
    compiled or in numba's disk cache, else the general one for sweeps of
    at most :data:`GENERAL_MAX_CASES`, else the specialised one."""
    from .core.jit import disk_cached  # looked up per call: tests replace it

    tier = validate.kernel_tier(kernel)
    if tier != "auto":
        return tier
    if not spec.cacheable or (friction and drag_linear and drag_quadratic) or n > GENERAL_MAX_CASES:
        return "specialised"
    specialised = curve_kernel_for(spec, method, one_sided=one_sided, friction=friction,
                                   drag_linear=drag_linear, drag_quadratic=drag_quadratic,
                                   joints=joints, vector=vector)
    ready = specialised.run_tiles.overloads or disk_cached(specialised.run_tiles)
    return "specialised" if ready else "general"


def curve_kernel_for(spec: CurveFamily, method: str, *, one_sided: bool, friction: bool,
                     drag_linear: bool, drag_quadratic: bool, joints: int, vector: bool = True):
    """The compiled lane kernel for these choices (built once per process);
    ``vector=False``: the scalar reference (curve_lanes.build_curve_kernel)."""
    key = (spec.key, method, one_sided, friction, drag_linear, drag_quadratic, joints, vector)
    if key not in _KERNELS or not spec.cacheable:
        kernel = curve_lanes.build_curve_kernel(
            spec.key, spec.frame, spec.point, method, one_sided=one_sided, friction=friction,
            drag_linear=drag_linear, drag_quadratic=drag_quadratic, joints=joints,
            cache=spec.cacheable, vector=vector, point_anywhere=spec.point_anywhere)
        if not spec.cacheable:
            return kernel
        _KERNELS[key] = kernel
    return _KERNELS[key]
