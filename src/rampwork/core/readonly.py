"""Reads of a kernel's ``shared`` data that a lane loop can vectorise.

A lane loop stores into the ``lanes`` array and, for a curve family with a
table (the family ``track``: core/curve_track.py), reads ``shared`` at
offsets computed from each lane's state.  LLVM cannot tell the two arrays
apart (both are pointers it was handed), and a read at a data-dependent
offset has no bounds that a run-time overlap check could test, so it keeps
the loop scalar ("cannot identify array bounds").  :func:`read` reads
through a pointer that LLVM takes for a fresh object: the return value of a
function marked ``noalias`` (as an allocator's), opaque to the optimiser
(``noinline optnone``, so it cannot see that it returns its argument), with
no effect it must keep (``memory(none) speculatable``, so it is hoisted out
of the loop: one call per loop entry).  Memory reached through such a
pointer cannot be the lanes', so the loads need no check and become
gathers.

What that asserts is true of ``shared``: nothing writes it while a kernel
runs (it is the population's data, read-only to every jitted function), so
no store can be reordered against these loads.  The loads themselves are
plain: the same value as ``shared[index]``, with no bounds check (as
numba's indexing without ``boundscheck``).
"""

from __future__ import annotations

from llvmlite import ir
from numba.core import types
from numba.extending import intrinsic

_VIEW = "rampwork_read_only_view"


def _view_function(module):
    """``ptr rampwork_read_only_view(ptr)``: returns its argument (defined in
    every module that calls it, linkonce_odr, so linked modules share one)."""
    try:
        return module.get_global(_VIEW)
    except KeyError:
        pass
    pointer = ir.IntType(8).as_pointer()
    function = ir.Function(module, ir.FunctionType(pointer, [pointer]), _VIEW)
    function.linkage = "linkonce_odr"
    for attribute in ("nounwind", "noinline", "optnone"):
        function.attributes.add(attribute)
    for attribute in ("willreturn", "speculatable", "memory(none)"):
        set.add(function.attributes, attribute)  # (not in llvmlite's list of known ones)
    function.return_value.add_attribute("noalias")
    builder = ir.IRBuilder(function.append_basic_block())
    builder.ret(function.args[0])
    return function


@intrinsic
def read(typingctx, array, index):
    """``array[index]`` for a contiguous 1-d float64 array that no jitted
    code writes while the caller runs (see the module docstring)."""
    if not (isinstance(array, types.Array) and array.dtype == types.float64 and array.ndim == 1
            and array.layout == "C" and isinstance(index, types.Integer)):
        return None

    def codegen(context, builder, sig, args):
        data = context.make_array(sig.args[0])(context, builder, args[0]).data
        view = builder.call(_view_function(builder.module),
                            [builder.bitcast(data, ir.IntType(8).as_pointer())])
        offset = context.cast(builder, args[1], sig.args[1], types.intp)
        return builder.load(builder.gep(builder.bitcast(view, data.type), [offset]))

    return types.float64(array, index), codegen
