"""Which compiled kernel runs a plan, and its compilation.

Two tiers, built from the same templates, with equal results:

* the **specialised** kernel of the plan's :class:`~rampwork.core.variant.KernelVariant`:
  every choice of the scene frozen at compile time; as fast as the hardware
  allows, and one compilation (2-9 s) per variant;
* the **general** kernel of the plan's kind (fixed steps, dopri5 or dop853):
  the ramp family, the fixed-step method and the effects read at run time
  (:mod:`rampwork.core.general`); compiled once per machine and then loaded
  from numba's disk cache in a fraction of a second.

``kernel="auto"`` (the default; ``RAMPWORK_KERNEL`` sets another) takes the
specialised kernel where it is loaded or cached already, else the general
one where that is (it is compiled only on request: ``kernel="general"``),
else compiles the specialised one.  On the general kernel,
:func:`rampwork.simulate` compiles the specialised kernel in the background
when the run is long enough to gain from it and hands over at a chunk
boundary.  Closed forms and ramps of user functions are always specialised.
"""

from __future__ import annotations

import functools
import hashlib
import os
import pathlib
import subprocess
import sys
import tempfile
import time

import numpy as np

from .core import general
from .core import kernel as K
from .core.jit import CORE_DIGEST, cache_location, disk_cached
from .core.steppers import ADAPTIVE_STEPPERS, STEPPERS
from .core.variant import ANY_FAMILY, ANY_FIXED_STEP, KernelVariant
from .plan import RunPlan
from .ramps import FAMILIES
from .validate import KERNEL_ENV, KERNEL_TIERS, kernel_tier  # noqa: F401 (KERNEL_ENV: public)

#: the kernel tiers a run may ask for (their one home: rampwork.validate, with KERNEL_ENV)
TIERS = KERNEL_TIERS
#: the environment variable that turns the background compilation of the
#: general kernels off ("0")
WARMUP_ENV = "RAMPWORK_WARMUP"
#: built-in families by their id in the general kernels
GENERAL_FAMILIES = tuple(name for name, family in FAMILIES.items()
                         if family.cacheable and family.general)
#: the general kernels, one per kind (fixed steps; each adaptive pair)
GENERAL_VARIANTS = (KernelVariant(ANY_FAMILY, ANY_FIXED_STEP, runtime=True),
                    *(KernelVariant(ANY_FAMILY, method, runtime=True)
                      for method in ADAPTIVE_STEPPERS))
#: a background compilation older than this is taken for dead (its lock is ignored)
WARMUP_STALE_S = 900

#: (run_batch, trace_one) by variant, built once per process (compiled or
#: loaded from the disk cache at their first call)
_KERNELS: dict = {}


requested_tier = kernel_tier  # ``kernel``, or the environment's default, checked


def has_general(plan: RunPlan) -> bool:
    """Whether a general kernel can run the plan (not a closed form or user functions)."""
    return not plan.variant.closed_form and plan.scene.ramp.spec.key in GENERAL_FAMILIES


def choose_tier(plan: RunPlan, kernel: str | None = None) -> str:
    """``"general"`` or ``"specialised"`` for the plan (see the module's doc)."""
    tier = requested_tier(kernel)
    if not has_general(plan):
        return "specialised"
    if tier == "auto":
        # the general kernel's first compilation costs more than a specialised
        # one's (it holds every family and effect): auto only takes it ready-made
        if (kernel_source(plan.variant, plan) == "compiled"
                and kernel_source(plan.variant.general(), plan) != "compiled"):
            return "general"
        return "specialised"
    return tier


def kernel_source(variant, plan: RunPlan) -> str:
    """Where the variant's kernel comes from: ``"loaded"`` (built in this
    process already), ``"disk cache"`` (numba's cache holds it) or
    ``"compiled"`` (it must be compiled: seconds, not milliseconds)."""
    (run_batch, _), _ = get_kernel(variant, plan)  # the dispatchers only: nothing compiled yet
    if run_batch.run_tiles.overloads:
        return "loaded"
    return "disk cache" if disk_cached(run_batch) else "compiled"


def get_kernel(variant, plan: RunPlan):
    """The compiled ``(run_batch, trace_one)`` of a variant (the plan's own or
    its general one), built once per process and loaded from numba's disk
    cache where it was compiled before.  Returns ``(kernels, seconds)``."""
    if variant in _KERNELS:
        return _KERNELS[variant], 0.0
    started = time.perf_counter()
    if variant.runtime:
        height, slope_curvature = _general_switches()
        cache = True
    else:
        spec = plan.scene.ramp.spec
        height, slope_curvature, cache = spec.height, spec.slope_curvature, spec.cacheable
    kernels = K.build_kernel(variant, height, slope_curvature, cache=cache)
    _KERNELS[variant] = kernels
    return kernels, time.perf_counter() - started


@functools.cache
def _general_switches():
    return general.build_switches((name, FAMILIES[name].height, FAMILIES[name].slope_curvature)
                                  for name in GENERAL_FAMILIES)


def tier_variant(plan: RunPlan, tier: str):
    return plan.variant.general() if tier == "general" else plan.variant


def tier_shared(plan: RunPlan, tier: str) -> np.ndarray:
    """The ``shared`` array a tier's kernel reads: a general kernel's starts
    with the family and fixed-step method ids."""
    shared = plan.scene.ramp.shared_array()
    if tier != "general":
        return shared
    method = plan.variant.method
    method_id = list(STEPPERS).index(method) if method in STEPPERS else 0
    header = general.shared_header(GENERAL_FAMILIES.index(plan.scene.ramp.spec.key), method_id,
                                   plan.variant.short_stages)
    return np.concatenate([header, shared])


def runtime_settings(plan: RunPlan) -> np.ndarray:
    """The run-time choices a general kernel reads after the settings
    (a specialised kernel ignores them)."""
    return general.runtime_values(plan.variant)


def missing_general() -> tuple:
    """The general kernels that are neither loaded here nor in the disk cache."""
    return tuple(variant for variant in GENERAL_VARIANTS
                 if kernel_source(variant, None) == "compiled")


def _warmup_lock() -> pathlib.Path:
    key = hashlib.sha256(f"{cache_location()}|{CORE_DIGEST}".encode()).hexdigest()[:16]
    return pathlib.Path(tempfile.gettempdir()) / f"rampwork-warmup-{key}.lock"


def warmup_wanted() -> bool:
    """Whether the general kernels should be compiled in the background now:
    some are missing and ``RAMPWORK_WARMUP`` is not "0"."""
    return os.environ.get(WARMUP_ENV, "1") != "0" and bool(missing_general())


def start_warmup() -> bool:
    """Compile the general kernels missing from the disk cache in a process of
    their own, in the background (once per machine and rampwork version):
    after it, a scene never run before starts in about a second.  Returns
    whether it started one (not where ``RAMPWORK_WARMUP=0``, where nothing is
    missing, or where one is running already)."""
    if not warmup_wanted():
        return False
    lock = _warmup_lock()
    try:
        if time.time() - lock.stat().st_mtime < WARMUP_STALE_S:
            return False
        lock.unlink()
    except FileNotFoundError:
        pass
    try:
        with open(lock, "x", encoding="utf-8") as handle:
            handle.write(str(os.getpid()))
    except FileExistsError:  # another process got there first
        return False
    subprocess.Popen([sys.executable, "-m", "rampwork.warmup", "--lock", str(lock)],
                     start_new_session=True, stdin=subprocess.DEVNULL,
                     stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return True
