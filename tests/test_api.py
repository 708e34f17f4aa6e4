"""The Python API (``import hertzian as hz``) against the command line: same stores, same one-line refusals; and
the command line's help screens, bare names of shipped files, plot's axes and a resume with nothing to do."""

from __future__ import annotations

import re
import subprocess
import sys

import hertzian as hz
import numpy as np
import pytest
import typer.main
import xarray as xr
from hertzian.cli import COMMANDS, app
from hertzian.sweeping.sweep_store import TIMING_VARIABLES, differing_arrays

from tests.helpers import invoke

SCENE = """
[chain]
grains = 8

[excitation]
impact = 1e-2

[integrator]
dt = 1e-4
duration = 0.02

[record]
every = 0.01
traces = [0, 7]
trace_every = 0.002
"""

SWEEP = (
    re.sub(r"^\[", "[scene.", SCENE, flags=re.MULTILINE)
    + """
[[axis]]
name = "v_imp"
key = "excitation.impact"
values = [1e-3, 1e-2]

[[axis]]
name = "l0"
key = "chain.l0"
values = [0.0, 1e-4, 2e-4]
"""
)


def without_timing(ds: xr.Dataset) -> xr.Dataset:
    """The dataset without what measures the machine: per-point timings and the provenance (clock times)."""
    ds = ds.drop_vars([v for v in TIMING_VARIABLES if v in ds.variables])
    ds.attrs = {k: v for k, v in ds.attrs.items() if k != "provenance"}
    return ds


@pytest.fixture(scope="module")
def sweep_stores(tmp_path_factory):
    """The same sweep file through hz.sweep and through ``hertzian sweep``: (file, API store, CLI store)."""
    root = tmp_path_factory.mktemp("api")
    path = root / "grid.toml"
    path.write_text(SWEEP)
    summary = hz.sweep(path, root / "api.zarr", device="cpu", batch_size=2)
    result = invoke("sweep", path, "--out", root / "cli.zarr", "--device", "cpu", "--batch-size", "2", "--quiet")
    assert result.exit_code == 0, result.stderr
    return path, root / "api.zarr", root / "cli.zarr", summary


def test_run_to_xarray_is_the_store_hertzian_run_writes(tmp_path):
    path = tmp_path / "scene.toml"
    path.write_text(SCENE)
    result = invoke("run", path, "--out", tmp_path / "run.zarr", "--device", "cpu", "--quiet")
    assert result.exit_code == 0, result.stderr
    stored = hz.open_store(tmp_path / "run.zarr").load()
    dataset = hz.run(hz.load_scene(path), device="cpu").to_xarray()
    xr.testing.assert_identical(without_timing(dataset), without_timing(stored))
    for name, variable in dataset.variables.items():
        assert variable.attrs == stored[name].attrs, name


def test_every_float_variable_has_units():
    scene = hz.load_scene(
        {"chain": {"grains": 6}, "integrator": {"dt": 1e-4, "duration": 0.01}, "record": {"every": 0.005}},
        {"record.traces": [0, 5], "record.trace_every": 0.001},
    )
    dataset = hz.run(scene, device="cpu").to_xarray()
    assert {"u", "v", "trace_u", "trace_v", "energy", "t", "trace_t"} <= set(dataset.variables)
    lacking = [n for n, v in dataset.variables.items() if v.dtype.kind in "fc" and not v.attrs.get("units")]
    assert lacking == []
    assert dataset.trace_v.attrs["units"] == dataset.v.attrs["units"]


def test_hz_sweep_writes_the_store_hertzian_sweep_writes(sweep_stores):
    _, api_store, cli_store, summary = sweep_stores
    assert differing_arrays(api_store, cli_store) == []
    assert summary["points"] == 6 and summary["batches"] == summary["batches_run"] > 1
    assert summary["status_counts"] == {"0": 6} and summary["store"] == str(api_store)
    xr.testing.assert_identical(without_timing(hz.open_store(api_store)), without_timing(hz.open_store(cli_store)))


def test_resume_with_nothing_left_says_so(sweep_stores):
    path, _, cli_store, summary = sweep_stores
    result = invoke("sweep", path, "--out", cli_store, "--device", "cpu", "--resume", "--quiet")
    assert result.exit_code == 0, result.stderr
    assert f"nothing to do: all {summary['batches']} batches were complete" in result.stdout
    assert "grain-steps/s" not in result.stdout


def test_plot_at_an_unknown_axis_lists_the_stores_axes(sweep_stores, tmp_path):
    _, api_store, _, _ = sweep_stores
    result = invoke("plot", api_store, "--at", "masss=4", "--out", tmp_path / "p.png")
    assert result.exit_code == 2
    assert "no sweep axis masss; the store's axes: v_imp, l0" in result.stderr, result.stderr


@pytest.mark.parametrize(
    "call,expected",
    [
        # no machine has 100 GPUs: refused on a GPU host as on a CPU one, the CPU listed first
        (lambda s: hz.run(s, device="cuda:99"), "device = 'cuda:99': not available here; available: cpu"),
        (lambda s: hz.run(s, device="cpu", kernel="fastest"), "kernel = 'fastest': one of auto"),
        (lambda s: hz.run("scene.toml", device="cpu"), "scenes = 'scene.toml': a Scene or a non-empty list of Scenes"),
        (lambda s: hz.run([s, "b"], device="cpu"), "scenes = 'list of 2': a Scene or a non-empty list of Scenes"),
        (lambda s: hz.run(3, device="cpu"), "scenes = 'int': a Scene or a non-empty list of Scenes"),
        (lambda s: hz.load_scene(42), "source = 'int': a path, a shipped example's name"),
        (lambda s: hz.sweep(None), "sweep = 'NoneType': a sweep file's path, a shipped sweep's name or a Sweep"),
        (lambda s: hz.load_scene("impact", ["chain.grains=5"]), "overrides = \"['chain.grains=5']\": a dict of"),
        (lambda s: hz.load_scene("impact", {1: 5}), "overrides = '{1: 5}': a dict of dotted scene keys"),
        (lambda s: hz.load_sweep(None), "sweep file = 'NoneType': a path or a shipped sweep's name"),
        (lambda s: hz.load_sweep("."), "sweep file = '.': is a folder, not a TOML file"),
        (lambda s: hz.load_scene("."), "scene file = '.': is a folder, not a TOML file"),
        (lambda s: hz.open_store(None), "path = 'NoneType': a path (a str or a pathlib.Path)"),
        (lambda s: hz.design("protector", out=3), "out = 'int': a path (a str or a pathlib.Path)"),
        (lambda s: hz.design(None, out="d.zarr"), "path = 'NoneType': a path"),
        (lambda s: hz.sweep("example", out=5), "out = 'int': a path"),
        (lambda s: hz.sweep("example", "e.zarr", progress=5), "progress = 'int': a SweepProgress or a function"),
        (lambda s: hz.sweep("example", "e.zarr", batch_size="2"), "batch_size = '2': an integer ≥ 1"),
        (lambda s: hz.sweep("example", "e.zarr", workers=1.5), "workers = 1.5: an integer ≥ 1"),
    ],
)
def test_python_refusals_are_one_line(call, expected, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    scene = hz.load_scene({"chain": {"grains": 4}, "integrator": {"dt": 1e-4, "duration": 0.01}})
    with pytest.raises((hz.OptionError, hz.SceneError)) as refused:
        call(scene)
    assert str(refused.value).startswith(expected) and "\n" not in str(refused.value)
    assert list(tmp_path.iterdir()) == []  # nothing written


def test_a_binary_file_or_a_store_given_as_a_scene_or_sweep_is_one_line(tmp_path):
    picture = tmp_path / "figure.png"
    picture.write_bytes(b"\x89PNG\r\n\x1a\n\xff\xfe")
    for call, kind in ((hz.load_scene, "scene file"), (hz.load_sweep, "sweep file")):
        with pytest.raises(hz.SceneError, match=rf"^{kind} = '.*figure.png': is not a text file"):
            call(picture)
    result = invoke("run", picture, "--device", "cpu")
    assert result.exit_code == 2 and "is not a text file" in result.stderr and "Traceback" not in result.output
    store = tmp_path / "run.zarr"
    assert invoke("run", "--set", "chain.grains=4", "--set", "integrator.duration=0.1", "--out", store).exit_code == 0
    for command in ("run", "sweep", "estimates", "warmup"):
        result = invoke(command, store, "--device", "cpu")
        assert result.exit_code == 2 and "is a store, not a TOML file (hertzian summarize" in result.stderr, command


def test_sweep_refusals_are_one_line_and_write_nothing(tmp_path):
    path = tmp_path / "grid.toml"
    path.write_text(SWEEP)
    with pytest.raises(hz.OptionError, match=r"^batch_size = 0: must be ≥ 1$"):
        hz.sweep(path, tmp_path / "o.zarr", batch_size=0)
    with pytest.raises(hz.SceneError, match=r"^chain.grainz: unknown key"):
        hz.sweep(path, tmp_path / "o.zarr", overrides={"chain.grainz": 3})
    assert sorted(p.name for p in tmp_path.iterdir()) == ["grid.toml"]


def test_shipped_files_by_bare_name(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    result = invoke("sweep", "example.toml", "--dry-run", "--device", "cpu")
    assert result.exit_code == 0, result.stderr
    assert "points: 9 over v_imp (3) × l0 (3)" in result.stdout
    assert hz.load_scene("impact").chain.grains == 1000
    assert hz.load_sweep("example").shape == (3, 3)  # the shipped sweep, as hz.sweep and hertzian sweep find it
    assert invoke("sweep", "no_such_sweep.toml", "--dry-run").exit_code == 2
    # the README's path of a shipped sweep works outside the repository too; other folders are not searched
    assert "points: 9 over" in invoke("sweep", "sweeps/example.toml", "--dry-run", "--device", "cpu").stdout
    assert invoke("sweep", "elsewhere/example.toml", "--dry-run").exit_code == 2
    assert list(tmp_path.iterdir()) == []


def _help(*command: str) -> str:
    result = invoke(*command, "--help", terminal_width=100)
    assert result.exit_code == 0, result.output
    return result.output


def _bracketed(command) -> set[str]:
    """Every [text] in a command's docstring and its parameters' help."""
    texts = [command.help or ""] + [getattr(p, "help", None) or "" for p in command.params]
    return {m for text in texts for m in re.findall(r"\[[^\]\n]*\]", text)}


@pytest.mark.parametrize("name", COMMANDS)
def test_help_screens_read_cleanly(name):
    command = typer.main.get_command(app).commands[name]
    shown = _help(name)
    flat = " ".join(shown.split())
    assert "``" not in shown and "SPEC" not in shown and "[]" not in shown, shown
    lost = [b for b in _bracketed(command) if " ".join(b.split()) not in flat]
    assert lost == [], shown


def test_help_keeps_the_brackets_rich_markup_ate():
    assert "[[axis]] tables" in " ".join(_help("sweep").split())
    assert "[program time]" in " ".join(_help("accuracy").split())
    assert "SPEC" not in _help()


def test_import_is_light():
    """``import hertzian`` loads neither Warp nor Zarr (``hertzian --help`` pays for neither)."""
    code = "import sys, hertzian; print(sorted({'warp', 'zarr', 'xarray'} & set(sys.modules)))"
    loaded = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert loaded.strip() == "[]"
    assert isinstance(hz.__version__, str) and set(hz.__all__) <= set(dir(hz))
    assert np.all([callable(getattr(hz, n)) for n in ("run", "sweep", "load_scene", "load_sweep", "open_store")])


def test_to_xarray_keeps_how_a_point_ran_as_coordinates():
    scene = hz.load_scene("impact", {"chain.grains": 12, "integrator.duration": 0.02, "record.every": 0.01})
    dataset = hz.run(scene, "cpu").to_xarray()
    for name in ("launch_group", "grain_steps_per_second"):
        assert name in dataset.coords and name not in dataset.data_vars, name
    assert {"u", "v", "energy", "status", "energy_error"} <= set(dataset.data_vars)


def test_hz_run_checks_as_hertzian_run_does():
    """hz.run and `hertzian run` share one path (hertzian.api.prepare_run): the same dt warning, as a Python
    warning, and with strict=True the same refusal; the result is frozen."""
    import dataclasses

    coarse = hz.load_scene("impact", {"chain.grains": 12, "integrator.dt": 1e-3, "integrator.duration": 0.02,
                                      "record.every": 0.01})  # fmt: skip
    with pytest.warns(UserWarning, match=r"integrator.dt = 0.001 looks inaccurate"):
        result = hz.run(coarse, "cpu")
    with pytest.raises(hz.RefusedError, match=r"^integrator.dt = 0.001 looks inaccurate"):
        hz.run(coarse, "cpu", strict=True)
    with pytest.raises(dataclasses.FrozenInstanceError):
        result.status = None
    cli = invoke("run", "--device", "cpu", "--out", "unused.zarr", "--strict", "--set", "integrator.dt=1e-3")
    assert cli.exit_code == 2 and "integrator.dt = 0.001 looks inaccurate" in cli.stderr


@pytest.mark.parametrize(
    "overrides, chains",
    [
        ({}, 1),
        ({"record.traces": [0, 5], "record.trace_every": 0.001, "record.error_estimate": True}, 1),
        ({"chain.radii": {"spread": 0.1, "seed": 3}}, 3),
    ],
)
def test_to_xarray_is_built_in_memory_and_equals_the_store(tmp_path, overrides, chains):
    """RunResult.to_xarray() writes nothing, and holds what `hertzian run --out` (write_result) stores: the same
    variables, coordinates, dims, dtypes, values and attributes (the provenance's times and host aside)."""
    import xarray as xr
    from hertzian.sweeping.sweep_store import write_result

    small = {"chain.grains": 12, "integrator.duration": 0.02, "record.every": 0.01, **overrides}
    base = hz.load_scene("impact", small)
    scenes = [base.with_overrides({"excitation.impact": 0.01 * (1 + k)}) for k in range(chains)]
    result = hz.run(scenes, "cpu")
    before = set(tmp_path.iterdir())
    memory = result.to_xarray()
    assert set(tmp_path.iterdir()) == before
    axes = {"chain": np.arange(chains)} if chains > 1 else None
    with xr.open_zarr(write_result(tmp_path / "run.zarr", result, axes=axes)) as stored:
        stored = stored.load()
    timing = ("finished", "created", "write_seconds", "build_seconds", "hosts", "session_wall_seconds")
    for dataset in (memory, stored):
        dataset.attrs["provenance"] = {k: v for k, v in dataset.attrs["provenance"].items() if k not in timing}
    xr.testing.assert_identical(memory, stored)
    assert {name: v.dtype for name, v in memory.variables.items()} == {
        name: v.dtype for name, v in stored.variables.items()
    }
