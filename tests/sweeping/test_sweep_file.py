"""Sweep files: the grid they describe (C order, exact axis values, zipped axes, a scene file beside them), the
fingerprint, and bad files and flags refused in one line with exit code 2 and nothing written."""

import numpy as np
import pytest
import xarray as xr
from hertzian.sweeping.spec import load_sweep, sweep_from_dict, sweep_scenes
from hertzian.sweeping.store import summary_records

from tests.helpers import GRID_SWEEP, run_store, sweep_cli, write_sweep


def test_grid_points_in_c_order_with_exact_axis_values(tmp_path):
    sweep = load_sweep(write_sweep(tmp_path))
    assert sweep.dims == ("v_imp", "l0") and sweep.shape == (3, 2) and sweep.point_count == 6
    np.testing.assert_array_equal(sweep.dimensions[0].axes[0].coordinate(), np.logspace(-3, -1, 3))
    scenes = sweep_scenes(sweep)
    # last axis fastest
    assert [(s.excitation.impact, s.chain.l0) for s in scenes[:3]] == [(1e-3, 0.0), (1e-3, 1e-4), (1e-2, 0.0)]


def test_linspace_and_scene_file_relative_to_the_sweep_file(tmp_path):
    (tmp_path / "scenes").mkdir()
    (tmp_path / "scenes" / "base.toml").write_text("[chain]\ngrains = 12\n[integrator]\nduration = 0.01\n")
    (tmp_path / "sweeps").mkdir()
    path = tmp_path / "sweeps" / "s.toml"
    path.write_text(
        'scene = "../scenes/base.toml"\n[[axis]]\nname = "g"\nkey = "chain.gravity"\nlinspace = [0.0, 1.0, 5]\n'
    )
    sweep = load_sweep(path)
    np.testing.assert_array_equal(sweep.dimensions[0].axes[0].coordinate(), np.linspace(0.0, 1.0, 5))
    assert sweep.base.chain.grains == 12


def test_zipped_axes_share_one_dimension(tmp_path):
    text = (
        GRID_SWEEP.replace("values = [0.0, 1e-4]", "values = [0.0, 1e-5, 1e-4]") + '[[zip]]\naxes = ["v_imp", "l0"]\n'
    )
    sweep = load_sweep(write_sweep(tmp_path, text))
    assert sweep.dims == ("v_imp",) and sweep.shape == (3,)
    assert [(s.excitation.impact, s.chain.l0) for s in sweep_scenes(sweep)] == [(1e-3, 0.0), (1e-2, 1e-5), (1e-1, 1e-4)]
    out = run_store(tmp_path, text)
    ds = xr.open_zarr(out)
    assert ds.u.dims == ("v_imp", "record", "grain") and ds.l0.dims == ("v_imp",)
    by_l0 = ds.swap_dims(v_imp="l0")
    np.testing.assert_array_equal(by_l0.u.sel(l0=1e-5).values, ds.u.sel(v_imp=1e-2).values)
    records = summary_records(out)
    assert [(r["v_imp"], r["l0"]) for r in records] == [(1e-3, 0.0), (1e-2, 1e-5), (1e-1, 1e-4)]


def test_fingerprint_is_the_meaning_not_the_spelling(tmp_path):
    a = load_sweep(write_sweep(tmp_path))
    b = load_sweep(
        write_sweep(
            tmp_path,
            GRID_SWEEP.replace("values = [0.0, 1e-4]", "linspace = [0, 1e-4, 2]") + "# comment\n",
            name="b.toml",
        )
    )
    c = load_sweep(write_sweep(tmp_path, GRID_SWEEP.replace("1e-4]", "2e-4]"), name="c.toml"))
    assert a.fingerprint() == b.fingerprint() != c.fingerprint()
    assert sweep_from_dict(a.to_dict()).fingerprint() == a.fingerprint()


BAD = [
    ("unknown top-level key", GRID_SWEEP + "[[axes]]\nname = 'x'\n", "axes: unknown key (did you mean 'axis'?)"),
    ("no scene", "[[axis]]" + GRID_SWEEP.split("[[axis]]", 1)[1], "scene = None: is required"),
    ("scene section at top", GRID_SWEEP.replace("[scene.chain]", "[chain]"), "chain: unknown key"),
    ("missing scene file", 'scene = "nope.toml"\n', "scene = 'nope.toml': no such scene file"),
    ("no values", GRID_SWEEP.replace("logspace = [-3, -1, 3]", ""), "axis[0] = 'v_imp': give exactly one of values"),
    (
        "two spacings",
        GRID_SWEEP.replace("logspace = [-3, -1, 3]", "logspace = [-3, -1, 3]\nvalues = [1.0]"),
        "give exactly one of",
    ),
    ("bad count", GRID_SWEEP.replace("logspace = [-3, -1, 3]", "logspace = [-3, -1, 2.5]"), "count must be an integer"),
    (
        "bad linspace",
        GRID_SWEEP.replace("logspace = [-3, -1, 3]", "linspace = [1, 2]"),
        "axis[0].linspace = [1, 2]: must be [first, last, count]",
    ),
    ("repeated values", GRID_SWEEP.replace("[0.0, 1e-4]", "[1e-4, 1e-4]"), "must not repeat"),
    ("mixed values", GRID_SWEEP.replace("[0.0, 1e-4]", '[0.0, "x"]'), "must all be numbers, all strings"),
    (
        "unknown axis key",
        GRID_SWEEP.replace('key = "chain.l0"', 'key = "chain.gravty"'),
        "axis[1].key = 'chain.gravty': not a scene key (chain.gravty: unknown key (did you mean 'gravity'?)",
    ),
    ("unknown section", GRID_SWEEP.replace('key = "chain.l0"', 'key = "chian.l0"'), "axis[1].key = 'chian.l0'"),
    (
        "missing impurity block",
        GRID_SWEEP.replace('key = "chain.l0"', 'key = "impurities.0.mass"'),
        "there are 0 impurity blocks",
    ),
    ("duplicate name", GRID_SWEEP.replace('name = "l0"', 'name = "v_imp"'), "axis[1].name = 'v_imp': already used"),
    ("duplicate key", GRID_SWEEP.replace('key = "chain.l0"', 'key = "excitation.impact"'), "already swept by axis[0]"),
    ("reserved name", GRID_SWEEP.replace('name = "l0"', 'name = "energy"'), "is a store variable name"),
    ("bad name", GRID_SWEEP.replace('name = "l0"', 'name = "l 0"'), "axis[1].name = 'l 0'"),
    ("unknown axis field", GRID_SWEEP + "step = 2\n", "axis[1].step: unknown key"),
    ("zip lengths", GRID_SWEEP + '[[zip]]\naxes = ["v_imp", "l0"]\n', "zipped axes need equal lengths"),
    ("zip unknown axis", GRID_SWEEP + '[[zip]]\naxes = ["v_imp", "l1"]\n', "zip[0].axes = 'l1': no such axis"),
    ("zip single axis", GRID_SWEEP + '[[zip]]\naxes = ["v_imp"]\n', "must list at least two axis names"),
    (
        "bad point",
        GRID_SWEEP.replace("[0.0, 1e-4]", "[0.0, -1e-4]"),
        "chain.l0 = -0.0001: must be ≥ 0 (at sweep point v_imp=0.001, l0=-0.0001)",
    ),
    (
        "layout axis",
        GRID_SWEEP.replace('key = "chain.l0"', 'key = "chain.grains"').replace("[0.0, 1e-4]", "[12, 20]"),
        "chain.grains = ['12', '20']: every point of a sweep shares the store's record/grain layout",
    ),
    ("bad base scene", GRID_SWEEP.replace("grains = 12", "grains = 1"), "chain.grains = 1: must be an integer ≥ 2"),
    ("not toml", "[[axis]\n", "is not valid TOML"),
]


@pytest.mark.parametrize("name,text,expected", BAD, ids=[b[0] for b in BAD])
def test_bad_sweep_is_one_line_exit_2_nothing_written(tmp_path, name, text, expected):
    out = tmp_path / "out.zarr"
    result = sweep_cli(write_sweep(tmp_path, text), "--out", out, "--device", "cpu")
    assert result.exit_code == 2, (result.stdout, result.stderr)
    lines = [ln for ln in result.stderr.splitlines() if ln.strip() and not ln.startswith("Warp CUDA warning")]
    assert len(lines) == 1 and lines[0].startswith("error: "), result.stderr
    assert expected in lines[0], lines[0]
    assert not out.exists() and [p.name for p in tmp_path.iterdir()] == ["sweep.toml"]


@pytest.mark.parametrize(
    "flags,expected",
    [
        ("--batch-size 0", "--batch-size = 0: must be ≥ 1"),
        ("--workers 0", "--workers = 0: must be ≥ 1"),
        ("--workers 99999999999999999999", "--workers = 99999999999999999999: at most"),
        ("--workers 1000000", "each worker process gets an even share of the host memory, and needs 1 GiB"),
        ("--workers 2 --scheduler tcp://x:1", "give either workers (a local cluster) or scheduler"),
        ("--resume --overwrite", "resume continues a store, overwrite replaces it"),
        ("--set chain.grainz=3", "chain.grainz: unknown key"),
        ("--precision float16", "integrator.precision = 'float16'"),
    ],
)
def test_bad_flags(tmp_path, flags, expected):
    result = sweep_cli(write_sweep(tmp_path), "--out", tmp_path / "o.zarr", *flags.split())
    assert result.exit_code == 2 and expected in result.stderr, result.stderr
    assert not (tmp_path / "o.zarr").exists()


def test_existing_store_needs_resume_or_overwrite(tmp_path):
    """A store of the project's: resume or overwrite it. A user's folder: neither option is offered, since neither
    applies (the folder is left as it is)."""
    out, sweep = tmp_path / "o.zarr", write_sweep(tmp_path)
    assert sweep_cli(sweep, "--out", out, "--device", "cpu", "--quiet").exit_code == 0
    result = sweep_cli(sweep, "--out", out)
    assert result.exit_code == 2 and "exists; resume to continue it or overwrite to replace it" in result.stderr
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "notes.txt").write_text("mine")
    result = sweep_cli(sweep, "--out", mine)
    assert result.exit_code == 2 and "exists and is not a hertzian store" in result.stderr, result.stderr
    assert "resume to continue" not in result.stderr and len(result.stderr.strip().splitlines()) == 1
    assert [p.name for p in mine.iterdir()] == ["notes.txt"]


def test_dry_run_prints_the_plan_and_writes_nothing(tmp_path):
    result = sweep_cli(
        write_sweep(tmp_path), "--out", tmp_path / "o.zarr", "--dry-run", "--batch-size", "2", "--device", "cpu"
    )
    assert result.exit_code == 0, result.stderr
    text = result.stdout
    assert "points: 6 over v_imp (3) × l0 (2)" in text
    assert "batches: 3 of up to 2 points" in text and "estimated work: 1.44e+04 grain-steps" in text
    assert "device mem" in text and "KiB" in text
    assert not (tmp_path / "o.zarr").exists()
