"""Defaults chosen from measurements: the detection forward model's step from the signal's noise
(ensemble/studies/detection/step.py) and the defaults study (hertzian estimates --defaults)."""

from __future__ import annotations

import numpy as np
import pytest
from hertzian.core.scene import scene_from_dict
from hertzian.studies.detection import forward_scene, front_times, signal_from_arrays
from hertzian.studies.detection.step import NOISE_FRACTION, noise_step

from tests.reference import reference_run

SPACING = 0.01
SAMPLES = 201  # t = 0 … 2
SIGMA = 1e-6
"""σ of the noise added [program velocity], 1e-4 v_imp: small enough that the ladder must leave dt = spacing."""
BASE = {
    "chain": {"grains": 12, "l0": 1e-4},
    "excitation": {"impact": 1e-2},
    "integrator": {"method": "gear4", "duration": 1.0},
}


def reference_velocity(dt: float) -> np.ndarray:
    """Grain 0's velocity at the sample times from the NumPy reference (tests/reference.py), gear6 at ``dt``."""
    data = scene_from_dict(BASE).to_dict()
    data["integrator"].update(method="gear6", dt=dt, duration=SPACING * (SAMPLES - 1))
    data["record"].update(traces=[0], trace_every=SPACING, every=None, fields=[])
    return reference_run(data)["trace_v"][:, 0]


@pytest.fixture(scope="module")
def exact():
    """The reference at spacing/128, checked to resolve σ/10 against spacing/64."""
    fine, coarser = reference_velocity(SPACING / 128), reference_velocity(SPACING / 64)
    assert np.max(np.abs(fine - coarser)) < SIGMA / NOISE_FRACTION / 30
    return fine


def choose(exact, given=None):
    noise = np.random.default_rng(7).normal(scale=SIGMA, size=exact.size)
    signal = signal_from_arrays(np.arange(SAMPLES) * SPACING, exact + noise, source="test")
    base = scene_from_dict(BASE)
    fronts = front_times(forward_scene(base, SPACING, SAMPLES), "cpu")
    return signal, base, noise_step(signal, base, fronts, 6, None, "cpu", given=given)


def test_noise_step_keeps_the_model_within_a_tenth_of_sigma(exact):
    signal, base, choice = choose(exact)
    assert choice is not None and not choice.given and choice.used == choice.dt
    assert choice.dt < SPACING, "the case must need a step below the sample spacing"
    assert 0.5 < choice.sigma / SIGMA < 2  # the detector's own noise estimate
    from hertzian.studies.detection.step import clean_trace

    model = clean_trace(base, SPACING, SAMPLES, choice.dt, "cpu")
    assert np.max(np.abs(model - exact)) <= SIGMA / NOISE_FRACTION
    coarser = clean_trace(base, SPACING, SAMPLES, 2 * choice.dt, "cpu")
    assert np.max(np.abs(coarser - exact)) > choice.sigma / NOISE_FRACTION / 30, "the step is not needlessly small"


def test_a_needlessly_small_base_step_is_warned_about(exact):
    _, _, choice = choose(exact)
    _, _, small = choose(exact, given=choice.dt / 16)
    assert small.given and small.dt == choice.dt
    assert "16× smaller than the noise needs" in small.warning()
    _, _, enough = choose(exact, given=choice.dt / 8)
    assert enough.warning() is None


def test_dt_given_reads_the_file_and_the_sets(tmp_path):
    from hertzian.cli.detect import dt_given

    bare, stepped = tmp_path / "bare.toml", tmp_path / "stepped.toml"
    bare.write_text("[chain]\ngrains = 12\n[excitation]\nimpact = 1e-2\n")
    stepped.write_text("[chain]\ngrains = 12\n[integrator]\ndt = 1e-4\n")
    assert not dt_given(bare, None)
    assert dt_given(stepped, None)
    assert dt_given(bare, ["integrator.dt=1e-4"])


def test_defaults_study_keeps_the_cheapest_run_meeting_each_target():
    from hertzian.studies.estimates import defaults_study

    scene = scene_from_dict({**BASE, "integrator": {"method": "gear4", "dt": 1e-3, "duration": 0.5}})
    scene = scene.with_overrides({"record.every": 0.1, "record.fields": ["u"]})
    row = defaults_study("cpu", scenes={"small": scene}, dts=(1e-3, 5e-4), targets=(1e-6, 1e-30))["scenes"]["small"]
    meeting = [r for r in row["records"] if r["status"] == 0 and r["error"] <= 1e-6]
    # per (method, events) the largest step meeting the target, then the fastest of those: a smaller step
    # that happened to time faster is not the cheapest setting
    largest = {}
    for r in meeting:
        key = (r["method"], r["events"])
        if key not in largest or r["dt"] > largest[key]["dt"]:
            largest[key] = r
    assert largest and row["cheapest"]["1e-06"]["seconds"] == min(r["seconds"] for r in largest.values())
    for events in ("auto", "off"):
        ours = [r for r in largest.values() if r["events"] == events]
        best = row["cheapest_per_events"]["1e-06"][events]
        assert best["seconds"] == min(r["seconds"] for r in ours) and best["events"] == events
    assert row["cheapest"]["1e-30"] is None


ESTIMATE_SWEEP = """
[scene.chain]
grains = 6
l0 = 1e-4
[scene.excitation]
impact = 1e-2
[scene.integrator]
method = "gear4"
dt = 1e-3
duration = 0.2
[scene.record]
every = 0.1
[[axis]]
name = "v_imp"
key = "excitation.impact"
values = [1e-2, 2e-2]
"""


def test_estimates_cost_takes_the_chains_asked_for(tmp_path):
    """``--cost-chains`` sizes the cost case (a GPU's default fills the device, a CPU's stays at 64)."""
    import json

    from tests.helpers import invoke

    sweep, out = tmp_path / "s.toml", tmp_path / "r.json"
    sweep.write_text(ESTIMATE_SWEEP)
    result = invoke(
        "estimates", sweep, "--events", "auto", "--cost", "--cost-chains", "3", "--device", "cpu", "--json", out
    )
    assert result.exit_code == 0, result.output
    written = json.loads(out.read_text())
    cost = written["cost"]
    assert cost["chains"] == 3 and cost["ratio"] > 1.0
    assert written["device"] == "cpu" and written["date"].startswith("20") and written["command"].startswith("hertzian")
    refused = invoke("estimates", sweep, "--cost-chains", "0", "--device", "cpu")
    assert refused.exit_code == 2 and "--cost-chains = 0" in refused.output


def test_cost_feature_cases_carry_their_features():
    """Each ``--cost-features`` case compiles the kernel variant of its feature: a profile static state with
    impurities under gravity, a driven surface, viscous and contact damping; the walls case is the cost case."""
    from hertzian.core.model import features_of
    from hertzian.studies.estimates import COST_FEATURES, cost_scenes, feature_cost_scenes

    features = {case: features_of(feature_cost_scenes(case, chains=2)) for case in COST_FEATURES}
    assert features["walls"] == features_of(cost_scenes(2))
    assert (features["walls"].surface, features["walls"].bottom) == ("wall", "wall")
    assert features["gravity, impurities"].static == "profile" and features["gravity, impurities"].heterogeneous
    assert features["drive"].surface == "driven"
    assert features["viscous damping"].damping == "viscous" and features["contact damping"].damping == "contact"


def test_cost_features_need_cost(tmp_path):
    from tests.helpers import invoke

    sweep = tmp_path / "s.toml"
    sweep.write_text(ESTIMATE_SWEEP)
    refused = invoke("estimates", sweep, "--cost-features", "--device", "cpu")
    assert refused.exit_code == 2 and refused.output.strip() == "error: --cost-features = true: needs --cost"
