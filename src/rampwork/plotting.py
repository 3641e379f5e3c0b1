"""Figures: one house style for the studies and the ``rampwork plot`` command.

matplotlib is imported here and nowhere else in the package, with the
non-interactive Agg backend.  Conventions: every axis label says what and in
which units (from the dataset's CF ``long_name``/``units``), colour maps stay
readable in greyscale (viridis, cividis), series differ by marker and line
style as well as colour, and constrained layout keeps text inside the figure.
"""

from __future__ import annotations

import shutil
from functools import cache
from pathlib import Path

import numpy as np

from .core.status import STATUS_TABLE
from .errors import ConfigError

__all__ = ["STYLE", "new_figure", "pretty_units", "label", "series", "heatmap", "category_map",
           "status_map",
           "status_bars", "save", "plot_dataset", "KINDS", "add_plot_command", "cmd_plot"]

STYLE = {
    "font.size": 10, "axes.titlesize": 11, "axes.labelsize": 10, "legend.fontsize": 9,
    "xtick.labelsize": 9, "ytick.labelsize": 9, "axes.grid": True, "grid.alpha": 0.3,
    "legend.frameon": False, "savefig.dpi": 130, "pdf.fonttype": 42,
}
SEQUENTIAL = "cividis"
#: markers and line styles that keep series apart in greyscale
MARKERS = "os^vDP<>X"
LINESTYLES = ("-", "--", "-.", ":", (0, (5, 1, 1, 1)), (0, (1, 1)))
#: (grey level, hatch) of each status: categories stay distinct without colour
STATUS_LOOK = {"not_run": ("1.0", ""), "stuck": ("0.25", ""), "exited": ("0.85", ""),
               "lifted_off": ("0.55", "//"), "timeout": ("0.7", "xx"), "diverged": ("0.0", "..")}
_UNITS = {"1": "", "m s-1": "m/s", "m s-2": "m/s²", "m-1": "1/m", "s-1": "1/s"}


@cache
def pyplot():
    """matplotlib.pyplot with the Agg backend, imported on first use (it takes
    seconds, and the command line builds its parser for every command)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _patch(**kwargs):
    from matplotlib.patches import Patch

    return Patch(**kwargs)


def new_figure(nrows: int = 1, ncols: int = 1, *, size=None, **kwargs):
    """A figure with constrained layout (no clipped text) in the house style."""
    plt = pyplot()
    plt.rcParams.update(STYLE)
    size = size or (4.6 * ncols + 0.4, 3.7 * nrows + 0.5)
    return plt.subplots(nrows, ncols, figsize=size, layout="constrained", squeeze=False, **kwargs)


def pretty_units(units: str) -> str:
    """UDUNITS spelling to what a reader expects on an axis ("m s-1" -> "m/s")."""
    return _UNITS.get(units, units)


#: axis labels of the common variables, shorter than their long_name
SHORT_NAMES = {"W_friction": "work against friction $W_f$",
               "W_excess": r"excess work $W_f - \mu m g\,|\Delta x|$",
               "W_linear": r"straight-ramp work $\mu m g\,|\Delta x|$",
               "convexity_mean": "convexity: mean $f''$ along the path",
               "v_end": "horizontal velocity at the end", "x_end": "position at the end x",
               "mu": r"friction coefficient $\mu$", "mu_k": r"kinetic friction $\mu_k$",
               "mu_s": r"static friction $\mu_s$", "v0": "start velocity v0",
               "x0": "start position x0"}


def label(variable, name: str | None = None) -> str:
    """"long name (units)" of a dataset variable (shorter for the common
    ones, SHORT_NAMES); dimensionless: no brackets."""
    attrs = getattr(variable, "attrs", {})
    name = name or str(getattr(variable, "name", ""))
    text = SHORT_NAMES.get(name) or attrs.get("long_name") or name
    units = pretty_units(str(attrs.get("units", "")))
    return f"{text} ({units})" if units else text


def series(k: int, n: int) -> dict:
    """Line keywords of series k of n: viridis colour, marker and line style."""
    colour = pyplot().get_cmap("viridis")(0.85 * k / max(1, n - 1))
    return dict(color=colour, marker=MARKERS[k % len(MARKERS)],
                linestyle=LINESTYLES[k % len(LINESTYLES)], markersize=4.5, linewidth=1.4)


def heatmap(ax, values, x, y, *, colorbar_label: str, cmap: str = SEQUENTIAL, zero: bool = False,
            levels: int = 6, mask_label: str | None = None):
    """values[y, x] as a cell map with a colour bar and labelled contour lines.

    ``zero``: draw the 0 contour bold (where the sign changes).  NaN cells are
    left light grey; ``mask_label`` names them in a legend.
    """
    values = np.ma.masked_invalid(np.asarray(values, dtype=float))
    colours = pyplot().get_cmap(cmap).with_extremes(bad="0.93")
    mesh = ax.pcolormesh(x, y, values, cmap=colours, shading="nearest")
    bar = ax.figure.colorbar(mesh, ax=ax, label=colorbar_label)
    ax.grid(False)
    finite = values.compressed()
    if finite.size and np.ptp(finite) > 0 and len(x) > 2 and len(y) > 2:
        lines = ax.contour(x, y, values, levels=levels, colors="k", linewidths=0.6, alpha=0.6)
        ax.clabel(lines, fontsize=7, fmt="%.3g")
        if zero and finite.min() < 0 < finite.max():
            ax.contour(x, y, values, levels=[0.0], colors="w", linewidths=2.4)
            ax.contour(x, y, values, levels=[0.0], colors="k", linewidths=1.2, linestyles="--")
            bar.ax.axhline(0.0, color="k", lw=1.2, ls="--")
    if mask_label and np.ma.count_masked(values):
        ax.legend(handles=[_patch(facecolor="0.93", edgecolor="0.5", label=mask_label)],
                  loc="upper right", frameon=True, framealpha=0.9)
    return mesh


def _status_names(status) -> list[str]:
    codes = {int(c) for c in np.unique(np.asarray(status))}
    return [name for code, name, _ in STATUS_TABLE if code in codes]


def category_map(ax, codes, x, y, looks, title: str | None = None):
    """Integer categories codes[y, x] as grey levels and hatches, with a legend
    beside the axes; ``looks`` maps code -> (label, grey, hatch)."""
    from matplotlib.colors import ListedColormap

    codes = np.asarray(codes)
    ax.grid(False)
    handles = []
    for code in sorted(int(c) for c in np.unique(codes[np.isfinite(codes)])):
        text, grey, hatch = looks.get(code, (f"code {code}", "0.5", ""))
        cells = np.ma.masked_where(codes != code, np.ones(codes.shape))
        ink = "1.0" if float(grey) < 0.45 else "0.2"  # hatch colour: visible on the grey
        ax.pcolor(_edges(x), _edges(y), cells, cmap=ListedColormap([grey]),
                  hatch=hatch, edgecolor=ink, linewidth=0, antialiased=False)
        handles.append(_patch(facecolor=grey, edgecolor=ink, hatch=hatch, label=text))
    return ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False,
                     title=title)


def status_map(ax, status, x, y):
    """End status[y, x] as grey levels and hatches, with a legend."""
    looks = {code: (name, *STATUS_LOOK.get(name, ("0.5", ""))) for code, name, _ in STATUS_TABLE}
    category_map(ax, status, x, y, looks, title="end status")


def _edges(centres) -> np.ndarray:
    """Cell edges around (possibly uneven) cell centres."""
    c = np.asarray(centres, dtype=float)
    if c.size == 1:
        return np.array([c[0] - 0.5, c[0] + 0.5])
    middle = (c[1:] + c[:-1]) / 2
    return np.concatenate([[2 * c[0] - middle[0]], middle, [2 * c[-1] - middle[-1]]])


def status_bars(ax, status):
    """How many trajectories ended in each status, as labelled bars."""
    status = np.asarray(status).ravel()
    status = status[np.isfinite(status)]
    names = _status_names(status)
    codes = {name: code for code, name, _ in STATUS_TABLE}
    counts = [int((status == codes[name]).sum()) for name in names]
    for k, (name, count) in enumerate(zip(names, counts)):
        grey, hatch = STATUS_LOOK.get(name, ("0.5", ""))
        ax.barh(k, count, color=grey, hatch=hatch, edgecolor="0.2")
        ax.annotate(f"{count:,} ({100 * count / status.size:.0f} %)", (count, k),
                    xytext=(3, 0), textcoords="offset points", va="center")
    ax.set_yticks(range(len(names)), names)
    ax.set_xlim(0, max(counts, default=1) * 1.35)
    ax.set_xlabel("trajectories")
    ax.set_title("end status")
    ax.grid(axis="y", visible=False)


def save(fig, directory: Path, stem: str, *, pdf: bool = True, gallery: Path | None = None
         ) -> list[Path]:
    """Write ``stem``.png (and .pdf) into ``directory``; copy the PNG into
    ``gallery`` when given.  Returns the paths written."""
    directory = Path(directory)
    written = [directory / f"{stem}.png"]
    fig.savefig(written[0])
    if pdf:
        written.append(directory / f"{stem}.pdf")
        fig.savefig(written[-1])
    pyplot().close(fig)
    if gallery is not None:
        written.append(Path(shutil.copyfile(written[0], Path(gallery) / written[0].name)))
    return written


# ----------------------------------------------------------------------------
# rampwork plot: the common figures of any result file
# ----------------------------------------------------------------------------

KINDS = ("auto", "lines", "map", "status", "convexity", "traces")
#: what a line or map shows, in order of preference
_QUANTITIES = ("W_friction", "W_excess", "v_end", "x_end")


def _sweep_dims(ds) -> list[str]:
    return [str(d) for d in ds["status"].dims] if "status" in ds else []


def _axis_dims(ds) -> list[str]:
    """Sweep dimensions that can be an axis: a numeric coordinate, more than one value."""
    return [d for d in _sweep_dims(ds) if d != "case" and d in ds.coords
            and ds[d].dtype.kind in "iuf" and ds.sizes[d] > 1]


def _title(ds) -> str:
    return str(ds.attrs.get("title", "rampwork result"))


def _value(item) -> str:
    value = item.item()
    return f"{value:.4g}" if isinstance(value, float) else str(value)


def _reduce_to(da, keep: list[str]):
    """Other sweep dims at their middle value; returns the data and a note."""
    picks = {d: da.sizes[d] // 2 for d in da.dims if d not in keep}
    note = ", ".join(f"{d} = {_value(da[d][i])}" if d in da.coords else f"{d} #{i}"
                     for d, i in picks.items())
    return da.isel(picks), note


def _lines(ds, fig_axes):
    dims = _axis_dims(ds)
    x, other = dims[0], dims[1:2]
    axes = fig_axes.ravel()
    for ax, name in zip(axes, _QUANTITIES):
        da, note = _reduce_to(ds[name], [x, *other])
        groups = [None] if not other else list(range(da.sizes[other[0]]))
        picks = groups if len(groups) <= 6 else np.unique(np.linspace(0, len(groups) - 1, 6).round().astype(int))
        for k, g in enumerate(picks):
            line = da if g is None else da.isel({other[0]: g})
            text = None if g is None else f"{other[0]} = {_value(ds[other[0]][g])}"
            ax.plot(ds[x].values, line.values, label=text, markevery=max(1, da.sizes[x] // 12),
                    **series(k, len(picks)))
        ax.set_xlabel(label(ds[x], x))
        ax.set_ylabel(label(ds[name], name))
        if note:
            ax.set_title(f"at {note}", fontsize=9)
        if other:
            ax.legend()


def _maps(ds, fig_axes):
    dims = _axis_dims(ds)
    x, y = dims[1], dims[0]
    axes = fig_axes.ravel()
    for ax, name in zip(axes[:3], ("W_friction", "W_excess", "v_end")):
        da, note = _reduce_to(ds[name], [y, x])
        heatmap(ax, da.transpose(y, x).values, ds[x].values, ds[y].values,
                colorbar_label=label(ds[name], name), zero=(name == "W_excess"))
        ax.set_xlabel(label(ds[x], x))
        ax.set_ylabel(label(ds[y], y))
        ax.set_title(name + (f" at {note}" if note else ""), fontsize=9)
    status, note = _reduce_to(ds["status"], [y, x])
    status_map(axes[3], status.transpose(y, x).values, ds[x].values, ds[y].values)
    axes[3].set_xlabel(label(ds[x], x))
    axes[3].set_ylabel(label(ds[y], y))
    if note:
        axes[3].set_title(f"at {note}", fontsize=9)


def _convexity(ds, ax):
    """Excess work against mean convexity, one point per trajectory, shaded by
    the friction coefficient (or else the first numeric sweep coordinate)."""
    shape_dims = ds["W_excess"].dims
    numeric = [str(c) for c in ds.coords if str(c) != "case" and ds[c].dims
               and set(ds[c].dims) <= set(shape_dims) and ds[c].dtype.kind in "iuf"]
    colour_by = next((c for c in ("mu", "mu_k") if c in numeric), numeric[0] if numeric else None)
    shade = ds[colour_by].broadcast_like(ds["W_excess"]).values.ravel() if colour_by else None
    points = ax.scatter(ds["convexity_mean"].values.ravel(), ds["W_excess"].values.ravel(),
                        c=shade, cmap="viridis", s=10, marker="o", edgecolors="none")
    if colour_by:
        ax.figure.colorbar(points, ax=ax, label=label(ds[colour_by], colour_by))
    ax.axhline(0, color="0.4", lw=0.8)
    ax.axvline(0, color="0.4", lw=0.8)
    ax.set_xlabel(label(ds["convexity_mean"], "convexity_mean"))
    ax.set_ylabel(label(ds["W_excess"], "W_excess"))
    ax.set_title("excess work against convexity")


def _traces(ds, ax_x, ax_v):
    n = ds.sizes["traced"]
    for k in range(n):
        t, x, v = (ds[name].isel(traced=k).values for name in ("trace_t", "trace_x", "trace_v"))
        keep = np.isfinite(t)
        look = series(k, n) | {"marker": None}
        ax_x.plot(t[keep], x[keep], **look, label=f"trajectory {int(ds['traced_index'][k])}")
        ax_v.plot(x[keep], v[keep], **look)
    ax_x.set_xlabel(label(ds["trace_t"]))
    ax_x.set_ylabel(label(ds["trace_x"]))
    ax_x.set_title("recorded trajectories")
    if n <= 8:
        ax_x.legend()
    ax_v.set_xlabel(label(ds["trace_x"]))
    ax_v.set_ylabel(label(ds["trace_v"]))
    ax_v.set_title("phase portrait")


def _pick_kind(ds) -> str:
    grid = _axis_dims(ds)
    if len(grid) >= 2:
        return "map"
    if len(grid) == 1:
        return "lines"
    if _sweep_dims(ds):
        return "convexity"
    return "traces" if "trace_t" in ds else "status"


def plot_dataset(ds, kind: str = "auto", where: str = "dataset"):
    """The figure of ``kind`` (see KINDS) for a rampwork dataset; ``auto`` picks
    from its dimensions.  Raises ConfigError naming ``where`` if the dataset
    cannot show that kind."""
    if kind not in KINDS:
        raise ConfigError("--kind", f"{kind!r} is not one of {', '.join(KINDS)}")
    if "status" not in ds:
        raise ConfigError(where, "has no status variable: not a rampwork result file")
    dims = _sweep_dims(ds)
    kind = _pick_kind(ds) if kind == "auto" else kind
    grid = _axis_dims(ds)
    needs = {"lines": (len(grid) >= 1, "needs a numeric sweep dimension (not case)"),
             "map": (len(grid) >= 2, "needs two numeric sweep dimensions (not case)"),
             "convexity": (bool(dims), "needs a sweep (one trajectory has one point)"),
             "traces": ("trace_t" in ds, "has no recorded trajectories (scene [record])")}
    ok, why = needs.get(kind, (True, ""))
    if not ok:
        raise ConfigError("--kind", f"{kind!r}: {where} {why}; its dimensions: "
                          f"{', '.join(dims) or 'none'}")
    if kind == "lines":
        fig, axes = new_figure(2, 3)
        _lines(ds, axes[:, :2].T)
        _convexity(ds, axes[0, 2])
        status_bars(axes[1, 2], ds["status"])
    elif kind == "map":
        fig, axes = new_figure(2, 3, size=(15.5, 7.6))
        _maps(ds, axes[:, :2].T)
        _convexity(ds, axes[0, 2])
        status_bars(axes[1, 2], ds["status"])
    elif kind == "convexity":
        fig, axes = new_figure(1, 2)
        _convexity(ds, axes[0, 0])
        status_bars(axes[0, 1], ds["status"])
    elif kind == "traces":
        fig, axes = new_figure(1, 2)
        _traces(ds, axes[0, 0], axes[0, 1])
    else:
        fig, axes = new_figure(1, 1)
        status_bars(axes[0, 0], ds["status"])
    fig.suptitle(_title(ds))
    return fig


def add_plot_command(subparsers) -> None:
    """Add ``rampwork plot`` to the command line's subparsers."""
    plot = subparsers.add_parser(
        "plot", help="draw the common figures of a rampwork netCDF file or Zarr store",
        description="Draw the common figures of DATASET (a file written by `rampwork run` or a "
                    "study): line plots for a 1-D sweep, maps for 2-D (other dimensions at their "
                    "middle value), excess work against convexity, end-status counts, recorded "
                    "trajectories.  --kind auto picks from the dataset's dimensions.")
    plot.add_argument("dataset", metavar="DATASET.nc", help="rampwork result file")
    plot.add_argument("-o", "--output", metavar="FIG.png", default=None,
                      help="figure to write: .png, .pdf or .svg (default: DATASET.png beside it)")
    plot.add_argument("--kind", choices=KINDS, default="auto",
                      help="which figure (default auto: lines for 1-D, map for 2-D or more, "
                           "convexity for cases, traces for a single recorded trajectory)")
    plot.add_argument("--overwrite", action="store_true", help="replace FIG if it exists")
    plot.set_defaults(handler=cmd_plot)


def cmd_plot(args) -> int:
    from . import io

    output = Path(args.output) if args.output else Path(args.dataset).with_suffix(".png")
    if output.suffix.lower() not in (".png", ".pdf", ".svg"):
        raise ConfigError(str(output), f"figure format {output.suffix or '(none)'!r} not "
                          "supported; use .png, .pdf or .svg")
    io.check_writable(output, args.overwrite)
    dataset = io.open_dataset(args.dataset)
    fig = plot_dataset(dataset, args.kind, where=args.dataset)
    fig.savefig(output)
    pyplot().close(fig)
    print(f"wrote {output}")
    return 0
