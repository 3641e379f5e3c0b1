"""A name for what user functions compute, so kernels built on them can be cached.

A kernel compiled on a ramp of user functions (``Ramp.from_functions``) has
the functions' code compiled into it.  numba's disk cache keys a kernel by its
name and by rampwork's own sources, so the name must change whenever the user
functions would compute something else: it carries :func:`content_digest`,
a digest of their byte code, constants and the values of every global and
closure variable they read (recursively through the jitted functions they
call).  Where a value cannot be named stably (an arbitrary object), there is
no digest and the kernel is compiled in every process, as before.
"""

from __future__ import annotations

import hashlib
import types

import numpy as np

#: types whose repr names their value exactly
_PLAIN = (bool, int, float, complex, str, bytes, type(None), np.number, np.bool_)


def content_digest(functions) -> str | None:
    """A digest of what ``functions`` (numba dispatchers or plain functions)
    compute, or None where one of them reads a value that has no stable name."""
    digest = hashlib.sha256()
    seen: set[int] = set()
    for function in functions:
        if not _add_function(digest, function, seen):
            return None
    return digest.hexdigest()[:20]


def _add_function(digest, function, seen) -> bool:
    python = getattr(function, "py_func", function)
    code = getattr(python, "__code__", None)
    if code is None:
        return False
    if id(python) in seen:
        digest.update(b"<seen>")
        return True
    seen.add(id(python))
    # numba's options for it (fastmath, error_model) change the code it compiles to
    digest.update(repr(sorted(getattr(function, "targetoptions", {}).items())).encode())
    _add_code(digest, code)
    names = set()
    _global_names(code, names)
    namespace = getattr(python, "__globals__", {})
    for name in sorted(names):
        if name in namespace:
            digest.update(name.encode())
            if not _add_value(digest, namespace[name], seen):
                return False
    for cell in python.__closure__ or ():
        if not _add_value(digest, cell.cell_contents, seen):
            return False
    return True


def _add_code(digest, code) -> None:
    digest.update(code.co_code)
    digest.update(repr((code.co_names, code.co_varnames, code.co_argcount)).encode())
    for constant in code.co_consts:
        if isinstance(constant, types.CodeType):
            _add_code(digest, constant)
        else:
            digest.update(repr(constant).encode())


def _global_names(code, names) -> None:
    names.update(code.co_names)
    for constant in code.co_consts:
        if isinstance(constant, types.CodeType):
            _global_names(constant, names)


def _add_value(digest, value, seen) -> bool:
    if isinstance(value, _PLAIN):
        digest.update(f"{type(value).__name__}:{value!r}".encode())
        return True
    if isinstance(value, tuple):
        return all(_add_value(digest, item, seen) for item in value)
    if isinstance(value, np.ndarray):
        digest.update(repr((value.dtype.str, value.shape)).encode() + value.tobytes())
        return True
    if isinstance(value, types.ModuleType):  # math, numpy: named by their version-free name
        digest.update(f"module:{value.__name__}".encode())
        return True
    if isinstance(value, types.BuiltinFunctionType):
        digest.update(f"builtin:{getattr(value, '__module__', '')}.{value.__name__}".encode())
        return True
    if isinstance(value, np.ufunc):
        digest.update(f"ufunc:{value.__name__}".encode())
        return True
    if callable(value) and hasattr(getattr(value, "py_func", value), "__code__"):
        return _add_function(digest, value, seen)
    return False
