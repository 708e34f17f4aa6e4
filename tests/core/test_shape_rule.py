"""The launch shape a GPU run takes without timing (hertzian.core.solvers.shape_rule) and ``hertzian tune``, which
times it: the shipped rule gives the shapes that timing every candidate chose on the GPUs on record, no run times
anything, and tune remembers what it measured. Decided on stand-in GPU models; the timing itself runs on the CPU."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from hertzian.core.model import build_model
from hertzian.core.solvers import calibrate
from hertzian.core.solvers.shape_rule import rule_for, shape_rules
from hertzian.kernels.features import Features

from tests.helpers import assert_refused, chains, invoke, make_scene

H100 = SimpleNamespace(name="cuda:0", is_cpu=False, is_cuda=True, sm_count=132, arch=90)
ON_RECORD = shape_rules()["architectures"]["90"]["calibrated"]


def gpu_model(features: Features, grains: int, chain_count: int, device=H100):
    return SimpleNamespace(features=features, device=device, grain_count=grains, chain_count=chain_count)


def shape_of(config, grains: int, chain_count: int) -> dict:
    """What makes a launch: kind, G, K, warps per chain (padding lanes in a chain's last warp cost nothing) and,
    for windows, blocks per chain."""
    from hertzian.core.solvers.tile import tile_plan

    s = config.shape
    out = {
        "kind": config.kind,
        "grains_per_lane": s.grains_per_lane,
        "warps": -(-s.lanes_per_chain // 32),
        "steps_per_launch": config.steps_per_launch,
    }
    if s.windowed:
        out["blocks_per_chain"] = tile_plan(config, grains, chain_count).blocks_per_chain
    return out


@pytest.mark.parametrize("entry", ON_RECORD, ids=[f"{e['workload']} {e['grains']}x{e['chains']}" for e in ON_RECORD])
def test_the_rule_gives_the_shape_timing_chose_on_record(entry, tmp_path, monkeypatch):
    monkeypatch.setenv("HERTZIAN_CACHE", str(tmp_path / "none.json"))
    n, count = entry["grains"], entry["chains"]
    model = gpu_model(replace(Features(), **entry["features"]), n, count)
    recorded = {k: entry[k] for k in ("kind", "grains_per_lane", "steps_per_launch", "blocks_per_chain") if k in entry}
    recorded["warps"] = -(-entry["lanes_per_chain"] // 32)
    got = shape_of(calibrate.choose_config(model, "auto", run_steps=10**6), n, count)
    if "rule_differs" in entry:
        assert got != recorded and got["kind"] == recorded["kind"], got
    else:
        assert got == recorded


def test_chain_lengths_share_lane_buckets(tmp_path, monkeypatch):
    # whole chains take lanes in whole warps, long windows 128 lanes: a sweep of chain.grains from 100 to 10 000 on
    # 16 384 chains needs a handful of compiled shapes, not one per length
    monkeypatch.setenv("HERTZIAN_CACHE", str(tmp_path / "none.json"))
    lengths = [100 + k * (10000 - 100) // 19 for k in range(20)]
    configs = {calibrate.choose_config(gpu_model(Features(), n, 16384), "auto") for n in lengths}
    assert len(configs) == 4, sorted(c.describe() for c in configs)  # docs/architecture.md, "The family"
    for config in configs:
        assert config.shape.lanes_per_chain % 32 == 0 and (config.shape.masked or config.shape.windowed)


def test_an_architecture_without_measurements_takes_the_fallback_rule(tmp_path, monkeypatch):
    monkeypatch.setenv("HERTZIAN_CACHE", str(tmp_path / "none.json"))
    assert rule_for(120)[0] == shape_rules()["fallback"] == rule_for(90)[0]
    newer = SimpleNamespace(**{**vars(H100), "arch": 120})
    for grains, count in ((500, 10000), (1000, 1), (4096, 16384)):
        assert calibrate.choose_config(gpu_model(Features(), grains, count, newer), "auto") == calibrate.choose_config(
            gpu_model(Features(), grains, count), "auto"
        )


@pytest.mark.parametrize("kernel", ["auto", "fused", "tile", "window"])
def test_no_run_times_a_shape(kernel, tmp_path, monkeypatch):
    # a long run on a GPU used to time the candidate shapes before its first step; now only `hertzian tune` does
    monkeypatch.setenv("HERTZIAN_CACHE", str(tmp_path / "none.json"))

    def timing(*args, **kwargs):
        raise AssertionError("a run timed a shape")

    monkeypatch.setattr(calibrate, "calibrate", timing)
    monkeypatch.setattr(calibrate, "time_solver", timing)
    for grains, count in ((500, 10000), (1000, 1), (4096, 16384), (1000, 16384)):
        config = calibrate.choose_config(gpu_model(Features(), grains, count), kernel, run_steps=10**7)
        assert config.kind in (("tile", "window") if kernel in ("auto", "fused") else (kernel,))
    assert not (tmp_path / "none.json").exists()


def test_a_forced_kind_takes_the_tuned_shape_only_of_its_kind(tmp_path, monkeypatch):
    cache = tmp_path / "calibration.json"
    monkeypatch.setenv("HERTZIAN_CACHE", str(cache))
    model = gpu_model(Features(), 1000, 16384)
    rule_tile = calibrate.choose_config(model, "tile")
    tuned_tile = next(c for c in calibrate.whole_chain_configs(model) if c != rule_tile)
    cache.write_text(json.dumps({calibrate._cache_key(model): tuned_tile.to_dict()}))
    assert calibrate.choose_config(model, "tile") == tuned_tile
    assert calibrate.choose_config(model, "auto") == tuned_tile
    window = calibrate.choose_config(model, "window")
    assert window.kind == "window" and window == calibrate._forced_config(model, "window")


def test_tune_times_the_rule_beside_the_candidates_and_remembers_the_fastest(tmp_path, monkeypatch):
    from hertzian.studies.tune import describe_row, tune_model

    cache = tmp_path / "calibration.json"
    monkeypatch.setenv("HERTZIAN_CACHE", str(cache))
    model = build_model(chains(4, chain={"grains": 24}, integrator={"events": "off", "duration": 0.01}), "cpu")
    row = tune_model(model, "tile")
    fastest, rule = row["fastest"], row["rule"]
    assert fastest["grain_steps_per_second"] >= rule["grain_steps_per_second"] > 0
    assert row["rule_gap"] == pytest.approx(1 - rule["grain_steps_per_second"] / fastest["grain_steps_per_second"])
    remembered = calibrate.cached_config(model)
    assert remembered is not None and remembered.describe() == fastest["shape"]
    assert "24 grains x 4 chains" in describe_row(row) and "% slower" in describe_row(row)


def test_tune_on_a_cpu_writes_nothing_and_bad_input_is_one_line(tmp_path, monkeypatch):
    monkeypatch.setenv("HERTZIAN_CACHE", str(tmp_path / "calibration.json"))
    done = invoke("tune", "example", "--device", "cpu", "--json")
    assert done.exit_code == 0 and json.loads(done.stdout)["groups"] == []
    assert not (tmp_path / "calibration.json").exists()
    for args, key in (
        ((), "tune: PATH, --paper"),
        (("example", "--paper"), "tune: PATH, --paper"),
        (("example", "--quick"), "tune: --quick"),
        (("example", "--kernel", "step"), "--kernel"),
        ((str(tmp_path / "missing.toml"),), "path"),
    ):
        assert_refused(invoke("tune", *args, "--device", "cpu"), tmp_path / "calibration.json", key)


def test_tune_builds_the_launch_groups_warmup_names():
    # the models tune times are the launch groups a sweep runs (as hertzian warmup names them) and a scene's one run
    from hertzian.core.shipped import shipped_file
    from hertzian.studies.tune import scene_or_sweep_models
    from hertzian.sweeping.distributed import sweep_needs

    sweep = shipped_file(Path("example"))
    built = [(m.features, m.grain_count, m.chain_count) for m in scene_or_sweep_models(sweep, "cpu")]
    named = [(n.features, n.grains, n.chains) for n in sweep_needs(sweep, {}, "cpu")]
    assert built == named and len(built) >= 1
    (scene,) = scene_or_sweep_models(shipped_file(Path("impact")), "cpu")
    assert scene.chain_count == 1 and scene.grain_count > 1


@pytest.mark.parametrize(
    "features",
    [Features(), replace(Features(), method="gear6", event_window=1.0), replace(Features(), surface="driven")],
    ids=["plain", "gear6 events", "driven"],
)
def test_every_length_and_count_takes_a_shape_of_the_family(features, tmp_path, monkeypatch):
    # what `hertzian warmup --any-length` compiles: any chain from 2 to 10^5 grains, in any number, then finds its
    # kernel compiled (drawn at random, not from the lengths the enumeration asks about)
    from hertzian.core.solvers.calibrate import shape_family

    monkeypatch.setenv("HERTZIAN_CACHE", str(tmp_path / "none.json"))
    family = {config for config, _, _ in shape_family(features)}
    assert 4 <= len(family) <= 16, len(family)
    rng = np.random.default_rng(0)
    grains = np.exp(rng.uniform(np.log(2), np.log(100_000), 200)).astype(int)
    counts = np.exp(rng.uniform(0, np.log(50_000), 200)).astype(int)
    for n, c in zip(grains, counts):
        config = calibrate.choose_config(gpu_model(features, int(n), int(c)), "auto")
        assert config in family, (n, c, config.describe())


def test_warmup_any_length_names_the_family_and_the_long_chains_records():
    import warp as wp
    from hertzian.core.scene import load_scene
    from hertzian.core.shipped import shipped_file
    from hertzian.core.solvers.calibrate import shape_family
    from hertzian.kernels.records import STAGED_GRAINS
    from hertzian.studies.warmup import any_length_needs, scene_needs

    needs = scene_needs(make_scene(chain={"grains": 50}))
    on_gpu = any_length_needs(needs, H100)
    assert {n.kernel for n in on_gpu} == {config for config, _, _ in shape_family(needs[0].features)}
    assert any(n.grains >= STAGED_GRAINS and n.kernel.kind == "window" for n in on_gpu)
    (on_cpu,) = any_length_needs(needs, wp.get_device("cpu"))
    assert (on_cpu.grains, on_cpu.kernel) == (STAGED_GRAINS, "fused")
    readme = scene_needs(load_scene(shipped_file(Path("impact"))))[0].features
    assert len(shape_family(readme)) == 12  # docs/fixed-costs.md, "hertzian warmup"
    listed = invoke("warmup", "example", "--any-length", "--dry-run", "--device", "cpu", "--json")
    assert listed.exit_code == 0 and "record_long" in listed.stdout, listed.output
