"""The Warp kernels against the independent NumPy float64 reference (tests/reference.py), which
integrates docs/model.md's direct equation of motion (explicit m·g and F0), while the kernels integrate
excess forces relative to the static state: agreement checks that equivalence too.

Every case runs until the pulse has reached the bottom grain and had time to come back (checked
inside the test on the reference's bottom-grain trace), so the bottom boundary, every impurity
and the reflections are compared, and the comparison is made grain by grain, each relative to
that grain's own largest displacement and speed.
"""

import numpy as np
import pytest
from hertzian.core.runner import run_scene

from tests.helpers import make_scene
from tests.reference import reference_run

GRAINS = 12
IMPURITIES = [{"grains": [3, 4], "mass": 0.5, "a": 2000.0}, {"grains": [8], "mass": 2.0, "a": 1e4}]
IMPURITY_GRAINS = [3, 4, 8]
MOVING = 1e-2
"""A grain has 'moved' once its speed exceeds this fraction of the largest traced speed."""

# name: (scene sections, duration); durations ≥ 2.2 × the time the bottom grain first moves
CASES = {
    "impact, precompressed, walls": (dict(chain={"l0": 1e-4}, excitation={"impact": 1e-2}), 1.5),
    "impurities, harmonic rule": (dict(chain={"l0": 1e-4}, impurities=IMPURITIES, excitation={"impact": 1e-2}), 1.5),
    "impurities, own rule": (
        dict(
            chain={"l0": 1e-4},
            impurities=[{**imp, "contact": "own"} for imp in IMPURITIES],
            excitation={"impact": 1e-2},
        ),
        1.5,
    ),
    "gravity column, free surface": (
        dict(chain={"gravity": 1.0}, boundary={"surface": "free"}, excitation={"impact": 1e-1}),
        1.0,
    ),
    "gravity + impurities + fixed bottom": (
        dict(
            chain={"gravity": 10.0},
            boundary={"surface": "free", "bottom": "fixed"},
            impurities=IMPURITIES,
            excitation={"impact": 1e-1},
        ),
        1.0,
    ),
    "load surface, wall bottom": (
        dict(chain={"l0": 1e-3}, boundary={"surface": "load"}, excitation={"impact": 1e-2}),
        1.0,
    ),
    "load given as a force, gravity": (
        dict(chain={"load": 0.5, "gravity": 1.0}, boundary={"surface": "load"}, excitation={"impact": 1e-2}),
        1.0,
    ),
    "unloaded chain: contacts open and close": (dict(excitation={"impact": 1e-1}), 1.5),
    "free ends": (dict(boundary={"surface": "free", "bottom": "free"}, excitation={"impact": 1e-1}), 1.5),
    "driven surface, fixed bottom, gravity": (
        dict(
            chain={"gravity": 1.0},
            boundary={"surface": "driven", "bottom": "fixed"},
            excitation={"drive_amplitude": 2e-3, "drive_period": 0.1},
        ),
        1.0,
    ),
    "driven surface, precompressed": (
        dict(
            chain={"l0": 1e-4},
            boundary={"surface": "driven", "bottom": "wall"},
            excitation={"drive_amplitude": 1e-4, "drive_period": 0.1},
        ),
        2.0,
    ),
    "non-Hertz exponent n = 2": (dict(chain={"l0": 1e-3, "exponent": 2.0}, excitation={"impact": 1e-2}), 1.0),
    "exponent n = 3, impurities": (
        dict(chain={"l0": 1e-3, "exponent": 3.0}, impurities=IMPURITIES, excitation={"impact": 1e-2}),
        3.5,
    ),
}


def build(name: str, method: str = "gear4", dt: float = 5e-4):
    case, duration = CASES[name]
    sections = {k: dict(v) if isinstance(v, dict) else v for k, v in case.items()}
    sections.setdefault("chain", {})["grains"] = GRAINS
    # the reference integrates plain Gear/Verlet steps: compare the kernels' plain steps (event-aware
    # steps, integrator.events = "auto", are checked by their order of accuracy in tests/kernels/test_event_steps.py)
    sections["integrator"] = {"method": method, "dt": dt, "duration": duration, "events": "off"}
    sections["record"] = {"every": duration / 20, "traces": [0, GRAINS // 2, GRAINS - 2, GRAINS - 1]}
    return make_scene(**sections)


def assert_round_trip(scene, ref) -> None:
    """The reference's bottom grain moved early enough for the pulse to come back up before the end,
    and every grain (impurities included) moved."""
    held_bottom = scene.boundary.bottom == "fixed"
    speed = np.abs(ref["trace_v"])
    moved = speed[:, -2 if held_bottom else -1] > MOVING * speed.max()
    assert moved.any(), "the pulse never reached the bottom grain"
    arrival = ref["trace_t"][np.argmax(moved)]
    assert scene.integrator.duration >= 2.2 * arrival, (arrival, scene.integrator.duration)
    largest = np.abs(ref["v"]).max(axis=0)
    free = largest[1:-1] if held_bottom else largest[1:]
    assert np.all(free > MOVING * largest.max()), largest
    if scene.impurities:
        assert np.all(largest[IMPURITY_GRAINS] > MOVING * largest.max())


def compare(result, ref, rtol=1e-10):
    """Grain by grain, each against its own largest |u| and |v| over the run."""
    u, v = result.u[0], result.v[0]
    for grain in range(u.shape[1]):
        scale_u, scale_v = np.abs(ref["u"][:, grain]).max(), np.abs(ref["v"][:, grain]).max()
        np.testing.assert_allclose(
            u[:, grain], ref["u"][:, grain], rtol=0, atol=rtol * scale_u, err_msg=f"u of grain {grain}"
        )
        np.testing.assert_allclose(
            v[:, grain], ref["v"][:, grain], rtol=0, atol=rtol * scale_v, err_msg=f"v of grain {grain}"
        )
    for column in range(ref["trace_u"].shape[1]):
        scale = np.abs(ref["trace_u"][:, column]).max()
        np.testing.assert_allclose(
            result.traces["u"][0][:, column],
            ref["trace_u"][:, column],
            rtol=0,
            atol=rtol * scale,
            err_msg=f"trace column {column}",
        )
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


def check(scene, device="cpu"):
    ref = reference_run(scene.to_dict())
    assert_round_trip(scene, ref)
    compare(run_scene(scene, device), ref)


@pytest.mark.parametrize("name", list(CASES))
def test_gear4_matches_reference(name):
    check(build(name))


@pytest.mark.parametrize("method", ["gear5", "gear6", "verlet"])
@pytest.mark.parametrize(
    "name",
    ["impurities, harmonic rule", "gravity + impurities + fixed bottom", "driven surface, fixed bottom, gravity"],
)
def test_other_methods_match_reference(method, name):
    check(build(name, method=method))


@pytest.mark.parametrize(
    "name",
    [
        "impurities, harmonic rule",
        "gravity + impurities + fixed bottom",
        "unloaded chain: contacts open and close",
        "free ends",
    ],
)
@pytest.mark.parametrize("method", ["yoshida4", "yoshida6"])
def test_yoshida_compositions_match_reference(name, method):
    """The Yoshida compositions' substeps in the kernels' scaled Nordsieck form against the reference's
    kick–drift–kick in (u, v), with the reference's own weights."""
    check(build(name, method=method))


def test_reference_agreement_on_device(device):
    check(build("gravity + impurities + fixed bottom", method="gear5"), device)


def test_compare_is_per_grain():
    """The comparison sees an error confined to one quiet grain that a whole-chain scale would hide."""
    scene = build("impact, precompressed, walls")
    ref = reference_run(scene.to_dict())
    result = run_scene(scene, "cpu")
    quiet = int(np.argmin(np.abs(ref["u"]).max(axis=0)))
    result.fields["u"][0, -1, quiet] += 1e-6 * np.abs(ref["u"][:, quiet]).max()
    with pytest.raises(AssertionError, match=f"grain {quiet}"):
        compare(result, ref)


# lattice laws (docs/lattices.md): strength a = 1 (lj: ε = 1), unit masses; (chain keys, impact, dt, duration)
LATTICE_CASES = {
    "fput α–β, fixed ends (walls)": (dict(potential="fput", a=1.0, alpha=0.25, beta=0.5), 0.4, 0.01, 30.0),
    "fput α, precompressed by a load": (dict(potential="fput", a=1.0, alpha=0.25, l0=0.2), 0.3, 0.01, 30.0),
    "toda, precompressed": (dict(potential="toda", a=1.0, b=2.0, l0=0.1), 0.5, 0.01, 30.0),
    "morse": (dict(potential="morse", a=1.0, alpha=1.0), 0.3, 0.01, 25.0),
    "lj, precompressed": (dict(potential="lj", a=1.0, sigma=1.0, l0=0.02), 0.3, 0.002, 6.0),
    "harmonic, impurities": (dict(potential="harmonic", a=1.0), 0.3, 0.01, 30.0),
    "fput ring": (dict(potential="fput", a=1.0, alpha=0.25, beta=0.5), 0.4, 0.01, 30.0),
    "toda ring, precompressed, impurities": (dict(potential="toda", a=1.0, b=2.0, l0=0.1), 0.5, 0.01, 30.0),
}
RING = {"surface": "periodic", "bottom": "periodic"}


def build_lattice(name: str, method: str) -> object:
    chain, impact, dt, duration = LATTICE_CASES[name]
    impurities = (
        [{"grains": [3, 4], "mass": 0.5, "a": 2.0}, {"grains": [8], "mass": 2.0}] if "impurities" in name else []
    )
    return make_scene(
        chain={"grains": GRAINS, **chain},
        boundary=RING if "ring" in name else {},
        impurities=impurities,
        excitation={"impact": impact},
        integrator={"method": method, "dt": dt, "duration": duration},
        record={"every": duration / 20, "traces": [0, GRAINS // 2, GRAINS - 2, GRAINS - 1]},
    )


@pytest.mark.parametrize("method", ["gear4", "yoshida6"])
@pytest.mark.parametrize("name", list(LATTICE_CASES))
def test_lattice_laws_match_reference(name, method):
    """Every lattice law against the reference's own textbook form of it (V of the extension r = −δ), with a static
    load where the case has one, on a Gear method and yoshida6 (every method's order on every law:
    tests/kernels/test_lattice_laws.py)."""
    check(build_lattice(name, method))


def test_hertz_ring_matches_reference():
    """A precompressed Hertz ring struck at grain 0 (plain steps: a ring takes no event steps)."""
    scene = make_scene(
        chain={"grains": GRAINS, "l0": 1e-4},
        boundary=RING,
        excitation={"impact": 1e-2},
        integrator={"method": "gear5", "dt": 5e-4, "duration": 1.0, "events": "off"},
        record={"every": 0.05, "traces": [0, GRAINS // 2, GRAINS - 2, GRAINS - 1]},
    )
    check(scene)
