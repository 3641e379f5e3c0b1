"""Vector instructions per step: the y = f(x) kernel's fixed step, the
engine's curve vector step and the (p, p') prototype's (pdot_kernel.py),
from numba's ``inspect_asm`` (AVX-512 machines; benchmarks/README.md,
curves.py, i20-pdot-11).

Each kernel is built and run once on a few starts; every function that
``jit.specialise`` compiles is recorded, and the assembly of the one asked
for (the curve kernels' ``vector_step``: one step of a block of BLOCK lanes;
the y = f(x) kernel's ``advance_lanes``: SUBSTEPS steps of LANES lanes, the
steps inlined) is counted: zmm instructions, of them moves (``vmovupd``,
``vmovapd``: loads, stores, spills), masked ones, divisions, square roots
and FMAs.

    PYTHONPATH=src python benchmarks/pdot_asm.py --cases graph:quadratic,graph:sine \
        --methods euler,rk4
"""

from __future__ import annotations

import collections
import pathlib
import re
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import curves as CB  # noqa: E402

BUILT = {}


def _recording(original):
    def specialise(template, name, constants, **options):
        dispatcher = original(template, name, constants, **options)
        BUILT[name] = dispatcher
        return dispatcher
    return specialise


def counts(dispatcher) -> dict:
    asm = "\n".join(dispatcher.inspect_asm().values())
    tally = collections.Counter()
    for line in asm.splitlines():
        line = line.strip()
        if not line or line.startswith((".", "#")) or line.endswith(":") or "zmm" not in line:
            continue
        mnemonic = line.split()[0]
        tally["zmm"] += 1
        if mnemonic.startswith(("vmovupd", "vmovapd")):
            tally["moves"] += 1
            # AT&T order: the destination last; a memory operand has parentheses
            operands = re.split(r",(?![^(]*\))", line.split(None, 1)[1].split("{")[0])
            if "(" in operands[-1]:
                tally["stores"] += 1
            elif "(" in operands[0]:
                tally["loads"] += 1
        if re.search(r"\{%k\d\}", line):
            tally["masked"] += 1
        if mnemonic.startswith("vdivpd"):
            tally["div"] += 1
        if mnemonic.startswith("vsqrtpd"):
            tally["sqrt"] += 1
        if mnemonic.startswith("vfm") or mnemonic.startswith("vfnm"):
            tally["fma"] += 1
        if mnemonic.startswith("vmulpd"):
            tally["mul"] += 1
    return dict(tally)


def main():
    import rampwork as rw
    import rampwork.core.curve_lanes as cl
    import rampwork.core.kernel as kernel

    import pdot_kernel as PK
    import pdot_prototype as PP

    for module in (cl, kernel, PK):
        module.specialise = _recording(module.specialise)
    args = CB.parse_args(["--n", "64"] + sys.argv[1:])
    x0, v0, mu = CB.starts(args)
    for method in args.methods.split(","):
        for case in args.cases.split(","):
            family = case.split(":")[1]
            BUILT.clear()
            scene = CB.ramp_scene(family, method, args)
            rw.simulate(scene, rw.Sweep.cases(x0=x0, v0=v0, mu=mu), kernel=CB.C.KERNEL)
            run = CB.curve_run(case, method, args, x0, v0, mu)
            PP.time_kernel(run.kernel, run)
            pd = PP.pd_kernel(case, method)
            PP.time_kernel(pd, run)
            for switches in ({"LEAN": True}, {"LEAN": True, "GRAPH": True}):
                if "GRAPH" in switches and not case.startswith("graph"):
                    continue
                PP.time_kernel(PP.pd_kernel(case, method, **switches), run)
            for name, dispatcher in BUILT.items():
                if name.startswith("advance_lanes") or name.endswith("_vector_step"):
                    print(method, case, name.split("_", 1)[0] if name.startswith("advance")
                          else name, counts(dispatcher), flush=True)


if __name__ == "__main__":
    main()
