"""``exp`` and ``atan`` a loop can vectorise (core.vmath's sibling: the same
rules, no calls, no data-dependent branches, explicit fused multiply-adds,
no fast-math; see core/vmath.py's docstring for why).

exp (the approach of SLEEF's xexp and fdlibm's e_exp.c)
    1. n = rint(x / ln 2) by the 1.5 * 2**52 shifter trick.
    2. Cody-Waite: r = (x - n LN2_HI) - n LN2_LO by two fused multiply-adds
       (LN2_HI has 32 significant bits: n LN2_HI is exact for |n| <= 2**21),
       |r| <= ~ln(2) / 2.
    3. exp(r) = 1 + r + r^2 (1/2 + r/6 + ... ), a degree-13 minimax-adjusted
       Taylor polynomial (SLEEF's coefficients) by Horner with fma; the last
       step ``fma(r*r, u, r) + 1`` keeps the large terms exact.
    4. The scale 2**n by two powers built from their bit patterns,
       (u * 2**(n//2)) * 2**(n - n//2): both are normal doubles for every n
       needed, the first product is exact, so a subnormal result is rounded
       once (gradual underflow, no flush).
    Edges: exp(x) = inf for x > EXP_OVERFLOW (709.782712893384, where the
    true result exceeds DBL_MAX), including +inf; exp(x) = 0 for
    x < EXP_UNDERFLOW (-745.1332191019412, where the true result is half the
    smallest subnormal),
    including -inf; NaN gives NaN; exp(+-0) = 1.
    Measured against long double expl over 10**7 arguments per range
    (``benchmarks/vmath.py --only exp_atan``; ``tests/test_vmath.py`` over
    10**6 per range and the edges): at most 0.97 ulp for normal results (90 %
    correctly rounded; numpy/glibc 0.51), 0.76 ulp of the subnormal spacing
    for subnormal ones; EXP_ULP is the bound the tests hold it to.

atan (fdlibm's s_atan.c, branch-free)
    1. On |x|: the interval index id = -1 (|x| < 7/16), 0 (< 11/16), 1 (< 19/16),
       2 (< 39/16) or 3, counted by comparisons; then one reduced argument of the
       one form t = (|x| - c) / (1 + c |x|), c = 0, 1/2, 1, 3/2 (t = -1/|x|
       for id 3), so atan|x| = atan(c) + atan(t), |t| <= 7/16.  The numerator
       is exact (Sterbenz) and the denominator one fma: a single division.
    2. fdlibm's odd polynomial t - t (T0 t^2 + ... + T10 t^22) on |t| <= 7/16,
       its even and odd coefficients in t^4 apart, and atan(c) as hi + lo
       (fdlibm's atanhi/atanlo): z = hi - ((t p(t) - lo) - t).
    3. The sign of x set back by or-ing its sign bit.
    Edges: atan(+-0) = +-0, tiny x -> x, +-1 -> +-pi/4 rounded, |x| >= 2**66
    and +-inf -> +-pi/2 rounded, NaN -> NaN.
    Measured against long double atanl over 10**7 arguments per range (|x| <= 3,
    <= 100, log-spaced 1e-300 .. 1e300): at most 0.77 ulp (94-99.98 %
    correctly rounded; numpy/glibc 0.52); ATAN_ULP is the bound the tests
    hold it to.
"""

from __future__ import annotations

from .jit import bits_float, float_bits, fma, jit
from .vmath import SHIFTER, SIGN_BIT

#: the error bounds (ulp of the correctly rounded result) the tests hold exp and atan to
EXP_ULP = 1.0
ATAN_ULP = 1.0

# -- exp ----------------------------------------------------------------------

INV_LN2 = 1.4426950408889634
LN2_HI = 0.69314718055966295651160180568695068359375  # 32 significant bits (SLEEF L2U)
LN2_LO = 0.28235290563031577122588448175013436025525412068e-12  # ln 2 - LN2_HI (SLEEF L2L)
#: the largest x with a finite exp(x) (log(DBL_MAX)); above it, inf
EXP_OVERFLOW = 709.782712893384
#: the smallest x whose exp rounds to a nonzero subnormal; below it, 0
EXP_UNDERFLOW = -745.1332191019412

# SLEEF xexp: exp(r) ~ 1 + r + r^2 (E2 + E3 r + ... + E13 r^11), |r| <= ln(2)/2
E13 = 2.08860621107283687536341e-09
E12 = 2.51112930892876518610661e-08
E11 = 2.75573911234900471893338e-07
E10 = 2.75572362911928827629423e-06
E9 = 2.4801587159235472998791e-05
E8 = 0.000198412698960509205564975
E7 = 0.00138888888889774492207962
E6 = 0.00833333333331652721664984
E5 = 0.0416666666666665047591422
E4 = 0.166666666666666851703837
E3 = 0.5


@jit
def exp(x):
    """exp(x), vectorisable; error and edges in the module docstring."""
    # clamp so that n stays in int range and a NaN stays a NaN through the selects
    clamped = min(max(x, -1100.0), 1100.0) if x == x else x
    shifted = fma(clamped, INV_LN2, SHIFTER)
    n = shifted - SHIFTER
    r = fma(-n, LN2_LO, fma(-n, LN2_HI, clamped))
    u = fma(r, E13, E12)
    u = fma(u, r, E11)
    u = fma(u, r, E10)
    u = fma(u, r, E9)
    u = fma(u, r, E8)
    u = fma(u, r, E7)
    u = fma(u, r, E6)
    u = fma(u, r, E5)
    u = fma(u, r, E4)
    u = fma(u, r, E3)
    u = fma(r * r, u, r) + 1.0
    # 2**n = 2**half * 2**(n - half): each factor a normal double for |n| <= 1100
    k = float_bits(shifted) - float_bits(SHIFTER)  # n as an integer (the shifter's low bits)
    half = k >> 1
    u = u * bits_float((half + 1023) << 52) * bits_float((k - half + 1023) << 52)
    u = 0.0 if x < EXP_UNDERFLOW else u
    return float("inf") if x > EXP_OVERFLOW else u


# -- atan ---------------------------------------------------------------------

# fdlibm s_atan.c: atan(0.5), atan(1), atan(1.5), atan(inf) as hi + lo
ATAN_HI_0 = 4.63647609000806093515e-01
ATAN_HI_1 = 7.85398163397448278999e-01
ATAN_HI_2 = 9.82793723247329054082e-01
ATAN_HI_3 = 1.57079632679489655800e+00
ATAN_LO_0 = 2.26987774529616870924e-17
ATAN_LO_1 = 3.06161699786838301793e-17
ATAN_LO_2 = 1.39033110312309984516e-17
ATAN_LO_3 = 6.12323399573676603587e-17
# atan(t) ~ t - t (T0 t^2 + T1 t^4 + ... + T10 t^22) on |t| <= 7/16
T0 = 3.33333333333329318027e-01
T1 = -1.99999999998764832476e-01
T2 = 1.42857142725034663711e-01
T3 = -1.11111104054623557880e-01
T4 = 9.09088713343650656196e-02
T5 = -7.69187620504482999495e-02
T6 = 6.66107313738753120669e-02
T7 = -5.83357013379057348645e-02
T8 = 4.97687799461593236017e-02
T9 = -3.65315727442169155270e-02
T10 = 1.62858201153657823623e-02


@jit
def atan(x):
    """atan(x), vectorisable; error and edges in the module docstring."""
    bits = float_bits(x)
    a = bits_float(bits & 0x7FFFFFFFFFFFFFFF)  # |x|
    above_0 = a >= 0.4375
    above_1 = a >= 0.6875
    above_2 = a >= 1.1875
    above_3 = a >= 2.4375
    c = 1.5 if above_2 else (1.0 if above_1 else (0.5 if above_0 else 0.0))
    hi = ATAN_HI_2 if above_2 else (ATAN_HI_1 if above_1 else (ATAN_HI_0 if above_0 else 0.0))
    lo = ATAN_LO_2 if above_2 else (ATAN_LO_1 if above_1 else (ATAN_LO_0 if above_0 else 0.0))
    hi = ATAN_HI_3 if above_3 else hi
    lo = ATAN_LO_3 if above_3 else lo
    numerator = -1.0 if above_3 else a - c
    denominator = a if above_3 else fma(c, a, 1.0)
    t = numerator / denominator
    z = t * t
    w = z * z
    s1 = z * fma(w, fma(w, fma(w, fma(w, fma(w, T10, T8), T6), T4), T2), T0)
    s2 = w * fma(w, fma(w, fma(w, fma(w, T9, T7), T5), T3), T1)
    result = hi - (fma(t, s1 + s2, -lo) - t)
    return bits_float(float_bits(result) | (bits & SIGN_BIT))
