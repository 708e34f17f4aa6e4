"""Fixed costs: every kernel a job launches is named and compiled before its first launch
(hertzian.core.solvers.compile), ``hertzian warmup`` fills Warp's cache so a run compiles nothing, and ``auto``
on a CPU takes the kernel that compiles and runs sooner, a cached kernel counting no compile."""

from __future__ import annotations

import os
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import pytest
import warp as wp
from hertzian.core.model import build_model, features_of
from hertzian.core.runner import Runner
from hertzian.core.solvers import CHAIN, STEP, calibrate, choose_config
from hertzian.core.solvers.calibrate import CPU_COSTS, cpu_auto_config, cpu_crossovers, cpu_seconds, step_reason
from hertzian.core.solvers.prepare import Need, kernel_variants, prepare_kernels
from hertzian.studies.warmup import scene_needs

from tests.helpers import hertzian, make_scene

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


@pytest.mark.parametrize("cpu_blocks", [False, True], ids=["", "after a tile kernel"])
@pytest.mark.parametrize("name", SCENES)
def test_prepare_names_every_kernel_a_run_loads(name, cpu_blocks, loads, monkeypatch):
    # a tile kernel run on the CPU turns Warp's CPU blocks on for the process (Solver.load); a run after it must
    # still load only what prepare named
    monkeypatch.setattr(wp.config, "enable_cpu_blocks", cpu_blocks)
    scene = make_scene(**SCENES[name])
    needs = scene_needs(scene)
    prepared = {(module.name, cpu_block(block)) for module, block in kernel_variants(needs, "cpu")}
    prepare_kernels(needs, "cpu")
    loads.clear()
    Runner(build_model([scene], "cpu")).run()
    asked = {(module, cpu_block(block)) for module, block in loads}
    assert asked <= prepared, asked - prepared


def test_a_run_recording_fields_prepares_no_traced_start_gather_and_loads_nothing_else(loads):
    """Record 0's snapshot holds the traced grains' start, so the gather is neither prepared nor launched."""
    scene = make_scene(chain={"grains": 30}, record={"every": 0.005, "traces": [0, 29], "fields": ["u"]})
    need = Need(features_of([scene]), 30, 1, scene.step_count, fields=True)
    prepared = {(module.name, cpu_block(block)) for module, block in kernel_variants([need], "cpu")}
    assert not any("traced_start" in name for name, _ in prepared), prepared
    assert any("traced_start" in module.name for module, _ in kernel_variants([replace(need, fields=False)], "cpu"))
    prepare_kernels([need], "cpu")
    loads.clear()
    Runner(build_model([scene], "cpu")).run()
    asked = {(module, cpu_block(block)) for module, block in loads}
    assert asked <= prepared, asked - prepared


def _cache_files(root: Path) -> set[str]:
    return {str(p.relative_to(root)) for p in root.rglob("*") if p.is_file()}


def _modules(root: Path) -> set[str]:
    """The kernel modules in a Warp cache (folder names, without the per-build hash suffix)."""
    return {p.name.rsplit("_", 1)[0] for p in root.rglob("wp_*") if p.is_dir()}


def _hertzian(*args, cache: Path) -> subprocess.CompletedProcess:
    """``hertzian ARGS`` in a subprocess whose Warp kernel cache and calibration file are under ``cache``."""
    return hertzian(
        *args, env={**os.environ, "WARP_CACHE_PATH": str(cache), "HERTZIAN_CACHE": str(cache / "calibration.json")}
    )


WARMUP_SCENES = {
    "hertz, traces": "[chain]\ngrains = 40\n[integrator]\nduration = 0.2\n"
    '[record]\nevery = 0.1\ntraces = [0, 39]\ntrace_every = 0.01\nfields = ["u"]\n',
    "fput ring, mode energies": '[chain]\ngrains = 16\npotential = "fput"\na = 1.0\nbeta = 1.0\n'
    '[boundary]\nsurface = "periodic"\nbottom = "periodic"\n[excitation]\nthermal = 0.1\n'
    '[integrator]\nmethod = "yoshida6"\ndt = 0.05\nduration = 100.0\n[record]\nevery = 5.0\nfields = ["u"]\nmodes = true\n',
}


@pytest.mark.parametrize("case", list(WARMUP_SCENES))
def test_warmup_then_run_compiles_nothing(tmp_path, case):
    scene = tmp_path / "scene.toml"
    scene.write_text(WARMUP_SCENES[case])
    cache = tmp_path / "warp-cache"
    warm = _hertzian("warmup", scene, "--device", "cpu", cache=cache)
    assert warm.returncode == 0, warm.stderr
    before = _cache_files(cache)
    assert before
    run = _hertzian("run", scene, "--device", "cpu", "--out", tmp_path / "o.zarr", "--quiet", cache=cache)
    assert run.returncode == 0, run.stderr
    assert _cache_files(cache) == before
    # and nothing more: a run on a cold cache compiles the same modules (a run recording fields, no traced start)
    cold = tmp_path / "cold-cache"
    alone = _hertzian("run", scene, "--device", "cpu", "--out", tmp_path / "p.zarr", "--quiet", cache=cold)
    assert alone.returncode == 0, alone.stderr
    assert _modules(cold) == _modules(cache)


DETECT_BASE = (
    '[chain]\ngrains = 40\nl0 = 1e-4\n[excitation]\nimpact = 1e-2\n[integrator]\nmethod = "gear4"\ndt = 1e-3\n'
)


def test_warmup_detect_then_detect_compiles_nothing(tmp_path):
    """``warmup --detect BASE`` names every variant a first detection launches (detect prepares the same list)."""
    base, planted = tmp_path / "base.toml", tmp_path / "planted.toml"
    base.write_text(DETECT_BASE + "duration = 1.0\n")
    planted.write_text(
        DETECT_BASE
        + "duration = 3.0\n[record]\ntraces = [0]\ntrace_every = 0.01\n[[impurities]]\ngrains = [8]\nmass = 0.4\n"
    )
    signal = tmp_path / "planted.zarr"
    made = _hertzian("run", planted, "--device", "cpu", "--out", signal, "--quiet", cache=tmp_path / "other")
    assert made.returncode == 0, made.stderr
    cache = tmp_path / "warp-cache"
    warm = _hertzian("warmup", "--detect", base, "--device", "cpu", cache=cache)
    assert warm.returncode == 0, warm.stderr
    before = _cache_files(cache)
    env = {"HERTZIAN_DETECT_CACHE": str(tmp_path / "library")}
    found = hertzian(
        "detect",
        signal,
        "--scene",
        base,
        "--noise",
        "1e-5",
        "--device",
        "cpu",
        "--json",
        env={**os.environ, **env, "WARP_CACHE_PATH": str(cache), "HERTZIAN_CACHE": str(cache / "calibration.json")},
    )
    assert found.returncode == 0, found.stderr
    assert _cache_files(cache) == before


def test_warmup_refuses_bad_input_in_one_line(tmp_path):
    result = _hertzian("warmup", "--paper", "--detect", tmp_path / "base.toml", cache=tmp_path / "c")
    assert result.returncode == 2
    assert result.stderr.count("\n") == 1 and result.stderr.startswith("error: ")
    assert not (tmp_path / "c").exists()


def test_cpu_auto_takes_the_chain_kernel_for_a_long_run():
    model = build_model([make_scene(chain={"grains": 20})], "cpu")
    assert choose_config(model, "auto", run_steps=None) == CHAIN
    assert choose_config(model, "auto", run_steps=10**9) == CHAIN
    assert step_reason(model, 10) is None


@pytest.mark.parametrize("chain_cached", [False, True])
@pytest.mark.parametrize("step_cached", [False, True])
def test_cpu_auto_rule_counts_only_uncached_compiles(monkeypatch, chain_cached, step_cached):
    """The rule against the cost model written out by hand: seconds = compile (unless cached) + work / rate."""
    costs = {"step": (2.0, 1e6), "chain": (5.0, 4e6)}  # crossovers: 4e6 (none cached), 6.67e6 (step cached)
    cached = {"chain": chain_cached, "step": step_cached}
    monkeypatch.setattr(
        calibrate, "in_kernel_cache", lambda module, device: cached["chain" if "chain" in module.name else "step"]
    )
    features = build_model([make_scene(chain={"grains": 20})], "cpu").features
    crossover = 4e6 if not step_cached else 5.0 / (1 / 1e6 - 1 / 4e6)
    assert cpu_crossovers(costs)["step_cached" if step_cached else "none_cached"] == pytest.approx(crossover)
    for work in (1e3, 0.5 * crossover, 2 * crossover, 1e12):
        expected = CHAIN if chain_cached or work > crossover else STEP
        assert cpu_auto_config(features, work, "cpu", costs) == expected, work


def test_cpu_auto_rule_counts_a_composed_method_s_substeps(monkeypatch):
    """yoshida6 takes seven substeps per step (seven per-step launches): its work is seven times its grain-steps, so
    the chain kernel pays where gear4's same grain-steps would not."""
    costs = {"step": (2.0, 1e6), "chain": (5.0, 4e6)}  # crossover 4e6 grain-steps, neither cached
    monkeypatch.setattr(calibrate, "in_kernel_cache", lambda module, device: False)
    composed = build_model([make_scene(chain={"grains": 20}, integrator={"method": "yoshida6"})], "cpu").features
    plain = build_model([make_scene(chain={"grains": 20})], "cpu").features
    assert cpu_auto_config(plain, 1e6, "cpu", costs) == STEP
    assert cpu_auto_config(composed, 1e6, "cpu", costs) == CHAIN


PROBE = """
import sys
from hertzian.core.model import build_model, features_of
from hertzian.core.scene import load_scene
from hertzian.core.solvers import choose_config
model = build_model([load_scene(sys.argv[1])], "cpu")
print(choose_config(model, "auto", run_steps=model.scenes[0].step_count).kind)
"""


def test_cpu_auto_reads_the_kernel_cache(tmp_path):
    """A tiny run on an empty Warp cache takes the kernel CPU_COSTS say compiles and runs sooner; after
    ``hertzian warmup`` of the same scene, the chain kernel."""
    scene = tmp_path / "scene.toml"
    scene.write_text('[chain]\ngrains = 20\n[integrator]\nduration = 0.01\n[record]\nevery = 0.01\nfields = ["u"]\n')
    cache = tmp_path / "warp-cache"
    env = {**os.environ, "WARP_CACHE_PATH": str(cache), "HERTZIAN_CACHE": str(cache / "calibration.json")}

    def choice() -> str:
        probe = subprocess.run([sys.executable, "-c", PROBE, scene], capture_output=True, text=True, env=env)
        assert probe.returncode == 0, probe.stderr
        return probe.stdout.split()[-1]

    work = 20 * 800  # grain-steps: 0.01 / dt 1.25e-5
    cheaper = min(("chain", "step"), key=lambda kind: cpu_seconds(kind, work, False, CPU_COSTS))
    assert choice() == cheaper
    warm = _hertzian("warmup", scene, "--device", "cpu", cache=cache)
    assert warm.returncode == 0, warm.stderr
    assert choice() == "chain"


PCH_PROBE = """
import sys
import warp as wp
from hertzian.core.devices import init_warp
from hertzian.kernels.features import KERNEL_OPTIONS

init_warp()
scale = float(sys.argv[1])

@wp.kernel(module="unique", module_options=KERNEL_OPTIONS)
def scaled(x: wp.array(dtype=wp.float64)):
    x[wp.tid()] = x[wp.tid()] * wp.float64(scale)

wp.load_module(scaled.module, device="cpu")
print(wp._src.context.runtime.get_clang_pch_dir())
"""


def test_cpu_precompiled_header_is_built_once_in_the_kernel_cache(tmp_path):
    """Two processes compiling different CPU modules: the first builds Warp's precompiled header into the kernel
    cache, the second compiles against that same file and builds none of its own."""
    cache = tmp_path / "warp-cache"
    env = {**os.environ, "WARP_CACHE_PATH": str(cache)}
    script = tmp_path / "probe.py"  # Warp reads a kernel's source from its file
    script.write_text(PCH_PROBE)
    folders, headers = [], []
    for scale in ("2.0", "3.0"):  # two kernels, two modules: each process compiles
        probe = subprocess.run([sys.executable, script, scale], capture_output=True, text=True, env=env)
        assert probe.returncode == 0, probe.stderr
        folders.append(Path(probe.stdout.split()[-1]))
        headers.append({p: p.stat().st_mtime_ns for p in cache.rglob("*.pch")})
    assert folders[0] == folders[1] and cache in folders[0].parents, folders
    assert len(headers[0]) == 1 and next(iter(headers[0])).parent == folders[0], headers[0]
    assert headers[1] == headers[0]  # the second process read it, did not write it again


PRIMER_PROBE = """
import sys, threading
from pathlib import Path
import warp as wp
import warp._src.build as build
from hertzian.core import devices
from hertzian.core.solvers.compile import load_variants
from hertzian.kernels.features import KERNEL_OPTIONS

seen = []  # (thread, whether the header existed when that compile began)
original = build.build_cpu

def build_cpu(*args, pch_dir=None, **kwargs):
    seen.append((threading.current_thread().name, any(Path(pch_dir).glob("*_bd1_*.pch"))))
    return original(*args, pch_dir=pch_dir, **kwargs)

build.build_cpu = build_cpu
devices.init_warp()
started = devices._header_primer is not None
if not started:  # a machine with CUDA: the compiles below start it
    assert wp.is_cuda_available()

def unique_kernel(scale):
    @wp.kernel(module="unique", module_options=KERNEL_OPTIONS)
    def scaled(x: wp.array(dtype=wp.float64)):
        x[wp.tid()] = x[wp.tid()] * wp.float64(scale)
    return scaled

kernels = [unique_kernel(s) for s in (2.0, 3.0, 5.0)]
workers, _ = load_variants([(k.module, None) for k in kernels], "cpu", max_workers=2)
print(repr((workers, started, seen)))
"""


def test_cpu_compiles_on_an_empty_cache_wait_for_one_precompiled_header(tmp_path):
    """On an empty kernel cache the precompiled header is built once, by the primer thread (started when Warp starts
    on a machine without CUDA, else by the first threaded CPU compile): every other compile, in two threads, begins
    with the header in place instead of building its own."""
    cache = tmp_path / "warp-cache"
    script = tmp_path / "probe.py"  # Warp reads a kernel's source from its file
    script.write_text(PRIMER_PROBE)
    probe = subprocess.run(
        [sys.executable, script], capture_output=True, text=True, env={**os.environ, "WARP_CACHE_PATH": str(cache)}
    )
    assert probe.returncode == 0, probe.stderr
    workers, started, seen = eval(probe.stdout.strip().splitlines()[-1])  # noqa: S307 (our own probe's repr)
    assert workers == 2 and (started or wp.is_cuda_available())
    primer = [has for name, has in seen if name == "hertzian-header-primer"]
    others = [has for name, has in seen if name != "hertzian-header-primer"]
    assert primer == [False] and others == [True, True, True], seen
    assert len(list(cache.rglob("*.pch"))) == 1


def test_an_abandoned_temporary_header_is_removed_and_a_fresh_one_kept(tmp_path):
    """A process that ended while building the header leaves clang's empty temporary file; the next primer removes
    those older than a minute, and never one another process may still be writing."""
    from hertzian.core.devices import _remove_abandoned_headers

    old, fresh = tmp_path / "builtin_bd1_x-1.pch.tmp", tmp_path / "builtin_bd1_x-2.pch.tmp"
    header = tmp_path / "builtin_bd1_x.pch"
    for path in (old, fresh, header):
        path.write_bytes(b"")
    os.utime(old, (0, 0))
    os.utime(header, (0, 0))
    _remove_abandoned_headers(tmp_path)
    assert not old.exists() and fresh.exists() and header.exists()
