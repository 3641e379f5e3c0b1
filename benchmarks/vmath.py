"""Error table and speed of core.vmath's sin, cos (and cbrt), of core.vmath_exp's exp and atan (issue 21), and of the cycloid family (issue 19, item 3).

Error: over ``--n`` (default 10**7) arguments per function and range, the
maximum and mean error in ulps against the exact value (long double sinl/cosl,
11 bits more than a double, where the platform has an 80-bit long double; else
numpy's float64, then the figures are distances to numpy), and the share of
results that are correctly rounded (equal to the long double value rounded
to double).  numpy's own float64 error is listed for comparison.  Then inverse_cbrt,
sin_small and cos_small (the cycloid's helpers), and the cycloid family's
f, f', f'' (core.ramps, no libm call) against a long double inverse of
x = r (u + sin u), over ``--n`` arguments per range and radius (r = 1 and
0.5: powers of 2, so that x / r is exact in the reference), the ranges
including both cusps, the switch between the two formulations and x -> 0.

exp and atan (core.vmath_exp) over ``--n`` arguments per range against
long double expl/atanl: the ranges the descent quadrature needs (|x| <= 2
for exp, |x| <= 3 for atan) and their whole domains (exp: normal and
subnormal results; atan: up to 1e300).

Speed: arguments/s of vmath.sin, vmath.sincos and math.sin, math.sin plus
math.cos, vmath_exp.exp and math.exp, vmath_exp.atan and math.atan in a
jitted loop over an array (the loop vectorises only with vmath).

    PYTHONPATH=src python benchmarks/vmath.py [--n 1e7] [--out benchmarks/results]
    PYTHONPATH=src python benchmarks/vmath.py --only exp_atan     # exp and atan alone
"""

from __future__ import annotations

import argparse
import math
import pathlib
import sys
import time

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import _common as C  # noqa: E402

#: (label, sampler) of the argument ranges
RANGES = ("|x| <= pi/4", "|x| <= 4", "|x| <= 100", "|x| <= 1e5 (valid range)",
          "log-spaced 1e-300..1e5", "near k*pi/4, |x| <= 1e5", "|x| <= 1e7", "|x| <= 1e10", "|x| <= 1e14")


def arguments(label, n, np, rng):
    if label.startswith("|x| <= "):
        bound = {"pi/4": math.pi / 4}.get(label.split()[2], None)
        bound = bound if bound is not None else float(label.split()[2])
        return rng.uniform(-bound, bound, n)
    if label.startswith("log-spaced"):
        return 10.0 ** rng.uniform(-300.0, 5.0, n) * rng.choice([-1.0, 1.0], n)
    # nearest doubles to k*pi/4 and up to 8 ulps around them, k random
    k = rng.integers(1, int(1e5 / (math.pi / 4)), n).astype(np.longdouble)
    centres = (k * np.longdouble("0.785398163397448309615660845819875721")).astype(np.float64)
    offsets = rng.integers(-8, 9, n)
    return (centres + offsets * np.spacing(centres)) * rng.choice([-1.0, 1.0], n)


def ulp_error(got, exact, np):
    exact64 = exact.astype(np.float64)
    exponent = np.frexp(np.abs(exact64))[1] - 1
    ulp = np.ldexp(np.ones_like(exact64), np.maximum(exponent, -1022) - 52)
    return np.abs((got.astype(np.longdouble) - exact) / ulp.astype(np.longdouble)).astype(np.float64)


# -- the cycloid family's u(x) (core.ramps), against a long double inverse ----

CYCLOID_RANGES = ("uniform |x| < pi r", "near the cusps (pi - |u| log-spaced 1e-5..pi/2)",
                  "near the centre/ends switch (1e-6 relative)", "near 0 (|x| log-spaced 1e-300..0.1)")


def cycloid_arguments(label, n, r, np, rng):
    if label.startswith("uniform"):
        x = rng.uniform(-math.pi * r, math.pi * r, n)
    elif label.startswith("near the cusps"):
        w = 10.0 ** rng.uniform(-5.0, math.log10(math.pi / 2), n).astype(np.longdouble)
        x = (r * (np.longdouble(math.pi) - (w - np.sin(w)))).astype(np.float64)
    elif label.startswith("near the centre"):
        x = (0.5 * math.pi + 1.0) * r * (1.0 + rng.uniform(-1e-6, 1e-6, n))
    else:
        x = 10.0 ** rng.uniform(-300.0, -1.0, n)
    return x * rng.choice([-1.0, 1.0], n)


def cycloid_exact(x, r, np):
    """(f, f', f'') at x in long double; r must be a power of 2 (x / r exact)."""
    from decimal import Decimal

    L = np.longdouble
    pi_hi = L("3.14159265358979323846264338327950288")  # pi to 64 bits
    # pi - pi_hi, from 40 digits of pi and the exact value of pi_hi
    hi = float(pi_hi)
    pi_lo = L(float(Decimal("3.141592653589793238462643383279502884197") - Decimal(hi)
                    - Decimal(float(pi_hi - L(hi)))))
    s = np.abs(x).astype(L) / L(r)
    centre = s < L(0.5 * math.pi + 1.0)
    t = (pi_hi - s) + pi_lo  # exact subtraction (Sterbenz) at the ends
    z = s / 2
    for _ in range(8):  # z + sin z = s
        z = z - (z + np.sin(z) - s) / (1 + np.cos(z))
    tp = np.where(centre, L(1), t)
    w = np.cbrt(6 * tp)
    for _ in range(10):  # w - sin w = t, with w - sin w summed as a series for small w
        w2 = w * w
        series = w * w2 * (L(1) / 6 - w2 * (L(1) / 120 - w2 * (L(1) / 5040 - w2 * (L(1) / 362880 - w2 * (
            L(1) / 39916800 - w2 * (L(1) / 6227020800 - w2 / L(1307674368000)))))))
        g = np.where(w < 0.1, series, w - np.sin(w))
        w = w - (g - tp) / (2 * np.sin(w / 2) ** 2)
    sh = np.where(centre, np.sin(z / 2), np.cos(w / 2))  # sin(u/2), cos(u/2)
    ch = np.where(centre, np.cos(z / 2), np.sin(w / 2))
    return 2 * L(r) * sh * sh, np.copysign(sh / ch, x.astype(L)), 1 / (4 * L(r) * ch ** 4)


def cycloid_table(n, chunk, np, rng):
    from rampwork.core import ramps as core
    from rampwork.core.jit import jit

    @jit(cache=False)
    def cycloid_loop(x, r, f, fp, fpp):
        for i in range(x.size):
            f[i] = core.cycloid_height(x[i], r, 0.0, 0.0, 0.0, x)
            fp[i], fpp[i] = core.cycloid_slope_curvature(x[i], r, 0.0, 0.0, 0.0, x)

    rows, table = [], []
    for r in (1.0, 0.5):
        for label in CYCLOID_RANGES:
            worst = {"f": 0.0, "f'": 0.0, "f''": 0.0}
            total = dict.fromkeys(worst, 0.0)
            done = 0
            while done < n:
                m = min(chunk, n - done)
                x = cycloid_arguments(label, m, r, np, rng)
                x = x[np.abs(x) < math.pi * r]
                x = x[[core.cycloid_cusp_gap(abs(float(v)), r) > 0 for v in x]] if label.startswith("near the cusps") else x
                f, fp, fpp = np.empty_like(x), np.empty_like(x), np.empty_like(x)
                cycloid_loop(x, r, f, fp, fpp)
                for key, got, exact in zip(worst, (f, fp, fpp), cycloid_exact(x, r, np)):
                    err = ulp_error(got, exact, np)
                    worst[key] = max(worst[key], float(err.max()))
                    total[key] += float(err.sum())
                done += m
            for key in worst:
                entry = {"function": f"cycloid {key}", "range": f"{label}, r = {r:g}", "n": n,
                         "max_ulp": worst[key], "mean_ulp": total[key] / n}
                table.append(entry)
                rows.append([entry["function"], entry["range"], f"{n:.0e}", f"{worst[key]:.3f}",
                             f"{entry['mean_ulp']:.4f}"])
                print("  " + "  ".join(rows[-1]), flush=True)
    return rows, table


def elementwise(function):
    """A jitted loop out[i] = function(x[i]) (the lane loop shape rampwork's
    kernels give the functions: one call per element, inlined)."""
    from rampwork.core.jit import jit

    @jit(cache=False)
    def loop(x, out):
        for i in range(x.size):
            out[i] = function(x[i])
    return loop


#: (function, low, high) of the exp and atan ranges (high None: log-spaced magnitudes, both signs)
EXP_ATAN_RANGES = (("exp", -2.0, 2.0), ("exp", -708.0, 709.78), ("exp", -745.13, -708.4),
                   ("atan", -3.0, 3.0), ("atan", -100.0, 100.0), ("atan", "log-spaced 1e-300..1e300", None))


def exp_atan_table(n, chunk, np, rng):
    """Max and mean ulp error, share correctly rounded, and numpy's max ulp, of
    vmath_exp.exp and vmath_exp.atan per range, against long double."""
    from rampwork.core import vmath_exp
    from rampwork.core.jit import jit

    @jit(cache=False)
    def loop(x, e, a):
        for i in range(x.size):
            e[i] = vmath_exp.exp(x[i])
            a[i] = vmath_exp.atan(x[i])

    rows, entries = [], []
    for name, low, high in EXP_ATAN_RANGES:
        worst = total = numpy_worst = 0.0
        rounded, done = 0, 0
        while done < n:
            m = min(chunk, n - done)
            if high is None:
                x = 10.0 ** rng.uniform(-300.0, 300.0, m) * rng.choice([-1.0, 1.0], m)
            else:
                x = rng.uniform(low, high, m)
            e, a = np.empty_like(x), np.empty_like(x)
            loop(x, e, a)
            got, numpy_f = (e, np.exp) if name == "exp" else (a, np.arctan)
            exact = numpy_f(x.astype(np.longdouble))
            err = ulp_error(got, exact, np)
            worst, total = max(worst, float(err.max())), total + float(err.sum())
            numpy_worst = max(numpy_worst, float(ulp_error(numpy_f(x), exact, np).max()))
            rounded += int((got == exact.astype(np.float64)).sum())
            done += m
        label = low if high is None else f"[{low:g}, {high:g}]"
        entries.append({"function": name, "range": label, "n": n, "max_ulp": worst, "mean_ulp": total / n,
                        "correctly_rounded": rounded / n, "numpy_max_ulp": numpy_worst})
        rows.append([name, label, f"{n:.0e}", f"{worst:.3f}", f"{total / n:.4f}", f"{100 * rounded / n:.2f}%",
                     f"{numpy_worst:.3f}"])
        print("  " + "  ".join(rows[-1]), flush=True)
    return rows, entries, loop


def exp_atan_speed(speed_n, np, rng):
    """arguments/s of vmath_exp.exp, math.exp, vmath_exp.atan, math.atan in a jitted loop (best of 5)."""
    from rampwork.core import vmath_exp
    from rampwork.core.jit import jit

    @jit(cache=False)
    def libm_exp(a):
        return math.exp(a)

    @jit(cache=False)
    def libm_atan(a):
        return math.atan(a)

    x = rng.uniform(-3.0, 3.0, speed_n)
    out = np.empty_like(x)
    speed = {}
    for name, function in (("vmath_exp.exp", vmath_exp.exp), ("math.exp", libm_exp),
                           ("vmath_exp.atan", vmath_exp.atan), ("math.atan", libm_atan)):
        loop = elementwise(function)
        loop(x, out)
        best = math.inf
        for _ in range(5):
            started = time.perf_counter()
            loop(x, out)
            best = min(best, time.perf_counter() - started)
        speed[name] = speed_n / best
    return speed


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--n", type=float, default=1e7, help="arguments per function and range (default 1e7)")
    p.add_argument("--chunk", type=int, default=2_000_000)
    p.add_argument("--speed-n", type=int, default=10_000_000)
    p.add_argument("--out", type=pathlib.Path, default=C.RESULTS_DIR)
    p.add_argument("--only", choices=("exp_atan",), help="only core.vmath_exp's exp and atan")
    args = p.parse_args(argv)
    n = int(args.n)

    import numpy as np

    if args.only == "exp_atan":
        return exp_atan_main(args, n, np)

    from rampwork.core import vmath
    from rampwork.core.jit import jit

    long_double = np.finfo(np.longdouble).nmant >= 63
    reference = "long double (sinl/cosl)" if long_double else "numpy float64"

    @jit(cache=False)
    def sincos_loop(x, s, c):
        for i in range(x.size):
            s[i], c[i] = vmath.sincos(x[i])

    @jit(cache=False)
    def libm_sincos_loop(x, s, c):
        for i in range(x.size):
            s[i] = math.sin(x[i])
            c[i] = math.cos(x[i])

    @jit(cache=False)
    def libm_sin(a):
        return math.sin(a)

    @jit(cache=False)
    def libm_cbrt(a):
        return a ** (1.0 / 3.0)

    sin_loop, libm_sin_loop = elementwise(vmath.sin), elementwise(libm_sin)
    cbrt_loop, inverse_cbrt_loop = elementwise(vmath.cbrt), elementwise(vmath.inverse_cbrt)
    sin_small_loop, cos_small_loop = elementwise(vmath.sin_small), elementwise(vmath.cos_small)
    libm_cbrt_loop = elementwise(libm_cbrt)

    rng = np.random.default_rng(19)
    rows, table = [], []
    print(f"error over {n:.0e} arguments per function and range, against {reference}", flush=True)
    for label in RANGES:
        stats = {f: {"max": 0.0, "sum": 0.0, "rounded": 0, "numpy_max": 0.0} for f in ("sin", "cos")}
        done = 0
        while done < n:
            m = min(args.chunk, n - done)
            x = arguments(label, m, np, rng)
            s, c = np.empty_like(x), np.empty_like(x)
            sincos_loop(x, s, c)
            xl = x.astype(np.longdouble)
            for f, got, numpy_f in (("sin", s, np.sin), ("cos", c, np.cos)):
                if long_double:
                    exact = numpy_f(xl)
                    err = ulp_error(got, exact, np)
                    stats[f]["numpy_max"] = max(stats[f]["numpy_max"], float(ulp_error(numpy_f(x), exact, np).max()))
                    stats[f]["rounded"] += int((got == exact.astype(np.float64)).sum())
                else:
                    ref = numpy_f(x)
                    err = np.abs(got - ref) / np.spacing(np.minimum(np.abs(got), np.abs(ref)))
                    stats[f]["rounded"] += int((got == ref).sum())
                stats[f]["max"] = max(stats[f]["max"], float(err.max()))
                stats[f]["sum"] += float(err.sum())
            done += m
        for f in ("sin", "cos"):
            st = stats[f]
            entry = {"function": f, "range": label, "n": n, "max_ulp": st["max"], "mean_ulp": st["sum"] / n,
                     "correctly_rounded": st["rounded"] / n, "numpy_max_ulp": st["numpy_max"] if long_double else None}
            table.append(entry)
            rows.append([f, label, f"{n:.0e}", f"{entry['max_ulp']:.3f}", f"{entry['mean_ulp']:.4f}",
                         f"{100 * entry['correctly_rounded']:.2f}%",
                         f"{entry['numpy_max_ulp']:.3f}" if long_double else "-"])
            print("  " + "  ".join(rows[-1]), flush=True)

    # cbrt: positive arguments over 600 decades
    x = 10.0 ** rng.uniform(-300.0, 300.0, min(n, args.chunk))
    out = np.empty_like(x)
    cbrt_loop(x, out)
    ref = np.cbrt(x)
    cbrt_err = float((np.abs(out - ref) / np.spacing(np.minimum(out, ref))).max())
    print(f"cbrt: max {cbrt_err:.0f} ulp from numpy.cbrt over {x.size:.0e} arguments in [1e-300, 1e300]")
    inverse_cbrt_loop(x, out)
    exact = 1 / np.cbrt(x.astype(np.longdouble))
    inverse_cbrt_err = float(ulp_error(out, exact, np).max())
    print(f"inverse_cbrt: max {inverse_cbrt_err:.2f} ulp over {x.size:.0e} arguments in [1e-300, 1e300]")
    # sin_small, cos_small: |x| <= pi/4 without range reduction
    small_rows = []
    for name, loop, numpy_f in (("sin_small", sin_small_loop, np.sin), ("cos_small", cos_small_loop, np.cos)):
        worst, done = 0.0, 0
        while done < n:
            m = min(args.chunk, n - done)
            xs = rng.uniform(-math.pi / 4, math.pi / 4, m)
            loop(xs, out[:m])
            worst = max(worst, float(ulp_error(out[:m], numpy_f(xs.astype(np.longdouble)), np).max()))
            done += m
        small_rows.append([name, "|x| <= pi/4", f"{n:.0e}", f"{worst:.3f}"])
        table.append({"function": name, "range": "|x| <= pi/4", "n": n, "max_ulp": worst})
        print("  " + "  ".join(small_rows[-1]), flush=True)
    print(f"cycloid family (core.ramps) over {n:.0e} arguments per range and radius, against long double")
    cycloid_rows, cycloid_entries = cycloid_table(n, args.chunk, np, rng)
    table += cycloid_entries
    print(f"exp and atan (core.vmath_exp) over {n:.0e} arguments per range, against long double")
    exp_atan_rows, exp_atan_entries, _ = exp_atan_table(n, args.chunk, np, rng)
    table += exp_atan_entries

    # speed: best of 5 over one array
    x = rng.uniform(-1e5, 1e5, args.speed_n)
    s, c = np.empty_like(x), np.empty_like(x)
    xc = 10.0 ** rng.uniform(-20, 20, args.speed_n)
    speed = {}
    for name, call in (("vmath.sin", lambda: sin_loop(x, s)), ("math.sin", lambda: libm_sin_loop(x, s)),
                       ("vmath.sincos", lambda: sincos_loop(x, s, c)),
                       ("math.sin + math.cos", lambda: libm_sincos_loop(x, s, c)),
                       ("vmath.cbrt", lambda: cbrt_loop(xc, s)), ("x ** (1/3)", lambda: libm_cbrt_loop(xc, s))):
        call()
        best = math.inf
        for _ in range(5):
            started = time.perf_counter()
            call()
            best = min(best, time.perf_counter() - started)
        speed[name] = args.speed_n / best
    speed.update(exp_atan_speed(args.speed_n, np, rng))
    speed_rows = [[name, C.fmt_rate(rate)] for name, rate in speed.items()]
    ratios = {"sin": speed["vmath.sin"] / speed["math.sin"],
              "sincos": speed["vmath.sincos"] / speed["math.sin + math.cos"],
              "cbrt": speed["vmath.cbrt"] / speed["x ** (1/3)"],
              "exp": speed["vmath_exp.exp"] / speed["math.exp"], "atan": speed["vmath_exp.atan"] / speed["math.atan"]}

    text = (f"core.vmath error over {n:.0e} arguments per function and range, against {reference}\n\n"
            + C.text_table(["function", "range", "n", "max ulp", "mean ulp", "correctly rounded",
                            "numpy max ulp"], rows)
            + f"\n\ncbrt: max {cbrt_err:.0f} ulp from numpy.cbrt; inverse_cbrt: max {inverse_cbrt_err:.2f} ulp\n\n"
            + C.text_table(["function", "range", "n", "max ulp"], small_rows)
            + f"\n\ncycloid family (core.ramps) over {n:.0e} arguments per range and radius, "
            + "against long double:\n\n"
            + C.text_table(["function", "range", "n", "max ulp", "mean ulp"], cycloid_rows) + "\n\n"
            + f"core.vmath_exp over {n:.0e} arguments per range, against long double:\n\n"
            + C.text_table(["function", "range", "n", "max ulp", "mean ulp", "correctly rounded", "numpy max ulp"],
                           exp_atan_rows) + "\n\n"
            + f"speed, jitted loop over {args.speed_n:.0e} arguments (one thread), arguments/s:\n\n"
            + C.text_table(["function", "arguments/s"], speed_rows)
            + "\n\nvmath / libm: " + ", ".join(f"{k} {v:.1f}x" for k, v in ratios.items()) + "\n")
    print(text)
    stamp = C.timestamp()
    data = {"utc": C.utc_now(), "machine": C.machine_info(), "reference": reference, "errors": table,
            "cbrt_max_ulp_vs_numpy": cbrt_err, "inverse_cbrt_max_ulp": inverse_cbrt_err, "speed_arguments_per_s": speed, "speed_ratios": ratios,
            "config": {"n": n, "speed_n": args.speed_n}}
    C.save_json(args.out / f"vmath-{stamp}.json", data)
    C.save_text(args.out / f"vmath-{stamp}.txt", text)
    print(f"saved {args.out / f'vmath-{stamp}.json'}")


def exp_atan_main(args, n, np):
    rng = np.random.default_rng(21)
    print(f"core.vmath_exp error over {n:.0e} arguments per function and range, against long double", flush=True)
    rows, entries, _ = exp_atan_table(n, args.chunk, np, rng)
    speed = exp_atan_speed(args.speed_n, np, rng)
    ratios = {"exp": speed["vmath_exp.exp"] / speed["math.exp"], "atan": speed["vmath_exp.atan"] / speed["math.atan"]}
    text = (f"core.vmath_exp error over {n:.0e} arguments per function and range, against long double\n\n"
            + C.text_table(["function", "range", "n", "max ulp", "mean ulp", "correctly rounded", "numpy max ulp"],
                           rows)
            + f"\n\nspeed, jitted loop over {args.speed_n:.0e} arguments in [-3, 3] (one thread), arguments/s:\n\n"
            + C.text_table(["function", "arguments/s"], [[k, C.fmt_rate(v)] for k, v in speed.items()])
            + "\n\nvmath_exp / libm: " + ", ".join(f"{k} {v:.1f}x" for k, v in ratios.items()) + "\n")
    print(text)
    stamp = C.timestamp()
    C.save_json(args.out / f"vmath_exp-{stamp}.json", {"utc": C.utc_now(), "machine": C.machine_info(),
                                                        "errors": entries, "speed_arguments_per_s": speed,
                                                        "speed_ratios": ratios,
                                                        "config": {"n": n, "speed_n": args.speed_n}})
    C.save_text(args.out / f"vmath_exp-{stamp}.txt", text)
    print(f"saved {args.out / f'vmath_exp-{stamp}.json'}")


if __name__ == "__main__":
    main()
