"""yoshida4: three velocity-Verlet substeps of w1·dt, w0·dt, w1·dt per step (w1 = 1/(2 − 2^(1/3)),
w0 = 1 − 2·w1), a symplectic method of order 4 (Yoshida 1990; Forest & Ruth 1990).

Claims checked here, each against something independent of the kernels' own output:

* the CPU chain kernel performs the per-step kernel's substeps in the same order: bit for bit equal states
  (walls, impurities + gravity + a fixed bottom, free ends, compensated float32), and equal records and
  traces through the runner (traces are written only at step boundaries);
* order 4 on a smooth (precompressed, no contact opens) chain against a gear6 reference at a much smaller
  step: tests/core/test_order_of_accuracy.py (EXPECTED["yoshida4"]);
* no energy drift over ~4000 contact times (symplectic: the error oscillates, bounded), where gear4 —
  not symplectic — drifts at the same step;
* the stability limit in ``hertzian check`` is the first ω·dt where |trace/2| of the one-step map of a
  harmonic oscillator reaches 1, recomputed here from Verlet's 2×2 kick–drift–kick matrices
  (tests/core/test_check.py also checks the scaled-Nordsieck matrix against the Warp kernel, and that runs
  blow up beyond the limit);
* a drive, damping and the window kernel are refused with one line (exit code 2 in the CLI); the tile kernel runs
  it (tests/kernels/test_tile.py).
"""

from __future__ import annotations

import numpy as np
import pytest
from hertzian.core.check import STABLE_OMEGA_DT, amplification_matrix
from hertzian.core.model import build_model
from hertzian.core.runner import Runner
from hertzian.core.scene import SceneError
from hertzian.core.solvers import choose_config
from hertzian.core.solvers.calibrate import fused_lacks
from hertzian.kernels.features import SUBSTEP_WEIGHTS

from tests.helpers import (
    COMPOSED_CASES,
    assert_every_window_moved,
    assert_refused,
    chains,
    invoke,
    make_scene,
    per_step,
    sweep,
    toml_text,
)

# ---- (a) the CPU chain kernel equals the per-step kernel, bit for bit ----------------------------------


@pytest.mark.parametrize("case", list(COMPOSED_CASES))
def test_sweep_equals_per_step(case):
    sections, n_chains, steps = COMPOSED_CASES[case]
    model = build_model(chains(n_chains, **sections), "cpu")
    assert model.features.method == "yoshida4" and model.features.substeps == 3
    want = per_step(model, steps)
    held = sections.get("boundary", {}).get("bottom") == "fixed"
    assert_every_window_moved(want, [(0, want.shape[2])], held_bottom=held)  # the pulse reached the bottom
    # several launches, an odd one last; sweep() asserts that the clock counts steps, not substeps
    np.testing.assert_array_equal(sweep(model, steps, steps_per_launch=7), want)


def test_runner_records_and_traces_agree_across_kernels():
    """Through the runner: records, energy and traces (per-step: written by the last substep in the kernel;
    sweep: sampled between launches) are the same bits, and fall on whole steps."""
    scenes = chains(
        2,
        chain={"grains": 20, "l0": 1e-4},
        integrator={"method": "yoshida4", "dt": 5e-4, "duration": 1.2},
        record={"every": 0.1, "traces": [0, 7, 19], "trace_every": 0.005},
    )
    model = build_model(scenes, "cpu")
    step = Runner(model, kernel="step").run()
    sweep = Runner(model, kernel="chain").run()
    assert step.steps == sweep.steps == 2400
    for got, want in (
        (sweep.u, step.u),
        (sweep.v, step.v),
        (sweep.energy, step.energy),
        (sweep.traces["u"], step.traces["u"]),
        (sweep.traces["v"], step.traces["v"]),
    ):
        np.testing.assert_array_equal(got, want)
    moved = np.abs(step.traces["u"][:, -1, 2]) / np.abs(step.traces["u"]).max(axis=(1, 2))
    assert np.all(moved > 1e-3), moved  # the pulse reached the bottom grain
    # the traces at record steps are the records' snapshots (a trace written mid-step would differ)
    sample_steps = np.rint(step.trace_t / 5e-4).astype(int)
    record_steps = np.rint(step.t / 5e-4).astype(int)
    at_records = np.isin(sample_steps, record_steps)
    assert at_records.sum() >= 10
    np.testing.assert_array_equal(step.traces["u"][:, at_records, 1], step.u[:, np.isin(record_steps, sample_steps), 7])


def test_plain_launches_equal_the_recorded_ones():
    """StepSolver.launch (the three substep launches a CUDA graph captures) and the CPU's recorded commands
    (StepSolver.launches) give the same bits, and a step from a ends in b with the clock one step on."""
    from hertzian.core.solvers import StepSolver

    model = build_model(
        chains(2, chain={"grains": 15, "l0": 1e-4}, integrator={"method": "yoshida4", "dt": 5e-4}), "cpu"
    )
    solver = StepSolver(model)
    assert solver.substeps == 3
    recorded = solver.advance(*model.state_pair(), 301).x.numpy()
    a, b = model.state_pair()
    for _ in range(301):
        solver.launch(a, b)
        assert b.clock.numpy()[0] == a.clock.numpy()[0] + 1
        a, b = b, a
    assert a.clock.numpy()[0] == 301
    assert np.max(np.abs(recorded)) > 0
    np.testing.assert_array_equal(a.x.numpy(), recorded)


# ---- (b) energy: bounded, no drift -----------------------------------------------------------------------


def energy_history(method: str) -> np.ndarray:
    """(E(t) − E(0))/E_inj at records every 0.4 over 400 time units (1e5 steps at T/dt ≈ 24) on the smooth chain."""
    scene = make_scene(
        chain={"grains": 20, "l0": 1e-2},
        excitation={"impact": 1e-4},
        integrator={"method": method, "dt": 4e-3, "duration": 400.0},
        record={"every": 0.4, "fields": ["u"]},
    )
    result = Runner(build_model([scene], "cpu"), kernel="chain", monitor_every=0).run()
    return (result.energy[0] - result.energy[0, 0]) / scene.injected_energy


def drift(error: np.ndarray) -> tuple[float, float]:
    """(|mean of the last quarter − mean of the first quarter|, max |error|)."""
    quarter = len(error) // 4
    return abs(error[-quarter:].mean() - error[:quarter].mean()), float(np.abs(error).max())


def test_energy_error_is_bounded_without_drift():
    """Symplectic: the energy error oscillates (measured max 3.8e-4 at this coarse step) and its mean does not
    move over the run; gear4 at the same step loses energy steadily (its mean moves by more than a third of its
    largest error), so the criterion can fail."""
    error = energy_history("yoshida4")
    assert len(error) == 1001
    shift, largest = drift(error)
    assert largest < 1e-3, largest
    assert shift < 0.05 * largest, (shift, largest)
    gear_shift, gear_largest = drift(energy_history("gear4"))
    assert gear_shift > 0.3 * gear_largest, (gear_shift, gear_largest)


# ---- (d) the stability limit -----------------------------------------------------------------------------


def kick_drift_kick(h: float, omega: float) -> np.ndarray:
    """Velocity Verlet of step h on ü = −ω²u, acting on (u, v)."""
    kick = np.array([[1.0, 0.0], [-0.5 * h * omega**2, 1.0]])
    drift_ = np.array([[1.0, h], [0.0, 1.0]])
    return kick @ drift_ @ kick


def yoshida_uv(omega_dt: float) -> np.ndarray:
    """yoshida4's one-step (u, v) map at ω = 1, dt = omega_dt, from the composition's definition."""
    w1 = 1.0 / (2.0 - 2.0 ** (1.0 / 3.0))
    w0 = -(2.0 ** (1.0 / 3.0)) * w1
    return (
        kick_drift_kick(w1 * omega_dt, 1.0) @ kick_drift_kick(w0 * omega_dt, 1.0) @ kick_drift_kick(w1 * omega_dt, 1.0)
    )


def half_trace(omega_dt: float) -> float:
    step = yoshida_uv(omega_dt)
    assert abs(np.linalg.det(step) - 1.0) < 1e-12  # symplectic: area preserving
    return float(np.trace(step) / 2.0)


def test_stability_limit_is_where_the_half_trace_reaches_one():
    below = np.linspace(1e-3, 1.0, 400) * STABLE_OMEGA_DT["yoshida4"]
    assert all(abs(half_trace(z)) <= 1.0 for z in below)  # stable (|trace/2| ≤ 1) everywhere below
    low, high = 1.0, 2.0
    assert abs(half_trace(low)) < 1.0 < abs(half_trace(high))
    for _ in range(60):
        mid = 0.5 * (low + high)
        low, high = (mid, high) if abs(half_trace(mid)) <= 1.0 else (low, mid)
    assert STABLE_OMEGA_DT["yoshida4"] <= low < STABLE_OMEGA_DT["yoshida4"] + 1e-4, low
    # check.py's scaled-Nordsieck matrix is the same map: same eigenvalues (and the zero of x2 = −z²/2·u)
    for z in (0.3, 1.0, 1.5, 1.6):
        eig = np.linalg.eigvals(amplification_matrix("yoshida4", z))
        assert np.min(np.abs(eig)) < 1e-12
        np.testing.assert_allclose(
            np.sort_complex(eig[np.abs(eig) > 1e-9]), np.sort_complex(np.linalg.eigvals(yoshida_uv(z))), atol=1e-12
        )


def test_weights_are_yoshidas():
    w1, w0, w1_again = SUBSTEP_WEIGHTS["yoshida4"]
    assert w1 == w1_again and w1 + w0 + w1 == 1.0
    assert w1 == pytest.approx(1.0 / (2.0 - 2.0 ** (1.0 / 3.0)), rel=1e-15)
    assert w0 == pytest.approx(-(2.0 ** (1.0 / 3.0)) / (2.0 - 2.0 ** (1.0 / 3.0)), rel=1e-15)
    assert abs(2.0 * w1**3 + w0**3) < 1e-14  # the third-order condition that makes the composition fourth order


# ---- (c) refusals ------------------------------------------------------------------------------------------

BASE = {
    "chain": {"grains": 8, "l0": 1e-4},
    "excitation": {"impact": 1e-2},
    "integrator": {"duration": 0.01, "dt": 2.5e-4, "method": "yoshida4"},
    "record": {"every": 0.005},
}
DRIVEN = {
    **BASE,
    "boundary": {"surface": "driven"},
    "excitation": {"impact": 0.0, "drive_amplitude": 1e-3, "drive_period": 1.0},
}


@pytest.mark.parametrize(
    "data, message",
    [
        (
            DRIVEN,
            "integrator.method = 'yoshida4': a driven surface (boundary.surface = \"driven\") is not implemented "
            "for yoshida4: use one of gear4, gear5, gear6, verlet",
        ),
        (
            {**BASE, "damping": {"model": "viscous", "gamma": 0.1}},
            "integrator.method = 'yoshida4': damping (damping.model = \"viscous\") is not implemented for yoshida4: use one "
            "of gear4, gear5, gear6, verlet",
        ),
        (
            {**BASE, "damping": {"model": "contact", "gamma": 0.1}},
            "integrator.method = 'yoshida4': damping (damping.model = \"contact\") is not implemented for yoshida4",
        ),
    ],
)
def test_drive_and_damping_are_refused(tmp_path, data, message):
    scene = tmp_path / "s.toml"
    scene.write_text(toml_text(data))
    out = tmp_path / "out.zarr"
    result = invoke("run", scene, "--out", out, "--device", "cpu")
    assert_refused(result, out, "integrator.method")
    assert message in result.stderr, result.stderr
    with pytest.raises(SceneError, match="not implemented for yoshida4"):
        make_scene(**{k: v for k, v in data.items()})


def test_the_window_kernel_is_refused_and_the_tile_kernel_taken(tmp_path):
    """A composed step fuses in whole chains only (kernels/tile_plan.py): ``--kernel window`` is refused in one line,
    the tile kernel runs it (its equality with the per-step kernel: tests/kernels/test_tile.py)."""
    model = build_model([make_scene(chain={"grains": 8}, integrator={"method": "yoshida4", "dt": 5e-4})], "cpu")
    assert fused_lacks(model.features, is_cpu=False) is None
    assert choose_config(model, "tile").kind == "tile"
    with pytest.raises(ValueError, match="fuses in whole chains only"):
        choose_config(model, "window")
    scene = tmp_path / "s.toml"
    scene.write_text(toml_text(BASE))
    out = tmp_path / "out.zarr"
    result = invoke("run", scene, "--out", out, "--device", "cpu", "--kernel", "window")
    assert_refused(result, out, "--kernel")
    assert "fuses in whole chains only" in result.stderr


def test_no_event_steps():
    """Event-aware steps are Gear steps: a yoshida4 scene whose contacts open compiles none."""
    model = build_model(
        [
            make_scene(
                chain={"grains": 8, "l0": 0.0},
                excitation={"impact": 1e-2},
                integrator={"method": "yoshida4", "dt": 5e-4},
            )
        ],
        "cpu",
    )
    assert model.features.event_window == 0.0


def test_check_knows_yoshida4(tmp_path):
    scene = tmp_path / "s.toml"
    scene.write_text(toml_text({**BASE, "integrator": {**BASE["integrator"], "dt": 1e-3}}))
    result = invoke("check", scene, "--json")
    assert result.exit_code == 0, result.stdout + result.stderr
    assert '"stable_omega_dt": 1.5734' in result.stdout and '"accurate_steps_per_contact_time": 400.0' in result.stdout
