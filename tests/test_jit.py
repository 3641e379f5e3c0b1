"""core/jit.py: helpers that only jitted code calls are link-only (no machine
code, no cache file of their own) and still run correctly inside a caller."""

import math

import numba
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
