"""A lane field of the curve kernels' state (core/curve_kernel.py's layout:
field F of lane i at ``lanes[F * LANES + i]``), loaded and stored by the
scalar helpers through :func:`field` and :func:`set_field`.

Each is the array access numba compiles for ``lanes[F * LANES + i]``, the
same load or store, written as one intrinsic: numba types and lowers an
array getitem (or setitem) and the index's two operations at every access,
some 250 per kernel, about half of a scalar helper's compile time
(benchmarks/README.md, "Compile time of the curve kernels"); the index is
nonnegative, so without numba's wraparound code for negative ones.  The
vector loop (curve_vector.py) keeps plain indexing on its view.
"""

from __future__ import annotations

from numba.core import cgutils, types as nbtypes
from numba.extending import intrinsic
from numba.np.arrayobj import load_item, make_array, store_item

#: lanes per block (the vector loop's width); results do not depend on it
LANES = 64


@intrinsic
def field(typingctx, lanes, index, i):
    """``lanes[index * LANES + i]`` (a 1-D array, nonnegative integers)."""
    if not (isinstance(lanes, nbtypes.Array) and lanes.ndim == 1
            and isinstance(index, nbtypes.Integer) and isinstance(i, nbtypes.Integer)):
        return None

    def codegen(context, builder, sig, args):
        pointer = _field_pointer(context, builder, sig, args)
        return load_item(context, builder, sig.args[0], pointer)

    return lanes.dtype(lanes, index, i), codegen


@intrinsic
def set_field(typingctx, lanes, index, i, value):
    """``lanes[index * LANES + i] = value``, as :func:`field` loads it."""
    if not (isinstance(lanes, nbtypes.Array) and lanes.ndim == 1
            and isinstance(index, nbtypes.Integer) and isinstance(i, nbtypes.Integer)
            and isinstance(value, (nbtypes.Float, nbtypes.Integer, nbtypes.Boolean))):
        return None

    def codegen(context, builder, sig, args):
        value = context.cast(builder, args[3], sig.args[3], sig.args[0].dtype)
        store_item(context, builder, sig.args[0], value,
                   _field_pointer(context, builder, sig, args))
        return context.get_dummy_value()

    return nbtypes.void(lanes, index, i, value), codegen


def _field_pointer(context, builder, sig, args):
    index = context.cast(builder, args[1], sig.args[1], nbtypes.intp)
    i = context.cast(builder, args[2], sig.args[2], nbtypes.intp)
    stride = context.get_constant(nbtypes.intp, LANES)
    offset = builder.add(builder.mul(index, stride, flags=["nsw"]), i, flags=["nsw"])
    array = make_array(sig.args[0])(context, builder, args[0])
    return cgutils.get_item_pointer(context, builder, sig.args[0], array, [offset],
                                    boundscheck=context.enable_boundscheck)
