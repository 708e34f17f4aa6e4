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
        (["--at", "v_imp"], "--at = 'v_imp': must be written axis=number"),
        (["--at", "v_imp=0.1"], "no sweep axis v_imp"),
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
