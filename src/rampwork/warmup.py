"""``python -m rampwork.warmup [--lock PATH] [KIND ...]``: compile the general
kernels missing from numba's disk cache (KIND: ``fixed_step``, ``dopri5``,
``dop853``; default all).  :func:`rampwork.kernels.start_warmup` starts it in
the background; it removes the lock file PATH when done."""

from __future__ import annotations

import argparse
import pathlib
import sys

from . import kernels
from .ramps import Ramp
from .runner import simulate
from .scene import Integrator, Scene, Sweep


def warm_up(kinds=None) -> None:
    """Run one tiny scene of each missing kind (of ``kinds``) on its general kernel."""
    for variant in kernels.missing_general():
        if kinds and variant.method not in kinds:
            continue
        method = variant.method
        integrator = Integrator("rk4", 1e-3) if method == "fixed_step" else Integrator(method)
        scene = Scene(ramp=Ramp.create("quadratic", curvature=1.0, domain=(-1.0, 1.0)), x0=0.5,
                      integrator=integrator, t_max=0.01)
        simulate(scene, Sweep.single(), kernel="general", threads=1)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m rampwork.warmup", description=__doc__)
    parser.add_argument("--lock", type=pathlib.Path, help="a lock file to remove when done")
    kinds = [variant.method for variant in kernels.GENERAL_VARIANTS]
    parser.add_argument("kinds", nargs="*", metavar="KIND",
                        help=f"the kinds to compile: {', '.join(kinds)} (default: all)")
    args = parser.parse_args(argv)
    unknown = sorted(set(args.kinds) - set(kinds))
    if unknown:
        parser.error(f"unknown kind {unknown[0]!r}; allowed: {', '.join(kinds)}")
    try:
        warm_up(args.kinds)
    finally:
        if args.lock is not None:
            args.lock.unlink(missing_ok=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
