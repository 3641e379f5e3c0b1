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

#: PI controller (Hairer, Norsett & Wanner, "Solving ODEs I", dopri5's
#: defaults): h_new = h * SAFETY * err^-ALPHA * err_previous^BETA, the factor
#: kept within [FACTOR_MIN, FACTOR_MAX]; after a rejection the step does not grow.
ORDER_ERROR = 5.0  # the embedded estimate is O(h^5)
BETA = 0.04
ALPHA = 1.0 / ORDER_ERROR - 0.75 * BETA
SAFETY = 0.9
FACTOR_MIN = 0.2
FACTOR_MAX = 10.0
#: the previous error is floored here (as in dopri5), so one lucky step cannot
#: make the next factor huge
ERROR_FLOOR = 1e-4
#: error below this counts as this (the factor is capped anyway)
ERROR_TINY = 1e-30


@jit
def log2_approx(x):
    """log2(x) for a normal x > 0 to about 1e-4 (absolute)."""
    bits = float_bits(x)
    exponent = (bits >> 52) - 1023
    u = bits_float((bits & _MANTISSA) | _EXPONENT_ONE) - 1.0  # mantissa - 1 in [0, 1)
    return exponent + u * (_L1 + u * (_L2 + u * (_L3 + u * _L4)))


@jit
def exp2_approx(y):
    """2**y for |y| < 1000 to a relative 1e-5."""
    whole = float(int(y)) if y >= 0.0 else -float(int(-y))
    whole = whole - 1.0 if whole > y else whole  # floor without a library call
    u = y - whole
    scale = bits_float((int(whole) + 1023) << 52)
    return scale * (1.0 + u * (_X1 + u * (_X2 + u * (_X3 + u * _X4))))


@jit
def step_factor(log2_error, log2_error_previous, accepted, rejected_before):
    """The factor for the next step size from the error norm's log2 (that of
    the last accepted step for the PI term).  ``accepted``: this step passed;
    ``rejected_before``: the previous attempt failed (then no growth)."""
    if accepted:
        factor = SAFETY * exp2_approx(BETA * log2_error_previous - ALPHA * log2_error)
        upper = 1.0 if rejected_before else FACTOR_MAX
    else:
        factor = SAFETY * exp2_approx(-ALPHA * log2_error)
        upper = 1.0
    return min(max(factor, FACTOR_MIN), upper)
