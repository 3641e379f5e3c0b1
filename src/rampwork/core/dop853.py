"""Dormand-Prince 8(5,3) (DOP853): an eighth-order embedded pair with a
seventh-order dense output, for tight tolerances (Hairer, Norsett & Wanner,
"Solving ODEs I", II.10).  Same interface as Dormand-Prince 5(4) in
``steppers.py``.

The tableau is that of Hairer's ``dop853.f`` (as scipy's
``dop853_coefficients`` prints it), stored by row with its zero entries left
out: each tuple's comment names the stages its entries multiply.  The 13th
evaluation is at the new state, so it is the next step's first (FSAL).  Error:
the fifth- and third-order estimates combined as in ``dop853.f``, at the tight
end with (x, v) apart (``control.error_norm2_two_estimates``).  Dense output:
three more stages and the seventh-order interpolant of ``dop853.f`` (exact at
both ends).
"""

from .jit import fma, jit
from .physics import normal_term

_stage = None  # bound per scene by kernel.build_kernel (steppers._stage)
DRAG = False  # air drag (bound per scene; steppers' module docstring)
FRICTION = True  # False: mu_k = 0 everywhere, no friction work (steppers' FRICTION)
_with_drag = None  # bound per scene (steppers._with_drag)

#: interpolant coefficients per component
N_DENSE = 7

# stage s (2..13) is at y + h sum_j A{s}_j k_j; stages 14-16 feed the dense output
# A2: stage 2 from stages 1
A2 = (0.05260015195876773,)
# A3: stage 3 from stages 1, 2
A3 = (0.0197250569845379, 0.0591751709536137)
# A4: stage 4 from stages 1, 3
A4 = (0.02958758547680685, 0.08876275643042054)
# A5: stage 5 from stages 1, 3, 4
A5 = (0.2413651341592667, -0.8845494793282861, 0.924834003261792)
# A6: stage 6 from stages 1, 4, 5
A6 = (0.037037037037037035, 0.17082860872947386, 0.12546768756682242)
# A7: stage 7 from stages 1, 4, 5, 6
A7 = (0.037109375, 0.17025221101954405, 0.06021653898045596, -0.017578125)
# A8: stage 8 from stages 1, 4, 5, 6, 7
A8 = (
    0.03709200011850479,
    0.17038392571223998,
    0.10726203044637328,
    -0.015319437748624402,
    0.008273789163814023,
)
# A9: stage 9 from stages 1, 4, 5, 6, 7, 8
A9 = (
    0.6241109587160757,
    -3.3608926294469414,
    -0.868219346841726,
    27.59209969944671,
    20.154067550477894,
    -43.48988418106996,
)
# A10: stage 10 from stages 1, 4, 5, 6, 7, 8, 9
A10 = (
    0.47766253643826434,
    -2.4881146199716677,
    -0.590290826836843,
    21.230051448181193,
    15.279233632882423,
    -33.28821096898486,
    -0.020331201708508627,
)
# A11: stage 11 from stages 1, 4, 5, 6, 7, 8, 9, 10
A11 = (
    -0.9371424300859873,
    5.186372428844064,
    1.0914373489967295,
    -8.149787010746927,
    -18.52006565999696,
    22.739487099350505,
    2.4936055526796523,
    -3.0467644718982196,
)
# A12: stage 12 from stages 1, 4, 5, 6, 7, 8, 9, 10, 11
A12 = (
    2.273310147516538,
    -10.53449546673725,
    -2.0008720582248625,
    -17.9589318631188,
    27.94888452941996,
    -2.8589982771350235,
    -8.87285693353063,
    12.360567175794303,
    0.6433927460157636,
)
# A13: stage 13 from stages 1, 6, 7, 8, 9, 10, 11, 12
A13 = (
    0.054293734116568765,
    4.450312892752409,
    1.8915178993145003,
    -5.801203960010585,
    0.3111643669578199,
    -0.1521609496625161,
    0.20136540080403034,
    0.04471061572777259,
)
# A14: stage 14 from stages 1, 7, 8, 9, 10, 11, 12, 13
A14 = (
    0.056167502283047954,
    0.25350021021662483,
    -0.2462390374708025,
    -0.12419142326381637,
    0.15329179827876568,
    0.00820105229563469,
    0.007567897660545699,
    -0.008298,
)
# A15: stage 15 from stages 1, 6, 7, 8, 11, 12, 13, 14
A15 = (
    0.03183464816350214,
    0.028300909672366776,
    0.053541988307438566,
    -0.05492374857139099,
    -0.00010834732869724932,
    0.0003825710908356584,
    -0.00034046500868740456,
    0.1413124436746325,
)
# A16: stage 16 from stages 1, 6, 7, 8, 9, 13, 14, 15
A16 = (
    -0.42889630158379194,
    -4.697621415361164,
    7.683421196062599,
    4.06898981839711,
    0.3567271874552811,
    -0.0013990241651590145,
    2.9475147891527724,
    -9.15095847217987,
)
# B: the solution, from stages 1, 6, 7, 8, 9, 10, 11, 12
B = (
    0.054293734116568765,
    4.450312892752409,
    1.8915178993145003,
    -5.801203960010585,
    0.3111643669578199,
    -0.1521609496625161,
    0.20136540080403034,
    0.04471061572777259,
)
# E5: the fifth-order error estimate, from stages 1, 6, 7, 8, 9, 10, 11, 12
E5 = (
    0.01312004499419488,
    -1.2251564463762044,
    -0.4957589496572502,
    1.6643771824549864,
    -0.35032884874997366,
    0.3341791187130175,
    0.08192320648511571,
    -0.022355307863886294,
)
# E3: the third-order error estimate, from stages 1, 6, 7, 8, 9, 10, 11, 12
E3 = (
    -0.18980075407240762,
    4.450312892752409,
    1.8915178993145003,
    -5.801203960010585,
    -0.4226823213237919,
    -0.1521609496625161,
    0.20136540080403034,
    0.02265179219836082,
)
# D1: interpolant coefficient 4, from stages 1, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16
D1 = (
    -8.428938276109013,
    0.5667149535193777,
    -3.0689499459498917,
    2.38466765651207,
    2.117034582445028,
    -0.871391583777973,
    2.2404374302607883,
    0.6315787787694688,
    -0.08899033645133331,
    18.148505520854727,
    -9.194632392478356,
    -4.436036387594894,
)
# D2: interpolant coefficient 5, from stages 1, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16
D2 = (
    10.427508642579134,
    242.28349177525817,
    165.20045171727028,
    -374.5467547226902,
    -22.113666853125306,
    7.733432668472264,
    -30.674084731089398,
    -9.332130526430229,
    15.697238121770845,
    -31.139403219565178,
    -9.35292435884448,
    35.81684148639408,
)
# D3: interpolant coefficient 6, from stages 1, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16
D3 = (
    19.985053242002433,
    -387.0373087493518,
    -189.17813819516758,
    527.8081592054236,
    -11.57390253995963,
    6.8812326946963,
    -1.0006050966910838,
    0.7777137798053443,
    -2.778205752353508,
    -60.19669523126412,
    84.32040550667716,
    11.99229113618279,
)
# D4: interpolant coefficient 7, from stages 1, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16
D4 = (
    -25.69393346270375,
    -154.18974869023643,
    -231.5293791760455,
    357.6391179106141,
    93.40532418362432,
    -37.45832313645163,
    104.0996495089623,
    29.8402934266605,
    -43.53345659001114,
    96.32455395918828,
    -39.17726167561544,
    -149.72683625798564,
)


@jit
def _dot1(c, k0):
    """sum_j c[j] k_j as a chain of fused multiply-adds."""
    return c[0] * k0


@jit
def _dot2(c, k0, k1):
    """See ``_dot1``."""
    return fma(c[1], k1, c[0] * k0)


@jit
def _dot3(c, k0, k1, k2):
    """See ``_dot1``."""
    return fma(c[2], k2, fma(c[1], k1, c[0] * k0))


@jit
def _dot4(c, k0, k1, k2, k3):
    """See ``_dot1``."""
    return fma(c[3], k3, fma(c[2], k2, fma(c[1], k1, c[0] * k0)))


@jit
def _dot5(c, k0, k1, k2, k3, k4):
    """See ``_dot1``."""
    return fma(c[4], k4, fma(c[3], k3, fma(c[2], k2, fma(c[1], k1, c[0] * k0))))


@jit
def _dot6(c, k0, k1, k2, k3, k4, k5):
    """See ``_dot1``."""
    return fma(c[5], k5, fma(c[4], k4, fma(c[3], k3, fma(c[2], k2, fma(c[1], k1, c[0] * k0)))))


@jit
def _dot7(c, k0, k1, k2, k3, k4, k5, k6):
    """See ``_dot1``."""
    return fma(
        c[6],
        k6,
        fma(c[5], k5, fma(c[4], k4, fma(c[3], k3, fma(c[2], k2, fma(c[1], k1, c[0] * k0))))),
    )


@jit
def _dot8(c, k0, k1, k2, k3, k4, k5, k6, k7):
    """See ``_dot1``."""
    return fma(
        c[7],
        k7,
        fma(
            c[6],
            k6,
            fma(c[5], k5, fma(c[4], k4, fma(c[3], k3, fma(c[2], k2, fma(c[1], k1, c[0] * k0))))),
        ),
    )


@jit
def _dot9(c, k0, k1, k2, k3, k4, k5, k6, k7, k8):
    """See ``_dot1``."""
    return fma(
        c[8],
        k8,
        fma(
            c[7],
            k7,
            fma(
                c[6],
                k6,
                fma(
                    c[5], k5, fma(c[4], k4, fma(c[3], k3, fma(c[2], k2, fma(c[1], k1, c[0] * k0))))
                ),
            ),
        ),
    )


@jit
def _dot12(c, k0, k1, k2, k3, k4, k5, k6, k7, k8, k9, k10, k11):
    """See ``_dot1``."""
    return fma(
        c[11],
        k11,
        fma(
            c[10],
            k10,
            fma(
                c[9],
                k9,
                fma(
                    c[8],
                    k8,
                    fma(
                        c[7],
                        k7,
                        fma(
                            c[6],
                            k6,
                            fma(
                                c[5],
                                k5,
                                fma(
                                    c[4],
                                    k4,
                                    fma(c[3], k3, fma(c[2], k2, fma(c[1], k1, c[0] * k0))),
                                ),
                            ),
                        ),
                    ),
                ),
            ),
        ),
    )


def _dop853_stages(x, v, fp, fpp, a1, q, d, h, g, p0, p1, p2, p3, shared, b, c):
    """Stages 2..13 of one step, the 13th at the new state ``(x13, v13)``.
    Returns ``(x13, v13, fp13, velocities, accelerations, normal_terms,
    curvatures, n_low, n_high, drag_powers)``, the middle four 13-tuples over
    the stages (stage 1 is the step start: v, a1, n(v, fpp), fpp), then the
    range of the normal term over stages 2..13 (see ``steppers._dopri5_stages``)
    and the 13-tuple of drag's power (zeros without drag)."""
    x2 = fma(h, _dot1(A2, v), x)
    v2 = fma(h, _dot1(A2, a1), v)
    _, fpp2, n2, a2, pd2 = _stage(x2, v2, q, g, p0, p1, p2, p3, shared, b, c, d)
    x3 = fma(h, _dot2(A3, v, v2), x)
    v3 = fma(h, _dot2(A3, a1, a2), v)
    _, fpp3, n3, a3, pd3 = _stage(x3, v3, q, g, p0, p1, p2, p3, shared, b, c, d)
    x4 = fma(h, _dot2(A4, v, v3), x)
    v4 = fma(h, _dot2(A4, a1, a3), v)
    _, fpp4, n4, a4, pd4 = _stage(x4, v4, q, g, p0, p1, p2, p3, shared, b, c, d)
    x5 = fma(h, _dot3(A5, v, v3, v4), x)
    v5 = fma(h, _dot3(A5, a1, a3, a4), v)
    _, fpp5, n5, a5, pd5 = _stage(x5, v5, q, g, p0, p1, p2, p3, shared, b, c, d)
    x6 = fma(h, _dot3(A6, v, v4, v5), x)
    v6 = fma(h, _dot3(A6, a1, a4, a5), v)
    _, fpp6, n6, a6, pd6 = _stage(x6, v6, q, g, p0, p1, p2, p3, shared, b, c, d)
    x7 = fma(h, _dot4(A7, v, v4, v5, v6), x)
    v7 = fma(h, _dot4(A7, a1, a4, a5, a6), v)
    _, fpp7, n7, a7, pd7 = _stage(x7, v7, q, g, p0, p1, p2, p3, shared, b, c, d)
    x8 = fma(h, _dot5(A8, v, v4, v5, v6, v7), x)
    v8 = fma(h, _dot5(A8, a1, a4, a5, a6, a7), v)
    _, fpp8, n8, a8, pd8 = _stage(x8, v8, q, g, p0, p1, p2, p3, shared, b, c, d)
    x9 = fma(h, _dot6(A9, v, v4, v5, v6, v7, v8), x)
    v9 = fma(h, _dot6(A9, a1, a4, a5, a6, a7, a8), v)
    _, fpp9, n9, a9, pd9 = _stage(x9, v9, q, g, p0, p1, p2, p3, shared, b, c, d)
    x10 = fma(h, _dot7(A10, v, v4, v5, v6, v7, v8, v9), x)
    v10 = fma(h, _dot7(A10, a1, a4, a5, a6, a7, a8, a9), v)
    _, fpp10, n10, a10, pd10 = _stage(x10, v10, q, g, p0, p1, p2, p3, shared, b, c, d)
    x11 = fma(h, _dot8(A11, v, v4, v5, v6, v7, v8, v9, v10), x)
    v11 = fma(h, _dot8(A11, a1, a4, a5, a6, a7, a8, a9, a10), v)
    _, fpp11, n11, a11, pd11 = _stage(x11, v11, q, g, p0, p1, p2, p3, shared, b, c, d)
    x12 = fma(h, _dot9(A12, v, v4, v5, v6, v7, v8, v9, v10, v11), x)
    v12 = fma(h, _dot9(A12, a1, a4, a5, a6, a7, a8, a9, a10, a11), v)
    _, fpp12, n12, a12, pd12 = _stage(x12, v12, q, g, p0, p1, p2, p3, shared, b, c, d)
    x13 = fma(h, _dot8(A13, v, v6, v7, v8, v9, v10, v11, v12), x)
    v13 = fma(h, _dot8(A13, a1, a6, a7, a8, a9, a10, a11, a12), v)
    fp13, fpp13, n13, a13, pd13 = _stage(x13, v13, q, g, p0, p1, p2, p3, shared, b, c, d)
    n_low = min(
        min(min(min(n2, n3), min(n4, n5)), min(min(n6, n7), min(n8, n9))),
        min(min(n10, n11), min(n12, n13)),
    )
    n_high = max(
        max(max(max(n2, n3), max(n4, n5)), max(max(n6, n7), max(n8, n9))),
        max(max(n10, n11), max(n12, n13)),
    )
    velocities = (v, v2, v3, v4, v5, v6, v7, v8, v9, v10, v11, v12, v13)
    accelerations = (a1, a2, a3, a4, a5, a6, a7, a8, a9, a10, a11, a12, a13)
    normal_terms = (normal_term(v, fpp, g), n2, n3, n4, n5, n6, n7, n8, n9, n10, n11, n12, n13)
    curvatures = (fpp, fpp2, fpp3, fpp4, fpp5, fpp6, fpp7, fpp8, fpp9, fpp10, fpp11, fpp12, fpp13)
    pd1 = 0.0
    if DRAG:  # a1 (carried over) has its drag already
        _, pd1 = _with_drag(a1, v, fp, b, c, d)
    drag_powers = (pd1, pd2, pd3, pd4, pd5, pd6, pd7, pd8, pd9, pd10, pd11, pd12, pd13)
    return (x13, v13, fp13, velocities, accelerations, normal_terms, curvatures, n_low, n_high,
            drag_powers)


@jit
def _weigh8(k):
    """sum_s B_s k_s over a 13-tuple of stage rates: the eighth-order quadrature."""
    return _dot8(B, k[0], k[5], k[6], k[7], k[8], k[9], k[10], k[11])


@jit
def _error5(k):
    """sum_s E5_s k_s: the fifth-order error estimate."""
    return _dot8(E5, k[0], k[5], k[6], k[7], k[8], k[9], k[10], k[11])


@jit
def _error3(k):
    """sum_s E3_s k_s: the third-order error estimate."""
    return _dot8(E3, k[0], k[5], k[6], k[7], k[8], k[9], k[10], k[11])


@jit
def _products(values, factors, scale):
    """scale * values_s * factors_s over the 13 stages (the integrals' rates)."""
    return (
        scale * values[0] * factors[0],
        scale * values[1] * factors[1],
        scale * values[2] * factors[2],
        scale * values[3] * factors[3],
        scale * values[4] * factors[4],
        scale * values[5] * factors[5],
        scale * values[6] * factors[6],
        scale * values[7] * factors[7],
        scale * values[8] * factors[8],
        scale * values[9] * factors[9],
        scale * values[10] * factors[10],
        scale * values[11] * factors[11],
        scale * values[12] * factors[12],
    )


def dop853_step(x, v, fp, fpp, a1, q, d, h, g, p0, p1, p2, p3, shared, b, c):
    """One DOP853 step of size h from (x, v) with FSAL acceleration a1: returns
    ``steppers.dopri5_step``'s tuple, with the third-order error estimates of
    the four components (err3_*) in their places, and the drag work's
    increment and fifth- and third-order estimates last."""
    x13, v13, fp13, vel, acc, normal, curv, n_low, n_high, drag_rate = _dop853_stages(
        x, v, fp, fpp, a1, q, d, h, g, p0, p1, p2, p3, shared, b, c
    )
    drag = 0.0
    err_drag = 0.0
    err3_drag = 0.0
    if DRAG:
        drag = h * _weigh8(drag_rate)
        err_drag = h * _error5(drag_rate)
        err3_drag = h * _error3(drag_rate)
    work_rate = _products(normal, vel, 1.0)
    curvature_rate = _products(curv, vel, 1.0)
    qh = q * h
    dh = d * h
    return (
        x13,
        v13,
        qh * _weigh8(work_rate) if FRICTION else 0.0,
        dh * _weigh8(curvature_rate),
        acc[12],
        fp13,
        curv[12],
        h * _error5(vel),
        h * _error5(acc),
        qh * _error5(work_rate) if FRICTION else 0.0,
        dh * _error5(curvature_rate),
        n_low,
        n_high,
        h * _error3(vel),
        h * _error3(acc),
        qh * _error3(work_rate) if FRICTION else 0.0,
        dh * _error3(curvature_rate),
        drag,
        err_drag,
        err3_drag,
    )


def dop853_dense(x, v, fp, fpp, a1, q, d, h, g, p0, p1, p2, p3, shared, b, c):
    """The step's dense output and end point, for events: as
    ``steppers.dopri5_dense``, with ``N_DENSE`` coefficients per component
    (evaluated by :func:`dop853_dense_point`)."""
    x13, v13, fp13, vel, acc, normal, curv, n_low, n_high, drag_rate = _dop853_stages(
        x, v, fp, fpp, a1, q, d, h, g, p0, p1, p2, p3, shared, b, c
    )
    x14 = fma(h, _dot8(A14, vel[0], vel[6], vel[7], vel[8], vel[9], vel[10], vel[11], vel[12]), x)
    v14 = fma(h, _dot8(A14, acc[0], acc[6], acc[7], acc[8], acc[9], acc[10], acc[11], acc[12]), v)
    _, fpp14, n14, a14, pd14 = _stage(x14, v14, q, g, p0, p1, p2, p3, shared, b, c, d)
    x15 = fma(h, _dot8(A15, vel[0], vel[5], vel[6], vel[7], vel[10], vel[11], vel[12], v14), x)
    v15 = fma(h, _dot8(A15, acc[0], acc[5], acc[6], acc[7], acc[10], acc[11], acc[12], a14), v)
    _, fpp15, n15, a15, pd15 = _stage(x15, v15, q, g, p0, p1, p2, p3, shared, b, c, d)
    x16 = fma(h, _dot8(A16, vel[0], vel[5], vel[6], vel[7], vel[8], vel[12], v14, v15), x)
    v16 = fma(h, _dot8(A16, acc[0], acc[5], acc[6], acc[7], acc[8], acc[12], a14, a15), v)
    _, fpp16, n16, a16, pd16 = _stage(x16, v16, q, g, p0, p1, p2, p3, shared, b, c, d)
    work_rate = _products(normal, vel, q)
    curvature_rate = _products(curv, vel, d)
    dense = (
        _interpolant(h * _weigh8(vel), h, vel, (v14, v15, v16))
        + _interpolant(h * _weigh8(acc), h, acc, (a14, a15, a16))
        + _interpolant(
            h * _weigh8(work_rate), h, work_rate, (q * n14 * v14, q * n15 * v15, q * n16 * v16)
        )
        + _interpolant(
            h * _weigh8(curvature_rate),
            h,
            curvature_rate,
            (d * fpp14 * v14, d * fpp15 * v15, d * fpp16 * v16),
        )
    )
    if DRAG:
        dense = dense + _interpolant(h * _weigh8(drag_rate), h, drag_rate, (pd14, pd15, pd16))
    return dense, x13, v13, curv[12], h * _error5(work_rate), n_low, n_high


@jit
def _interpolant(delta, h, k, extra):
    """One component's seven interpolant coefficients (dop853.f's rcont1..8
    less the start value) from its increment delta over the step, its 13
    stage rates k and the three extra stages' rates."""
    # the rates that enter D1..D4 (stages 1, 6-13 and the three extra ones)
    rates = (k[0], k[5], k[6], k[7], k[8], k[9], k[10], k[11], k[12],
             extra[0], extra[1], extra[2])
    return (
        delta,
        fma(h, k[0], -delta),
        fma(-h, k[12] + k[0], 2.0 * delta),
        h * _dot_rates(D1, rates),
        h * _dot_rates(D2, rates),
        h * _dot_rates(D3, rates),
        h * _dot_rates(D4, rates),
    )


@jit
def _dot_rates(c, r):
    """``_dot12`` over a 12-tuple of rates."""
    return _dot12(c, r[0], r[1], r[2], r[3], r[4], r[5], r[6], r[7], r[8], r[9], r[10], r[11])


def dop853_dense_point(dense, h, theta, component):
    """Increment over [0, theta] of component 0 (x), 1 (v), 2 (friction work),
    3 (curvature integral) or, with drag, 4 (drag work) of the dense output
    (dop853.f's contd8; the coefficients carry h already)."""
    o = N_DENSE * component
    rest = 1.0 - theta
    y = dense[o + 6] * theta
    y = (y + dense[o + 5]) * rest
    y = (y + dense[o + 4]) * theta
    y = (y + dense[o + 3]) * rest
    y = (y + dense[o + 2]) * theta
    y = (y + dense[o + 1]) * rest
    return (y + dense[o]) * theta
