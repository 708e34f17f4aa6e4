"""``hertzian bench`` on the CPU: records, the equality check across implementations, bad input."""

from __future__ import annotations

import json
import time
from datetime import datetime, timezone

import numpy as np
import pytest
from hertzian.core.model import build_model
from hertzian.studies.bench import bench_scenes
from hertzian.studies.peers import NumpyGear4, problem_from_model

from tests.helpers import invoke, per_step


def plain_gear(scenes):
    """The peers integrate plain Gear steps: compare with the per-step kernel's plain steps (events off)."""
    return [s.with_overrides({"integrator.events": "off"}) for s in scenes]


def test_bench_json_records():
    days = {datetime.now(timezone.utc).date().isoformat()}
    started = time.perf_counter()
    result = invoke(
        "bench", "--device", "cpu", "--chains", "3,1", "--grains", "40,60", "--steps", "20", "--repeats", "1", "--json"
    )
    elapsed = time.perf_counter() - started
    days.add(datetime.now(timezone.utc).date().isoformat())
    assert result.exit_code == 0, result.output
    records = json.loads(result.stdout)
    names = {(r["implementation"], r["chains"], r["grains"]) for r in records}
    assert {("warp-step", 3, 40), ("warp-chain", 3, 40), ("numpy", 3, 40), ("warp-step", 1, 60)} <= names
    for r in records:
        assert r["grain_steps_per_second"] > 0
        # the timed steps ran inside this call: the rate cannot be slower than the whole call allows
        assert (
            0 < r["seconds"] < elapsed
            and r["grain_steps_per_second"] > r["chains"] * r["grains"] * r["steps"] / elapsed
        )
        assert r["date"] in days  # the measurement's own date, not a constant
        assert 0 < r["ratio_to_best"] <= 1
        assert r["max_relative_difference"] <= 1e-10
        assert r["bytes_per_grain_step"] == 64


def test_numpy_peer_matches_per_step_kernel():
    # the peer is written from the equations, independently of the kernels: same state after 50 steps
    model = build_model(plain_gear(bench_scenes(4, 30)), "cpu")
    peer = NumpyGear4(problem_from_model(model))
    peer.run(50)
    want = per_step(model, 50)
    assert np.max(np.abs(peer.state() - want)) <= 1e-13 * np.max(np.abs(want))


def test_numpy_peer_matches_per_step_kernel_on_fput():
    # the β-FPUT ensemble of ``bench --law fput``: the peer's FPUT force against the kernels', after 50 steps of a
    # nonlinear pulse (a Hertz force in its place would be far off: the comparison sees the law)
    from dataclasses import replace

    model = build_model(plain_gear(bench_scenes(4, 30, "fput")), "cpu")
    problem = problem_from_model(model)
    assert problem.fput == (0.0, 1.0)
    want = per_step(model, 50)
    peer = NumpyGear4(problem)
    peer.run(50)
    assert np.max(np.abs(peer.state() - want)) <= 1e-13 * np.max(np.abs(want))
    harmonic = NumpyGear4(replace(problem, fput=(0.0, 0.0)))
    harmonic.run(50)
    assert np.max(np.abs(harmonic.state() - want)) > 1e-6 * np.max(np.abs(want))


def test_bench_bad_input():
    for args, key in (
        (["--chains", "0"], "--chains"),
        (["--grains", "x"], "--grains"),
        (["--device", "cpu", "--grains", "1"], "--grains"),
        (["--kernel", "fastest"], "--kernel"),
        (["--device", "cpu", "--kernel", "tile"], "--kernel"),
        (["--chains", "1,2", "--grains", "5,6,7"], "--grains"),
        (["--law", "toda"], "--law"),
    ):
        result = invoke("bench", *args)
        assert result.exit_code == 2, (args, result.output)
        assert result.output.strip().startswith(f"error: {key} = ")
        assert "Traceback" not in result.output
    refused = invoke("bench", "--device", "cpu", "--scale-out", "0", "--sweep", "example")
    assert (
        refused.exit_code == 2
        and refused.output == "error: --scale-out = '0': integers ≥ 1, comma-separated (e.g. 1,2,4)\n"
    )


def test_jax_peer_matches_per_step_kernel():
    # tuple carry, scalar constants, searched unroll: still the same equations (skipped without JAX)
    pytest.importorskip("jax")
    from hertzian.studies.peers import JaxGear4

    model = build_model(plain_gear(bench_scenes(3, 20)), "cpu")
    peer = JaxGear4(problem_from_model(model), "cpu")
    peer.run(50)
    assert peer.unroll in JaxGear4.UNROLLS
    want = per_step(model, 50)
    assert np.max(np.abs(peer.state() - want)) <= 1e-12 * np.max(np.abs(want))


def test_end_to_end_scene_json(tmp_path):
    scene = tmp_path / "traced.toml"
    scene.write_text(
        "[chain]\ngrains = 30\nl0 = 1e-4\n[excitation]\nimpact = 1e-2\n"
        "[integrator]\ndt = 5e-4\nduration = 0.4\n"
        '[record]\nevery = 0.1\nfields = ["u"]\ntraces = [0, 29]\ntrace_every = 0.002\n'
    )
    started = time.perf_counter()
    result = invoke("bench", "--device", "cpu", "--scene", str(scene), "--kernel", "chain", "--json")
    elapsed = time.perf_counter() - started
    assert result.exit_code == 0, result.output
    (record,) = json.loads(result.stdout)
    assert record["kernel"] == "chain" and record["steps"] == 800 and record["grain_steps"] == 30 * 800
    s = record["seconds"]
    parts = s["build"] + s["compile"] + s["kernel"] + s["record"] + s["store"]
    assert 0 < s["kernel"] and 0 < s["store"] and parts <= s["total"] < elapsed
    assert 0 < s["startup"] and s["startup"] + s["total"] < elapsed  # the device made ready before the clock
    assert 0 < record["device_busy"] <= 1


def test_end_to_end_sweep_json(tmp_path):
    sweep = tmp_path / "sweep.toml"
    sweep.write_text(
        "[scene.chain]\ngrains = 20\nl0 = 1e-4\n[scene.excitation]\nimpact = 1e-2\n"
        '[scene.integrator]\ndt = 5e-4\nduration = 0.2\n[scene.record]\nevery = 0.1\nfields = ["u"]\n'
        '[[axis]]\nname = "v_imp"\nkey = "excitation.impact"\nvalues = [1e-3, 1e-2, 2e-2]\n'
    )
    result = invoke("bench", "--device", "cpu", "--sweep", str(sweep), "--kernel", "chain", "--json")
    assert result.exit_code == 0, result.output
    (record,) = json.loads(result.stdout)
    assert record["kernel"] == "chain" and record["grain_steps"] == 3 * 20 * 400
    s = record["seconds"]
    assert 0 < s["kernel"] and 0 < s["store"] and s["build"] + s["kernel"] + s["store"] <= s["total"]
    assert 0 < s["startup"]


def test_end_to_end_bad_input(tmp_path):
    for args, key in (
        (["--scene", str(tmp_path / "none.toml")], "--scene"),
        (["--scene", "a.toml", "--sweep", "b.toml"], "--sweep"),
    ):
        (tmp_path / "a.toml").write_text("")
        result = invoke("bench", *args)
        assert result.exit_code == 2, (args, result.output)
        assert result.output.strip().startswith(f"error: {key} = ")
        assert "Traceback" not in result.output
    refused = invoke("bench", "--device", "cpu", "--scale-out", "0", "--sweep", "example")
    assert (
        refused.exit_code == 2
        and refused.output == "error: --scale-out = '0': integers ≥ 1, comma-separated (e.g. 1,2,4)\n"
    )


def test_jax_peer_matches_per_step_kernel_on_fput():
    # the JAX peer's FPUT force against the kernels' (skipped without JAX)
    pytest.importorskip("jax")
    from hertzian.studies.peers import JaxGear4

    model = build_model(plain_gear(bench_scenes(3, 20, "fput")), "cpu")
    peer = JaxGear4(problem_from_model(model), "cpu")
    peer.run(50)
    want = per_step(model, 50)
    assert np.max(np.abs(peer.state() - want)) <= 1e-12 * np.max(np.abs(want))


def test_bench_all_on_a_gpu_measures_the_rule_s_shape_beside_the_fastest(tmp_path, monkeypatch):
    # `hertzian bench` on a GPU times tile and window kernels in their fastest shapes, and the shape a run takes
    # untuned (the shipped rule's), whatever `hertzian tune` remembered: their ratio is the rule's cost
    import json
    from types import SimpleNamespace

    from hertzian.core.solvers import calibrate
    from hertzian.kernels.features import Features
    from hertzian.studies.bench import bench_config, bench_kernel_names

    assert bench_kernel_names("all", True) == ["step", "tile", "window", "rule"]
    assert bench_kernel_names("all", False) == ["step", "chain"] and bench_kernel_names("tile", True) == ["tile"]
    monkeypatch.setenv("HERTZIAN_CACHE", str(tmp_path / "calibration.json"))
    gpu = SimpleNamespace(name="cuda:0", is_cpu=False, is_cuda=True, sm_count=132, arch=90)
    model = SimpleNamespace(features=Features(), device=gpu, grain_count=1000, chain_count=16384)
    rule = calibrate.default_config(model)
    tuned = next(c for c in calibrate.whole_chain_configs(model) if c != rule)
    (tmp_path / "calibration.json").write_text(json.dumps({calibrate._cache_key(model): tuned.to_dict()}))
    assert calibrate.choose_config(model, "auto") == tuned
    assert bench_config(model, "rule", None, None) == rule


def test_a_bench_run_is_added_to_its_record(tmp_path):
    """--record FILE --part NAME: each run's --json records, with its command, date and device, under
    parts.NAME.runs; a second run adds to the part, another part is kept; a user's file is refused, untouched."""
    path, scene = tmp_path / "bench.json", tmp_path / "tiny.toml"
    scene.write_text("[chain]\ngrains = 12\n[integrator]\ndt = 5e-4\nduration = 0.05\n[record]\nevery = 0.05\n")
    kernels = ("bench", "--device", "cpu", "--chains", "2", "--grains", "30", "--steps", "10", "--repeats", "1")
    printed = []
    for args in ((*kernels, "--part", "kernels"), ("bench", "--scene", str(scene), "--device", "cpu", "--part", "e2e")):
        for _ in range(1 if "kernels" in args else 2):
            result = invoke(*args, "--json", "--record", str(path))
            assert result.exit_code == 0, result.output
            printed.append(json.loads(result.stdout))
    parts = json.loads(path.read_text())["parts"]
    runs = parts["kernels"]["runs"] + parts["e2e"]["runs"]
    assert [len(parts["kernels"]["runs"]), len(parts["e2e"]["runs"])] == [1, 2]
    assert [run["records"] for run in runs] == printed
    assert all(run["command"].startswith("hertzian ") and run["device"] == "cpu" for run in runs)
    mine = tmp_path / "mine.json"
    mine.write_text('{"a": 1}')
    result = invoke(*kernels, "--record", str(mine))
    assert result.exit_code == 2 and "--record = " in result.output and mine.read_text() == '{"a": 1}'
    result = invoke("bench", "--scale-out", "1", "--record", str(path))
    assert result.exit_code == 2 and "not with --scale-out" in result.output
