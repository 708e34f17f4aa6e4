"""Prebuilt kernels (hertzian.core.solvers.prebuilt): ``hertzian prebuild`` compiles a job's kernels into a folder,
a run on an empty Warp kernel cache loads them from there and compiles nothing, with the same results; binaries of
another Warp version are not read; CUDA binaries are named as a GPU of each architecture looks for them."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import zipfile
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
import zarr
from hertzian.core.solvers import prebuilt
from hertzian.core.solvers.compile import block_of, prebuild_variants
from hertzian.kernels.features import Features
from hertzian.kernels.step import step_kernel

from tests.helpers import hertzian

SCENE = "[chain]\ngrains = 40\nl0 = 1e-4\n[excitation]\nimpact = 1e-2\n[integrator]\ndt = 1e-3\nduration = 1.0\n"
SCENE += '[record]\nevery = 0.1\nfields = ["u", "v"]\ntraces = [0]\ntrace_every = 0.01\n'


def _env(cache: Path, prebuilt_folder: str, timeline: Path | None = None) -> dict:
    env = {**os.environ, "WARP_CACHE_PATH": str(cache), "HERTZIAN_PREBUILT": prebuilt_folder}
    return env | ({"HERTZIAN_TIMELINE": str(timeline)} if timeline else {})


def _compiled_modules(cache: Path) -> set[str]:
    """Module folders Warp compiled into its kernel cache (the shared precompiled header is not one)."""
    return {p.name for p in cache.rglob("wp_*") if p.is_dir()}


def test_a_run_on_an_empty_cache_loads_prebuilt_kernels_compiles_nothing_and_agrees(tmp_path):
    scene = tmp_path / "scene.toml"
    scene.write_text(SCENE)
    folder = tmp_path / "prebuilt"
    built = hertzian("prebuild", scene, "--device", "cpu", "--out", folder, env=_env(tmp_path / "c0", "off"))
    assert built.returncode == 0, built.stderr
    assert json.loads((folder / prebuilt.INDEX).read_text())["devices"] == ["cpu"]

    timeline = tmp_path / "timeline.json"
    cache = tmp_path / "c1"
    run = hertzian(
        "run", scene, "--device", "cpu", "--out", tmp_path / "a.zarr", env=_env(cache, str(folder), timeline)
    )
    assert run.returncode == 0, run.stderr
    phases = {p["phase"]: p for p in json.loads(timeline.read_text())["phases"]}
    loads = phases["kernels_loaded"]["variants"]
    assert loads and all(load["prebuilt"] for load in loads), loads
    assert _compiled_modules(cache) == set()
    assert "precompiled_header_built" not in phases  # nothing to compile, so no header is built either

    compiled = hertzian("run", scene, "--device", "cpu", "--out", tmp_path / "b.zarr", env=_env(tmp_path / "c2", "off"))
    assert compiled.returncode == 0, compiled.stderr
    assert _compiled_modules(tmp_path / "c2")
    a, b = zarr.open_group(tmp_path / "a.zarr", mode="r"), zarr.open_group(tmp_path / "b.zarr", mode="r")
    for name in ("u", "v", "energy", "trace_v"):
        np.testing.assert_array_equal(a[name][...], b[name][...])


def test_a_folder_built_by_another_warp_version_is_not_read(tmp_path, monkeypatch):
    folder = tmp_path / "prebuilt"
    folder.mkdir()
    monkeypatch.setenv(prebuilt.ENVIRONMENT, str(folder))
    (folder / prebuilt.INDEX).write_text(json.dumps({"warp": "0.0.1", "modules": []}))
    assert folder not in prebuilt.roots()
    (folder / prebuilt.INDEX).write_text(json.dumps({"warp": prebuilt.wp.config.version, "modules": []}))
    assert folder in prebuilt.roots()
    monkeypatch.setenv(prebuilt.ENVIRONMENT, "off")
    assert prebuilt.roots() == []


def _gpu(arch: int) -> SimpleNamespace:
    """What the lookup reads of a CUDA device: its architecture."""
    return SimpleNamespace(is_cpu=False, is_cuda=True, arch=arch)


def test_cuda_binaries_are_built_without_a_gpu_and_found_by_architecture(tmp_path, monkeypatch):
    """A cubin for sm_80 and PTX for sm_80 and sm_90: an sm_80 GPU takes its cubin, an sm_90 one the PTX of its own
    architecture, an sm_120 one the newest PTX, an sm_75 one nothing (it compiles)."""
    module = step_kernel(Features()).module
    block = block_of(prebuilt.wp.get_device("cpu"), None)
    report = prebuild_variants([(module, None)], "cpu", tmp_path, archs=[80], ptx=[80, 90])
    assert report["binaries"] == 4  # the CPU object, one cubin, two PTX
    monkeypatch.setenv(prebuilt.ENVIRONMENT, str(tmp_path))
    for gpu, suffix, arch in ((80, ".cubin", 80), (90, ".ptx", 90), (120, ".ptx", 90)):
        binary, _, found = prebuilt.find(module, _gpu(gpu), block)
        assert (binary.suffix, found) == (suffix, arch), gpu
    assert prebuilt.find(module, _gpu(75), block) is None


def test_the_companion_wheel_installs_a_folder_that_runs_find(tmp_path):
    folder = tmp_path / "prebuilt"
    module = step_kernel(Features()).module
    prebuild_variants([(module, None)], "cpu", folder)
    wheel = prebuilt.write_wheel(folder, tmp_path / "dist", "9.9")
    site = tmp_path / "site"
    with zipfile.ZipFile(wheel) as archive:
        names = archive.namelist()
        archive.extractall(site)
    assert f"{prebuilt.COMPANION}/{prebuilt.INDEX}" in names
    assert any(name.endswith(".dist-info/RECORD") for name in names)
    probe = "from hertzian.core.solvers import prebuilt; print([str(p) for p in prebuilt.roots()])"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(site), os.environ.get("PYTHONPATH", "")])}
    env.pop(prebuilt.ENVIRONMENT, None)
    found = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, env=env)
    assert str(site / prebuilt.COMPANION) in found.stdout, found.stderr


@pytest.mark.parametrize(
    "args, key",
    [(["--device", "cpu", "--arch", "90"], "--device"), (["--arch", "x9"], "--arch"), (["--ptx", "9"], "--ptx")],
)
def test_prebuild_refuses_bad_options_in_one_line(tmp_path, args, key):
    result = hertzian("prebuild", *args, "--out", tmp_path / "out")
    assert result.returncode == 2
    assert result.stderr.startswith(f"error: {key} = ") and result.stderr.count("\n") == 1, result.stderr
    assert not (tmp_path / "out").exists()


def test_warmup_list_prints_the_default_family_with_the_readme_kernels(tmp_path):
    listed = hertzian("warmup", "--list", "--device", "cpu", "--json")
    assert listed.returncode == 0, listed.stderr
    rows = json.loads(listed.stdout)["modules"]
    readme = hertzian("warmup", "impact", "--device", "cpu", "--dry-run", "--json")
    names = {name.split(" ")[0] for name in json.loads(readme.stdout)["variants"]}
    assert names <= {row["module"] for row in rows}
    assert any("1000x1" in row["shapes"] for row in rows if row["module"].startswith("chain_kernel"))


def test_prebuild_any_length_adds_the_long_chains_record_kernels(tmp_path):
    # on a CPU the chain kernel takes any length; --any-length adds what a chain of 2 048 grains or more records with
    # (the example's own chains are 20 grains long)
    out = tmp_path / "any"
    done = hertzian("prebuild", "example", "--device", "cpu", "--out", out, "--json", "--any-length")
    assert done.returncode == 0, done.stderr
    built = {p.name.split("__")[-1].rsplit("_", 2)[0] for p in out.rglob("*") if p.is_dir()}
    assert {"chain_steps", "record_parts", "record_long", "record_grains"} <= built, built


def test_a_gpu_family_planned_without_a_gpu_holds_what_its_runs_load(tmp_path, monkeypatch):
    # `hertzian prebuild --gpu-family 90` plans here what an sm_90 GPU loads for the scene's features at any chain
    # length and count; runs of random lengths and counts on that GPU then load nothing outside it
    from hertzian.core.solvers.prepare import Need, kernel_variants
    from hertzian.core.solvers.shape_rule import PlannedGPU
    from hertzian.studies.warmup import gpu_family_variants, scene_needs

    from tests.helpers import make_scene

    monkeypatch.setenv("HERTZIAN_CACHE", str(tmp_path / "none.json"))
    gpu = PlannedGPU(90)
    needs = scene_needs(make_scene(chain={"grains": 40}, record={"every": 0.005, "traces": [0]}))
    family = set(gpu_family_variants(needs, gpu))
    assert any(block == 128 for _, block in family) and any("record_long" in m.name for m, _ in family)
    rng = np.random.default_rng(2)
    grains = np.exp(rng.uniform(np.log(2), np.log(100_000), 60)).astype(int)
    counts = np.exp(rng.uniform(0, np.log(50_000), 60)).astype(int)
    for n, c in zip(grains, counts):
        loads = set(kernel_variants([Need(needs[0].features, int(n), int(c))], gpu))
        assert loads <= family, (n, c, loads - family)
    bad = hertzian("prebuild", "--gpu-family", "7", "--out", tmp_path / "out")
    assert bad.returncode == 2 and "--gpu-family" in bad.stderr and not (tmp_path / "out").exists()


def test_prebuild_writes_only_into_a_new_an_empty_or_its_own_folder(tmp_path):
    """A folder of the user's is not filled with kernel modules, and a missing parent is not made."""
    from tests.helpers import invoke

    mine = tmp_path / "thesis"
    mine.mkdir()
    (mine / "thesis.tex").write_text("mine")
    result = invoke("prebuild", "impact", "--device", "cpu", "--out", mine)
    assert result.exit_code == 2 and "a folder holding other files (no family.json)" in result.stderr
    assert [p.name for p in mine.iterdir()] == ["thesis.tex"]
    deep = tmp_path / "no" / "such" / "kernels"
    result = invoke("prebuild", "impact", "--device", "cpu", "--out", deep)
    assert result.exit_code == 2 and "parent directory does not exist" in result.stderr
    assert not (tmp_path / "no").exists()
