"""``hertzian plot STORE`` on any store: the built-in example (shortened) and a sweep-like store with an axis."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr
from hertzian.plotting.figures import PlotError, select_point
from hertzian.studies.analysis import energy_drift

from tests.helpers import invoke


@pytest.fixture(scope="module")
def impact_store(tmp_path_factory):
    """The built-in example, 100 grains for 1 time unit (records every 0.25, grain 0 traced)."""
    out = tmp_path_factory.mktemp("plot") / "impact.zarr"
    result = invoke(
        "run",
        "--device",
        "cpu",
        "--quiet",
        "--set",
        "chain.grains=100",
        "--set",
        "integrator.duration=1.0",
        "--set",
        "record.every=0.25",
        "--out",
        str(out),
    )
    assert result.exit_code == 0, result.output
    return out


def test_plot_any_store_writes_a_png(impact_store, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    result = invoke("plot", str(impact_store))
    assert result.exit_code == 0, result.output
    png = tmp_path / "impact.png"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 10_000
    result = invoke("plot", str(impact_store), "--field", "u", "--out", str(tmp_path / "u.png"))
    assert result.exit_code == 0, result.output


@pytest.mark.parametrize(
    "args,message",
    [
        (["--field", "w"], "--field = 'w': u or v"),
        (["--at", "v_imp"], "--at = 'v_imp': must be written axis=value"),
        (["--at", "v_imp=0.1"], "no sweep axis v_imp"),
        (["--at", "v_imp=nan"], "--at = 'v_imp=nan': the value must be a finite number"),
        (["--figure", "fig42"], "--figure = 'fig42'"),
        (["--out", "x.svg"], "must end in .png"),
    ],
)
def test_plot_bad_input_is_one_line_exit_2(impact_store, tmp_path, monkeypatch, args, message):
    monkeypatch.chdir(tmp_path)
    result = invoke("plot", str(impact_store), *args)
    assert result.exit_code == 2
    assert message in result.output and "Traceback" not in result.output
    assert not list(tmp_path.glob("*.png")) and not list(tmp_path.glob("*.svg"))


def test_select_point_takes_a_named_value_on_an_axis_of_names():
    """An axis of names (a sweep over chain.potential or a material): --at law=toda picks that point; a name not on
    the axis, or a word on a number axis, is refused naming the axis' values; the picture's title names the point."""
    from hertzian.plotting.figures import point_label

    ds = xr.Dataset(
        {
            "status": (("law", "v_imp"), np.zeros((3, 2), dtype=np.int32)),
            "u": (("law", "v_imp", "record"), np.arange(12, dtype=float).reshape(3, 2, 2)),
        },
        coords={"law": ["hertz", "harmonic", "toda"], "v_imp": [0.1, 0.2]},
    )
    point = select_point(ds, {"law": "toda", "v_imp": 0.2})
    assert str(point.law.values) == "toda" and float(point.v_imp) == 0.2
    np.testing.assert_array_equal(point.u.values, [10.0, 11.0])
    assert point_label(ds, point) == "law = toda, v_imp = 0.2"
    with pytest.raises(PlotError, match=r"law=lj: not on the axis \(hertz, harmonic, toda\)"):
        select_point(ds, {"law": "lj"})
    with pytest.raises(PlotError, match=r"v_imp=fast: v_imp is a number axis \(0.1, 0.2\)"):
        select_point(ds, {"v_imp": "fast"})


def test_select_point_takes_the_nearest_coordinate():
    ds = xr.Dataset(
        {
            "status": (("v_imp",), np.zeros(3, dtype=np.int32)),
            "u": (("v_imp", "record", "grain"), np.arange(3 * 2 * 4, dtype=float).reshape(3, 2, 4)),
        },
        coords={"v_imp": [0.01, 0.02, 0.04]},
    )
    assert float(select_point(ds, {"v_imp": 0.021}).v_imp) == 0.02
    assert float(select_point(ds).v_imp) == 0.01
    with pytest.raises(PlotError, match="no sweep axis l0"):
        select_point(ds, {"l0": 1e-4})


def test_energy_drift_uses_the_injected_energy_or_the_work():
    energy = np.array([2.0, 2.0 + 1e-6, 2.0 - 2e-6])
    drift, scale = energy_drift(energy)
    np.testing.assert_allclose(drift, [0.0, 0.5e-6, -1e-6], rtol=1e-9, atol=1e-18)
    assert scale == "E_inj"
    work = np.array([0.0, 4.0, -8.0])
    drift, scale = energy_drift(np.array([0.0, 4.0, -7.0]), work)
    np.testing.assert_allclose(drift, [0.0, 0.0, 1.0 / 8.0])
    assert scale == "max |W|"


def captured_figures(monkeypatch):
    """The figures the drawing functions finish, kept open for the test to read."""
    import hertzian.plotting.figures as figures

    kept = []
    monkeypatch.setattr(figures, "_finish", lambda fig, out: kept.append(fig) or out)
    return kept


def test_the_depth_time_picture_shows_the_grains_that_moved(impact_store, monkeypatch):
    from hertzian.plotting.figures import plot_store

    kept = captured_figures(monkeypatch)
    with xr.open_zarr(impact_store) as ds:
        plot_store(ds, "unused.png", field="v")
        v = np.abs(ds.v.values)
    picture = kept[0].axes[0]
    peak = v.max(axis=0)
    deepest = int(np.flatnonzero(peak >= 1e-3 * v.max())[-1]) + 1  # grains 0 … deepest-1 reach 0.1 % of the peak
    low, high = picture.get_xlim()
    assert deepest < 100 and deepest - 0.5 < high <= deepest + max(10, deepest // 10) - 0.5 + 1e-9
    assert f"grains {round(high + 0.5)}–99" in picture.get_xlabel() and "not shown" in picture.get_xlabel()


def test_the_built_in_example_records_enough_snapshots_for_a_picture():
    import hertzian as hz

    scene = hz.load_scene("impact")
    spacing = scene.record.every * 17  # the pulse moves about 17 grains per time unit at v_imp = 1e-2, l0 = 1e-4
    assert scene.record_count >= 100 and spacing <= 2


DRIVE_MAP = """
[scene.chain]
grains = 10
l0 = 1e-3
[scene.boundary]
surface = "driven"
bottom = "fixed"
[scene.excitation]
drive_amplitude = 1e-4
drive_period = 0.5
[scene.integrator]
dt = 1e-3
duration = 2.0
[scene.record]
every = 0.5
fields = ["v"]
traces = [2, 5]
trace_every = 0.05
response_start = 0.5
response_periods = 1
response_windows = 2
harmonics = 2
[[axis]]
name = "tau"
key = "excitation.drive_period"
values = [0.25, 0.5]
[[axis]]
name = "A"
key = "excitation.drive_amplitude"
values = [1e-4, 3e-3]
"""


def test_the_drive_map_names_its_panels_for_what_they_show(tmp_path, monkeypatch):
    from hertzian.plotting.figures import drive_map
    from hertzian.studies.analysis import LABELS

    sweep = tmp_path / "map.toml"
    sweep.write_text(DRIVE_MAP)
    out = tmp_path / "map.zarr"
    assert invoke("sweep", sweep, "--out", out, "--device", "cpu", "--quiet").exit_code == 0
    kept = captured_figures(monkeypatch)
    with xr.open_zarr(out) as ds:
        drive_map(ds, tmp_path / "map.png")
    titles = [ax.get_title() for ax in kept[0].axes]
    assert not any("standing-wave ratio" in t for t in titles) and "not a standing-wave test" in titles[0]
    label_panel = next(ax for ax in kept[0].axes if ax.get_title().startswith("stroboscopic label"))
    assert all(len(text.get_text()) <= 2 for text in label_panel.texts)  # P, QP, C or ?: fits a cell
    assert {text.get_text() for text in label_panel.texts} <= {"P", "QP", "C", "?"} and len(LABELS) == 4
    assert len(kept[0].axes) == 8 + 7  # eight panels, a colour scale on each but the label's


def test_the_distribution_has_a_panel_per_spread_with_units(tmp_path, monkeypatch):
    import matplotlib.pyplot as plt
    from hertzian.studies import realisations

    sweep = tmp_path / "disorder.toml"
    sweep.write_text(
        "[scene.chain]\ngrains = 12\nradii = { spread = 0.0, seed = 0 }\n[scene.excitation]\nimpact = 0.1\n"
        "[scene.integrator]\ndt = 5e-5\nduration = 0.6\n[scene.record]\nevery = 0.02\nfields = ['v']\n"
        "[[axis]]\nname = 'spread'\nkey = 'chain.radii.spread'\nvalues = [0.0, 0.2]\n"
        "[[axis]]\nname = 'seed'\nkey = 'chain.radii.seed'\nvalues = [0, 1, 2, 3]\n"
    )
    out = tmp_path / "disorder.zarr"
    assert invoke("sweep", sweep, "--out", out, "--device", "cpu", "--quiet").exit_code == 0
    kept = []
    monkeypatch.setattr(plt.Figure, "savefig", lambda fig, *a, **k: kept.append(fig))
    monkeypatch.setattr(plt, "close", lambda fig=None: None)
    with xr.open_zarr(out) as ds:
        realisations.plot_distribution(ds, "bottom_fraction", tmp_path / "d.png")
    axes = kept[0].axes
    assert [ax.get_title().split(":")[0] for ax in axes] == ["spread = 0", "spread = 0.2"]
    assert all("4 realisations" in ax.get_title() for ax in axes)
    assert axes[-1].get_xlabel() == "bottom_fraction [of the injected energy]"
