"""`hertzian check`: the contact-time estimate and the stability limits, against independent references.

* The one-step amplification matrices (ensemble/core/check.py) are checked against the Warp kernels on
  a linear chain (n = 2: springs), where a normal mode evolves exactly by the matrix.
* The highest-frequency bound is checked against dense eigenvalues of the linearised chain.
* The overlap bound is checked against the largest overlap real runs reach.
"""

import json
import math

import numpy as np
import pytest
from hertzian.core.check import (
    STABLE_OMEGA_DT,
    amplification_matrix,
    check_scene,
    dt_warning,
    excess_potential,
    growth_per_period,
    overlap_reach,
)
from hertzian.core.model import build_model
from hertzian.core.runner import Runner, run_scene
from hertzian.core.static import static_state

from tests.helpers import hertzian, make_scene

A = 5657.0
METHODS = ["gear4", "gear5", "gear6", "verlet", "yoshida4", "yoshida6"]


def linear_pair(method: str, omega_dt: float, steps: int):
    """Two unit grains between walls joined by springs k = 2a (n = 2, l0 = 1 keeps every contact closed).

    Normal modes: (1, 1) at ω² = k and (1, −1) at ω² = 3k; ``omega_dt`` is the fast mode's ω·dt.
    """
    dt = omega_dt / math.sqrt(3 * 2 * A)
    return make_scene(
        chain={"grains": 2, "exponent": 2.0, "l0": 1.0},
        excitation={"impact": 1e-5},
        integrator={"method": method, "dt": dt, "duration": dt * steps},
        record={"every": dt},
    )


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("fraction", [0.5, 1.1])
def test_amplification_matrix_is_what_the_kernel_does(method, fraction):
    """The fast mode u0 − u1 of the Warp run follows M(ω dt)^k applied to its start, to rounding."""
    omega_dt = fraction * STABLE_OMEGA_DT[method]
    scene = linear_pair(method, omega_dt, 40)
    assert check_scene(scene).omega_dt == pytest.approx(omega_dt, rel=1e-12)  # Gershgorin is exact here
    runner = Runner(build_model([scene], "cpu"))
    start = runner.buffers[0].x.numpy()[:, 0, :].copy()  # (a CPU array.numpy() is a view)
    fast = runner.run().u[0]
    fast = fast[:, 0] - fast[:, 1]
    matrix = amplification_matrix(method, omega_dt)
    predicted = [start[:, 0] - start[:, 1]]
    for _ in range(40):
        predicted.append(matrix @ predicted[-1])
    predicted = np.array(predicted)[:, 0]
    linear = np.abs(predicted) < 1e-3  # contacts stay closed (|d| ≪ l0 = 1): the chain is linear
    assert linear[:10].all()
    scale = np.abs(predicted[linear]).max()
    assert np.abs(fast[linear] - predicted[linear]).max() < 1e-6 * scale


@pytest.mark.parametrize("method", METHODS)
def test_stability_limits(method):
    """Below the limit the amplitude grows by < 10 % per period (gear4 damps); just above it, by more."""
    limit = STABLE_OMEGA_DT[method]
    for z in np.linspace(0.05, 0.97, 24) * limit:
        assert growth_per_period(method, z) < 0.1, z
    # just above: yoshida6's first unstable band is narrow (ω dt 2.269-2.327, stable again up to 2.818)
    assert growth_per_period(method, (1.01 if method == "yoshida6" else 1.03) * limit) > 0.1
    if method in ("gear4", "verlet", "yoshida4", "yoshida6"):
        # no growth at all below the limit (gear4 damps, Verlet and the Yoshida compositions conserve)
        for z in np.linspace(0.05, 0.99, 24) * limit:
            rho = np.max(np.abs(np.linalg.eigvals(amplification_matrix(method, z))))
            assert rho <= 1 + 1e-12, (z, rho)


@pytest.mark.parametrize("method", METHODS)
def test_run_beyond_the_limit_blows_up_and_below_stays_bounded(method):
    """End to end on the linear pair: 30 periods at 0.7× the limit stay bounded, at 1.3× they explode."""

    def amplitude_growth(fraction):
        omega_dt = fraction * STABLE_OMEGA_DT[method]
        steps = int(30 * 2 * math.pi / omega_dt)
        result = run_scene(linear_pair(method, omega_dt, steps), "cpu")
        fast = np.abs(result.u[0][:, 0] - result.u[0][:, 1])
        period = int(2 * math.pi / omega_dt) + 1
        return (fast[-period:].max() if np.all(np.isfinite(fast)) else np.inf) / fast[:period].max()

    assert amplitude_growth(0.7) < 3.0
    assert amplitude_growth(1.3) > 1e3


def test_highest_frequency_bounds_the_chain_spectrum():
    """Gershgorin's ω_max ≥ the largest eigenfrequency of the linearised chain (dense eigvalsh), and is tight."""
    scene = make_scene(
        chain={"grains": 12, "l0": 1e-3, "gravity": 2.0},
        impurities=[{"grains": [3], "mass": 0.1, "a": 2e4}, {"grains": [7, 8], "mass": 5.0}],
        excitation={"impact": 1e-2},
    )
    result = check_scene(scene)
    st = static_state(scene)
    # rebuild the stiffness matrix independently from the per-contact largest overlaps
    n = st.exponent
    energy = 0.5 * st.mass[0] * 1e-2**2
    reach = overlap_reach(st.static_overlap, st.contact_constant, n, energy)
    k = n * (n - 1) * st.contact_constant * (st.static_overlap + reach) ** (n - 2)
    stiffness = np.zeros((12, 12))
    for c in range(13):  # padded contact c joins grains c-1 and c
        for i in (c - 1, c):
            if 0 <= i < 12:
                stiffness[i, i] += k[c]
        if 1 <= c <= 11:
            stiffness[c - 1, c] -= k[c]
            stiffness[c, c - 1] -= k[c]
    inv_sqrt_m = 1 / np.sqrt(st.mass)
    omega_max = math.sqrt(np.linalg.eigvalsh(stiffness * np.outer(inv_sqrt_m, inv_sqrt_m)).max())
    assert omega_max <= result.highest_frequency * (1 + 1e-12)
    assert result.highest_frequency < 1.5 * omega_max


def test_overlap_bound_solves_the_energy_equation():
    delta0 = np.array([0.0, 1e-4, 1e-2])
    a_c = np.array([A, A, 2 * A])
    d = overlap_reach(delta0, a_c, 2.5, 5e-5)
    assert np.allclose(excess_potential(delta0, d, a_c, 2.5), 5e-5, rtol=1e-10)
    assert d[0] == pytest.approx((5e-5 / A) ** 0.4, rel=1e-10)  # closed form with no static overlap
    # small-ratio branch agrees with the direct formula where both are accurate
    r = np.array([2e-4, 5e-4])
    direct = A * ((1 + r) ** 2.5 - 1 - 2.5 * r)
    assert np.allclose(excess_potential(np.ones(2), r, np.full(2, A), 2.5), direct, rtol=1e-6)


@pytest.mark.parametrize(
    "case",
    [
        {"chain": {"grains": 30, "l0": 1e-4}},
        {"chain": {"grains": 30}},
        {"chain": {"grains": 30, "gravity": 5.0}, "impurities": [{"grains": [2], "mass": 0.05}]},
        {"chain": {"grains": 30, "exponent": 3.0, "l0": 1e-3}},
    ],
)
def test_overlap_bound_holds_in_real_runs(case):
    """The largest overlap a run reaches (recorded often) never exceeds the bound, and the bound is not loose."""
    scene = make_scene(
        **case,
        excitation={"impact": 1e-2},
        integrator={"dt": 5e-5, "duration": 1.5},
        record={"every": 5e-4, "fields": ["u"]},
    )
    reached = float(run_scene(scene, "cpu").max_overlap[0])
    bound = check_scene(scene).largest_overlap
    assert reached <= bound
    assert reached > 0.5 * bound


def test_contact_time_closed_form():
    """l0 = 0, impact v on equal grains: δ = (½ m v²/a)^(2/5), T = 2π sqrt((m/2)/(n(n−1)aδ^(n−2)))."""
    scene = make_scene(chain={"grains": 5}, excitation={"impact": 0.1}, integrator={"dt": 1e-4})
    delta = (0.5 * 0.01 / A) ** 0.4
    expected = 2 * math.pi * math.sqrt(0.5 / (3.75 * A * math.sqrt(delta)))
    result = check_scene(scene)
    assert result.largest_overlap == pytest.approx(delta, rel=1e-9)
    assert result.contact_time == pytest.approx(expected, rel=1e-9)
    assert result.stiffest_contact == 1


def test_gravity_and_validity():
    """g = 100 on 10^4 grains: the static bottom overlap alone, ((g Σm)/(n a))^(2/3), exceeds 0.1·diameter."""
    scene = make_scene(chain={"grains": 10_000, "gravity": 100.0}, integrator={"dt": 1e-5, "duration": 1e-3})
    bottom = (100.0 * 10_000 / (2.5 * A)) ** (2 / 3)
    result = check_scene(scene)
    assert result.largest_overlap == pytest.approx(bottom, rel=1e-9)
    assert result.beyond_validity and any("0.1·diameter" in note for note in result.notes)
    assert result.stiffest_contact == 9_999  # the last inner contact: m_red = ½ beats the wall's 1


@pytest.mark.parametrize("method", METHODS)
def test_suggested_dt_passes_its_own_check(method):
    scene = make_scene(
        chain={"grains": 50, "l0": 1e-4},
        excitation={"impact": 1e-2},
        integrator={"method": method, "dt": 0.05, "duration": 1.0},
    )
    first = check_scene(scene)
    assert first.verdict == "unstable" and dt_warning(scene) is not None
    fixed = scene.with_overrides({"integrator.dt": first.suggested_dt})
    assert check_scene(fixed).verdict == "ok" and dt_warning(fixed) is None


def test_cli_check_and_strict_run(tmp_path):
    scene = tmp_path / "s.toml"
    scene.write_text(
        "[chain]\ngrains = 10\nl0 = 1e-4\n[excitation]\nimpact = 1e-2\n"
        '[integrator]\ndt = 0.02\nduration = 0.2\nmethod = "gear6"\n'
    )
    out = hertzian("check", str(scene), "--json", cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    data = json.loads(out.stdout)
    assert data["verdict"] in ("unstable", "inaccurate") and data["suggested_dt"] < 0.02
    refused = hertzian("run", str(scene), "--out", str(tmp_path / "x.zarr"), "--strict", cwd=tmp_path)
    assert refused.returncode == 2
    assert refused.stderr.startswith("error: integrator.dt = 0.02") and refused.stderr.count("\n") == 1
    assert not (tmp_path / "x.zarr").exists()
    warned = hertzian("run", str(scene), "--out", str(tmp_path / "x.zarr"), "--quiet", cwd=tmp_path)
    assert warned.returncode == 0, warned.stderr
    assert "warning: integrator.dt = 0.02" in warned.stderr and (tmp_path / "x.zarr").exists()
    safe = hertzian(
        "run",
        str(scene),
        "--out",
        str(tmp_path / "y.zarr"),
        "--strict",
        "--quiet",
        "--set",
        f"integrator.dt={data['suggested_dt']}",
        cwd=tmp_path,
    )
    assert safe.returncode == 0 and "warning: integrator.dt" not in safe.stderr


def test_an_accepted_step_is_not_warned_about_but_an_unstable_one_is():
    """integrator.accepted_steps_per_contact silences the accuracy warning only down to that many steps per contact
    time, and never an unstable step."""
    scene = make_scene(
        chain={"grains": 50, "l0": 1e-4}, excitation={"impact": 1e-2}, integrator={"dt": 1e-4, "duration": 1.0}
    )
    steps = check_scene(scene).contact_time / 1e-4
    inaccurate = scene.with_overrides({"integrator.dt": check_scene(scene).contact_time / 250})
    assert check_scene(inaccurate).verdict == "inaccurate" and "looks inaccurate" in dt_warning(inaccurate)
    accepted = inaccurate.with_overrides({"integrator.accepted_steps_per_contact": 240})
    assert check_scene(accepted).verdict == "accepted" and dt_warning(accepted) is None
    short = inaccurate.with_overrides({"integrator.accepted_steps_per_contact": 260})
    assert check_scene(short).verdict == "inaccurate" and dt_warning(short) is not None
    unstable = accepted.with_overrides({"integrator.dt": 0.05, "integrator.accepted_steps_per_contact": 1})
    assert check_scene(unstable).verdict == "unstable" and "looks unstable" in dt_warning(unstable)
    assert steps > 400  # the base scene itself is accurate


@pytest.mark.parametrize("name", ["paper_sec6_standing.toml", "paper_fig9_10.toml", "paper_fig7_8.toml"])
def test_paper_sweeps_at_the_papers_step_run_without_a_dt_warning(name, tmp_path):
    result = hertzian("sweep", name, "--out", tmp_path / "s.zarr", "--dry-run", "--device", "cpu")
    assert result.returncode == 0, result.stderr
    assert "looks" not in result.stdout + result.stderr
