"""Install time (hertzian/_install.py): building the package compiles the default CPU family into it, so the README's
first run on an empty kernel cache compiles nothing; a build that cannot compile says why in one line and leaves no
partial folder."""

from __future__ import annotations

import json
import os
import sys
import tomllib
from fnmatch import fnmatch
from pathlib import Path

import pytest
from hertzian import _install
from hertzian.core.solvers import prebuilt

from tests.helpers import hertzian

ROOT = Path(__file__).resolve().parents[2]


def test_the_build_compiles_the_default_family_and_the_readme_run_loads_it(tmp_path):
    assert _install.compile_family(tmp_path / "build") == ""
    folder = tmp_path / "build" / _install.FOLDER
    assert json.loads((folder / prebuilt.INDEX).read_text())["devices"] == ["cpu"]

    cache, timeline = tmp_path / "cache", tmp_path / "timeline.json"
    env = {**os.environ, "WARP_CACHE_PATH": str(cache), "HERTZIAN_PREBUILT": str(folder)}
    env["HERTZIAN_TIMELINE"] = str(timeline)
    run = hertzian("run", "--device", "cpu", "--set", "integrator.duration=2", "--out", tmp_path / "a.zarr", env=env)
    assert run.returncode == 0, run.stderr
    phases = {p["phase"]: p for p in json.loads(timeline.read_text())["phases"]}
    loads = phases["kernels_loaded"]["variants"]
    assert loads and all(load["prebuilt"] for load in loads), loads
    assert not [p for p in cache.rglob("wp_*") if p.is_dir()]


def test_a_build_that_cannot_compile_says_why_and_leaves_no_folder(tmp_path, monkeypatch):
    """A child that writes part of the folder and fails: its last line is the reason, and the part is removed."""
    child = tmp_path / "python"
    child.write_text('#!/bin/sh\nmkdir -p "$3/wp_partial"\necho "compiler: not found" >&2\nexit 1\n')
    child.chmod(0o755)
    monkeypatch.setattr(sys, "executable", str(child))
    note = _install.compile_family(tmp_path / "build")
    assert note == "built without prebuilt kernels (compiler: not found); runs compile what they need"
    assert (tmp_path / "build").is_dir() and not (tmp_path / "build" / _install.FOLDER).exists()


def test_the_build_runs_the_hook_and_ships_the_folders_index():
    """pyproject.toml wires the hook into build_py, and its package data takes the folder's index and modules."""
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    assert config["cmdclass"]["build_py"] == "hertzian._install.BuildWithKernels"
    patterns = config["package-data"]["hertzian"]
    for name in (f"prebuilt-kernels/{prebuilt.INDEX}", "prebuilt-kernels/wp_chain_0123/chain.o"):
        assert any(fnmatch(name, pattern) for pattern in patterns), name


def test_a_device_that_cannot_compile_is_left_out_and_named(tmp_path, monkeypatch, capsys):
    """A GPU seen at install whose family cannot be built (here: no CUDA behind it) leaves the CPU family in place."""
    from hertzian.core.scene import load_scene
    from hertzian.core.shipped import example_path
    from hertzian.studies import warmup

    small = warmup.scene_needs(load_scene(example_path("impact"), {"chain.grains": 20, "integrator.duration": 0.1}))
    monkeypatch.setattr(warmup, "family_needs", lambda device: small)  # a family of one small scene
    monkeypatch.setattr(prebuilt.wp, "is_cuda_available", lambda: True)
    _install.main(str(tmp_path))
    assert "hertzian: no prebuilt cuda kernels (" in capsys.readouterr().err
    assert json.loads((tmp_path / prebuilt.INDEX).read_text())["devices"] == ["cpu"]


def test_an_install_where_no_device_compiles_fails_the_child(tmp_path, monkeypatch):
    from hertzian.core.solvers import compile as compiling

    def cannot(*args, **kwargs):
        raise RuntimeError("no compiler")

    monkeypatch.setattr(compiling, "prebuild_variants", cannot)
    with pytest.raises(SystemExit, match="no device could compile the family"):
        _install.main(str(tmp_path))


def test_the_module_imports_where_setuptools_is_missing():
    """Python 3.12 environments may have no setuptools at run time; the tests and the child process import this."""
    import subprocess

    blocked = "; ".join(f"sys.modules[{m!r}] = None" for m in ("setuptools", "setuptools.command.build_py"))
    probe = f"import sys; {blocked}; import hertzian._install as m; print(m.compile_family.__name__)"
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True)
    assert done.returncode == 0 and done.stdout.strip() == "compile_family", done.stderr


def test_a_previous_builds_family_is_replaced_and_a_prebuild_in_the_sources_kept(tmp_path):
    """pip builds in the source tree's build/ folder, which outlives a build: a family left there was compiled from
    the sources as they were then, and would ship beside today's kernels. A ``hertzian prebuild`` folder in the source
    package is the user's and is kept (build_py copied it)."""
    source, build_lib = tmp_path / "ensemble", tmp_path / "build" / "lib"
    stale = build_lib / _install.FOLDER
    (stale / "wp_chain_old").mkdir(parents=True)
    (stale / prebuilt.INDEX).write_text("{}")
    source.mkdir()
    assert _install.family_to_compile(source, build_lib)
    assert not stale.exists() and build_lib.is_dir()

    (source / _install.FOLDER.name).mkdir()
    (source / _install.FOLDER.name / prebuilt.INDEX).write_text("{}")
    (stale / "wp_chain_user").mkdir(parents=True)
    assert not _install.family_to_compile(source, build_lib)
    assert (stale / "wp_chain_user").is_dir()
