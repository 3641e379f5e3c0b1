#!/usr/bin/env python
"""What a user waits for: rampwork's latency from a new process (issue 17).

Every measurement runs in a FRESH subprocess (``python -c CHILD``) with its own
``NUMBA_CACHE_DIR`` in a temporary folder (removed at the end, so the source
tree gets no numba cache files), ``NUMBA_NUM_THREADS`` unset and ``PYTHONPATH``
pointing at this tree's ``src/``. The parent passes its wall-clock time at the
spawn, so each child reports the time *from process start to the first
Dataset* (interpreter start-up included, process teardown not); it also reports
the time from before ``import rampwork`` to after ``simulate`` returns, and the
dataset's ``compile_time_s``, ``run_time_s``, ``kernel_effects`` and
``kernel_tier`` (None where rampwork does not set it).

Parts (``--parts``):

``import``      ``import rampwork`` alone in a new process (median of
                ``--import-repeat``; the first on an empty cache apart), beside
                ``python -c pass``.
``first``       each built-in ramp family (``rampwork.FAMILIES``, user-function
                families skipped) x each method (euler, semi_implicit_euler,
                rk4, dopri5, dop853): a 6-trajectory sweep
                ``Sweep.grid(mu=[0.1, 0.2, 0.3], v0=[0.0, 0.3])`` on the
                family's example ramp (``src/rampwork/examples``), with an
                EMPTY cache (a fresh machine) and again in a new process with
                the same cache (WARM). The straight family uses its closed
                form whatever the method; it is measured all the same.
``variant``     a variant never run before on a cache that holds another one
                ("a machine that has run rampwork once"): the cache that has
                run quadratic + rk4 (part ``first``'s, or a run of its own
                where that part did not run it) is copied for each of
                sine + rk4, quadratic + euler and quadratic + rk4 with linear
                drag, each run in a new process.
``user``        a ramp from ``Ramp.from_functions`` whose numba-jitted
                functions live in a module FILE (so they can be found again):
                a first process, then a second one on the same cache.
``mixed``       20 mixed scenes (families x one/two-sided contact x drag off /
                linear / linear + quadratic x mu = 0 / mu_s > mu_k / swept mu)
                x the 5 methods from an empty cache, all in ONE process (as a
                study script or a CI job would run them): total time.
``throughput``  the specialised kernels' throughput on throughput.py's grid:
                ``benchmarks/throughput.py --no-figure --no-scaling`` with its
                peers off (``--scipy-subset 0 --numpy-subset 0
                --accuracy-subset 1 --uniform 0``) at ``--throughput-n``
                trajectories, for this tree and, with ``--baseline REF``, for a
                ``git worktree`` of REF, alternately (ABAB...), each tree's own
                ``src`` imported (checked: the child prints
                ``rampwork.__file__``). The measuring script is this tree's
                ``throughput.py`` for both, so only the library differs. Each
                tree has its own cache, filled first by an untimed run on 1000
                trajectories (so no timed run shares the cores with a
                compiler); a run that fails is run once more on an empty
                cache. Verdict: the best run of each tree (other load
                on a shared machine only slows a run down); the median of the
                ratios of the pairs run back to back is reported beside it.

After each child the script waits until nothing that child started is still
running (processes are found by a variable, ``RAMPWORK_LATENCY_TAG``, that
the child's environment passes on; rampwork may compile kernels in a detached
background process), so measurements never share the cores with each other;
how long that took is reported as "background s" (the machine stays busy
that much longer after the user's first result). An interrupted run stops
those processes by pid.

The summary compares the numbers with the issue's targets (PASS/FAIL), all
from process start to the first Dataset: ``first`` on an empty cache, median
<= 8 s and worst <= 12 s over every family x method; warm, worst <= 1 s; a new
variant, worst <= 3 s; ``from_functions`` in the second process <= 2 s; the 20
x 5 mixed runs <= 90 s in all; throughput, current / baseline >= 0.97 per
method. A FAIL does not change the exit status: the script reports.

Run from the repository root::

    .venv/bin/python benchmarks/latency.py --quick                # ~5 min: 3 families x 2 methods,
                                                                  # import, variant, user
    .venv/bin/python benchmarks/latency.py                        # everything (about 25 min on 2 cores)
    .venv/bin/python benchmarks/latency.py --baseline HEAD        # ... with throughput before/after
    .venv/bin/python benchmarks/latency.py --parts variant,user   # some parts only

Results (JSON and markdown) go to benchmarks/results/latency-<stamp>[-quick].*.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import pathlib
import shutil
import signal
import statistics
import subprocess
import sys
import tempfile
import textwrap
import time
import traceback

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import _common as C  # noqa: E402

BENCH_DIR = pathlib.Path(__file__).resolve().parent
REPO = BENCH_DIR.parent
SRC = REPO / "src"

METHODS = ("euler", "semi_implicit_euler", "rk4", "dopri5", "dop853")
PARTS = ("import", "first", "variant", "user", "mixed", "throughput")
QUICK_PARTS = ("import", "first", "variant", "user")
QUICK_FAMILIES = ("quadratic", "sine", "straight")
QUICK_METHODS = ("euler", "rk4")

#: the 6-trajectory sweep of the "first result" runs (valid on every family's ramp below)
SWEEP = {"mu": [0.1, 0.2, 0.3], "v0": [0.0, 0.3]}
T_MAX = 10.0

#: each built-in family's ramp and start, from src/rampwork/examples/*.toml
FAMILY_SCENES = {
    "straight": {"params": {"slope": -0.5, "height": 1.0}, "domain": [0.0, 2.0], "x0": 0.0},
    "quadratic": {"params": {"curvature": 1.0}, "domain": [-1.0, 1.0], "x0": -0.9},
    "circular_bowl": {"params": {"radius": 1.0, "y_bottom": 0.0}, "domain": [-0.95, 0.95], "x0": -0.85},
    "circular_dome": {"params": {"radius": 1.0}, "domain": [-0.9, 0.9], "x0": -0.3},
    "cycloid": {"params": {"radius": 0.5}, "domain": [-1.5, 1.5], "x0": -1.4},
    "sine": {"params": {"mean_slope": -0.3, "amplitude": 0.03, "wavenumber": 5.0, "phase": math.pi},
             "domain": [0.0, 4.0], "x0": 0.0},
    "spline": {"params": {"x_points": [0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0],
                          "y_points": [1.0, 0.62, 0.38, 0.25, 0.2, 0.12, 0.0]},
               "domain": [0.0, 3.0], "x0": 0.0},
}

#: part "variant": the cache holds PRIMED; each of VARIANTS is new to it
PRIMED = ("quadratic", "rk4", None)
VARIANTS = (("sine", "rk4", None), ("quadratic", "euler", None), ("quadratic", "rk4", [0.2, 0.0]))

#: part "user": the module written to a file (plain @numba.njit, as a user writes it)
USER_MODULE = "latency_user_ramp"
USER_SOURCE = textwrap.dedent('''\
    """A user's ramp for rampwork.Ramp.from_functions: a quartic bowl."""
    import numba


    @numba.njit
    def f(x):
        return 0.5 * x * x + 0.05 * x ** 4


    @numba.njit
    def fp(x):
        return x + 0.2 * x ** 3


    @numba.njit
    def fpp(x):
        return 1.0 + 0.6 * x * x
    ''')
USER_RAMP = {"user_module": USER_MODULE, "domain": [-1.0, 1.0], "curvature_sign": 1, "name": "quartic_bowl"}
USER_X0 = -0.9

#: the issue's targets (seconds; throughput: the least current/baseline ratio)
TARGETS = {"first_median": 8.0, "first_worst": 12.0, "variant": 3.0, "warm": 1.0, "user_second": 2.0,
           "mixed": 90.0, "throughput_ratio": 0.97}

#: set in each child's environment (inherited by anything it starts in the background)
TAG_ENV = "RAMPWORK_LATENCY_TAG"

#: runs in a fresh process: argv = [spawn wall-clock time, JSON list of scene specs]
CHILD = textwrap.dedent(r'''
    import json, sys, time
    spawned = float(sys.argv[1])
    specs = json.loads(sys.argv[2])
    started = time.perf_counter()
    import rampwork as rw
    out = {"import_s": time.perf_counter() - started, "rampwork_file": rw.__file__, "runs": []}


    def make_ramp(r):
        if r.get("user_module"):
            import importlib
            sys.path.insert(0, r["user_dir"])
            module = importlib.import_module(r["user_module"])
            return rw.Ramp.from_functions(module.f, module.fp, module.fpp, tuple(r["domain"]),
                                          curvature_sign=r.get("curvature_sign"), name=r["name"])
        return rw.Ramp.create(r["family"], domain=tuple(r["domain"]), **r["params"])


    for spec in specs:
        began = time.perf_counter()
        extra = {"drag": rw.Drag(*spec["drag"])} if spec.get("drag") else {}
        scene = rw.Scene(ramp=make_ramp(spec["ramp"]), friction=rw.Friction(*spec["friction"]),
                         integrator=rw.Integrator(spec["method"]), x0=spec["x0"], t_max=spec["t_max"],
                         contact=spec["contact"], **extra)
        ds = rw.simulate(scene, rw.Sweep.grid(**spec["sweep"]))
        now = time.perf_counter()
        attrs = ds.attrs
        out["runs"].append({
            "label": spec["label"],
            "since_spawn_s": time.time() - spawned,
            "since_import_start_s": now - started,
            "call_s": now - began,
            "compile_time_s": float(attrs.get("compile_time_s", float("nan"))),
            "run_time_s": float(attrs.get("run_time_s", float("nan"))),
            "kernel_tier": attrs.get("kernel_tier"),
            "kernel_effects": attrs.get("kernel_effects"),
            "trajectories": int(attrs.get("n_trajectories", -1)),
            "status": [int(s) for s in ds["status"].values.ravel()],
        })
    out["since_spawn_s"] = time.time() - spawned
    out["in_process_s"] = time.perf_counter() - started
    print("LATENCY_JSON " + json.dumps(out, default=str), flush=True)
''')

#: runs throughput.py in a fresh process after saying which rampwork it imports
THROUGHPUT_CHILD = textwrap.dedent(r'''
    import runpy, sys
    import rampwork
    print("LATENCY_RAMPWORK_FILE " + rampwork.__file__, flush=True)
    script = sys.argv[1]
    sys.argv = [script] + sys.argv[2:]
    runpy.run_path(script, run_name="__main__")
''')


def parse_args(argv=None):
    p = argparse.ArgumentParser(
        prog="latency.py",
        description=(
            "What a user waits for (issue 17): from a new process with an empty or warm numba "
            "cache to the first Dataset, per ramp family and method; a new variant on a cache "
            "that holds others; a from_functions ramp in a second process; import rampwork; 20 "
            "mixed scenes x 5 methods; throughput before/after (--baseline). Prints a table "
            "against the issue's targets and saves JSON and markdown under --out."))
    p.add_argument("--quick", action="store_true",
                   help=f"a subset: families {','.join(QUICK_FAMILIES)} x methods {','.join(QUICK_METHODS)}; "
                        f"parts {','.join(QUICK_PARTS)} (no mixed, no throughput)")
    p.add_argument("--parts", default=None,
                   help=f"comma-separated parts to run, of {','.join(PARTS)} (default all; --quick: "
                        f"{','.join(QUICK_PARTS)})")
    p.add_argument("--families", default=None,
                   help="comma-separated ramp families of part 'first' (default every built-in family "
                        "in rampwork.FAMILIES; --quick " + ",".join(QUICK_FAMILIES) + ")")
    p.add_argument("--methods", default=None,
                   help=f"comma-separated methods of part 'first' (default {','.join(METHODS)}; "
                        f"--quick {','.join(QUICK_METHODS)})")
    p.add_argument("--import-repeat", type=int, default=5,
                   help="new processes timed for 'import rampwork' (median; default %(default)s)")
    p.add_argument("--baseline", default=None, metavar="REF",
                   help="git ref whose src/ is measured beside this tree's in part 'throughput' "
                        "(a temporary git worktree, removed afterwards); default: this tree only")
    p.add_argument("--throughput-n", type=float, default=1e6,
                   help="trajectories of throughput.py's grid (default %(default)g: its full grid)")
    p.add_argument("--throughput-methods", default="euler,rk4",
                   help="methods passed to throughput.py (default %(default)s)")
    p.add_argument("--throughput-runs", type=int, default=2,
                   help="runs of each tree, alternating (ABAB...; default %(default)s)")
    p.add_argument("--throughput-repeat", type=int, default=2,
                   help="throughput.py --repeat: timed runs in each process, the fastest counts "
                        "(default %(default)s)")
    p.add_argument("--timeout", type=float, default=1800,
                   help="seconds allowed to one child process (default %(default)s; 'mixed' gets 3x)")
    p.add_argument("--out", type=pathlib.Path, default=C.RESULTS_DIR,
                   help="folder for the JSON and markdown results (default benchmarks/results)")
    p.add_argument("--keep-tmp", action="store_true", help="keep the temporary folder (caches, worktree)")
    args = p.parse_args(argv)
    parts = args.parts or (",".join(QUICK_PARTS) if args.quick else ",".join(PARTS))
    args.parts = [s.strip() for s in parts.split(",") if s.strip()]
    unknown = [s for s in args.parts if s not in PARTS]
    if unknown:
        p.error(f"--parts: unknown {unknown}; choose from {', '.join(PARTS)}")
    methods = args.methods or (",".join(QUICK_METHODS) if args.quick else ",".join(METHODS))
    args.methods = [m.strip() for m in methods.split(",") if m.strip()]
    if any(m not in METHODS for m in args.methods):
        p.error(f"--methods: choose from {', '.join(METHODS)}")
    args.families = ([f.strip() for f in args.families.split(",") if f.strip()] if args.families
                     else list(QUICK_FAMILIES) if args.quick else None)
    args.throughput_methods = [m.strip() for m in args.throughput_methods.split(",") if m.strip()]
    if args.import_repeat < 1 or args.throughput_runs < 1 or args.throughput_repeat < 1:
        p.error("--import-repeat, --throughput-runs and --throughput-repeat must be >= 1")
    return args


# ------------------------------------------------------------------------------
# children
# ------------------------------------------------------------------------------
class Runner:
    """Spawns the children: one temporary root, one env per cache folder."""

    def __init__(self, root: pathlib.Path, timeout: float, log):
        self.root = root
        self.timeout = timeout
        self.log = log
        self._count = 0
        self.children = 0

    def cache(self, name: str) -> pathlib.Path:
        self._count += 1
        path = self.root / f"cache-{self._count:03d}-{name}"
        path.mkdir(parents=True)
        return path

    def tag(self) -> str:
        return f"{self.root}#{self.children}"

    @staticmethod
    def env(cache: pathlib.Path, src: pathlib.Path = SRC, tag: str | None = None) -> dict:
        env = dict(os.environ)
        env.pop("NUMBA_NUM_THREADS", None)  # numba's default: every core
        env["NUMBA_CACHE_DIR"] = str(cache)
        env["PYTHONPATH"] = str(src) + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
        if tag is not None:
            env[TAG_ENV] = tag
        return env

    def settle(self, tag: str) -> dict:
        """After a child: wait for what it left running (see :func:`wait_background`)."""
        info = wait_background(tag, self.timeout)
        if info["background_processes"]:
            self.log(f"    (waited {info['background_s']:.1f} s for {info['background_processes']} "
                     f"background process(es) the child left running: {'; '.join(info['background_commands'])})")
        return info

    def child(self, cache: pathlib.Path, specs: list[dict], timeout: float | None = None) -> dict:
        """Run the scenes ``specs`` in a new process on ``cache``; never raises."""
        self.children += 1
        tag = self.tag()
        spawned_wall = time.time()
        started = time.perf_counter()
        try:
            done = subprocess.run([sys.executable, "-c", CHILD, repr(spawned_wall), json.dumps(specs)],
                                  env=self.env(cache, tag=tag), cwd=self.root, capture_output=True, text=True,
                                  timeout=timeout or self.timeout)
        except subprocess.TimeoutExpired as error:
            return {"error": f"timed out after {error.timeout:.0f} s", "process_wall_s": time.perf_counter() - started,
                    **self.settle(tag)}
        wall = time.perf_counter() - started
        background = self.settle(tag)
        line = next((s for s in reversed(done.stdout.splitlines()) if s.startswith("LATENCY_JSON ")), None)
        if done.returncode != 0 or line is None:
            return {"error": f"exit {done.returncode}: {done.stderr.strip()[-1500:]}", "process_wall_s": wall,
                    **background}
        result = json.loads(line[len("LATENCY_JSON "):])
        result["process_wall_s"] = wall  # spawn to exit, teardown included
        result.update(background)
        result["cache_files"] = cache_files(cache)
        if not str(pathlib.Path(result["rampwork_file"]).resolve()).startswith(str(SRC.resolve())):
            result["warning"] = f"imported {result['rampwork_file']}, not this tree's src"
        return result


def tagged_pids(tag: str) -> list[int]:
    """Processes whose environment holds ``TAG_ENV=tag``: a child and whatever it left running
    in the background (rampwork may start a detached process that compiles kernels)."""
    needle = f"{TAG_ENV}={tag}".encode()
    pids = []
    try:
        entries = os.listdir("/proc")
    except OSError:  # pragma: no cover - not Linux: nothing to wait for
        return pids
    for entry in entries:
        if not entry.isdigit() or int(entry) == os.getpid():
            continue
        try:
            with open(f"/proc/{entry}/environ", "rb") as handle:
                if needle in handle.read().split(b"\0"):
                    pids.append(int(entry))
        except OSError:
            continue
    return pids


def wait_background(tag: str, timeout: float) -> dict:
    """Wait until nothing that a child started is running any more, so that the next
    measurement does not share the cores with it; say how many and how long."""
    started = time.perf_counter()
    seen: dict[int, str] = {}
    while True:
        pids = tagged_pids(tag)
        for pid in pids:
            if pid not in seen:
                try:
                    with open(f"/proc/{pid}/cmdline", "rb") as handle:
                        seen[pid] = handle.read().replace(b"\0", b" ").decode(errors="replace")[:200].strip()
                except OSError:
                    seen[pid] = "?"
        waited = time.perf_counter() - started
        info = {"background_processes": len(seen), "background_s": waited if seen else 0.0,
                "background_commands": sorted(set(seen.values()))}
        if not pids:
            return info
        if waited > timeout:
            return {**info, "background_left": pids}
        time.sleep(0.1)


def cache_files(cache: pathlib.Path) -> int:
    """numba cache index files (one per cached function) in ``cache``."""
    return sum(1 for _ in cache.rglob("*.nbi"))


def scene_spec(family: str, method: str, *, drag=None, contact="one_sided", friction=(0.1, None),
               sweep=None, label=None) -> dict:
    fs = FAMILY_SCENES[family]
    return {"label": label or f"{family}+{method}" + ("+drag" if drag else ""),
            "ramp": {"family": family, "params": fs["params"], "domain": fs["domain"]},
            "method": method, "x0": fs["x0"], "t_max": T_MAX, "contact": contact,
            "friction": list(friction), "drag": drag, "sweep": sweep or SWEEP}


def user_spec(user_dir: pathlib.Path, method="rk4") -> dict:
    return {"label": f"from_functions+{method}", "ramp": {**USER_RAMP, "user_dir": str(user_dir)},
            "method": method, "x0": USER_X0, "t_max": T_MAX, "contact": "one_sided",
            "friction": [0.1, None], "drag": None, "sweep": SWEEP}


def first_run(result: dict) -> dict:
    """The measurement of a one-scene child: its first (only) run, or its error."""
    if "error" in result:
        return {"error": result["error"], "process_wall_s": result.get("process_wall_s")}
    run = dict(result["runs"][0])
    for key in ("import_s", "process_wall_s", "cache_files", "warning", "background_processes",
                "background_s", "background_commands", "background_left"):
        if key in result:
            run[key] = result[key]
    return run


def _s(value, digits=2) -> str:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "-"
    return f"{value:.{digits}f}"


def describe(run: dict) -> str:
    if "error" in run:
        return "ERROR " + run["error"].splitlines()[-1][:200]
    return (f"{run['since_spawn_s']:.2f} s to the dataset (compile {run['compile_time_s']:.2f} s, "
            f"run {run['run_time_s']:.3f} s, tier {run.get('kernel_tier')}, exit at {run['process_wall_s']:.2f} s, "
            f"{run.get('cache_files', '-')} cache files"
            + (f", background {run['background_s']:.1f} s more" if run.get("background_processes") else "") + ")")


# ------------------------------------------------------------------------------
# the parts
# ------------------------------------------------------------------------------
def part_import(runner: Runner, args, log) -> dict:
    log("import rampwork (new processes)")
    out = {}
    times = []
    for _ in range(3):
        started = time.perf_counter()
        subprocess.run([sys.executable, "-c", "pass"], env=Runner.env(runner.root), check=False)
        times.append(time.perf_counter() - started)
    out["python_pass_median_s"] = statistics.median(times)
    cache = runner.cache("import")
    first = runner.child(cache, [])
    out["empty_cache"] = first
    samples = [runner.child(cache, []) for _ in range(args.import_repeat)]
    good = [s for s in samples if "error" not in s]
    out["samples"] = samples
    if good:
        out["import_s"] = [s["import_s"] for s in good]
        out["since_spawn_s"] = [s["since_spawn_s"] for s in good]
        out["import_median_s"] = statistics.median(out["import_s"])
        out["since_spawn_median_s"] = statistics.median(out["since_spawn_s"])
        log(f"  python -c pass {out['python_pass_median_s']:.3f} s; import rampwork: median "
            f"{out['import_median_s']:.3f} s (range {min(out['import_s']):.3f}-{max(out['import_s']):.3f}), "
            f"process start to imported {out['since_spawn_median_s']:.3f} s; on an empty cache "
            f"{first.get('import_s', float('nan')):.3f} s")
    else:
        log(f"  ERROR {samples[0].get('error')}")
    return out


def part_first(runner: Runner, args, families, log, caches: dict) -> dict:
    log(f"first result, empty then warm cache: {len(families)} families x {len(args.methods)} methods")
    rows = []
    for family in families:
        for method in args.methods:
            cache = runner.cache(f"{family}-{method}")
            spec = scene_spec(family, method)
            cold = first_run(runner.child(cache, [spec]))
            warm = first_run(runner.child(cache, [spec]))
            caches[(family, method)] = cache
            rows.append({"family": family, "method": method, "cold": cold, "warm": warm})
            log(f"  {family:>13} {method:>19}: empty {describe(cold)}")
            log(f"  {'':>13} {'':>19}  warm  {describe(warm)}")
    return {"sweep": SWEEP, "t_max": T_MAX, "rows": rows}


def part_variant(runner: Runner, args, log, caches: dict) -> dict:
    family, method, drag = PRIMED
    log(f"a new variant on a cache that holds {family} + {method}")
    out = {"primed_with": f"{family}+{method}", "rows": []}
    primed = caches.get((family, method))
    if primed is not None:
        out["primed_by"] = "part 'first' (its empty- and warm-cache runs)"
    else:
        primed = runner.cache("primed")
        out["primed_by"] = "a run of its own"
        out["prime_run"] = first_run(runner.child(primed, [scene_spec(family, method, drag=drag)]))
        log(f"  prime {family}+{method}: {describe(out['prime_run'])}")
    out["primed_cache_files"] = cache_files(primed)
    for v_family, v_method, v_drag in VARIANTS:
        cache = runner.cache(f"variant-{v_family}-{v_method}" + ("-drag" if v_drag else ""))
        shutil.copytree(primed, cache, dirs_exist_ok=True)  # each variant on a copy of the primed cache
        spec = scene_spec(v_family, v_method, drag=v_drag)
        run = first_run(runner.child(cache, [spec]))
        run["label"] = spec["label"]
        run["drag"] = v_drag
        out["rows"].append(run)
        log(f"  {spec['label']:>20}: {describe(run)}")
    return out


def part_user(runner: Runner, args, log) -> dict:
    user_dir = runner.root / "user"
    user_dir.mkdir()
    (user_dir / f"{USER_MODULE}.py").write_text(USER_SOURCE, encoding="utf-8")
    log("Ramp.from_functions with functions in a module file: first process, then a second one")
    cache = runner.cache("user")
    spec = user_spec(user_dir)
    first = first_run(runner.child(cache, [spec]))
    log(f"  first  process: {describe(first)}")
    second = first_run(runner.child(cache, [spec]))
    log(f"  second process: {describe(second)}")
    return {"module_source": USER_SOURCE, "method": spec["method"], "first": first, "second": second}


def mixed_specs() -> list[tuple[str, dict]]:
    """20 mixed scenes (families, contact, drag, friction vary together)."""
    families = ("quadratic", "circular_bowl", "circular_dome", "cycloid", "sine", "spline", "straight")
    drags = (None, [0.2, 0.0], [0.2, 0.1])
    scenes = []
    for i in range(20):
        family = families[i % len(families)]
        contact = ("one_sided", "two_sided")[i % 2]
        drag = drags[i % 3]
        kind = ("mu", "mu", "mu_s", "mu0")[i % 4]
        friction, sweep = {"mu": ((0.1, None), SWEEP),
                           "mu_s": ((0.1, 0.2), {"v0": [0.0, 0.1, 0.2, 0.3, 0.4, 0.5]}),
                           "mu0": ((0.0, None), {"v0": [0.0, 0.1, 0.2, 0.3, 0.4, 0.5]})}[kind]
        name = (f"{family}/{contact}/" + ("no drag" if drag is None else "drag b" if not drag[1] else "drag b+c")
                + f"/{ {'mu': 'mu swept', 'mu_s': 'mu_s>mu_k', 'mu0': 'mu=0'}[kind] }")
        scenes.append((name, dict(family=family, contact=contact, drag=drag, friction=friction, sweep=sweep)))
    return scenes


def part_mixed(runner: Runner, args, log) -> dict:
    scenes = mixed_specs()
    specs = [scene_spec(s["family"], method, drag=s["drag"], contact=s["contact"], friction=s["friction"],
                        sweep=s["sweep"], label=f"{name} | {method}")
             for name, s in scenes for method in METHODS]
    log(f"{len(scenes)} mixed scenes x {len(METHODS)} methods = {len(specs)} runs, one process, empty cache "
        "(this takes a while)")
    cache = runner.cache("mixed")
    result = runner.child(cache, specs, timeout=3 * args.timeout)
    out = {"scenes": [name for name, _ in scenes], "methods": list(METHODS), "one_process": True}
    if "error" in result:
        out["error"] = result["error"]
        log(f"  ERROR {result['error'][-300:]}")
        return out
    runs = result["runs"]
    out.update({"runs": runs, "total_s": result["since_spawn_s"], "process_wall_s": result["process_wall_s"],
                "background_processes": result.get("background_processes"),
                "background_s": result.get("background_s"),
                "import_s": result["import_s"], "cache_files": result["cache_files"],
                "compile_s": sum(r["compile_time_s"] for r in runs),
                "run_s": sum(r["run_time_s"] for r in runs),
                "runs_that_compiled": sum(r["compile_time_s"] > 0.05 for r in runs),
                "kernel_tiers": {str(t): sum(r["kernel_tier"] == t for r in runs)
                                 for t in dict.fromkeys(r["kernel_tier"] for r in runs)},
                "distinct_effects": len({(r["label"].split("/")[0], r["label"].rsplit("| ", 1)[1],
                                          r["kernel_effects"]) for r in runs})})
    slowest = sorted(runs, key=lambda r: -r["compile_time_s"])[:5]
    out["slowest"] = [(r["label"], r["compile_time_s"]) for r in slowest]
    log(f"  total {out['total_s']:.1f} s (process exit {out['process_wall_s']:.1f} s): compile "
        f"{out['compile_s']:.1f} s, run {out['run_s']:.2f} s; {out['runs_that_compiled']} of {len(runs)} runs "
        f"compiled (> 0.05 s), kernel tiers {out['kernel_tiers']}, {out['distinct_effects']} distinct "
        f"(family, method, effects), {out['cache_files']} cache files")
    log("  slowest: " + "; ".join(f"{label} {s:.1f} s" for label, s in out["slowest"]))
    return out


def _throughput_once(runner: Runner, label: str, tree_src: pathlib.Path, cache: pathlib.Path,
                     out_dir: pathlib.Path, args, log, n: float | None = None) -> dict:
    out_dir.mkdir(parents=True)
    cmd = [sys.executable, "-c", THROUGHPUT_CHILD, str(BENCH_DIR / "throughput.py"),
           "--n", f"{n or args.throughput_n:g}", "--methods", ",".join(args.throughput_methods),
           "--no-figure", "--no-scaling", "--scipy-subset", "0", "--numpy-subset", "0",
           # --accuracy-subset 1, not 0: throughput.py's report needs a reference (KeyError
           # 'reference' at 0); one scipy trajectory costs nothing
           "--accuracy-subset", "1", "--uniform", "0", "--repeat", str(args.throughput_repeat),
           "--out", str(out_dir)]
    runner.children += 1
    tag = runner.tag()
    started = time.perf_counter()
    try:
        done = subprocess.run(cmd, env=Runner.env(cache, tree_src, tag), cwd=out_dir, capture_output=True,
                              text=True, timeout=args.timeout)
    except subprocess.TimeoutExpired:
        runner.settle(tag)
        return {"tree": label, "error": "timed out"}
    wall = time.perf_counter() - started
    background = runner.settle(tag)
    imported = next((s.split(" ", 1)[1] for s in done.stdout.splitlines()
                     if s.startswith("LATENCY_RAMPWORK_FILE ")), None)
    found = sorted(out_dir.glob("throughput-*.json"))
    if done.returncode != 0 or not found:
        return {"tree": label, "error": f"exit {done.returncode}: {done.stderr.strip()[-1500:]}",
                "rampwork_file": imported}
    data = json.loads(found[-1].read_text(encoding="utf-8"))
    ok = imported is not None and str(pathlib.Path(imported).resolve()).startswith(str(tree_src.resolve()))
    res = {"tree": label, "rampwork_file": imported, "imported_expected_tree": ok, "process_wall_s": wall,
           "n": data["grid"]["n"],
           "steps_per_s": {m: v["main"]["steps_per_s"] for m, v in data["methods"].items()},
           "compile_s": {m: v["first_compile"]["compile_time_s"] for m, v in data["methods"].items()},
           "division_ceiling_per_s": data["division_ceiling"]["divisions_per_s"],
           "load_average": data["machine"].get("load_average_1_5_15min"), **background}
    load = res["load_average"][0] if res["load_average"] else float("nan")
    if n is not None:  # the untimed warm-up
        log(f"  {label:>8}: warm-up done ({wall:.0f} s; rampwork from {imported}"
            + ("" if ok else " - NOT THE EXPECTED TREE") + ")")
        return res
    log(f"  {label:>8}: " + ", ".join(f"{m} {v:.3e} steps/s" for m, v in res["steps_per_s"].items())
        + f" ({wall:.0f} s, load {load:.2f}; rampwork from {imported}"
        + ("" if ok else " - NOT THE EXPECTED TREE") + ")")
    return res


def part_throughput(runner: Runner, args, log) -> dict:
    out = {"n": args.throughput_n, "methods": args.throughput_methods, "baseline_ref": args.baseline,
           "measuring_script": str(BENCH_DIR / "throughput.py"), "runs": []}
    trees = [("current", SRC)]
    worktree = None
    if args.baseline:
        worktree = runner.root / "baseline"
        made = subprocess.run(["git", "worktree", "add", "--detach", str(worktree), args.baseline],
                              cwd=REPO, capture_output=True, text=True)
        if made.returncode != 0:
            out["error"] = f"git worktree add failed: {made.stderr.strip()}"
            log(f"  {out['error']}")
            worktree = None
        else:
            out["baseline_commit"] = subprocess.run(["git", "rev-parse", "HEAD"], cwd=worktree,
                                                    capture_output=True, text=True).stdout.strip()
            trees = [("baseline", worktree / "src"), ("current", SRC)]
    log(f"throughput on throughput.py's grid ({args.throughput_n:g} trajectories, "
        f"{','.join(args.throughput_methods)}): " + " / ".join(t for t, _ in trees)
        + f" alternately, {args.throughput_runs} run(s) each")
    try:
        caches = {label: runner.cache(f"throughput-{label}") for label, _ in trees}
        # untimed first: each tree compiles its kernels (and whatever it compiles in the background
        # finishes) before the timed runs, so no timed run shares the cores with a compiler
        out["warmup_runs"] = []
        log("  a small untimed run of each tree first (1000 trajectories: compiles the kernels)")
        for label, tree_src in trees:
            out["warmup_runs"].append(_throughput_once(runner, label, tree_src, caches[label],
                                                       runner.root / f"throughput-{label}-warmup", args, log,
                                                       n=1000))
        for k in range(args.throughput_runs):
            for label, tree_src in trees:
                run = _throughput_once(runner, label, tree_src, caches[label],
                                       runner.root / f"throughput-{label}-{k}", args, log)
                if "error" in run:  # once more on an empty cache: a stale cache, or a broken tree?
                    log(f"  {label} failed ({run['error'].splitlines()[0][:200]}); again on an empty cache")
                    caches[label] = runner.cache(f"throughput-{label}-retry")
                    retry = _throughput_once(runner, label, tree_src, caches[label],
                                             runner.root / f"throughput-{label}-{k}-retry", args, log)
                    retry["retry_of"] = run
                    run = retry
                run["pair"] = k
                out["runs"].append(run)
    finally:
        if worktree is not None:
            removed = subprocess.run(["git", "worktree", "remove", "--force", str(worktree)], cwd=REPO,
                                     capture_output=True, text=True)
            if removed.returncode != 0:
                log(f"  git worktree remove failed: {removed.stderr.strip()}")
    good = [r for r in out["runs"] if "error" not in r and r["imported_expected_tree"]]
    out["median_steps_per_s"] = {
        label: {m: statistics.median([r["steps_per_s"][m] for r in good if r["tree"] == label])
                for m in args.throughput_methods
                if any(r["tree"] == label and m in r["steps_per_s"] for r in good)}
        for label, _ in trees}
    if args.baseline and len(trees) == 2:
        by_pair = {}
        for r in good:
            by_pair.setdefault(r["pair"], {})[r["tree"]] = r
        pairs = [(p["baseline"], p["current"]) for _, p in sorted(by_pair.items()) if len(p) == 2]
        out["paired_ratios"] = {m: [b["steps_per_s"][m] / a["steps_per_s"][m] for a, b in pairs]
                                for m in args.throughput_methods}
        out["ratio_paired_median"] = {m: (statistics.median(v) if v else None)
                                      for m, v in out["paired_ratios"].items()}
        # the verdict: best of each tree (on a shared machine, other load only slows a run down)
        best = {label: {m: max((r["steps_per_s"][m] for r in good if r["tree"] == label), default=None)
                        for m in args.throughput_methods} for label, _ in trees}
        out["best_steps_per_s"] = best
        out["ratio_current_over_baseline"] = {
            m: (best["current"][m] / best["baseline"][m] if best["current"][m] and best["baseline"][m] else None)
            for m in args.throughput_methods}
        log("  current / baseline, best of each: " + ", ".join(
            f"{m} {_s(v, 3)}" for m, v in out["ratio_current_over_baseline"].items())
            + "; median of paired ratios: " + ", ".join(
            f"{m} {_s(v, 3)}" for m, v in out["ratio_paired_median"].items()))
    return out


# ------------------------------------------------------------------------------
# summary
# ------------------------------------------------------------------------------
def _verdict(value, target, higher_is_better=False) -> str:
    if value is None:
        return "n/a"
    return "PASS" if (value >= target if higher_is_better else value <= target) else "FAIL"


def summary(res: dict) -> list[list]:
    rows = []
    imp = res.get("import")
    if imp and "import_median_s" in imp:
        rows.append(["import rampwork, new process (median; spawn to imported)",
                     f"{imp['import_median_s']:.2f} s ({imp['since_spawn_median_s']:.2f} s)",
                     "- (0.7-1.3 s in the issue)", "info"])
    first = res.get("first")
    if first:
        cold = [r["cold"]["since_spawn_s"] for r in first["rows"] if "error" not in r["cold"]]
        warm = [r["warm"]["since_spawn_s"] for r in first["rows"] if "error" not in r["warm"]]
        errors = sum(("error" in r["cold"]) + ("error" in r["warm"]) for r in first["rows"])
        worst = max(first["rows"], key=lambda r: r["cold"].get("since_spawn_s", -1))
        median = statistics.median(cold) if cold else None
        rows.append([f"first result, empty cache: median of {len(cold)}", _s(median) + " s",
                     f"<= {TARGETS['first_median']:g} s", _verdict(median, TARGETS["first_median"])])
        rows.append([f"first result, empty cache: worst ({worst['family']}+{worst['method']})",
                     _s(max(cold) if cold else None) + " s", f"<= {TARGETS['first_worst']:g} s",
                     _verdict(max(cold) if cold else None, TARGETS["first_worst"])])
        wworst = max((r for r in first["rows"] if "error" not in r["warm"]),
                     key=lambda r: r["warm"]["since_spawn_s"], default=None)
        rows.append([f"warm cache, new process: worst of {len(warm)}"
                     + (f" ({wworst['family']}+{wworst['method']}; median {statistics.median(warm):.2f} s)"
                        if wworst else ""),
                     _s(max(warm) if warm else None) + " s", f"<= {TARGETS['warm']:g} s",
                     _verdict(max(warm) if warm else None, TARGETS["warm"])])
        if errors:
            rows.append(["first/warm runs that failed", str(errors), "0", "FAIL"])
    var = res.get("variant")
    if var:
        good = [r for r in var["rows"] if "error" not in r]
        value = max((r["since_spawn_s"] for r in good), default=None)
        label = max(good, key=lambda r: r["since_spawn_s"])["label"] if good else "-"
        rows.append([f"new variant on a cache holding {var['primed_with']}: worst of {len(good)} ({label})",
                     _s(value) + " s", f"<= {TARGETS['variant']:g} s",
                     _verdict(value, TARGETS["variant"]) if len(good) == len(var["rows"]) else "FAIL"])
    user = res.get("user")
    if user:
        value = user["second"].get("since_spawn_s")
        rows.append([f"from_functions, second process (first: {_s(user['first'].get('since_spawn_s'))} s)",
                     _s(value) + " s", f"<= {TARGETS['user_second']:g} s",
                     _verdict(value, TARGETS["user_second"]) if value is not None else "FAIL"])
    mixed = res.get("mixed")
    if mixed:
        value = mixed.get("total_s")
        rows.append([f"{len(mixed['scenes'])} mixed scenes x {len(mixed['methods'])} methods, empty cache, "
                     "one process" + (f" (compile {mixed['compile_s']:.0f} s, run {mixed['run_s']:.1f} s)"
                                      if value is not None else ""),
                     _s(value, 1) + " s", f"<= {TARGETS['mixed']:g} s",
                     _verdict(value, TARGETS["mixed"]) if value is not None else "FAIL"])
    thr = res.get("throughput")
    if thr:
        ratios = thr.get("ratio_current_over_baseline")
        if ratios:
            for m, value in ratios.items():
                paired = thr.get("ratio_paired_median", {}).get(m)
                rows.append([f"throughput {m}, current / baseline {thr['baseline_ref']}, best of each "
                             f"(median of paired ratios {_s(paired, 3)})",
                             _s(value, 3), f">= {TARGETS['throughput_ratio']:g}",
                             _verdict(value, TARGETS["throughput_ratio"], higher_is_better=True)])
        else:
            for m, value in thr.get("median_steps_per_s", {}).get("current", {}).items():
                rows.append([f"throughput {m}, this tree (no --baseline)", f"{value:.3e} steps/s",
                             f"within 3 % of a baseline", "n/a"])
    for name, error in res.get("part_errors", {}).items():
        rows.append([f"part {name!r} failed: {error.strip().splitlines()[-1][:80]}", "-", "-", "FAIL"])
    return rows


def first_table(first: dict) -> tuple[list[str], list[list]]:
    headers = ["family", "method", "empty: to dataset s", "empty: compile s", "empty: run s",
               "empty: to exit s", "empty: background s", "warm: to dataset s", "warm: compile s", "import s (warm)",
               "kernel_tier empty / warm", "cache files"]
    rows = []
    for r in first["rows"]:
        c, w = r["cold"], r["warm"]
        rows.append([r["family"], r["method"], _s(c.get("since_spawn_s")), _s(c.get("compile_time_s")),
                     _s(c.get("run_time_s"), 4), _s(c.get("process_wall_s")), _s(c.get("background_s"), 1),
                     _s(w.get("since_spawn_s")),
                     _s(w.get("compile_time_s")), _s(w.get("import_s")),
                     f"{c.get('kernel_tier', '-')} / {w.get('kernel_tier', '-')}", str(w.get("cache_files", "-"))])
    return headers, rows


def build_report(res: dict) -> tuple[str, str]:
    text, md = [], [f"# latency.py, {res['started_utc']}\n",
                    f"{res['machine']['cpu_model']}, {res['machine']['usable_cores']} cores, "
                    f"load average at start {res['machine']['load_average_1_5_15min']}, commit "
                    f"{res['machine']['git_commit']}"
                    + (f" with uncommitted changes in src/ ({len(res['src_changes'])} files)"
                       if res["src_changes"] else "") + ".\n"]
    if res.get("first"):
        headers, rows = first_table(res["first"])
        text += ["FIRST RESULT (6-trajectory sweep; seconds from process start)", C.text_table(headers, rows), ""]
        md += ["## First result: empty cache, then warm (seconds from process start)\n",
               C.markdown_table(headers, rows), ""]
    if res.get("variant"):
        headers = ["new variant", "to dataset s", "compile s", "run s", "to exit s", "background s", "kernel_tier",
                   "cache files"]
        rows = [[r.get("label"), _s(r.get("since_spawn_s")), _s(r.get("compile_time_s")), _s(r.get("run_time_s"), 4),
                 _s(r.get("process_wall_s")), _s(r.get("background_s"), 1), str(r.get("kernel_tier", "-")),
                 str(r.get("cache_files", "-"))]
                for r in res["variant"]["rows"]]
        title = f"NEW VARIANT on a cache that holds {res['variant']['primed_with']}"
        text += [title, C.text_table(headers, rows), ""]
        md += [f"## New variant on a cache that holds {res['variant']['primed_with']}\n",
               C.markdown_table(headers, rows), ""]
    if res.get("user"):
        headers = ["from_functions (module file)", "to dataset s", "compile s", "run s", "to exit s",
                   "background s", "kernel_tier"]
        rows = [[k, _s(res["user"][k].get("since_spawn_s")), _s(res["user"][k].get("compile_time_s")),
                 _s(res["user"][k].get("run_time_s"), 4), _s(res["user"][k].get("process_wall_s")),
                 _s(res["user"][k].get("background_s"), 1), str(res["user"][k].get("kernel_tier", "-"))]
                for k in ("first", "second")]
        text += ["FROM_FUNCTIONS", C.text_table(headers, rows), ""]
        md += ["## `Ramp.from_functions`, functions in a module file\n", C.markdown_table(headers, rows), ""]
    if res.get("throughput") and res["throughput"].get("runs"):
        headers = ["run", "tree", "rampwork imported from", *(f"{m} steps/s" for m in res["throughput"]["methods"])]
        rows = [[str(k), r["tree"], r.get("rampwork_file") or "-",
                 *(f"{r['steps_per_s'].get(m, float('nan')):.3e}" if "steps_per_s" in r else "error"
                   for m in res["throughput"]["methods"])]
                for k, r in enumerate(res["throughput"]["runs"])]
        text += ["THROUGHPUT (throughput.py's grid, peers off)", C.text_table(headers, rows), ""]
        md += [f"## Throughput on throughput.py's grid ({res['throughput']['n']:g} trajectories)\n",
               C.markdown_table(headers, rows), ""]
    headers = ["what a user does", "measured", "target", "verdict"]
    rows = summary(res)
    text += ["SUMMARY against issue 17's targets", C.text_table(headers, rows)]
    md += ["## Summary against issue 17's targets\n", C.markdown_table(headers, rows)]
    return "\n".join(text), "\n".join(md) + "\n"


# ------------------------------------------------------------------------------
# main
# ------------------------------------------------------------------------------
def _terminate(signum, frame):  # noqa: ARG001 - a kill runs the clean-up (finally) too
    raise SystemExit(128 + signum)


def main(argv=None) -> int:
    args = parse_args(argv)
    signal.signal(signal.SIGTERM, _terminate)
    wall_started = time.perf_counter()
    root = pathlib.Path(tempfile.mkdtemp(prefix="rampwork-latency-"))
    # the parent imports rampwork too (its family list, machine_info): its cache goes to root as well
    os.environ.pop("NUMBA_NUM_THREADS", None)
    parent_cache = root / "cache-parent"
    parent_cache.mkdir()
    os.environ["NUMBA_CACHE_DIR"] = str(parent_cache)
    sys.path.insert(0, str(SRC))
    try:
        import rampwork as rw
    except BaseException:
        shutil.rmtree(root, ignore_errors=True)
        raise

    def log(message: str) -> None:
        print(f"[{time.perf_counter() - wall_started:7.1f} s] {message}", flush=True)

    families = args.families or [name for name in rw.FAMILIES if name != "callable"]
    skipped = [f for f in families if f not in FAMILY_SCENES]
    families = [f for f in families if f in FAMILY_SCENES]
    if skipped:
        log(f"skipped families without an example scene here: {', '.join(skipped)}")
    src_changes = subprocess.run(["git", "status", "--porcelain", "--", "src"], cwd=REPO, capture_output=True,
                                 text=True).stdout.splitlines()
    res = {"benchmark": "latency", "started_utc": C.utc_now(), "machine": C.machine_info(),
           "rampwork_file": rw.__file__, "src_changes": src_changes,
           "config": {"quick": args.quick, "parts": args.parts, "families": families, "methods": args.methods,
                      "skipped_families": skipped, "sweep": SWEEP, "t_max": T_MAX,
                      "family_scenes": {f: FAMILY_SCENES[f] for f in families},
                      "import_repeat": args.import_repeat, "baseline": args.baseline,
                      "throughput_n": args.throughput_n, "throughput_methods": args.throughput_methods,
                      "throughput_runs": args.throughput_runs, "throughput_repeat": args.throughput_repeat,
                      "rampwork_env": {k: v for k, v in os.environ.items() if k.startswith("RAMPWORK_")}},
           "targets": TARGETS}
    log(f"temporary folder {root}; rampwork from {rw.__file__}"
        + (f"; {len(src_changes)} uncommitted change(s) in src/" if src_changes else ""))
    runner = Runner(root, args.timeout, log)
    caches: dict = {}
    parts = {"import": lambda: part_import(runner, args, log),
             "first": lambda: part_first(runner, args, families, log, caches),
             "variant": lambda: part_variant(runner, args, log, caches),
             "user": lambda: part_user(runner, args, log),
             "mixed": lambda: part_mixed(runner, args, log),
             "throughput": lambda: part_throughput(runner, args, log)}
    try:
        for name in PARTS:
            if name in args.parts:
                try:
                    res[name] = parts[name]()
                except Exception:  # noqa: BLE001 - one part's failure must not lose the others
                    res.setdefault("part_errors", {})[name] = traceback.format_exc()
                    log(f"part {name!r} failed:\n{res['part_errors'][name]}")
    finally:
        # only on an interrupted run: what our own children left running, by pid
        leftovers = [pid for k in range(runner.children + 1) for pid in tagged_pids(f"{root}#{k}")]
        for pid in leftovers:
            try:
                os.kill(pid, signal.SIGTERM)
            except OSError:
                pass
        if args.keep_tmp:
            log(f"kept {root}")
        else:
            shutil.rmtree(root, ignore_errors=True)
    res["child_processes"] = runner.children
    res["total_wall_s"] = time.perf_counter() - wall_started
    try:
        res["machine"]["load_average_at_end"] = list(os.getloadavg())
    except OSError:
        pass
    text, md = build_report(res)
    print("\n" + text)
    stem = f"latency-{C.timestamp()}" + ("-quick" if args.quick else "")
    paths = [C.save_json(args.out / f"{stem}.json", res), C.save_text(args.out / f"{stem}.md", md)]
    print("\nsaved: " + ", ".join(str(p) for p in paths))
    print(f"total wall time {res['total_wall_s']:.1f} s ({runner.children} child processes)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
