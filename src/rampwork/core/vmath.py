"""Elementary functions a lane loop can vectorise: ``sin``, ``cos``, ``sincos``, ``cbrt``, ``inverse_cbrt``,
and the small-argument pieces ``sin_small``, ``cos_small``, ``cos_minus_one_small``, ``sin_cos_minus_one_near``.

numba lowers ``math.sin`` and friends to calls into libm; a call LLVM cannot
inline keeps a lane loop scalar (and the pip llvmlite has no SVML vector
library).  The functions here are plain jitted arithmetic (multiplies,
fused multiply-adds, one division-free select per result, bit operations):
no calls, no data-dependent branches, so the lane loops that inline them
vectorise.  No fast-math is involved: they round the same in a vector body
and in its scalar remainder.

sin, cos, sincos (the approach of fdlibm and SLEEF)
    1. Quadrant: n = rint(x * 2/pi), by the 1.5 * 2**52 shifter trick; its
       two lowest bits are read from the shifted sum's bit pattern.
    2. Cody-Waite reduction with pi/2 split in three doubles,
       pi/2 = P1 + P2 + P3 (P1 = pi/2 rounded, P2 and P3 the next 53 bits
       each): r1 = fma(-n, P1, x) is exact (the exact difference is a multiple
       of 2**-53 below 1 in magnitude); r1 - n*P2 - n*P3 is then formed as a
       double-double (hi, lo) with exact products (fma) and an exact two-sum.
       Its absolute error is about |n| * 2**-143 (roundings of the low-order
       terms) plus |n| * 2**-161 (pi/2 beyond P3); the result is never closer
       to 0 than ~2**-61 for a double argument (Kahan and McDonald's worst
       cases), so the reduction adds far less than an ulp for |x| up to ~2**45.
    3. sin and cos of (hi + lo), |hi| <= ~pi/4, with fdlibm's kernels
       ``_kernel_sin`` / ``_kernel_cos`` (FreeBSD msun k_sin.c and k_cos.c,
       Sun Microsystems 1993, freely usable: degree-13 and degree-14 minimax
       polynomials with |error| < 2**-58 on [-pi/4, pi/4], and the lo part
       folded in to first order).
    4. The quadrant picks sin or cos of the reduced argument with a select and
       sets the sign by xor-ing the sign bit.

    Measured against the exact values (long double sinl/cosl) over 10**7
    arguments per range (``benchmarks/vmath.py``; ``tests/test_vmath.py``
    over 10**6 plus the reduction's hard cases): at most 1 ulp for
    |x| <= VALID_ARGUMENT (measured maximum 0.80 ulp; 95-97 % correctly
    rounded; numpy/glibc: 0.56 ulp).  Not guaranteed beyond, but measured the
    same up to |x| = 1e14 (the rounding of x * 2/pi lets |hi| exceed pi/4 a
    little, where the kernels' polynomials are still accurate); above 2**51
    the shifter trick fails and the results are meaningless.
    inf and NaN give NaN; sin(-0.0) = -0.0.

    The ``sine`` ramp family guarantees |wavenumber * x + phase| <= VALID_ARGUMENT
    on its domain (its parameter validation raises otherwise).

cbrt
    An exponent-thirding bit trick (through an int64 <-> float64 conversion,
    which vectorises) to ~6 %, then four Newton steps y <- y - (y - a/y**2)/3:
    relative error ~1 ulp for positive normal arguments; cbrt(0) = 0; NaN and
    negative arguments are returned unchanged (only a >= 0 is needed).

inverse_cbrt, sin_small, cos_small (the cycloid family's helpers, core.cycloid)
    inverse_cbrt: a ** (-1/3) without a division (the bit trick, then two
    fourth-order steps): measured <= 1.8 ulp.  sin_small, cos_small: the
    fdlibm kernels alone, for |x| <= pi/4 (no reduction): measured <= 0.66
    and 0.74 ulp.  Figures: benchmarks/vmath.py (10**7 arguments),
    tests/test_vmath.py.

The polynomials are evaluated with explicit fused multiply-adds (fewer
instructions in the lane loops; the error bounds above were measured so).
"""

from __future__ import annotations

from .jit import bits_float, float_bits, fma, jit

#: the largest |argument| for which sin/cos are tested to VALID_ULP
VALID_ARGUMENT = 1.0e5
#: the documented error bound (ulp of the correctly rounded result) inside it
VALID_ULP = 1.0

# pi/2 = P1 + P2 + P3 to ~2**-161 (from a 100-digit pi, exact with fractions)
P1 = 1.5707963267948966  # 0x3FF921FB54442D18
P2 = 6.123233995736766e-17  # 0x3C91A62633145C07
P3 = -1.4973849048591698e-33  # 0xB91F1976B7ED8FBC
TWO_OVER_PI = 0.6366197723675814
SHIFTER = 6755399441055744.0  # 1.5 * 2**52: x + SHIFTER - SHIFTER = rint(x), |x| < 2**51

# fdlibm _kernel_sin: sin(x) ~ x + S1 x^3 + ... + S6 x^13 on [-pi/4, pi/4]
S1 = -1.66666666666666324348e-01
S2 = 8.33333333332248946124e-03
S3 = -1.98412698298579493134e-04
S4 = 2.75573137070700676789e-06
S5 = -2.50507602534068634195e-08
S6 = 1.58969099521155010221e-10

# fdlibm _kernel_cos: cos(x) ~ 1 - x^2/2 + C1 x^4 + ... + C6 x^14 on [-pi/4, pi/4]
C1 = 4.16666666666666019037e-02
C2 = -1.38888888888741095749e-03
C3 = 2.48015872894767294178e-05
C4 = -2.75573143513906633035e-07
C5 = 2.08757232129817482790e-09
C6 = -1.13596475577881948265e-11

SIGN_BIT = -0x8000000000000000  # int64 with only bit 63 set


@jit
def _reduce(x):
    """(hi, lo, q): x = q * pi/2 + (hi + lo) (mod 2*pi), q = quadrant in 0..3."""
    shifted = fma(x, TWO_OVER_PI, SHIFTER)  # one rounding: rint(x*2/pi) + SHIFTER
    q = float_bits(shifted) & 3  # the low bits of the mantissa hold rint(x*2/pi) mod 4
    n = shifted - SHIFTER
    r1 = fma(-n, P1, x)  # exact
    p = n * P2
    p_err = fma(n, P2, -p)  # n*P2 = p + p_err exactly
    s = r1 - p  # two-sum: r1 - p = s + e exactly
    bb = s - r1
    e = (r1 - (s - bb)) + (-p - bb)
    # lo = e - p_err - n*P3, written so that it is -0.0 where all are zero
    # (then hi = s + lo keeps the sign of x = -0.0)
    lo = -((n * P3 + p_err) - e)
    hi = s + lo  # fast two-sum (|s| >= |lo|)
    lo = lo - (hi - s)
    return hi, lo, q


@jit
def kernel_sin(x, y):
    """sin(x + y) for |x| <= ~pi/4, |y| <= ~ulp(x) (fdlibm _kernel_sin, iy = 1,
    its products and sums fused: 11 operations instead of 16)."""
    z = x * x
    v = z * x
    r = fma(z, fma(z, fma(z, fma(z, S6, S5), S4), S3), S2)
    # fdlibm: x - ((z*(0.5*y - v*r) - y) - v*S1)
    return x - fma(-v, S1, fma(z, fma(-v, r, 0.5 * y), -y))


@jit
def kernel_cos(x, y):
    """cos(x + y) for |x| <= ~pi/4, |y| <= ~ulp(x) (fdlibm _kernel_cos, its
    products and sums fused)."""
    z = x * x
    r = fma(z, fma(z, fma(z, fma(z, fma(z, C6, C5), C4), C3), C2), C1)
    hz = 0.5 * z
    w = 1.0 - hz
    # fdlibm: w + (((1 - w) - hz) + (z*(z*r) - x*y))
    return w + (((1.0 - w) - hz) + fma(z * z, r, -x * y))


@jit
def sin_small(x):
    """sin(x) for |x| <= pi/4, no range reduction (kernel_sin with y = 0)."""
    z = x * x
    r = fma(z, fma(z, fma(z, fma(z, S6, S5), S4), S3), S2)
    return fma(z * x, fma(z, r, S1), x)


@jit
def cos_small(x):
    """cos(x) for |x| <= pi/4, no range reduction (kernel_cos with y = 0)."""
    z = x * x
    r = fma(z, fma(z, fma(z, fma(z, fma(z, C6, C5), C4), C3), C2), C1)
    hz = 0.5 * z
    w = 1.0 - hz
    return w + (((1.0 - w) - hz) + (z * z) * r)


@jit
def cos_minus_one_small(x):
    """cos(x) - 1 for |x| <= pi/4, without the cancellation of forming cos
    first (kernel_cos's polynomial: -x^2/2 + x^4 (C1 + ... + C6 x^10))."""
    z = x * x
    r = fma(z, fma(z, fma(z, fma(z, fma(z, C6, C5), C4), C3), C2), C1)
    return fma(z * z, r, -0.5 * z)


@jit
def sin_cos_minus_one_near(y):
    """(sin y, cos y - 1) for a small |y| (the angle of a short step): a
    two-term Cody-Waite reduction y = n pi/2 + r (no double-double: |n| is
    small), then sin_small and cos_minus_one_small of r and the quadrant.
    Accurate to a few ulp of 1 for |y| up to ~20 (tests/test_sine_stages.py);
    use sincos for large arguments."""
    shifted = fma(y, TWO_OVER_PI, SHIFTER)
    quadrant = float_bits(shifted) & 3
    n = shifted - SHIFTER
    r = fma(-n, P2, fma(-n, P1, y))
    sin_r = sin_small(r)
    cos_r_m1 = cos_minus_one_small(r)
    # the quadrant: (sin y, cos y - 1) = (s, c-1), (c, -s-1), (-s, -c-1), (-c, s-1)
    odd = (quadrant & 1) != 0
    sin_abs = (1.0 + cos_r_m1) if odd else sin_r
    sin_y = -sin_abs if (quadrant & 2) != 0 else sin_abs
    cos_abs_m1 = (sin_r - 1.0) if odd else cos_r_m1
    cos_y_m1 = (-2.0 - cos_abs_m1) if (quadrant == 2) | (quadrant == 1) else cos_abs_m1
    return sin_y, cos_y_m1


@jit
def sincos(x):
    """(sin(x), cos(x)), vectorisable; error in the module docstring."""
    hi, lo, q = _reduce(x)
    s = kernel_sin(hi, lo)
    c = kernel_cos(hi, lo)
    odd = (q & 1) != 0
    sin_abs = c if odd else s
    cos_abs = s if odd else c
    # sin: negative in quadrants 2, 3; cos: negative in quadrants 1, 2
    sin_sign = (q & 2) << 62
    cos_sign = ((q + 1) & 2) << 62
    return bits_float(float_bits(sin_abs) ^ sin_sign), bits_float(float_bits(cos_abs) ^ cos_sign)


@jit
def sin(x):
    """sin(x), vectorisable; error in the module docstring."""
    return sincos(x)[0]


@jit
def cos(x):
    """cos(x), vectorisable; error in the module docstring."""
    return sincos(x)[1]


CBRT_MAGIC = 0x2A9F7893 << 32  # Kahan's B1 (fdlibm s_cbrt.c): ~(1023 - 0.03306) * 2**52 * 2/3


@jit
def cbrt(a):
    """a ** (1/3) for a >= 0, vectorisable (relative error ~1 ulp; 0 -> 0)."""
    bits = float_bits(a)
    guess = bits_float(CBRT_MAGIC + int(float(bits) * (1.0 / 3.0)))
    y = guess if a > 0.0 else 0.0
    y = y - (y - a / (y * y)) * (1.0 / 3.0) if a > 0.0 else a
    y = y - (y - a / (y * y)) * (1.0 / 3.0) if a > 0.0 else a
    y = y - (y - a / (y * y)) * (1.0 / 3.0) if a > 0.0 else a
    y = y - (y - a / (y * y)) * (1.0 / 3.0) if a > 0.0 else a
    return y


INVERSE_CBRT_MAGIC = 0x553EF0FF289DD796  # bits(a**(-1/3)) ~ MAGIC - bits(a)/3, to ~3.5 %


@jit
def inverse_cbrt(a):
    """a ** (-1/3) for positive normal a, vectorisable and division-free
    (relative error < 1e-15, a few ulps: measured in tests/test_vmath.py).

    The exponent-thirding bit trick, then two steps of the fourth-order
    iteration y <- y (1 + e/3 + 2e^2/9 + 14e^3/81), e = 1 - a y^3 (the series
    of (1 - e)**(-1/3)): 3.5 % -> ~1e-6 -> rounding."""
    y = bits_float(INVERSE_CBRT_MAGIC - int(float(float_bits(a)) * (1.0 / 3.0)))
    e = 1.0 - a * (y * y * y)
    y = y * fma(e, fma(e, fma(e, 14.0 / 81.0, 2.0 / 9.0), 1.0 / 3.0), 1.0)
    e = 1.0 - a * (y * y * y)
    return y * fma(e, fma(e, fma(e, 14.0 / 81.0, 2.0 / 9.0), 1.0 / 3.0), 1.0)
