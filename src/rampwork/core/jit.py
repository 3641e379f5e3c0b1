"""The one place that sets numba's compilation options.

Every jitted function in rampwork is built with :func:`jit` (plain functions) or
:func:`specialise` (kernels built per scene from a template).  Keep NaN/inf checks
valid: no ``fastmath`` flag that assumes finite values.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import pathlib
import types

import llvmlite.binding as llvm
import numba
import numpy as np
from llvmlite import ir
from numba.core.codegen import JITCodeLibrary
from numba.core.compiler import Compiler
from numba.core.compiler_lock import require_global_compiler_lock
from numba.core import types as nbtypes
from numba.extending import intrinsic

#: Options shared by every jitted function.  ``error_model="numpy"`` makes a
#: division by zero give inf/NaN (caught by status codes) instead of raising, and
#: lets LLVM vectorise loops that divide.  No fast-math flag at all: NaN and
#: infinity checks stay valid, and a vector loop rounds exactly like its scalar
#: remainder, which keeps results independent of the lane a trajectory runs in
#: (fused multiply-adds, where they pay, are written explicitly with ``fma``).
JIT_OPTIONS = dict(cache=True, nogil=True, error_model="numpy", fastmath=False)


#: LLVM's inlining budget (its default at -O3 is 250).  A lane loop vectorises
#: only if every call in its body is inlined, and one step of a 7-stage pair
#: with its error norm is far over the default budget.
INLINE_THRESHOLD = 5000


def _tune_llvm() -> None:
    """Code-generation settings for the lane loops (results unchanged).

    * Vector width: LLVM's tuning for recent Intel cores says 'prefer-256-bit';
      the lane loops run about 1.4x faster with 512-bit vectors where the CPU
      has AVX-512.  Effective only if nothing was compiled in this process yet.
    * Inlining budget: see INLINE_THRESHOLD (without it the adaptive lane loop
      stays scalar, 2.5x slower).
    * Interleaving: a request to interleave two vector iterations of a lane
      loop (LLVM does not always follow it for large loop bodies; the lane
      loops interleave two halves of the block explicitly anyway).

    All are process-wide LLVM settings that only change instruction
    selection.  Set RAMPWORK_VECTOR_WIDTH=256 (or NUMBA_CPU_FEATURES) to keep
    LLVM's vector width, RAMPWORK_INTERLEAVE=0 to keep its interleaving.
    """
    llvm.set_option("rampwork", f"-inline-threshold={INLINE_THRESHOLD}")
    interleave = os.environ.get("RAMPWORK_INTERLEAVE", "2")
    if interleave != "0":
        llvm.set_option("rampwork", f"-force-vector-interleave={interleave}")
    if os.environ.get("NUMBA_CPU_FEATURES") or os.environ.get("RAMPWORK_VECTOR_WIDTH") == "256":
        return
    features = llvm.get_host_cpu_features()
    if features.get("avx512f", False):
        numba.config.CPU_FEATURES = features.flatten() + ",-prefer-256-bit"


_tune_llvm()


class _LinkOnlyLibrary(JITCodeLibrary):
    """The code library of a function that only jitted code calls.

    numba finalizes every compiled function's library on its own: it links
    in the callee tree, optimises the whole module and emits machine code
    (then caches it).  For a helper that only a kernel calls, all of that
    is repeated when the kernel links it in and is never used: measured on
    a dop853 kernel, 81 helper libraries took 4.9 s of an 11 s compilation
    against 1.0 s for the kernel's own.  This library links its callees and
    stops; the caller's module optimises everything once.  Machine code is
    still emitted if anything asks for it (a defined symbol's address, a
    serialisation, the assembly)."""

    _emitted = False
    _environments = ()

    @property
    def codegen(self):
        return _EnvironmentDeferringCodegen(self)

    def finalize(self):
        require_global_compiler_lock()
        self._raise_if_finalized()
        seen = set()
        for library in self._linking_libraries:
            if library not in seen:
                seen.add(library)
                self._reload_init.update(library._reload_init)
                self._final_module.link_in(library._get_module_for_linking(), preserve=True)
        self._finalized = True

    def _emit(self):
        self._ensure_finalized()
        if not self._emitted:
            self._emitted = True
            self._optimize_final_module()
            self._final_module.verify()
            self._finalize_final_module()
            for name, environment in self._environments:
                self._codegen.set_env(name, environment)

    def _defines(self, name) -> bool:
        self._ensure_finalized()
        try:
            return not self._final_module.get_function(name).is_declaration
        except NameError:
            return False

    def get_pointer_to_function(self, name):
        # numba asks for the (absent) Python wrapper of every function it compiles
        if not self._defines(name):
            return 0
        self._emit()
        return super().get_pointer_to_function(name)

    def has_dynamic_globals(self):
        self._emit()
        return super().has_dynamic_globals()

    def serialize_using_object_code(self):
        self._emit()
        return super().serialize_using_object_code()

    def serialize_using_bitcode(self):
        self._emit()
        return super().serialize_using_bitcode()

    def get_asm_str(self):
        self._emit()
        return super().get_asm_str()


class _EnvironmentDeferringCodegen:
    """The codegen as numba sees it through a :class:`_LinkOnlyLibrary`:
    ``set_env`` writes into the emitted module's globals, so it waits for
    the emission (where the code runs inside a caller, the caller's module
    has its own copy of the global: as with numba's own libraries)."""

    def __init__(self, library):
        self._library = library

    def set_env(self, name, environment):
        library = self._library
        library._environments = (*library._environments, (name, environment))
        if library._emitted:
            library._codegen.set_env(name, environment)

    def __getattr__(self, name):
        return getattr(self._library._codegen, name)


class _LinkOnlyCompiler(Compiler):
    """numba's pipeline, lowering into a :class:`_LinkOnlyLibrary`."""

    def compile_extra(self, func):
        if self.state.library is None:
            self.state.library = _LinkOnlyLibrary(self.state.targetctx.codegen(), func.__qualname__)
        return super().compile_extra(func)


#: the options of a function only jitted code calls (``jit(..., internal=True)``):
#: no Python or C wrapper, a link-only library, and so no disk cache of its own
#: (the kernels that call it are cached with its code inside them)
INTERNAL_OPTIONS = dict(no_cpython_wrapper=True, no_cfunc_wrapper=True,
                        pipeline_class=_LinkOnlyCompiler, cache=False)


def jit(function=None, *, internal: bool = False, refcount: bool = True, **overrides):
    """``numba.njit`` with the project's options (usable bare or with
    overrides); ``internal=True`` for a function that only jitted code calls
    (:data:`INTERNAL_OPTIONS`); ``refcount=False`` for one that allocates
    nothing: compiled without numba's reference counting, so a call that
    passes an array does no atomic incref/decref pair (in a lane loop they
    cost more than the arithmetic, and keep it from vectorising)."""
    options = {**JIT_OPTIONS, **overrides, **(INTERNAL_OPTIONS if internal else {})}
    if not refcount:
        options["_nrt"] = False
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
    ``jit_overrides`` go to :func:`jit`.
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


#: LLVM optimisation level of the general kernels (see :func:`quick_codegen`)
QUICK_OPT = 1


@contextlib.contextmanager
def quick_codegen():
    """Compile inside the block at a low LLVM optimisation level and without
    vectorisation, for the general kernels: their code holds every family and
    effect, so full optimisation of it would take far longer than the runs
    it serves (a fallback tier: run time matters less than latency).  The
    arithmetic is the same (no fast-math at any level), so are the results.
    Holds numba's compiler lock, so no other compilation sees the settings."""
    from numba.core.compiler_lock import global_compiler_lock

    with global_compiler_lock:
        saved = numba.config.OPT, numba.config.LOOP_VECTORIZE, numba.config.SLP_VECTORIZE
        numba.config.OPT = type(saved[0])(QUICK_OPT)
        numba.config.LOOP_VECTORIZE = numba.config.SLP_VECTORIZE = False
        try:
            yield
        finally:
            numba.config.OPT, numba.config.LOOP_VECTORIZE, numba.config.SLP_VECTORIZE = saved


def disk_cached(dispatcher) -> bool | None:
    """Whether numba's disk cache holds a current compilation of ``dispatcher``
    (its index exists and matches the source), without compiling or loading
    it; None where that cannot be told (no cache, or numba's internals moved)."""
    try:
        cache = dispatcher._cache
        return bool(cache._cache_file._load_index()) if cache is not None else None
    except Exception:  # noqa: BLE001 - a private API: unknown rather than wrong
        return None


def cache_location() -> str:
    """Where numba keeps compiled kernels: NUMBA_CACHE_DIR, or __pycache__
    folders beside rampwork's sources."""
    return numba.config.CACHE_DIR or str(pathlib.Path(__file__).parent / "__pycache__")


@intrinsic
def fma(typingctx, a, b, c):
    """``a * b + c`` rounded once (LLVM's ``llvm.fma.f64``), for float64 arguments.

    Written out rather than left to the compiler's contraction so that the
    vector body of a lane loop and its scalar remainder round identically
    (a hardware FMA on x86-64 with FMA3, a correctly rounded library call
    elsewhere), and a step's dependency chains get shorter."""
    if not all(isinstance(t, nbtypes.Float) for t in (a, b, c)):
        return None
    signature = nbtypes.float64(nbtypes.float64, nbtypes.float64, nbtypes.float64)

    def codegen(context, builder, sig, args):
        args = [context.cast(builder, value, ty, nbtypes.float64) for value, ty in zip(args, sig.args)]
        double = ir.DoubleType()
        function = builder.module.declare_intrinsic(
            "llvm.fma", [double], ir.FunctionType(double, [double, double, double]))
        return builder.call(function, args)

    return signature, codegen


@intrinsic
def float_bits(typingctx, x):
    """The IEEE-754 bits of a float64 as an int64 (a bit cast, vectorisable)."""
    if not isinstance(x, nbtypes.Float):
        return None

    def codegen(context, builder, sig, args):
        value = context.cast(builder, args[0], sig.args[0], nbtypes.float64)
        return builder.bitcast(value, ir.IntType(64))

    return nbtypes.int64(x), codegen


@intrinsic
def bits_float(typingctx, bits):
    """The float64 whose IEEE-754 bits are the int64 ``bits`` (a bit cast)."""
    if not isinstance(bits, nbtypes.Integer):
        return None

    def codegen(context, builder, sig, args):
        value = context.cast(builder, args[0], sig.args[0], nbtypes.int64)
        return builder.bitcast(value, ir.DoubleType())

    return nbtypes.float64(bits), codegen


@jit
def flip_sign(y, sign):
    """``y`` with its sign bit flipped where ``sign`` is -0.0 (kept where it
    is 0.0): ``d * y`` for d = +-1 given d's sign bit, exact, NaN stays NaN.
    A logic operation instead of a multiplication (the lane loops' multiply
    pipes are their bottleneck)."""
    return bits_float(float_bits(y) ^ float_bits(sign))


#: bytes: a cache line.  numba aligns the arrays it allocates to 32 bytes only,
#: so a lane loop's 512-bit loads straddled two cache lines in about half of
#: the processes: Euler's grid ran at 29 % or 33 % of the division ceiling
#: from one process to the next (benchmarks/events.py)
CACHE_LINE = 64


@jit
def aligned_zeros(size):
    """A float64 array of ``size`` zeros that starts on a cache line (a view
    into a slightly longer allocation, C-contiguous)."""
    pad = CACHE_LINE // 8
    buffer = np.zeros(size + pad)
    first = ((CACHE_LINE - buffer.ctypes.data % CACHE_LINE) % CACHE_LINE) // 8
    return buffer[first:first + size]
