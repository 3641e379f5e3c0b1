"""What every study script shares: its options, provenance and where outputs go.

Each study runs as ``python studies/NAME.py [--smoke | --full] [--out DIR] [--pdf] [--gallery]``
and writes NAME.nc and NAME.png into the output folder (default
studies/output/, gitignored), and NAME.pdf with ``--pdf`` (as
convexity_comparison.py does); ``--gallery`` also copies the PNG into
studies/gallery/ (committed, shown in the README).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
DEFAULT_OUT = HERE / "output"
GALLERY = HERE / "gallery"


def parser(doc: str) -> argparse.ArgumentParser:
    """The options every study takes; ``doc`` is the script's docstring."""
    p = argparse.ArgumentParser(description=doc.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    size = p.add_mutually_exclusive_group()
    size.add_argument("--full", action="store_true", help="publication-scale grids")
    size.add_argument("--smoke", action="store_true",
                      help="tiny grids: checks that the study runs (tests)")
    p.add_argument("--out", type=Path, default=DEFAULT_OUT,
                   help="output folder (default: studies/output; created if missing)")
    p.add_argument("--pdf", action="store_true", help="also write the figure as PDF")
    p.add_argument("--gallery", action="store_true",
                   help="also copy the PNG into studies/gallery/ (the README's figures)")
    return p


def scale(args, smoke, default, full):
    """The grid size of the chosen mode."""
    return smoke if args.smoke else full if args.full else default


def even(start: float, stop: float, intervals: int):
    """``intervals + 1`` evenly spaced values, rounded to 12 decimals so that
    round values (0, 0.2, ...) are exact grid values that ``sel`` finds."""
    import numpy as np

    return np.round(np.linspace(start, stop, intervals + 1), 12)


def fail(study: str, message: str) -> None:
    sys.exit(f"{study}: FAILED: {message}")


def note_history(ds, study: str, what: str) -> None:
    """Record in the dataset which script made it and what it added."""
    from rampwork.schema import utc_timestamp

    ds.attrs["study"] = f"studies/{study}.py"
    ds.attrs["history"] = f"{ds.attrs.get('history', '')}\n{utc_timestamp()}: studies/{study}.py: {what}"


def finish(study: str, ds, fig, args, started: float) -> list[Path]:
    """Write the dataset and the figure (PNG; PDF too with --pdf), print
    where and how long it took."""
    import rampwork as rw
    from rampwork.plotting import save

    args.out.mkdir(parents=True, exist_ok=True)
    written = [rw.write_netcdf(ds, args.out / f"{study}.nc", overwrite=True)]
    written += save(fig, args.out, study, pdf=args.pdf, gallery=GALLERY if args.gallery else None)
    for path in written:
        print(f"  wrote {path}")
    print(f"  total {time.perf_counter() - started:.1f} s")
    return written


def simulate_grid(scene, derived=None, **axes):
    """Run ``scene`` over the outer product of ``axes`` (name -> values) with
    dims in that order, where ``derived(columns)`` may add ramp parameters that
    depend on the swept ones (e.g. the slope that keeps a parabola through
    both end points).  A grid Sweep cannot express those, so this runs the
    points as cases and unstacks them; derived columns are dropped."""
    import numpy as np
    import rampwork as rw

    names = list(axes)
    mesh = np.meshgrid(*(np.asarray(axes[n], dtype=float) for n in names), indexing="ij")
    columns = {n: m.ravel() for n, m in zip(names, mesh)}
    extra = derived(columns) if derived else {}
    ds = rw.simulate(scene, rw.Sweep.cases(**columns, **extra))
    ds = ds.drop_vars(["case", *extra]).set_index(case=names).unstack("case")
    return ds.reindex({n: np.asarray(axes[n], dtype=float) for n in names}).transpose(*names, ...)
