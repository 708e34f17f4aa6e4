"""Command line: bad input gives one clear line and exit code 2, writes nothing; a run writes an
xarray-readable store that summarize reads."""

import json

import numpy as np
import pytest
import xarray as xr

from tests.helpers import hertzian

SCENE = """
[chain]
grains = 20
l0 = 1e-4
[excitation]
impact = 1e-2
[integrator]
dt = 1e-4
duration = 0.05
[record]
every = 0.01
traces = [0, 5]
"""

BAD = [
    ("--set chain.grainz=3", "chain.grainz: unknown key (did you mean 'grains'?)"),
    ("--set chain.grains=-5", "chain.grains = -5"),
    ("--set chain.mass=0", "chain.mass = 0.0: must be > 0"),
    ("--set chain.a=-1", "chain.a = -1.0: must be > 0"),
    ("--set integrator.dt=0", "integrator.dt = 0.0: must be > 0"),
    ("--set integrator.method=gear7", "did you mean 'gear6'?"),
    ("--set boundary.surface=free", "a free surface cannot carry a load"),
    ("--set boundary.bottom=free", "a free bottom cannot hold a load"),
    ("--set boundary.surface=flying", "boundary.surface = 'flying': must be one of"),
    ("--set excitation.drive_amplitude=2", 'a drive needs boundary.surface = "driven"'),
    ("--set record.traces=[0,99]", "record.traces = 99: grain index outside the chain"),
    ('--set record.fields=["w"]', "record.fields = 'w'"),
    ("--set chain.l0=1e-4 --set chain.load=1", "give either chain.l0 or chain.load"),
    ("--set nonsense=1", "nonsense: unknown key"),
    ("--set chain.l0", "must be written key=value"),
    ("--precision float16", "integrator.precision = 'float16'"),
    ("--device tpu", "--device = 'tpu': not available"),
]


@pytest.fixture
def scene_file(tmp_path):
    path = tmp_path / "scene.toml"
    path.write_text(SCENE)
    return path


@pytest.mark.parametrize("flags,expected", BAD)
def test_bad_input_is_one_line_exit_2_nothing_written(tmp_path, scene_file, flags, expected):
    out = tmp_path / "out.zarr"
    proc = hertzian("run", str(scene_file), "--out", str(out), *flags.split())
    assert proc.returncode == 2, proc.stderr
    lines = [line for line in proc.stderr.splitlines() if line.strip() and not line.startswith("Warp CUDA warning")]
    assert len(lines) == 1 and lines[0].startswith("error: "), proc.stderr
    assert expected in lines[0]
    assert "Traceback" not in proc.stderr
    assert not out.exists()


def test_bad_scene_files(tmp_path):
    cases = {
        "impurity outside the chain": SCENE + "[[impurities]]\ngrains = [25]\nmass = 0.5\n",
        "missing duration": SCENE.replace("duration = 0.05", ""),
        "not toml": "[chain\ngrains = 3",
        "unknown section": SCENE + "[chian]\ngrains = 3\n",
    }
    for name, text in cases.items():
        path = tmp_path / "bad.toml"
        path.write_text(text)
        proc = hertzian("run", str(path), "--out", str(tmp_path / "o.zarr"))
        assert proc.returncode == 2, (name, proc.stderr)
        assert "Traceback" not in proc.stderr and "error: " in proc.stderr, name
        assert not (tmp_path / "o.zarr").exists()
    proc = hertzian("run", str(tmp_path / "missing.toml"), "--out", str(tmp_path / "o.zarr"))
    assert proc.returncode == 2 and "no such file" in proc.stderr


def test_existing_store_is_not_overwritten(tmp_path, scene_file):
    out = tmp_path / "out.zarr"
    out.mkdir()
    (out / "keep").write_text("precious")
    proc = hertzian("run", str(scene_file), "--out", str(out))
    assert proc.returncode == 2 and "exists" in proc.stderr
    assert (out / "keep").read_text() == "precious"


def test_run_writes_store_that_xarray_and_summarize_read(tmp_path, scene_file):
    out = tmp_path / "out.zarr"
    proc = hertzian("run", str(scene_file), "--out", str(out), "--device", "cpu")
    assert proc.returncode == 0, proc.stderr
    assert str(out) in proc.stdout
    ds = xr.open_zarr(out)
    assert ds.u.dims == ("record", "grain") and ds.u.shape == (6, 20)
    assert ds.trace_u.dims == ("sample", "traced") and ds.trace_u.shape == (501, 2)
    np.testing.assert_allclose(ds.t.values, np.arange(6) * 0.01, rtol=1e-12)
    assert int(ds.status) == 0
    prov = ds.attrs["provenance"]
    for key in (
        "package_version",
        "warp_version",
        "device",
        "precision",
        "method",
        "dt",
        "steps",
        "wall_seconds",
        "grain_steps_per_second",
        "energy_error_max",
    ):
        assert key in prov
    assert json.loads(ds.attrs["scene"])["chain"]["grains"] == 20
    summary = hertzian("summarize", str(out), "--json")
    assert summary.returncode == 0, summary.stderr
    records = json.loads(summary.stdout)
    assert records[0]["status"] == 0 and records[0]["energy_error"] == pytest.approx(float(ds.energy_error))
    bad = hertzian("summarize", str(tmp_path / "nope.zarr"))
    assert bad.returncode == 2 and "error:" in bad.stderr
