"""The Warp kernels against the independent NumPy float64 reference (tests/reference.py), which
integrates SPEC's direct equation of motion (explicit m·g and F0), while the kernels integrate
excess forces relative to the static state: agreement checks that equivalence too."""

import numpy as np
import pytest

from ensemble.runner import run_scene
from reference import reference_run

from conftest import make_scene

IMPURITIES = [{"grains": [6, 7], "mass": 0.5, "a": 2000.0}, {"grains": [14], "mass": 2.0, "a": 1e4}]

CASES = {
    "impact, precompressed, walls": dict(chain={"l0": 1e-4}, excitation={"impact": 1e-2}),
    "impurities, harmonic rule": dict(chain={"l0": 1e-4}, impurities=IMPURITIES, excitation={"impact": 1e-2}),
    "impurities, own rule": dict(chain={"l0": 1e-4},
                                 impurities=[{**imp, "contact": "own"} for imp in IMPURITIES],
                                 excitation={"impact": 1e-2}),
    "gravity column, free surface": dict(chain={"gravity": 1.0}, boundary={"surface": "free"},
                                         excitation={"impact": 1e-1}),
    "gravity + impurities + fixed bottom": dict(chain={"gravity": 10.0}, boundary={"surface": "free", "bottom": "fixed"},
                                                impurities=IMPURITIES, excitation={"impact": 1e-1}),
    "load surface, wall bottom": dict(chain={"l0": 1e-3}, boundary={"surface": "load"}, excitation={"impact": 1e-2}),
    "load given as a force, gravity": dict(chain={"load": 0.5, "gravity": 1.0}, boundary={"surface": "load"},
                                           excitation={"impact": 1e-2}),
    "unloaded chain: contacts open and close": dict(excitation={"impact": 1e-2}),
    "free ends": dict(boundary={"surface": "free", "bottom": "free"}, excitation={"impact": 1e-2}),
    "driven surface, fixed bottom, gravity": dict(chain={"gravity": 1.0}, boundary={"surface": "driven", "bottom": "fixed"},
                                                  excitation={"drive_amplitude": 2e-3, "drive_period": 0.05}),
    "driven surface, precompressed": dict(chain={"l0": 1e-4}, boundary={"surface": "driven", "bottom": "wall"},
                                          excitation={"drive_amplitude": 1e-4, "drive_period": 0.02}),
    "non-Hertz exponent n = 2": dict(chain={"l0": 1e-3, "exponent": 2.0}, excitation={"impact": 1e-2}),
    "exponent n = 3, impurities": dict(chain={"l0": 1e-3, "exponent": 3.0}, impurities=IMPURITIES,
                                       excitation={"impact": 1e-2}),
}


def build(case: dict, method: str = "gear4", dt: float = 1e-4, grains: int = 20, duration: float = 0.08):
    sections = {k: dict(v) if isinstance(v, dict) else v for k, v in case.items()}
    sections.setdefault("chain", {})["grains"] = grains
    # plain Gear steps: the NumPy reference implements those (event-aware steps: tests/test_events.py)
    sections["integrator"] = {"method": method, "dt": dt, "duration": duration, "events": "off"}
    sections["record"] = {"every": duration / 4, "traces": [0, grains // 2]}
    return make_scene(**sections)


def compare(result, ref, rtol=1e-10):
    u, v = result.u[0], result.v[0]
    scale_u = max(np.abs(ref["u"]).max(), 1e-300)
    scale_v = max(np.abs(ref["v"]).max(), 1e-300)
    np.testing.assert_allclose(u, ref["u"], rtol=0, atol=rtol * scale_u)
    np.testing.assert_allclose(v, ref["v"], rtol=0, atol=rtol * scale_v)
    np.testing.assert_allclose(result.traces["u"][0], ref["trace_u"], rtol=0, atol=rtol * scale_u)
    np.testing.assert_allclose(result.trace_t, ref["trace_t"], rtol=1e-14)
    # energies differ by a constant (ours is relative to the static state): compare changes
    de, de_ref = result.energy[0] - result.energy[0, 0], ref["energy"] - ref["energy"][0]
    scale_e = max(np.abs(ref["energy"]).max(), np.abs(result.energy[0]).max(), 1e-300)
    np.testing.assert_allclose(de, de_ref, rtol=0, atol=1e-9 * scale_e)
    if result.work is not None:
        # Both integrate the driver's power by the trapezoid rule, but the kernels take the static
        # force's share exactly: they differ by the trapezoid error, O((ω dt)²) of the work.
        scene = result.scenes[0]
        omega_dt = 2 * np.pi * scene.integrator.dt / scene.excitation.drive_period
        np.testing.assert_allclose(result.work[0], ref["work"], rtol=0, atol=omega_dt**2 * np.abs(ref["work"]).max())


@pytest.mark.parametrize("name", list(CASES))
def test_gear4_matches_reference(name):
    scene = build(CASES[name])
    compare(run_scene(scene, "cpu"), reference_run(scene.to_dict()))


@pytest.mark.parametrize("method", ["gear5", "gear6", "verlet"])
@pytest.mark.parametrize("name", ["impurities, harmonic rule", "gravity + impurities + fixed bottom",
                                  "driven surface, fixed bottom, gravity"])
def test_other_methods_match_reference(method, name):
    scene = build(CASES[name], method=method)
    compare(run_scene(scene, "cpu"), reference_run(scene.to_dict()))


def test_reference_agreement_on_device(device):
    scene = build(CASES["gravity + impurities + fixed bottom"], method="gear5")
    compare(run_scene(scene, device), reference_run(scene.to_dict()))
