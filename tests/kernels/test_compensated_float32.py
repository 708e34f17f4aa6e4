"""Compensated float32 (kernels/gear.py): the energy and position errors stay near float64's.

The plain float32 update u ← u + Σ x_j loses the increments' low bits every step, so its error
grows as dt shrinks. Compensated float32 carries
u and dt·v as hi + lo pairs and forms the contacts' displacements from them. Here a 100-grain
precompressed chain (the paper's l0 = 1e-4, v_imp = 1e-2, walls) runs 160 000 steps in float64, in
plain float32 and in compensated float32, gear4 and Verlet; the claims checked:

* compensated float32's energy error (docs/model.md §5) is ≤ 2e-7 (docs/stability.md, §2b, gives the paper's
  1000-grain scene to t = 20 from docs/records/accuracy/float32.json), and its positions are within 2e-6
  (relative) of float64's;
* the plain float32 update is more than 100 times worse in both, so the scene is one where float32's rounding
  matters and the comparison can fail.
Without the compensated contact displacements (``gap`` from rounded positions) the energy drifts linearly in
time, to about 6e-7 at t = 4 here: the 2e-7 bound catches that too.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from hertzian.core.model import build_model, features_of
from hertzian.core.runner import Runner
from hertzian.core.scene import scene_from_dict

ENERGY_BOUND = 2e-7
POSITION_BOUND = 2e-6
PLAIN_FACTOR = 100.0


def run(method: str, precision: str, compensated: bool):
    scene = scene_from_dict(
        {
            "chain": {"grains": 100, "l0": 1e-4},
            "excitation": {"impact": 1e-2},
            "integrator": {"method": method, "dt": 2.5e-5, "duration": 4.0, "precision": precision},
            "record": {"every": 0.25, "fields": ["u"]},
        }
    )
    features = replace(features_of([scene]), compensated=compensated)
    model = build_model([scene], "cpu", features=features)
    assert model.features.values == features.nordsieck_values + (2 if precision == "float32" and compensated else 0)
    result = Runner(model, kernel="chain").run()
    return float(result.energy_error[0]), np.asarray(result.fields["u"][0], dtype=np.float64)


@pytest.mark.parametrize("method", ["gear4", "verlet", "yoshida4", "yoshida6"])
def test_compensated_float32_keeps_float64_accuracy(method):
    _, u64 = run(method, "float64", False)
    plain_energy, u_plain = run(method, "float32", False)
    energy, u = run(method, "float32", True)
    scale = np.max(np.abs(u64))
    assert np.abs(u64[-1, 60]) > 1e-3 * scale  # the pulse travelled past grain 60
    position = np.max(np.abs(u - u64)) / scale
    plain_position = np.max(np.abs(u_plain - u64)) / scale
    assert energy <= ENERGY_BOUND, f"{method}: compensated float32 energy error {energy:.3g}"
    assert position <= POSITION_BOUND, f"{method}: compensated float32 position error {position:.3g}"
    assert plain_energy > PLAIN_FACTOR * energy, f"{method}: plain {plain_energy:.3g} vs compensated {energy:.3g}"
    assert plain_position > PLAIN_FACTOR * position, f"{method}: plain {plain_position:.3g} vs {position:.3g}"


def test_compensated_state_carries_the_low_parts():
    """The state rows Q, Q + 1 hold what float32 rounding of u and dt·v left out (|lo| ≤ half an ulp of hi)."""
    scene = scene_from_dict(
        {
            "chain": {"grains": 30, "l0": 1e-4},
            "excitation": {"impact": 1e-2},
            "integrator": {"dt": 2.5e-5, "duration": 0.05, "precision": "float32"},
            "record": {"every": 0.05},
        }
    )
    model = build_model([scene], "cpu")
    assert model.features.compensation and model.features.values == 6
    runner = Runner(model, kernel="chain")
    runner.advance(2000)
    x = runner.current.x.numpy()
    hi, lo = x[[0, 1]], x[[4, 5]]
    assert np.count_nonzero(lo) > 0
    assert np.all(np.abs(lo) <= 0.5 * np.spacing(np.abs(hi)))
