"""yoshida6: seven velocity-Verlet substeps per step (Yoshida 1990, solution A: w3, w2, w1, w0, w1, w2, w3 with
w0 = 1 − 2(w1 + w2 + w3)), a symplectic method of order 6.

Claims checked here, each against something independent of the kernels' own output:

* the CPU chain kernel performs the per-step kernel's substeps in the same order: bit for bit equal states;
* the weights are the published ones and satisfy the composition's order conditions;
* order 6 on a smooth chain: tests/core/test_order_of_accuracy.py (EXPECTED["yoshida6"]); the NumPy reference
  with its own weights: tests/core/test_against_reference.py;
* no energy drift over ~4000 contact times;
* the stability limit in ``hertzian check`` is where |trace/2| of the one-step map of a harmonic oscillator,
  built here from kick–drift–kick matrices, reaches 1;
* its accuracy threshold is what the extreme-case suite measured (docs/records/accuracy/composed.json);
* a drive and damping are refused with one line.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from hertzian.core.check import ACCURATE_STEPS_PER_CONTACT_TIME, STABLE_OMEGA_DT, amplification_matrix
from hertzian.core.model import build_model
from hertzian.core.scene import SceneError
from hertzian.kernels.features import SUBSTEP_WEIGHTS

from tests.helpers import COMPOSED_CASES, chains, invoke, make_scene, per_step, sweep, toml_text
from tests.kernels.test_yoshida4 import BASE, drift, energy_history, kick_drift_kick

PUBLISHED = (-1.17767998417887, 0.235573213359357, 0.784513610477560)
"""w1, w2, w3 of Yoshida (1990), Phys. Lett. A 150, 262, solution A."""


@pytest.mark.parametrize("case", list(COMPOSED_CASES))
def test_sweep_equals_per_step(case):
    sections, n_chains, steps = COMPOSED_CASES[case]
    sections = {**sections, "integrator": {**sections["integrator"], "method": "yoshida6"}}
    model = build_model(chains(n_chains, **sections), "cpu")
    assert model.features.substeps == 7
    want = per_step(model, steps)
    assert np.max(np.abs(want[0, :, -2])) > 1e-3 * np.max(np.abs(want[0]))  # the pulse reached the bottom
    np.testing.assert_array_equal(sweep(model, steps, steps_per_launch=7), want)


def test_weights_are_yoshidas():
    w = SUBSTEP_WEIGHTS["yoshida6"]
    w1, w2, w3 = PUBLISHED
    assert w == w[::-1] and w[:3] == (w3, w2, w1)
    assert w[3] == pytest.approx(1.0 - 2.0 * (w1 + w2 + w3), rel=1e-15)
    assert sum(w) == pytest.approx(1.0, abs=1e-15)
    # order conditions of a symmetric composition of a second-order method (Yoshida 1990): Σ w³ = Σ w⁵ = 0
    assert abs(sum(x**3 for x in w)) < 1e-12 and abs(sum(x**5 for x in w)) < 1e-12


def yoshida6_uv(omega_dt: float) -> np.ndarray:
    """yoshida6's one-step (u, v) map at ω = 1, dt = omega_dt, from the published weights."""
    w1, w2, w3 = PUBLISHED
    step = np.eye(2)
    for w in (w3, w2, w1, 1.0 - 2.0 * (w1 + w2 + w3), w1, w2, w3):
        step = kick_drift_kick(w * omega_dt, 1.0) @ step
    return step


def test_stability_limit_is_where_the_half_trace_reaches_one():
    def half_trace(z):
        step = yoshida6_uv(z)
        assert abs(np.linalg.det(step) - 1.0) < 1e-12
        return abs(np.trace(step) / 2.0)

    limit = STABLE_OMEGA_DT["yoshida6"]
    assert all(half_trace(z) <= 1.0 for z in np.linspace(1e-3, 1.0, 400) * limit)
    low, high = 2.0, 2.3  # the first unstable band is narrow: 2.269-2.327, then stable again up to 2.818
    assert half_trace(low) < 1.0 < half_trace(high)
    for _ in range(60):
        mid = 0.5 * (low + high)
        low, high = (mid, high) if half_trace(mid) <= 1.0 else (low, mid)
    assert limit <= low < limit + 1e-4, low
    for z in (0.3, 1.0, 2.0, 2.2):
        eig = np.linalg.eigvals(amplification_matrix("yoshida6", z))
        np.testing.assert_allclose(
            np.sort_complex(eig[np.abs(eig) > 1e-9]), np.sort_complex(np.linalg.eigvals(yoshida6_uv(z))), atol=1e-12
        )


def test_energy_error_is_bounded_without_drift():
    error = energy_history("yoshida6")
    shift, largest = drift(error)
    assert largest < 1e-4, largest
    assert shift < 0.05 * largest, (shift, largest)


def test_accuracy_threshold_is_the_suites():
    record = json.loads((Path(__file__).parents[2] / "docs/records/accuracy/composed.json").read_text())
    methods = record["thresholds"]["methods"]
    for method in ("yoshida4", "yoshida6"):
        assert methods[method]["threshold"] == ACCURATE_STEPS_PER_CONTACT_TIME[method]
    assert ACCURATE_STEPS_PER_CONTACT_TIME["yoshida6"] == 150.0


def test_drive_and_damping_are_refused():
    with pytest.raises(SceneError, match="not implemented for yoshida6"):
        make_scene(
            **{
                **BASE,
                "integrator": {**BASE["integrator"], "method": "yoshida6"},
                "damping": {"model": "viscous", "gamma": 0.1},
            }
        )


def test_check_knows_yoshida6(tmp_path):
    scene = tmp_path / "s.toml"
    scene.write_text(toml_text({**BASE, "integrator": {**BASE["integrator"], "dt": 1e-3, "method": "yoshida6"}}))
    result = invoke("check", scene, "--json")
    assert result.exit_code == 0, result.stdout + result.stderr
    assert '"stable_omega_dt": 2.269' in result.stdout and '"accurate_steps_per_contact_time": 150.0' in result.stdout
