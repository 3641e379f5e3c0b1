"""Step-size control for the adaptive pair, in branch-free arithmetic.

The controller needs powers of the error norm every step in every lane.
``math.pow`` / ``exp`` / ``log`` are library calls that LLVM cannot vectorise
without a vector math library (numba's SVML is optional), so the lane loop
would run them one lane at a time.  The controller does not need them exact:
``log2`` and ``exp2`` here are bit-level range reductions with 4th-degree
polynomials (relative error below 1e-4), deterministic and vectorisable.
"""

from .jit import bits_float, float_bits, jit

_MANTISSA = (1 << 52) - 1
_EXPONENT_ONE = 1023 << 52
# least-squares fits on [0, 1]: log2(1 + u) ~ u * poly(u), 2**u ~ 1 + u * poly(u)
_L1, _L2, _L3, _L4 = 1.43863745, -0.67773914, 0.32187145, -0.0828558
_X1, _X2, _X3, _X4 = 0.69301748, 0.24144886, 0.05194755, 0.0135819

#: PI controller (Hairer, Norsett & Wanner, "Solving ODEs I"):
#: h_new = h * SAFETY * err^-alpha * err_previous^beta, the factor kept within
#: [FACTOR_MIN, FACTOR_MAX]; after a rejection the step does not grow.
#: (alpha, beta) per pair, as in dopri5.f and dop853.f: the error estimate is
#: O(h^5) for Dormand-Prince 5(4) and behaves as O(h^8) for DOP853's combined one.
PI_DOPRI5 = (1.0 / 5.0 - 0.75 * 0.04, 0.04)
PI_DOP853 = (1.0 / 8.0, 0.0)
SAFETY = 0.9
FACTOR_MIN = 0.2
FACTOR_MAX = 10.0
#: the previous error is floored here (as in dopri5), so one lucky step cannot
#: make the next factor huge
ERROR_FLOOR = 1e-4
#: error below this counts as this (the factor is capped anyway)
ERROR_TINY = 1e-30


#: 2^52: a float in [2^52, 2^53) holds the integer (float - 2^52) in its low bits
_TWO_52 = 4503599627370496.0
_TWO_52_BITS = 0x4330000000000000
#: 1.5 * 2^52: adding it rounds a float with |y| < 2^51 to an integer kept in
#: the sum's low bits (the sum's bits less these bits)
_ROUND_MAGIC = 6755399441055744.0
_ROUND_MAGIC_BITS = 0x4338000000000000


# Why the magic numbers: a conversion between int64 and float64 has no AVX2
# vector instruction (AVX-512 has one), so ``float(int(y))`` in the lane loop
# is done one lane at a time with extracts and inserts, which measured as a
# third of the adaptive attempt's instructions.  Bit casts, integer adds and
# shifts do vectorise; the values are exactly those of the plain conversions.
@jit
def log2_approx(x):
    """log2(x) for a normal x > 0 to about 1e-4 (absolute)."""
    bits = float_bits(x)
    # the biased exponent e in [0, 2047] as a float: (2^52 + e) - 2^52, exact
    exponent = bits_float((bits >> 52) | _TWO_52_BITS) - _TWO_52 - 1023.0
    u = bits_float((bits & _MANTISSA) | _EXPONENT_ONE) - 1.0  # mantissa - 1 in [0, 1)
    return exponent + u * (_L1 + u * (_L2 + u * (_L3 + u * _L4)))


@jit
def exp2_approx(y):
    """2**y for |y| < 1000 to a relative 1e-5."""
    shifted = y + _ROUND_MAGIC
    nearest = shifted - _ROUND_MAGIC  # y rounded to an integer
    whole_bits = float_bits(shifted) - _ROUND_MAGIC_BITS  # the same integer, as int64
    above = nearest > y  # floor: one less
    whole = nearest - 1.0 if above else nearest
    whole_bits = whole_bits - 1 if above else whole_bits
    u = y - whole  # in [0, 1)
    scale = bits_float((whole_bits + 1023) << 52)
    return scale * (1.0 + u * (_X1 + u * (_X2 + u * (_X3 + u * _X4))))


#: bits(1/x) ~ _RECIPROCAL_MAGIC - bits(x) for normal x > 0, to about 12 %
_RECIPROCAL_MAGIC = 0x7FDE623822FC16E6


@jit
def reciprocal_approx(x):
    """1/x for a normal x > 0 to a relative 1e-10: a bit-level first guess and
    three Newton steps (fused multiply-adds; no division, which is what bounds
    the adaptive lane loop).  For corrections that need only a few digits."""
    y = bits_float(_RECIPROCAL_MAGIC - float_bits(x))
    for _ in range(3):
        y = y * (2.0 - x * y)
    return y


@jit
def step_factor(log2_error, log2_error_previous, accepted, rejected_before, alpha, beta):
    """The factor for the next step size from the error norm's log2 (that of
    the last accepted step for the PI term).  ``accepted``: this step passed;
    ``rejected_before``: the previous attempt failed (then no growth);
    ``alpha``, ``beta``: the pair's PI gains (``PI_DOPRI5``, ``PI_DOP853``)."""
    if accepted:
        factor = SAFETY * exp2_approx(beta * log2_error_previous - alpha * log2_error)
        upper = 1.0 if rejected_before else FACTOR_MAX
    else:
        factor = SAFETY * exp2_approx(-alpha * log2_error)
        upper = 1.0
    return min(max(factor, FACTOR_MIN), upper)


# ------------------------------------------------------------------------------
# error norms of the pairs' estimates
# ------------------------------------------------------------------------------
# The norm is the RMS over (x, v, friction work, curvature integral) of each
# estimate scaled by atol + rtol * max(|start|, |end|).  The four scales'
# products form a common denominator, so that the norm costs one division
# (divisions are what bound the lane loop); that product of eight scales stays
# far from underflow for atol >= 1e-20.

@jit
def _scaled_square_parts(x, v, w, k, x1, v1, w1, k1, err_x, err_v, err_w, err_k, rtol, atol):
    """(states, integrals, denominator): sum_c (err_c / scale_c)^2 over (x, v)
    is states / denominator, over (friction work, curvature integral)
    integrals / denominator."""
    sx = atol + rtol * max(abs(x), abs(x1))
    sv = atol + rtol * max(abs(v), abs(v1))
    sw = atol + rtol * max(abs(w), abs(w1))
    sk = atol + rtol * max(abs(k), abs(k1))
    ex, ev, ew, ek = err_x * sv, err_v * sx, err_w * sk, err_k * sw
    xv = sx * sv
    wk = sw * sk
    xv2 = xv * xv
    wk2 = wk * wk
    return (ex * ex + ev * ev) * wk2, (ew * ew + ek * ek) * xv2, xv2 * wk2


@jit
def _scaled_squares(x, v, w, k, x1, v1, w1, k1, err_x, err_v, err_w, err_k, rtol, atol):
    """(numerator, denominator) with sum_c (err_c / scale_c)^2 = numerator / denominator."""
    states, integrals, denominator = _scaled_square_parts(x, v, w, k, x1, v1, w1, k1, err_x,
                                                          err_v, err_w, err_k, rtol, atol)
    return states + integrals, denominator


@jit
def error_norm2(x, v, w, k, x1, v1, w1, k1, err_x, err_v, err_w, err_k,
                err3_x, err3_v, err3_w, err3_k, rtol, atol):
    """The squared RMS norm of one embedded estimate (Dormand-Prince 5(4);
    the err3 arguments are not used)."""
    numerator, denominator = _scaled_squares(x, v, w, k, x1, v1, w1, k1, err_x, err_v, err_w,
                                             err_k, rtol, atol)
    return 0.25 * numerator / denominator


#: below this rtol DOP853's norm has (x, v) take their own estimates' ratio and
#: the integrals' (works, curvature integral) squared estimates count
#: TIGHT_INTEGRALS_WEIGHT times (held to about rtol / 2.8); at and above it,
#: dop853.f's norm: the loose end's step sequences and the error's
#: proportionality to rtol (tested down to 1e-10) stay as they were.  Why and
#: the measurements: benchmarks/README.md, tight_reference.py (i19-tight-10)
TIGHT_RTOL = 1e-10
TIGHT_INTEGRALS_WEIGHT = 8.0


@jit
def _tight_norm2(states5, states3, integrals, ratio):
    """The tight end's sum of squares (times the denominator): the states'
    with their own ratio, the integrals' weighted, with the whole vector's."""
    own = states5 / (states5 + 0.01 * states3) if states5 > 0.0 else 0.0
    return states5 * own + TIGHT_INTEGRALS_WEIGHT * integrals * ratio


@jit
def error_norm2_two_estimates(x, v, w, k, x1, v1, w1, k1, err_x, err_v, err_w, err_k,
                              err3_x, err3_v, err3_w, err3_k, rtol, atol):
    """DOP853's combined norm squared, err5^2 * err5^2 / (err5^2 + 0.01 err3^2),
    from its fifth- and third-order estimates (dop853.f; 0 where both vanish);
    below ``TIGHT_RTOL`` split as ``_tight_norm2``.  Why: from W = 0 W's scale
    is small and its third-order estimate dominates the single ratio, which
    then shrinks x's and v's fifth-order estimates by up to 1e-7; W's estimate
    alone sets the steps, and the short exits and stops ended 0.25 rtol off
    in W against a median of 0.01 rtol."""
    states5, integrals5, denominator = _scaled_square_parts(
        x, v, w, k, x1, v1, w1, k1, err_x, err_v, err_w, err_k, rtol, atol)
    states3, integrals3, _ = _scaled_square_parts(x, v, w, k, x1, v1, w1, k1, err3_x, err3_v,
                                                  err3_w, err3_k, rtol, atol)
    num5 = states5 + integrals5
    num3 = states3 + integrals3
    ratio = num5 / (num5 + 0.01 * num3) if num5 > 0.0 else 0.0
    if rtol < TIGHT_RTOL:  # one value per run: the same branch in every lane
        return 0.25 * _tight_norm2(states5, states3, integrals5, ratio) / denominator
    return 0.25 * num5 / denominator * ratio


# With air drag the norm takes a fifth component, the drag work, scaled alike
# (its own division: the four-scale common denominator above stays as it is).
@jit
def _drag_square(wd, wd1, err_d, rtol, atol):
    """(err_d / scale)^2 for the drag work's estimate."""
    e = err_d / (atol + rtol * max(abs(wd), abs(wd1)))
    return e * e


@jit
def error_norm2_drag(x, v, w, k, wd, x1, v1, w1, k1, wd1, err_x, err_v, err_w, err_k, err_d,
                     err3_x, err3_v, err3_w, err3_k, err3_d, rtol, atol):
    """``error_norm2`` over five components: (x, v, friction work, curvature
    integral, drag work)."""
    numerator, denominator = _scaled_squares(x, v, w, k, x1, v1, w1, k1, err_x, err_v, err_w,
                                             err_k, rtol, atol)
    return 0.2 * (numerator / denominator + _drag_square(wd, wd1, err_d, rtol, atol))


@jit
def error_norm2_two_estimates_drag(x, v, w, k, wd, x1, v1, w1, k1, wd1, err_x, err_v, err_w,
                                   err_k, err_d, err3_x, err3_v, err3_w, err3_k, err3_d,
                                   rtol, atol):
    """``error_norm2_two_estimates`` over five components (the drag work one
    of the integrals)."""
    states5, integrals5, denominator = _scaled_square_parts(
        x, v, w, k, x1, v1, w1, k1, err_x, err_v, err_w, err_k, rtol, atol)
    states3, integrals3, _ = _scaled_square_parts(x, v, w, k, x1, v1, w1, k1, err3_x, err3_v,
                                                  err3_w, err3_k, rtol, atol)
    drag5 = _drag_square(wd, wd1, err_d, rtol, atol)
    sum5 = (states5 + integrals5) / denominator + drag5
    sum3 = (states3 + integrals3) / denominator + _drag_square(wd, wd1, err3_d, rtol, atol)
    ratio = sum5 / (sum5 + 0.01 * sum3) if sum5 > 0.0 else 0.0
    if rtol < TIGHT_RTOL:
        return 0.2 * (_tight_norm2(states5, states3, integrals5, ratio) / denominator
                      + TIGHT_INTEGRALS_WEIGHT * drag5 * ratio)
    return 0.2 * sum5 * ratio
