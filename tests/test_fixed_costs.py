"""Fixed costs: every kernel a job launches is named and compiled before its first launch
(hertzian.core.solvers.compile), ``hertzian warmup`` fills Warp's cache so a run compiles nothing, and ``auto``
takes the CPU chain kernel for short runs."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
import warp as wp
from conftest import make_scene
from hertzian.core.model import build_model
from hertzian.core.runner import Runner
from hertzian.core.solvers import CHAIN, choose_config
from hertzian.core.solvers.calibrate import step_reason
from hertzian.core.solvers.prepare import kernel_variants, prepare_kernels
from hertzian.studies.warmup import scene_needs

SCENES = {
    "impact, traces": dict(chain={"grains": 30}, record={"every": 0.005, "traces": [0, 29], "trace_every": 0.001}),
    "precompressed, gear5": dict(chain={"grains": 20, "l0": 1e-4}, integrator={"method": "gear5"}),
    "long chain": dict(chain={"grains": 2100}, integrator={"duration": 0.0005, "dt": 1e-4}),
}


@pytest.fixture
def loads(monkeypatch):
    """Every (module name, block_dim) Module.load is asked for while the fixture is active."""
    seen = []
    original = wp._src.context.Module.load

    def load(self, device, block_dim=None, *args, **kwargs):
        seen.append((self.name, block_dim))
        return original(self, device, block_dim, *args, **kwargs)

    monkeypatch.setattr(wp._src.context.Module, "load", load)
    return seen


def cpu_block(block: int | None) -> int | None:
    """A CPU block size as Warp resolves it: None and 1 are one variant."""
    return None if block in (None, 1) else block


@pytest.mark.parametrize("name", SCENES)
def test_prepare_names_every_kernel_a_run_loads(name, loads):
    scene = make_scene(**SCENES[name])
    needs = scene_needs(scene)
    prepared = {(module.name, cpu_block(block)) for module, block in kernel_variants(needs, "cpu")}
    prepare_kernels(needs, "cpu")
    loads.clear()
    Runner(build_model([scene], "cpu")).run()
    asked = {(module, cpu_block(block)) for module, block in loads}
    assert asked <= prepared, asked - prepared


def _cache_files(root: Path) -> set[str]:
    return {str(p.relative_to(root)) for p in root.rglob("*") if p.is_file()}


def _hertzian(*args, cache: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "WARP_CACHE_PATH": str(cache), "HERTZIAN_CACHE": str(cache / "calibration.json")}
    return subprocess.run(
        [sys.executable, "-m", "hertzian.cli", *map(str, args)], capture_output=True, text=True, env=env
    )


def test_warmup_then_run_compiles_nothing(tmp_path):
    scene = tmp_path / "scene.toml"
    scene.write_text(
        "[chain]\ngrains = 40\n[integrator]\nduration = 0.2\n"
        '[record]\nevery = 0.1\ntraces = [0, 39]\ntrace_every = 0.01\nfields = ["u"]\n'
    )
    cache = tmp_path / "warp-cache"
    warm = _hertzian("warmup", scene, "--device", "cpu", cache=cache)
    assert warm.returncode == 0, warm.stderr
    before = _cache_files(cache)
    assert before
    run = _hertzian("run", scene, "--device", "cpu", "--out", tmp_path / "o.zarr", "--quiet", cache=cache)
    assert run.returncode == 0, run.stderr
    assert _cache_files(cache) == before


def test_warmup_refuses_bad_input_in_one_line(tmp_path):
    result = _hertzian("warmup", "--paper", "--detect", tmp_path / "base.toml", cache=tmp_path / "c")
    assert result.returncode == 2
    assert result.stderr.count("\n") == 1 and result.stderr.startswith("error: ")
    assert not (tmp_path / "c").exists()


def test_cpu_auto_takes_the_chain_kernel_for_a_short_run():
    model = build_model([make_scene(chain={"grains": 20})], "cpu")
    assert model.chain_count * model.grain_count * 10 < 1e3
    assert choose_config(model, "auto", run_steps=10) == CHAIN
    assert step_reason(model, 10) is None
