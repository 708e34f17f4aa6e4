"""Numerical stability on stiff and extreme cases, on small sizes.

* Per-chain status, never a crash: a member that blows up is flagged and frozen, and the other
  members stay bitwise equal to their single runs (same kernel), on every CPU kernel path.
* Each status code is reached by a scene built to reach it, and named in the store.
* The extreme cases (hertzian.studies.thresholds), run at the step ``hertzian check`` suggests, keep
  the energy conserved (the independent check: docs/model.md §5's energy) and stay OK.
* l0 = 0: contacts open and close, the force F ∝ δ^(n−1) is not smooth at δ = 0, and every Gear
  method falls to order ≈ 2.3 (measured), against 4/5/6 on a smooth precompressed chain.
"""

import json
import math

import numpy as np
import pytest
import zarr
from hertzian.core.check import check_scene
from hertzian.core.model import build_model
from hertzian.core.runner import Runner, run_ensemble, run_scene
from hertzian.core.static import static_state
from hertzian.core.status import Status
from hertzian.studies.accuracy import work_precision
from hertzian.studies.thresholds import EXTREMES, extreme
from hertzian.sweeping.sweep_store import write_result

from tests.helpers import DEVICES, make_scene, slope

PAPER_DT = 1.25e-5


def member(**chain):
    v = chain.pop("impact", 1e-2)
    return make_scene(
        chain={"grains": 20, "l0": 1e-4, **chain},
        excitation={"impact": v},
        integrator={"dt": 2e-4, "duration": 0.2},
        record={"every": 0.01},
    )


KERNELS = [("cpu", "step"), ("cpu", "chain")] + [(d, "auto") for d in DEVICES if d != "cpu"]


@pytest.mark.parametrize("device, kernel", KERNELS)
def test_blown_up_member_is_frozen_and_the_others_are_untouched(device, kernel):
    """An absurdly stiff member (a = 1e10: ω·dt ≈ 5e3) goes non-finite; its neighbours don't notice."""
    scenes = [member(), member(a=1e10), member(impact=3e-2)]
    model = build_model(scenes, device)
    result = Runner(model, kernel=kernel).run()
    assert list(result.status) == [Status.OK, Status.NON_FINITE, Status.OK]
    assert np.isinf(result.energy_error[1]) and np.all(result.energy_error[[0, 2]] < 1e-6)
    for k in (0, 2):
        alone = Runner(build_model([scenes[k]], device, features=model.features), kernel=kernel).run()
        assert np.array_equal(alone.u[0], result.u[k]) and np.array_equal(alone.v[0], result.v[k])
        assert np.array_equal(alone.energy[0], result.energy[k])
    # frozen from the first record that saw it blow up: later snapshots repeat it (NaN for NaN)
    bad = result.u[1]
    first = int(np.argmax(~np.all(np.isfinite(bad), axis=1)))
    assert first > 0
    for r in range(first + 1, bad.shape[0]):
        assert np.array_equal(bad[r], bad[first], equal_nan=True)


def test_status_names_are_in_the_store(tmp_path):
    result = run_ensemble([member(), member(a=1e10)], "cpu")
    write_result(tmp_path / "s.zarr", result, axes={"a": np.array([5657.0, 1e10])})
    group = zarr.open_group(str(tmp_path / "s.zarr"), mode="r")
    codes = dict(group.attrs["status_codes"])
    # every run status, plus the sweep writer's -1 (NOT_RUN: a batch not yet written)
    assert {int(k) for k in codes} == {int(s) for s in Status} | {-1}
    assert codes[str(int(Status.NON_FINITE))].startswith("NON_FINITE")
    assert list(group["status"][...]) == [0, int(Status.NON_FINITE)]
    # the second point's scene is kept (not only the first's): the axis is the scene key chain.a
    assert group["a"].attrs["scene_key"] == "chain.a"
    assert json.loads(group.attrs["scene_overrides"]) == {"chain.a": [5657.0, 1e10]}


def test_gravity_100_on_ten_thousand_grains():
    """g = 100, 10^4 grains: the bottom's static overlap (17.1) is beyond 0.1·diameter; flagged, never raised.

    A short run at the step check suggests: the energy of the impact is still conserved.
    """
    scene = make_scene(
        chain={"grains": 10_000, "l0": 1e-4, "gravity": 100.0},
        excitation={"impact": 1e-2},
        integrator={"duration": 0.05},
        record={"every": 0.01, "fields": ["u"]},
    )
    check = check_scene(scene)
    assert check.beyond_validity
    scene = scene.with_overrides({"integrator.dt": 0.01 / math.ceil(0.01 / check.suggested_dt - 1e-9)})
    result = run_scene(scene, "cpu")
    assert result.status[0] == Status.OVERLAP_BEYOND_VALIDITY
    bottom = static_state(scene).static_overlap.max()
    assert bottom <= result.max_overlap[0] <= check.largest_overlap  # the static bottom, within the bound
    assert 0 < result.energy_error[0] <= 1e-6  # what check's accuracy threshold promises


def test_energy_drift_is_flagged():
    """Verlet at ω_max·dt ≈ 1.5 (stable, below 2, but coarse) drifts by more than 1e-2 of E_inj: ENERGY_DRIFT."""
    scene = make_scene(
        chain={"grains": 30, "l0": 1e-4},
        excitation={"impact": 1e-2},
        integrator={"method": "verlet", "dt": 0.032, "duration": 2.048},
        record={"every": 0.064},
    )
    assert check_scene(scene).omega_dt == pytest.approx(1.48, abs=0.01)
    result = run_scene(scene, "cpu")
    assert result.status[0] == Status.ENERGY_DRIFT
    assert np.all(np.isfinite(result.u)) and 1e-2 < result.energy_error[0] < 1


@pytest.mark.parametrize(
    "method, events",
    [(m, e) for m in ("gear4", "gear5", "gear6") for e in ("auto", "off")]
    + [(m, "auto") for m in ("verlet", "yoshida4", "yoshida6")],
)
@pytest.mark.parametrize("case", list(EXTREMES))
def test_extreme_case_at_the_suggested_step_conserves_energy(case, method, events):
    """At check's suggested dt (≈ its 'accurate' steps per contact time) every extreme keeps E to ≤ 1e-6, the
    energy error ACCURATE_STEPS_PER_CONTACT_TIME was measured to guarantee, with either event setting (the check
    does not ask which one a run takes)."""
    scene = extreme(case, method, events)
    assert check_scene(scene).verdict == "ok"
    result = run_scene(scene, "cpu")
    assert result.status[0] == Status.OK
    assert result.energy_error[0] <= 1e-6, result.energy_error[0]


@pytest.mark.parametrize("factor, tolerance", [(10.0, 1e-6), (0.01, 1e-9)])
def test_paper_step_times_ten_and_times_a_hundredth(factor, tolerance):
    """dt = 10× and 0.01× the paper's on its chain: both stable, and the energy error shrinks with dt."""
    dt = PAPER_DT * factor
    scene = make_scene(
        chain={"grains": 30, "l0": 1e-4},
        excitation={"impact": 1e-2},
        integrator={"dt": dt, "duration": 0.02 if factor < 1 else 0.5},
        record={"every": 0.01, "fields": ["u"]},
    )
    result = Runner(build_model([scene], "cpu"), kernel="chain").run()
    assert result.status[0] == Status.OK
    assert result.energy_error[0] < tolerance


def test_order_loss_where_contacts_open():
    """l0 = 0: F ∝ δ^(3/2) is not smooth at δ = 0 and plain Gear steps (integrator.events = "off") fall
    to order ≈ 2.3 (Verlet stays 2); at l0 = 1e-2 (no contact opens) gear6 shows its order 6. Reference:
    gear6 at dt/4, Richardson-checked. tests/kernels/test_event_steps.py checks the order event-aware steps restore."""
    dts = [2e-3, 1e-3, 5e-4]
    orders = {}
    for l0, impact in ((0.0, 1e-2), (1e-2, 1e-4)):
        scene = make_scene(
            chain={"grains": 20, "l0": l0},
            excitation={"impact": impact},
            integrator={"duration": 1.0, "events": "off"},
            record={"every": 0.25, "fields": ["u"]},
        )
        records, _, _ = work_precision(scene, ["gear4", "gear6", "verlet"], dts, ["float64"], device="cpu")
        for method in ("gear4", "gear6", "verlet"):
            orders[l0, method] = slope(dts, [r.error for r in records if r.method == method])
    assert 1.8 < orders[0.0, "gear4"] < 3.0 and 1.8 < orders[0.0, "gear6"] < 3.0, orders
    assert abs(orders[0.0, "verlet"] - 2.0) < 0.3, orders
    assert orders[1e-2, "gear6"] > 5.0, orders


def test_the_threshold_scan_refuses_an_unknown_event_setting(tmp_path):
    import subprocess
    import sys

    out = tmp_path / "t.json"
    args = ["--methods", "gear4", "--ratios", "400", "--events", "auto,sometimes", "--out", str(out)]
    done = subprocess.run([sys.executable, "-m", "hertzian.studies.thresholds", *args], capture_output=True, text=True)
    assert done.returncode == 2 and not out.exists()
    assert done.stderr == "error: --events = 'auto,sometimes': distinct ones of auto, off, comma-separated\n"
