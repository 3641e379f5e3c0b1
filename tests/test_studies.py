"""The study scripts (studies/*.py) in their --smoke mode, and `rampwork plot`.

Each study runs once per session in-process on tiny grids (the kernels are
the studies' own few variants, cached on disk by numba) and must write a
readable rampwork netCDF file, a PNG and, with --pdf, a PDF.  The physics assertions use
closed forms (the paper's eq. 1 on the chord, sqrt(2 g (H - mu L))), the
ordering claim of the paper, the first-order perturbation formula for a wave
on the chord (its error must shrink as a^2), the analytic disagreement region
of the two lift-off criteria, scipy reference trajectories, and the Ishigami
function's analytic Sobol' indices.
"""

from __future__ import annotations

import importlib
import re
import sys
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

import rampwork as rw
from rampwork.cli import main

STUDIES_DIR = Path(__file__).resolve().parents[1] / "studies"
STUDIES = ("exam_question", "excess_work_map", "sign_changing_convexity", "phase_portraits",
           "liftoff_map", "sensitivity_excess_work", "loop_the_loop",
           "descent_two_points", "least_most_work", "frictional_brachistochrone")
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def study_module(name: str):
    if str(STUDIES_DIR) not in sys.path:
        sys.path.insert(0, str(STUDIES_DIR))
    return importlib.import_module(name)


@pytest.fixture(scope="module")
def outputs(tmp_path_factory):
    """Every study run once with --smoke; name -> (module, output folder)."""
    runs = {}
    for name in STUDIES:
        folder = tmp_path_factory.mktemp(name)
        module = study_module(name)
        assert module.main(["--smoke", "--out", str(folder), "--pdf"]) == 0
        runs[name] = (module, folder)
    return runs


def dataset(outputs, name):
    return rw.open_dataset(outputs[name][1] / f"{name}.nc")


@pytest.mark.parametrize("name", STUDIES)
def test_study_writes_dataset_png_and_pdf(outputs, name):
    folder = outputs[name][1]
    ds = rw.open_dataset(folder / f"{name}.nc")  # refuses a file that is not a rampwork dataset
    assert ds.attrs["study"] == f"studies/{name}.py"
    assert f"studies/{name}.py" in ds.attrs["history"]
    assert ds["status"].size > 0 and not (ds["status"] == 5).any()  # nothing diverged
    png = (folder / f"{name}.png").read_bytes()
    assert png.startswith(PNG_MAGIC) and len(png) > 20_000
    assert (folder / f"{name}.pdf").read_bytes().startswith(b"%PDF")


def test_gallery_option_copies_the_png(outputs, tmp_path, monkeypatch):
    import _study
    from rampwork.plotting import new_figure

    monkeypatch.setattr(_study, "GALLERY", tmp_path)
    args = _study.parser("A study.").parse_args(["--out", str(tmp_path / "out"), "--gallery"])
    fig, axes = new_figure()
    axes[0, 0].plot([0, 1], [0, 1])
    _study.finish("tiny", dataset(outputs, "phase_portraits"), fig, args, 0.0)
    assert (tmp_path / "tiny.png").read_bytes() == (tmp_path / "out" / "tiny.png").read_bytes()
    assert rw.open_dataset(tmp_path / "out" / "tiny.nc").sizes == \
        dataset(outputs, "phase_portraits").sizes


def test_a_pdf_only_with_the_pdf_option(tmp_path):
    """Every study writes NAME.nc and NAME.png, and NAME.pdf only with --pdf,
    as each one's docstring says (convexity_comparison.py included)."""
    from rampwork.plotting import new_figure

    _study = study_module("_study")

    for options, pdf in (([], False), (["--pdf"], True)):
        args = _study.parser("A study.").parse_args(["--out", str(tmp_path / str(pdf))] + options)
        fig, axes = new_figure()
        axes[0, 0].plot([0, 1], [0, 1])
        _study.finish("tiny", xr.Dataset(), fig, args, 0.0)
        assert (tmp_path / str(pdf) / "tiny.png").exists()
        assert (tmp_path / str(pdf) / "tiny.pdf").exists() == pdf
    for path in STUDIES_DIR.glob("*.py"):
        doc = study_module(path.stem).__doc__
        assert re.search(r"\.pdf[^.]* with (``)?--pdf", " ".join(doc.split())), path.name


def test_least_most_work_bounds_and_reference(outputs):
    ds = dataset(outputs, "least_most_work")
    w_chord = 0.2 * 9.81 * 2.0
    assert ds.attrs["W_chord"] == pytest.approx(w_chord, rel=1e-7)  # mu m g L
    w = ds["W_friction"].values
    assert np.allclose(w, ds["W_friction_reference"].values, rtol=1e-6, atol=1e-9)
    least, most, free_least, free_most = w
    assert least < w_chord < most <= 9.81 * (1 + 1e-9)  # an arriving block: at most m g H
    assert 0 <= free_least and free_most <= 9.81 * 1.5 * (1 + 1e-9)  # at most m g (H - y_floor)
    assert ds["arrived"].values[:2].all()


def test_exam_question_closed_forms_and_ordering(outputs):
    module = outputs["exam_question"][0]
    ds = dataset(outputs, "exam_question")
    chord = ds.sel(curvature=0.0)
    moving = chord["mu"] < module.H / module.L
    assert bool(chord["reached_B"].where(moving, True).all())
    # paper eq. (1): W_f = mu m g L on the chord, whatever its slope
    w = module.M * module.G * module.L * chord["mu"]
    np.testing.assert_allclose(chord["W_friction"].where(moving, 0), w.where(moving, 0),
                               rtol=0, atol=1e-9)
    # energy balance on the chord: speed at B = sqrt(2 g (H - mu L))
    speed = np.sqrt(2 * module.G * (module.H - chord["mu"] * module.L))
    np.testing.assert_allclose(chord["speed_end"].where(moving, 0), speed.where(moving, 0),
                               rtol=0, atol=1e-9)
    # the paper's claim, for blocks from rest that reach B: convex > straight > concave
    both = ds["reached_B"].all("curvature") & (ds["mu"] > 0)
    assert int(both.sum()) >= 3
    convex, straight, concave = (ds["W_friction"].sel(curvature=c).where(both, drop=True)
                                 for _, c in module.RAMPS)
    assert bool((convex > straight).all()) and bool((straight > concave).all())
    # and the concave ramp delivers the block fastest
    v = [ds["speed_end"].sel(curvature=c).where(both, drop=True) for _, c in module.RAMPS]
    assert bool((v[2] > v[1]).all()) and bool((v[1] > v[0]).all())


def test_excess_work_sign_and_reference(outputs, reference):
    module = outputs["excess_work_map"][0]
    ds = dataset(outputs, "excess_work_map")
    assert set(ds["family"].values) == set(module.FAMILIES)
    reached = ds["reached_B"].astype(bool) & (ds["mu"] > 0) & (ds["kappa"] != 0)
    assert int(reached.sum()) > 50
    wrong = reached & (np.sign(ds["W_excess"]) != np.sign(ds["kappa"]))
    assert not bool(wrong.any())
    # the circular arcs through A and B, against scipy's DOP853 on the same geometry
    mu, v0 = 0.1, 0.0
    for kappa in (-0.3, 0.3):
        xc, yc, radius = module.arc_centre(kappa)
        family = "circular_bowl" if kappa > 0 else "circular_dome"
        height = {"y_bottom": yc - radius} if family == "circular_bowl" else {"y_centre": yc}
        ramp = rw.Ramp.create(family, radius=radius, x_centre=xc, **height, domain=(0.0, module.L))
        assert abs(ramp.evaluate([0.0])[0][0]) < 1e-12
        assert abs(ramp.evaluate([module.L])[0][0] + module.H) < 1e-12
        scene = rw.Scene(ramp=ramp, friction=rw.Friction(mu), x0=0.0, v0=v0, m=module.M,
                         g=module.G)
        ref = reference.reference_trajectory(scene)
        cell = ds.sel(family="circular").sel(kappa=kappa, mu=mu, v0=v0, method="nearest")
        assert ref["status"] == int(cell["status"]) == 2  # reaches B
        assert abs(ref["W_friction"] - float(cell["W_friction"])) < 1e-8


def test_sign_changing_first_order_and_equal_cost(outputs):
    module = outputs["sign_changing_convexity"][0]
    ds = dataset(outputs, "sign_changing_convexity")
    assert float(np.abs(ds["convexity_mean"].sel(amplitude=ds["amplitude"] > 0)).max()) < 1e-9
    # the curved ramp costs more at phase 0 (convex late, where the block is fast) and less at pi
    top = ds.sel(amplitude=module.A_MAX, mu=0.2)
    assert float(top["W_excess"].sel(phase=0.0)) > 0 > float(top["W_excess"].sel(phase=np.pi,
                                                                                   method="nearest"))
    # the deviation from the first-order formula is O(a^2): halving a quarters it
    scene = rw.Scene(ramp=rw.Ramp.create("sine", amplitude=0.0, wavenumber=module.K,
                                         mean_slope=-module.SLOPE, domain=(0.0, module.L)),
                     x0=0.0, v0=module.V0, m=module.M, g=module.G)
    amplitudes = np.array([0.02, 0.01, 0.005])
    run = rw.simulate(scene, rw.Sweep.grid(amplitude=amplitudes, phase=[0.0, 1.0], mu=[0.2]))
    deviation = np.abs(run["W_excess"] - module.first_order(run["phase"], run["amplitude"],
                                                           run["mu"])).squeeze("mu")
    ratios = (deviation.isel(amplitude=slice(None, -1)).values
              / deviation.isel(amplitude=slice(1, None)).values)
    assert np.all((ratios > 3.6) & (ratios < 4.4)), ratios
    # phases of equal cost: near pi/2 and 3 pi/2 for a small wave
    small = run["W_excess"].sel(mu=0.2, amplitude=0.005)
    assert abs(module.equal_cost_phases(np.cos(np.linspace(0, 2 * np.pi, 9)),
                                        np.linspace(0, 2 * np.pi, 9))[0] - np.pi / 2) < 1e-12
    assert float(small.sel(phase=0.0)) > 0


def test_phase_portraits_energy_balance_along_the_path(outputs):
    module = outputs["phase_portraits"][0]
    ds = dataset(outputs, "phase_portraits")
    statuses = [int(s) for s in ds["status"].values]
    assert statuses.count(1) == 3 and statuses.count(3) == 1  # three stick, one lifts off
    for k in range(len(module.CASES)):
        t, x, v, w = module.trace(ds, k)
        f, fp, fpp = module.ramp(x)
        energy = module.M * (module.G * f + v**2 * (1 + fp**2) / 2)
        assert np.all(np.diff(t) >= 0) and np.all(np.diff(w) >= -1e-12)
        np.testing.assert_allclose(energy + w, energy[0], rtol=0, atol=1e-6)
        assert int(np.sum(v[1:-1] == 0.0)) == int(ds["n_reversals"][k])
        if statuses[k] == 3:  # the contact force vanishes where it leaves
            assert abs(module.G + v[-1] ** 2 * fpp[-1]) < 1e-6
    assert int(ds["n_reversals"][0]) > int(ds["n_reversals"][1])  # less friction, more swings


def test_liftoff_map_disagreement_is_where_the_paper_predicts(outputs, reference):
    module = outputs["liftoff_map"][0]
    ds = dataset(outputs, "liftoff_map")
    curvature = ds["curvature"].values[:, None]
    v0 = ds["v0"].values[None, :]
    _, fp, fpp = module.dome(module.X0, 1 / curvature)
    predicted = (module.MU * fp > 1) & (module.G + v0**2 * fpp > 0)
    assert predicted.any() and (~predicted).any()
    np.testing.assert_array_equal(ds["outcome"].values == 2, predicted)
    # eq. (26) never fires later than the contact criterion
    both = np.isfinite(ds["x_lift_off"].values)
    assert np.all(np.isfinite(ds["x_lift_off_paper"].values[both]))
    # the engine's end status for one corner cell, against scipy's DOP853
    cell = ds.isel(curvature=-1, v0=0)
    scene = rw.Scene(ramp=rw.Ramp.create("circular_dome", radius=float(cell["radius"]),
                                         domain=(-module.HALF_WIDTH, module.HALF_WIDTH)),
                     friction=rw.Friction(module.MU), x0=module.X0, v0=float(cell["v0"]),
                     t_max=10.0)
    ref = reference.reference_trajectory(scene)
    assert ref["status"] == int(cell["status"])
    assert abs(ref["W_friction"] - float(cell["W_friction"])) < 1e-7


def test_sensitivity_study_checks_ishigami_then_explains_the_bowl(outputs):
    module = outputs["sensitivity_excess_work"][0]
    ds = dataset(outputs, "sensitivity_excess_work")
    # the machinery's check ran first, and passed: estimates near the analytic indices
    for key in ("S1", "ST"):
        error = np.abs(ds[f"ishigami_{key}"] - ds[f"ishigami_{key}_exact"])
        assert bool((error <= ds[f"ishigami_{key}_conf"] + module.ISHIGAMI_SLACK).all())
    np.testing.assert_allclose(ds["ishigami_ST_exact"], [0.5576, 0.4424, 0.2437], atol=5e-5)
    assert ds.attrs["ishigami_check"].startswith("passed")
    # the bowl: every design row ran, inside its range, and every block came to rest
    assert list(ds["parameter"].values) == list(module.RANGES)
    assert ds.attrs["output"] == "W_excess" and ds.attrs["output_units"] == "J"
    assert ds.sizes["case"] == ds.attrs["n_runs"] == 64 * (2 * 4 + 2)
    assert bool((ds["status"] == 1).all())
    for name, (low, high) in module.RANGES.items():
        assert low <= float(ds[name].min()) and float(ds[name].max()) <= high
    # on a bowl the friction work is the energy above the resting point: mu hardly matters
    np.testing.assert_allclose(ds["W_friction"], module.energy_above_rest(ds), rtol=0, atol=1e-8)
    assert float(ds["W_friction_ST"].sel(parameter="mu")) < module.MU_WF_MAX
    assert float(ds["ST"].sel(parameter="mu")) > 0.1  # but it drives the excess, through W_linear
    assert ds["S2"].dims == ("parameter", "parameter2")


def test_sensitivity_study_refuses_when_the_machinery_misses_ishigami(tmp_path, monkeypatch):
    import rampwork.sensitivity as sensitivity

    module = study_module("sensitivity_excess_work")
    right = sensitivity._scale
    # a design drawn on half of each range: the Ishigami indices come out wrong
    monkeypatch.setattr(sensitivity, "_scale",
                        lambda unit, low, high, is_log: right(unit / 2, low, high, is_log))
    monkeypatch.setattr(sensitivity, "simulate", None)  # rampwork must not run
    with pytest.raises(SystemExit) as stop:
        module.main(["--smoke", "--out", str(tmp_path)])
    assert "misses the Ishigami function's analytic indices" in str(stop.value)
    assert not list(tmp_path.iterdir())


# ----------------------------------------------------------------------------
# rampwork plot
# ----------------------------------------------------------------------------


def one_line_error(capsys) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("rampwork: error: "), err
    return err[0]


@pytest.mark.parametrize("name, kind", [("exam_question", "auto"), ("excess_work_map", "map"),
                                        ("phase_portraits", "auto"), ("phase_portraits", "traces"),
                                        ("liftoff_map", "status"),
                                        ("sensitivity_excess_work", "auto")])
def test_plot_writes_a_png(outputs, tmp_path, capsys, name, kind):
    figure = tmp_path / f"{name}-{kind}.png"
    nc = outputs[name][1] / f"{name}.nc"
    assert main(["plot", str(nc), "-o", str(figure), "--kind", kind]) == 0
    assert figure.read_bytes().startswith(PNG_MAGIC)
    assert str(figure) in capsys.readouterr().out


def test_plot_one_dimensional_sweep_default_output(outputs, tmp_path):
    ds = dataset(outputs, "exam_question").sel(curvature=0.0)  # 1-D along mu
    nc = rw.write_netcdf(ds, tmp_path / "chord.nc")
    assert main(["plot", str(nc)]) == 0
    assert (tmp_path / "chord.png").read_bytes().startswith(PNG_MAGIC)
    assert main(["plot", str(nc)]) == 2  # exists: not replaced without --overwrite
    assert main(["plot", str(nc), "--overwrite", "--kind", "convexity"]) == 0


def test_plot_errors_are_one_line(outputs, tmp_path, capsys):
    assert main(["plot", str(tmp_path / "missing.nc")]) == 2
    assert "missing.nc: no such file" in one_line_error(capsys)

    foreign = tmp_path / "foreign.nc"
    xr.Dataset({"a": ("x", np.arange(3.0))}).to_netcdf(foreign)
    assert main(["plot", str(foreign), "-o", str(tmp_path / "f.png")]) == 2
    assert "not a rampwork dataset" in one_line_error(capsys)

    text = tmp_path / "text.nc"
    text.write_text("not netCDF")
    assert main(["plot", str(text), "-o", str(tmp_path / "t.png")]) == 2
    assert "cannot be read as netCDF" in one_line_error(capsys)

    cases = outputs["phase_portraits"][1] / "phase_portraits.nc"
    assert main(["plot", str(cases), "-o", str(tmp_path / "p.png"), "--kind", "map"]) == 2
    assert "needs two numeric sweep dimensions" in one_line_error(capsys)

    assert main(["plot", str(cases), "-o", str(tmp_path / "p.jpg")]) == 2
    assert "use .png, .pdf or .svg" in one_line_error(capsys)
    assert not (tmp_path / "p.png").exists() and not (tmp_path / "p.jpg").exists()


def test_loop_the_loop_threshold_is_sqrt_5gr_without_friction_and_grows_with_mu(outputs):
    ds = dataset(outputs, "loop_the_loop")
    free = np.sqrt(5 * 9.81 * ds["radius"])
    np.testing.assert_allclose(ds["u0_threshold"].sel(mu=0.0), free, rtol=2e-5)
    assert (ds["u0_threshold"].diff("mu") > 0).all()
    # Coulomb friction has no length scale: the ratio to sqrt(5gR) is the same for every R
    ratio = ds["threshold_ratio"]
    np.testing.assert_allclose(ratio, ratio.isel(radius=0).broadcast_like(ratio), rtol=5e-5)


def test_descent_two_points_chord_and_cycloid_closed_forms_and_optimum(outputs):
    ds = dataset(outputs, "descent_two_points")
    g = 9.81
    for i, (bx, by) in enumerate(zip(ds["B_x"].values, ds["B_y"].values)):
        one = ds.isel(end=i)
        length, beta = np.hypot(bx, by), np.arctan2(-by, bx)
        mu = one["mu"].values
        drive = g * (np.sin(beta) - mu * np.cos(beta))
        moving = drive > 0
        np.testing.assert_allclose(one["time"].sel(curve="chord").values[moving],
                                   np.sqrt(2 * length / drive[moving]), rtol=1e-9)
        r, theta = ds.attrs["cycloid_radius_m"][i], ds.attrs["cycloid_end_angle_rad"][i]
        assert one["time"].sel(curve="cycloid", mu=0.0).item() == pytest.approx(
            theta * np.sqrt(r / g), rel=1e-9)
        assert np.isclose(r * (theta - np.sin(theta)), bx) and np.isclose(-r * (1 - np.cos(theta)), by)
        best = one["time"].sel(curve="optimum")
        # the optimum run through the engine (convex_cusp) in the time of its quadrature
        np.testing.assert_allclose(best, one["optimum_time_quadrature"], rtol=1e-9)
        engine = one["time"].sel(curve=["chord", "parabola", "circle", "cycloid"])
        assert not (engine < best * (1 - 1e-6)).any()  # NaN (did not arrive) compares False
        assert engine.notnull().any()


def test_frictional_brachistochrone_optimised_against_the_cycloid_and_the_derived_optimum(outputs):
    from scipy.optimize import brentq

    ds = dataset(outputs, "frictional_brachistochrone")
    g = 9.81
    assert list(ds["curve"].values) == ["chord", "circle", "cycloid", "optimised", "optimum"]
    for i, (bx, by) in enumerate(zip(ds["B_x"].values, ds["B_y"].values)):
        one = ds.isel(end=i)
        # mu = 0: the optimised curve runs in the cycloid's closed-form time theta sqrt(r / g)
        theta = brentq(lambda t: (t - np.sin(t)) * -by - bx * (1 - np.cos(t)), 1e-6, 2 * np.pi - 1e-9)
        cycloid = theta * np.sqrt(-by / (1 - np.cos(theta)) / g)
        assert one["time"].sel(curve="optimised", mu=0.0).item() == pytest.approx(cycloid, rel=1e-6)
        # with friction: close to the derived optimum (smoke: K = 3), never faster than it
        best = one["time"].sel(curve="optimum")
        assert np.abs(one["time"].sel(curve="optimised") / best - 1).max() < 1e-4
        assert not (one["time"].sel(curve=["chord", "circle", "cycloid", "optimised"]) < best * (1 - 1e-9)).any()
        # the chord against sqrt(2 L / (g (sin beta - mu cos beta)))
        length, beta = np.hypot(bx, by), np.arctan2(-by, bx)
        np.testing.assert_allclose(one["time"].sel(curve="chord").values,
                                   np.sqrt(2 * length / (g * (np.sin(beta) - one["mu"].values * np.cos(beta)))),
                                   rtol=1e-9)
        # both drawn curves run from A to B
        for which in ("optimised", "optimum"):
            path = one["path"].sel(which=which)
            assert np.abs(path.isel(point=0).values).max() < 1e-12
            np.testing.assert_allclose(path.isel(point=-1).sel(axis="X"), bx, atol=1e-12)
            np.testing.assert_allclose(path.isel(point=-1).sel(axis="Y"), by, atol=1e-12)
        assert (one["status"].sel(curve="optimised") == 2).all() and one["reached_B"].sel(curve="optimised").all()
