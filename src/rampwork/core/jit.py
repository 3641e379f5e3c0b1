"""The one place that sets numba's compilation options.

Every jitted function in rampwork is built with :func:`jit` (plain functions) or
:func:`specialise` (kernels built per scene from a template).  Keep NaN/inf checks
valid: no ``fastmath`` flag that assumes finite values.
"""

from __future__ import annotations

import hashlib
import os
import pathlib
import types

import numba

#: Options shared by every jitted function.  ``error_model="numpy"`` makes a
#: division by zero give inf/NaN (caught by status codes) instead of raising, and
#: lets LLVM vectorise loops that divide.
JIT_OPTIONS = dict(cache=True, nogil=True, error_model="numpy", fastmath=False)


def _prefer_wide_vectors() -> str | None:
    """Let LLVM use 512-bit vectors where the CPU has AVX-512.

    LLVM's tuning for recent Intel cores says 'prefer-256-bit'; the lane loops
    are bound by division throughput and run about 1.4x faster with 512-bit
    vectors.  This only changes instruction selection, never results' meaning,
    and only if nothing has been compiled in this process yet.  Set
    RAMPWORK_VECTOR_WIDTH=256 (or NUMBA_CPU_FEATURES) to keep LLVM's default.
    """
    if os.environ.get("NUMBA_CPU_FEATURES") or os.environ.get("RAMPWORK_VECTOR_WIDTH") == "256":
        return None
    try:
        import llvmlite.binding as llvm

        features = llvm.get_host_cpu_features()
    except Exception:  # pragma: no cover - unusual llvmlite builds
        return None
    if not features.get("avx512f", False):
        return None
    numba.config.CPU_FEATURES = features.flatten() + ",-prefer-256-bit"
    return numba.config.CPU_FEATURES


_prefer_wide_vectors()


def jit(function=None, **overrides):
    """``numba.njit`` with the project's options (usable bare or with overrides)."""
    options = {**JIT_OPTIONS, **overrides}
    if function is None:
        return lambda f: numba.njit(**options)(f)
    return numba.njit(**options)(function)


def _core_source_digest() -> str:
    """A digest of the core sources: numba's cache only watches the file that
    defines a function, so a kernel's cache name carries this to be invalidated
    when any core module it inlines changes."""
    digest = hashlib.sha256()
    for path in sorted(pathlib.Path(__file__).parent.glob("*.py")):
        digest.update(path.read_bytes())
    return digest.hexdigest()[:12]


CORE_DIGEST = _core_source_digest()


def specialise(template, name: str, constants: dict, **jit_overrides):
    """Compile ``template`` with some of its globals replaced by ``constants``.

    This is how a kernel is built per scene: the template's code reads names
    such as ``ramp_slope_curvature`` or ``ONE_SIDED`` as globals, and here they
    become compile-time constants (numba freezes global values), so branches a
    scene does not need are removed by the compiler.  A closure would do the
    same, but numba cannot cache closures that capture jitted functions across
    processes (their pickles differ); a fresh function object with its own
    globals and a unique qualified name caches to its own file.

    ``name`` must be unique per set of constants; pass ``cache=False`` in
    ``jit_overrides`` when a constant cannot be named stably (user callables).
    """
    namespace = dict(template.__globals__)
    namespace.update(constants)
    qualname = f"{name}_{CORE_DIGEST}"
    function = types.FunctionType(
        template.__code__, namespace, qualname, template.__defaults__, template.__closure__
    )
    function.__qualname__ = qualname
    function.__doc__ = template.__doc__
    return jit(function, **jit_overrides)
