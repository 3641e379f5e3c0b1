"""core/jit.py: helpers that only jitted code calls are link-only (no machine
code, no cache file of their own) and still run correctly inside a caller."""

import math

import numba
import numpy as np
import pytest

from rampwork.core.jit import INTERNAL_OPTIONS, jit


@jit(internal=True)
def _inner(x):
    return math.sin(x) * x + 1.0


@jit(internal=True)
def _middle(x):
    return _inner(x) * _inner(x + 1.0)


@jit(cache=False)
def _outer(x):
    return _middle(x) - 2.0


def _library(dispatcher):
    (overload,) = dispatcher.overloads.values()
    return overload.library


def test_internal_helpers_run_inside_a_caller_without_machine_code_of_their_own():
    x = 0.7
    expected = (math.sin(x) * x + 1.0) * (math.sin(x + 1.0) * (x + 1.0) + 1.0) - 2.0
    assert _outer(x) == pytest.approx(expected, rel=1e-15)
    for helper in (_inner, _middle):
        library = _library(helper)
        assert type(library).__name__ == "_LinkOnlyLibrary"
        assert not library._emitted, "a link-only helper was emitted to machine code"
    assert type(_library(_outer)).__name__ != "_LinkOnlyLibrary"


def test_internal_helpers_have_no_wrapper_and_no_cache():
    # (not callable from Python: numba gives them no wrapper to call)
    assert INTERNAL_OPTIONS["no_cpython_wrapper"] and INTERNAL_OPTIONS["cache"] is False
    _outer(0.2)
    assert _inner._cache.__class__.__name__ == "NullCache"


def test_a_link_only_library_is_emitted_when_asked_for_its_code():
    _outer(0.1)
    library = _library(_middle)
    assert "ret" in library.get_asm_str()
    assert library._emitted


def test_internal_overrides_cannot_turn_the_cache_back_on():
    helper = jit(lambda x: x + 1.0, internal=True, cache=True)
    assert isinstance(helper, numba.core.registry.CPUDispatcher)
    assert helper._cache.__class__.__name__ == "NullCache"


@pytest.mark.parametrize("size", [1, 7, 8, 63, 64, 1000, 4097])
def test_aligned_zeros_start_on_a_cache_line(size):
    # numba itself aligns to 32 bytes: over a few dozen live allocations of
    # varied sizes some would start mid-line without the padding
    from rampwork.core.jit import CACHE_LINE, aligned_zeros

    @numba.njit
    def offsets(n, count):
        out = np.empty((count, 3), np.int64)
        previous = aligned_zeros(1)
        for k in range(count):
            a = aligned_zeros(n + k % 3)
            out[k, 0] = a.ctypes.data % CACHE_LINE
            out[k, 1] = a.size - (n + k % 3)
            out[k, 2] = np.count_nonzero(a)
            a[-1] = previous[0]  # both stay live: the allocator moves on
            previous = a
        return out

    assert not offsets(size, 40).any()


def test_refcount_off_compiles_without_numba_reference_counting():
    """``refcount=False``: numba's ``_nrt=False`` (a helper that allocates
    nothing, passing arrays without incref/decref pairs)."""
    helper = jit(lambda a, i: a[i] * 2.0, internal=True, refcount=False)
    assert helper.targetoptions["_nrt"] is False
    assert "_nrt" not in jit(lambda x: x, cache=False).targetoptions
