"""The lattice laws of ``chain.potential`` (kernels/physics.py, docs/lattices.md), each claim against something
independent of the kernels' own output:

* Toda's exact one-soliton solution, to ≤ 1e-8 over 100 time units;
* the order of every method on every law, from the slope of its error against dt (the law is smooth);
* energy conservation over many periods (the record kernels' lattice energies);
* the CPU chain kernel takes the per-step kernel's steps, bit for bit;
* a lattice law's code is absent from a Hertz kernel, and a Hertz kernel's from a lattice one;
* bad parameters are refused in one line before anything runs (detection, which builds Hertz chain sets, too).

The NumPy reference's textbook forms of the laws are compared in tests/core/test_against_reference.py.
"""

from __future__ import annotations

import functools

import numpy as np
import pytest
from hertzian.core.model import build_model
from hertzian.core.runner import Runner, run_scene
from hertzian.kernels.features import LATTICE_LAWS, Features
from hertzian.kernels.step import step_kernel

from tests.helpers import (
    assert_refused,
    chains,
    generated_source,
    invoke,
    make_scene,
    per_step,
    slope,
    sweep,
    toml_text,
)

SHAPES = {
    "fput": {"alpha": 0.25, "beta": 0.5},
    "toda": {"b": 2.0},
    "morse": {"alpha": 1.0},
    "lj": {"sigma": 1.0},
    "harmonic": {},
}
"""Shape keys of each law in these tests (strength a = 1, unit masses)."""
IMPACT = {"fput": 0.4, "toda": 0.4, "morse": 0.3, "lj": 0.1, "harmonic": 0.3}
"""Impacts that make every law nonlinear without driving it out of its well."""


def lattice_chain(law: str, **chain) -> dict:
    return {"potential": law, "a": 1.0, **SHAPES[law], **chain}


# ---- Toda's soliton ------------------------------------------------------------------------------------------------


def toda_soliton(n: np.ndarray, t: float, kappa: float, centre: float, a: float = 1.0, b: float = 1.0):
    """(u, v) of Toda's one-soliton solution (Toda, Theory of Nonlinear Lattices, §2.4) for V(r) = (a/b) e^{−br} + a r
    and unit masses: e^{−b r_n} − 1 = sinh²κ sech²(κ n − ω t + φ), ω = √(ab) sinh κ, in the displacements
    q_n = (1/b) ln[(1 + e^{2(κ(n−1) − ωt + φ)}) / (1 + e^{2(κn − ωt + φ)})], φ = −κ·centre."""
    omega = np.sqrt(a * b) * np.sinh(kappa)
    behind, ahead = 2.0 * (kappa * (n - 1) - omega * t - kappa * centre), 2.0 * (kappa * n - omega * t - kappa * centre)
    u = (np.logaddexp(0.0, behind) - np.logaddexp(0.0, ahead)) / b

    def logistic(x):
        return 0.5 * (1.0 + np.tanh(0.5 * x))

    v = 2.0 * omega * (logistic(ahead) - logistic(behind)) / b
    return u, v


def test_toda_soliton_closed_form_solves_the_equation_of_motion():
    """The closed form itself, before it judges the kernels: its acceleration (central differences in time) is
    the Toda force balance a(e^{bδ_{n−1}} − e^{bδ_n}) with δ_n = u_n − u_{n+1}."""
    n, t, h = np.arange(60.0), 3.0, 1e-4
    u = [toda_soliton(n, t + k * h, 1.0, 20.0, b=2.0)[0] for k in (-1, 0, 1)]
    acceleration = (u[0] - 2 * u[1] + u[2]) / h**2
    force = np.expm1(2.0 * (u[1][:-1] - u[1][1:]))
    balance = force[:-1] - force[1:]
    np.testing.assert_allclose(acceleration[1:-1], balance, atol=1e-6 * np.abs(balance).max())


def test_toda_soliton_over_100_time_units():
    """A κ = 1 soliton crossing 117 grains of a free 200-grain Toda chain (a = b = 1) with yoshida6: every grain's
    displacement equals the closed form to ≤ 1e-8 at every record."""
    grains, kappa, centre = 200, 1.0, 50.0
    scene = make_scene(
        chain={"grains": grains, "potential": "toda", "a": 1.0, "b": 1.0},
        boundary={"surface": "free", "bottom": "free"},
        integrator={"method": "yoshida6", "dt": 0.01, "duration": 100.0},
        record={"every": 10.0},
    )
    model = build_model([scene], "cpu")
    runner = Runner(model)
    n = np.arange(grains, dtype=np.float64)
    u, v = toda_soliton(n, 0.0, kappa, centre)
    force = np.expm1(u[:-1] - u[1:])
    acceleration = np.concatenate([[0.0], force]) - np.concatenate([force, [0.0]])
    dt = scene.integrator.dt
    runner.buffers[0].x.assign(np.stack([u, dt * v, dt * dt / 2 * acceleration])[:, None, :])
    result = runner.run()
    exact = np.stack([toda_soliton(n, t, kappa, centre)[0] for t in result.t])
    assert exact[-1, 160] - exact[0, 160] > 1.9  # the soliton passed grain 160, moving it by 2κ/b
    assert np.abs(result.u[0] - exact).max() <= 1e-8


# ---- order, energy, kernels ----------------------------------------------------------------------------------------

DTS = np.array([0.05, 0.025, 0.0125])
ORDER = {"verlet": (2.0, 2.0), "gear4": (4.0, 4.0), "gear5": (4.0, 5.0), "gear6": (6.0, 6.0)}
ORDER |= {"yoshida4": (4.0, 4.0), "yoshida6": (6.0, 6.0)}
"""(lowest, highest) slope of each method. gear5 lies between 4 and 5 on these chains: on a harmonic lattice its
errors fall 24, 23 and 21 times per halving from dt = 0.05 to 0.00625 (slopes 4.7, 4.5, 4.4), and the NumPy
reference's own gear5 gives the same errors to three digits; on the precompressed Hertz chain of
tests/core/test_order_of_accuracy.py it stays at 5."""


def smooth_scene(law: str, method: str, dt: float):
    return make_scene(
        chain={"grains": 10, **lattice_chain(law)},
        excitation={"impact": IMPACT[law]},
        integrator={"method": method, "dt": dt, "duration": 2.0},
        record={"every": 0.5},
    )


@functools.cache
def reference_u(law: str) -> np.ndarray:
    """gear6 at a quarter of the finest step: the reference of every method on ``law``."""
    return run_scene(smooth_scene(law, "gear6", DTS[-1] / 4), "cpu").u[0]


@pytest.mark.parametrize("method", list(ORDER))
@pytest.mark.parametrize("law", LATTICE_LAWS)
def test_order_of_every_method_on_every_law(law, method):
    reference = reference_u(law)
    errors = [
        np.abs(run_scene(smooth_scene(law, method, dt), "cpu").u[0] - reference).max() / np.abs(reference).max()
        for dt in DTS
    ]
    lowest, highest = ORDER[method]
    assert lowest - 0.3 < slope(DTS, errors) < highest + 0.3, (errors, slope(DTS, errors))


@pytest.mark.parametrize("law", LATTICE_LAWS)
def test_energy_is_conserved(law):
    """yoshida6 over about 120 periods of the fastest mode: the recorded energy (the record kernels' lattice
    potentials) stays within 1e-9 of the injected ½ m v² and does not drift."""
    scene = make_scene(
        chain={"grains": 16, **lattice_chain(law)},
        excitation={"impact": IMPACT[law]},
        integrator={
            "method": "yoshida6",
            "dt": 0.005 if law == "lj" else 0.02,
            "duration": 80.0 if law == "lj" else 400.0,
        },
        record={"every": 10.0},
    )
    energy = run_scene(scene, "cpu").energy[0]
    injected = 0.5 * IMPACT[law] ** 2
    assert energy[0] == pytest.approx(injected, rel=1e-14)
    assert np.abs(energy - injected).max() <= 1e-9 * injected


LAYOUTS = {
    "gear5, impurities": (dict(impurities=[{"grains": [5, 6], "mass": 0.5, "a": 2.0}]), "profile", "gear5"),
    "yoshida6, uniform ring": (dict(boundary={"surface": "periodic", "bottom": "periodic"}), "uniform", "yoshida6"),
}


@pytest.mark.parametrize(
    "law, layout",
    [("fput", "gear5, impurities"), ("morse", "gear5, impurities")]
    + [(law, "yoshida6, uniform ring") for law in ("toda", "lj", "harmonic")],
)
def test_chain_kernel_equals_per_step(law, layout):
    """Three chains loaded to a static overlap (with two impurities, or a uniform ring) swept by the CPU chain
    kernel, bit for bit the per-step kernel's state, once the pulse has reached the bottom."""
    extra, static, method = LAYOUTS[layout]
    sections = dict(
        chain={"grains": 20, **lattice_chain(law), "l0": 0.01},
        excitation={"impact": IMPACT[law] / 2},
        integrator={"method": method, "dt": 0.01},
        **extra,
    )
    model = build_model(chains(3, **sections), "cpu")
    assert model.features.potential == law and model.features.static == static
    steps = 3001
    want = per_step(model, steps)
    assert np.abs(want[1, :, -1]).max() > 1e-3 * np.abs(want[1]).max()  # the pulse reached the bottom
    np.testing.assert_array_equal(sweep(model, steps, steps_per_launch=100), want)


def test_a_law_is_compiled_only_where_a_chain_uses_it():
    """A Hertz kernel carries no exponential (no lattice law); Toda's carries no square root (no Hertz contact)."""
    hertz = generated_source(step_kernel(Features()))
    toda = generated_source(step_kernel(Features(hertz=False, potential="toda")))
    assert "wp::exp(" not in hertz and "wp::sqrt(" in hertz
    assert "wp::exp(" in toda and "wp::sqrt(" not in toda


# ---- refusals ------------------------------------------------------------------------------------------------------

REFUSED = {
    "toda b ≤ 0": ({"potential": "toda", "b": 0.0}, "chain.b"),
    "negative σ": ({"potential": "lj", "sigma": -1.0}, "chain.sigma"),
    "morse α ≤ 0": ({"potential": "morse", "alpha": -1.0}, "chain.alpha"),
    "a shape key of another law": ({"potential": "toda", "beta": 1.0}, "chain.beta"),
    "an unknown law": ({"potential": "fpu"}, "chain.potential"),
    "an exponent with a lattice law": ({"potential": "harmonic", "exponent": 3.0}, "chain.exponent"),
    "a load beyond fput-α's largest force": ({"potential": "fput", "a": 1.0, "alpha": 1.0, "load": 1.0}, "chain.load"),
    "a precompression whose Toda force overflows": ({"potential": "toda", "l0": 1e9}, "chain.l0"),
}


@pytest.mark.parametrize("case", list(REFUSED))
def test_bad_parameters_are_refused_in_one_line(case, tmp_path):
    chain, key = REFUSED[case]
    scene = tmp_path / "scene.toml"
    scene.write_text(toml_text({"chain": {"grains": 8, **chain}, "integrator": {"duration": 1.0}}))
    out = tmp_path / "out.zarr"
    assert_refused(invoke("run", scene, "--out", out), out, key)


def test_a_dashpot_is_refused_with_a_lattice_law(tmp_path):
    scene = tmp_path / "scene.toml"
    data = {"chain": {"grains": 8, "potential": "fput"}, "damping": {"model": "contact", "gamma": 0.1}}
    scene.write_text(toml_text({**data, "integrator": {"duration": 1.0}}))
    out = tmp_path / "out.zarr"
    assert_refused(invoke("run", scene, "--out", out), out, "damping.model")


def test_detection_refuses_a_lattice_host_in_one_line(tmp_path):
    """``hertzian detect`` builds its library through the sweeps' path: a lattice base scene is refused, one line."""
    signal = tmp_path / "signal.csv"
    signal.write_text("t,v\n0,0.1\n0.1,0.09\n0.2,0.08\n0.3,0.05\n")
    base = tmp_path / "base.toml"
    scene = {"chain": {"grains": 20, **lattice_chain("fput")}, "excitation": {"impact": 0.1}}
    base.write_text(toml_text({**scene, "integrator": {"duration": 1.0, "dt": 0.01}}))
    result = invoke("detect", signal, "--scene", base)
    assert result.exit_code == 2, (result.stdout, result.stderr)
    assert result.stderr.strip().startswith("error: chain.potential") and len(result.stderr.strip().splitlines()) == 1


@pytest.mark.parametrize("law", LATTICE_LAWS)
def test_static_overlap_is_the_smallest_float_that_carries_the_force(law):
    """δ0 solves F(δ0) = force on the law's rising branch to the last float: F of the float below δ0 is short of the
    force, F(δ0) is not (an unloaded contact: exactly 0)."""
    from hertzian.core.potentials import Law

    shape = {"fput": (0.25, 0.5), "toda": (2.0, 0.0), "morse": (1.0, 0.0), "lj": (1.0, 0.0)}.get(law, (0.0, 0.0))
    rule = Law(law, *shape)
    rng = np.random.default_rng(3)
    force = np.concatenate([[0.0], rng.uniform(1e-4, 0.1, 40)])
    a = rng.uniform(0.5, 2.0, force.shape)
    delta = rule.static_overlap(force, a)
    assert delta[0] == 0.0 and np.all(delta[1:] > 0)
    below = np.nextafter(delta[1:], 0.0)
    assert np.all(rule.force(below, a[1:]) < force[1:])
    assert np.all(rule.force(delta[1:], a[1:]) >= force[1:])
    np.testing.assert_array_equal(rule.static_overlap(np.zeros(5), np.ones(5)), np.zeros(5))
