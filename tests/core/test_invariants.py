"""Core simulator checks that need no reference implementation: determinism, ensembles,
the contact law, float64 precision, the static state, specialisation, energy conservation."""

import numpy as np
import pytest
import warp as wp
from hertzian.core.model import build_model
from hertzian.core.runner import Runner, run_ensemble, run_scene
from hertzian.core.static import static_state
from hertzian.kernels.features import EVENT_WINDOW, Features
from hertzian.kernels.physics import contact_functions, contact_potential, excess_potential
from hertzian.kernels.step import step_kernel

from tests.helpers import accessed_arrays, generated_source, make_scene


def impact_scene(**over):
    base = dict(
        chain={"grains": 40, "l0": 1e-4},
        excitation={"impact": 1e-2},
        integrator={"duration": 0.2, "dt": 1e-4},
        record={"every": 0.05, "traces": [0, 7]},
    )
    for k, v in over.items():
        base.setdefault(k, {}).update(v)
    return make_scene(**base)


def test_two_identical_runs_are_bitwise_equal(device):
    a = run_scene(impact_scene(), device)
    b = run_scene(impact_scene(), device)
    np.testing.assert_array_equal(a.u, b.u)
    np.testing.assert_array_equal(a.v, b.v)
    np.testing.assert_array_equal(a.energy, b.energy)
    np.testing.assert_array_equal(a.traces["u"], b.traces["u"])


@pytest.mark.parametrize("kind", ["homogeneous", "impurities"])
def test_ensemble_member_equals_same_chain_alone(device, kind):
    imp = [{"grains": [10, 11], "mass": 0.5, "a": 2000.0}] if kind == "impurities" else []
    scenes = [
        make_scene(
            chain={"grains": 30, "l0": l0, "gravity": g},
            impurities=imp,
            excitation={"impact": v},
            integrator={"duration": 0.1, "dt": 1e-4},
            record={"every": 0.05},
        )
        for l0, g, v in [(1e-4, 0.0, 1e-2), (1e-5, 1.0, 1e-1), (0.0, 0.5, 1e-3)]
    ]
    together = run_ensemble(scenes, device)
    for c, scene in enumerate(scenes):
        # alone, but with the same kernel variant (features are the union over the ensemble)
        alone = Runner(build_model([scene], device, features=together.features)).run()
        np.testing.assert_array_equal(together.u[c], alone.u[0])
        np.testing.assert_array_equal(together.v[c], alone.v[0])
        np.testing.assert_array_equal(together.energy[c], alone.energy[0])


def test_driven_ensemble_members_differ_in_amplitude_and_period(device):
    scenes = [
        make_scene(
            chain={"grains": 25, "gravity": g},
            boundary={"surface": "driven", "bottom": "fixed"},
            excitation={"drive_amplitude": amp, "drive_period": period},
            integrator={"duration": 0.1, "dt": 1e-4},
            record={"every": 0.05, "traces": [0, 3]},
        )
        for amp, period, g in [(1e-3, 0.05, 1.0), (3e-3, 0.02, 0.0), (2e-3, 0.1, 5.0)]
    ]
    together = run_ensemble(scenes, device)
    for c, scene in enumerate(scenes):
        alone = Runner(build_model([scene], device, features=together.features)).run()
        np.testing.assert_array_equal(together.u[c], alone.u[0])
        np.testing.assert_array_equal(together.work[c], alone.work[0])
        np.testing.assert_array_equal(together.traces["v"][c], alone.traces["v"][0])
    # the surface grain follows the drive exactly
    t = together.trace_t
    np.testing.assert_allclose(
        together.traces["u"][1, :, 0], 3e-3 * np.sin(2 * np.pi * t / 0.02), rtol=0, atol=1e-13 * 3e-3
    )


def test_member_alone_with_its_own_smaller_kernel_agrees(device):
    """A chain run alone gets a leaner kernel variant; it must agree to rounding."""
    scenes = [impact_scene(chain={"gravity": 1.0}), impact_scene()]
    together = run_ensemble(scenes, device)
    alone = run_scene(scenes[1], device)
    assert alone.features.static == "uniform" and together.features.static == "profile"
    np.testing.assert_allclose(together.u[1], alone.u[0], rtol=0, atol=1e-15 * np.abs(alone.u).max())


@pytest.mark.parametrize("precision", ["float64", "float32"])
@pytest.mark.parametrize("exponent", [2.5, 2.0, 3.0])
def test_force_is_minus_potential_gradient(precision, exponent):
    """F(δ) = dV/dδ, checked by central finite differences of the (float64) potential."""
    hertz = exponent == 2.5
    force, _ = contact_functions(precision, hertz)
    real = wp.float64 if precision == "float64" else wp.float32

    @wp.kernel(module="unique")
    def evaluate(
        delta: wp.array(dtype=real), out_f: wp.array(dtype=real), out_v: wp.array(dtype=wp.float64), a: real, n: real
    ):
        i = wp.tid()
        out_f[i] = force(delta[i], a, n)
        out_v[i] = contact_potential(wp.float64(delta[i]), wp.float64(a), wp.float64(n))

    a = 5657.0
    deltas = np.array([-1e-3, 0.0, 1e-6, 1e-4, 3e-3, 0.5, 2.0])
    d = wp.array(deltas, dtype=real)
    f_out = wp.zeros(len(deltas), dtype=real)
    v_out = wp.zeros(len(deltas), dtype=wp.float64)
    wp.launch(evaluate, dim=len(deltas), inputs=[d, f_out, v_out, a, exponent], device="cpu")
    f = f_out.numpy().astype(np.float64)
    v = v_out.numpy()
    deltas = d.numpy().astype(np.float64)  # as the kernel saw them (float32-rounded in float32)
    np.testing.assert_allclose(v, a * np.maximum(deltas, 0) ** exponent, rtol=1e-14)
    h = 1e-6 * np.maximum(np.abs(deltas), 1e-6)
    vp = a * np.maximum(deltas + h, 0) ** exponent
    vm = a * np.maximum(deltas - h, 0) ** exponent
    numeric = (vp - vm) / (2 * h)
    positive = deltas > 0
    rtol = 1e-6 if precision == "float32" else 1e-8
    np.testing.assert_allclose(f[positive], numeric[positive], rtol=rtol)
    assert np.all(f[~positive] == 0)  # no tension


def test_excess_potential_matches_naive_form_where_that_is_accurate():
    @wp.kernel(module="unique")
    def evaluate(d0: wp.array(dtype=wp.float64), d: wp.array(dtype=wp.float64), out: wp.array(dtype=wp.float64)):
        i = wp.tid()
        out[i] = excess_potential(d0[i], d[i], wp.float64(5657.0), wp.float64(2.5))

    d0 = np.array([1e-4, 1e-4, 1e-4, 1e-4, 0.0, 1.0])
    d = np.array([1e-7, -3e-5, 2e-3, -5e-4, 1e-3, 1e-9])
    out = wp.zeros(len(d), dtype=wp.float64)
    wp.launch(evaluate, dim=len(d), inputs=[wp.array(d0, dtype=wp.float64), wp.array(d, dtype=wp.float64), out])
    import decimal

    decimal.getcontext().prec = 50
    ref = []
    for x0, x in zip(d0, d):
        D = decimal.Decimal
        V = lambda z: D(5657) * (max(D(z), D(0)) ** D("2.5")) if z > 0 else D(0)  # noqa: E731
        dV0 = D("2.5") * D(5657) * (D(x0) ** D("1.5")) if x0 > 0 else D(0)
        ref.append(float(V(D(x0) + D(x)) - V(D(x0)) - dV0 * D(x)))
    np.testing.assert_allclose(out.numpy(), ref, rtol=1e-12, atol=0)


def test_float64_kernels_hold_float64_accuracy(device):
    """A Verlet step from a known state against the same arithmetic in NumPy float64 (a float32
    constant anywhere in the kernel would show up as a ~1e-8 relative error)."""
    scene = make_scene(
        chain={"grains": 3, "l0": 1e-4},
        boundary={"surface": "free", "bottom": "free"} if False else {},
        excitation={"impact": 0.0123456789},
        integrator={"duration": 1e-4, "dt": 1e-4, "method": "verlet"},
    )
    result = run_scene(scene, device)
    st = static_state(scene)
    a, dt, v0 = 5657.0, 1e-4, 0.0123456789
    u = np.array([dt * v0, 0.0, 0.0])  # positions after one step (a = 0 initially)
    d0 = st.static_overlap
    F = lambda x: 2.5 * a * np.maximum(x, 0) ** 1.5  # noqa: E731
    excess = [
        F(d0[0] - u[0]) - F(d0[0]),
        F(d0[1] + u[0] - u[1]) - F(d0[1]),
        F(d0[2] + u[1] - u[2]) - F(d0[2]),
        F(d0[3] + u[2]) - F(d0[3]),
    ]
    acc = np.array([excess[0] - excess[1], excess[1] - excess[2], excess[2] - excess[3]])
    v1 = np.array([v0, 0, 0]) + 0.5 * dt * acc
    np.testing.assert_allclose(result.u[0, -1], u, rtol=1e-15, atol=0)
    np.testing.assert_allclose(result.v[0, -1], v1, rtol=1e-13, atol=1e-20)
    assert abs(result.v[0, -1, 1] - v1[1]) <= 1e-12 * abs(v1[1])


def test_scene_without_excitation_stays_at_rest_in_a_2000_grain_column():
    scene = make_scene(
        chain={"grains": 2000, "gravity": 10.0},
        boundary={"surface": "free", "bottom": "wall"},
        integrator={"duration": 10_000 * 1.25e-5},
        record={"every": 2_500 * 1.25e-5},
    )
    result = run_scene(scene, "cpu")
    assert result.steps == 10_000
    assert np.max(np.abs(result.v)) <= 1e-12
    assert np.max(np.abs(result.u)) <= 1e-12


def linear_chain_motion(scene, times: np.ndarray, *, overlap_factor: float = 1.0) -> np.ndarray:
    """Displacements (len(times), N) of a chain struck at grain 0, from linear theory (NumPy only).

    Static overlaps from the sum rule (contact k carries F0 + g Σ_{j<k} m_j, δ0 = (F/(n a_c))^(1/(n−1)),
    times ``overlap_factor``), contact constants from docs/model.md's rules (harmonic mean, or an impurity's own
    constant), stiffness k = F'(δ0) = n(n−1) a_c δ0^(n−2); normal modes of M ü = −K u."""
    c, n, N = scene.chain, scene.chain.exponent, scene.chain.grains
    mass, a, own = np.full(N, c.mass), np.full(N, c.a), np.zeros(N, bool)
    for imp in scene.impurities:
        mass[list(imp.grains)] = imp.mass
        a[list(imp.grains)] = imp.a
        own[list(imp.grains)] = imp.contact == "own"
    a_c = np.zeros(N + 1)
    for k in range(1, N):
        i, j = k - 1, k
        a_c[k] = (
            a[i]
            if own[i] and not own[j]
            else a[j]
            if own[j] and not own[i]
            else a[i]
            if a[i] == a[j]
            else 2 * a[i] * a[j] / (a[i] + a[j])
        )
    walls = {0: scene.boundary.surface == "wall", N: scene.boundary.bottom == "wall"}
    a_c[0], a_c[N] = (a[0] if walls[0] else 0.0), (a[-1] if walls[N] else 0.0)
    carried = c.surface_force + c.gravity * np.concatenate([[0.0], np.cumsum(mass)])
    overlap = overlap_factor * (carried / (n * np.where(a_c > 0, a_c, 1.0))) ** (1 / (n - 1))
    stiffness = np.where(a_c > 0, n * (n - 1) * a_c * overlap ** (n - 2), 0.0)
    moving = N - 1 if scene.boundary.bottom == "fixed" else N
    K = np.zeros((N + 1, N + 1))  # grain N stands for anything held
    for k in range(N + 1):
        above, below = (k - 1 if k >= 1 else N), (k if k < moving else N)
        for x, y in ((above, above), (below, below)):
            K[x, y] += stiffness[k]
        K[above, below] -= stiffness[k]
        K[below, above] -= stiffness[k]
    K = K[:moving, :moving]
    root_m = np.sqrt(mass[:moving])
    omega2, Q = np.linalg.eigh(K / np.outer(root_m, root_m))
    assert np.all(omega2 > 0), "every mode must be bound by a preloaded contact"
    omega = np.sqrt(omega2)
    start = np.zeros(moving)
    start[0] = scene.excitation.impact * root_m[0]
    modal = Q.T @ start
    u = (np.sin(np.outer(times, omega)) / omega * modal) @ Q.T / root_m
    return np.pad(u, ((0, 0), (0, N - moving)))


LINEAR_CASES = {
    "walls, uniform precompression": dict(chain={"l0": 1e-4}),
    "fixed bottom, gravity, harmonic impurity": dict(
        chain={"l0": 1e-4, "gravity": 2.0},
        boundary={"bottom": "fixed"},
        impurities=[{"grains": [3], "mass": 0.5, "a": 2000.0}],
    ),
    "load surface, own-rule impurities, n = 3": dict(
        chain={"l0": 1e-3, "exponent": 3.0},
        boundary={"surface": "load"},
        impurities=[{"grains": [2, 3], "mass": 2.0, "a": 1e4, "contact": "own"}],
    ),
    "free surface held by gravity": dict(chain={"gravity": 1.0}, boundary={"surface": "free"}),
}


@pytest.mark.parametrize("case", list(LINEAR_CASES))
def test_small_motion_about_the_static_state_follows_linear_theory(case):
    """A tiny impact on a preloaded chain: the kernel's motion is the linear chain's with stiffness
    F'(δ0) at the sum-rule static overlaps. A wrong δ0 anywhere (host or kernel) changes the mode
    frequencies; 0.1 % in δ0 is 50× beyond the tolerance (asserted below)."""
    sections = {k: dict(v) if isinstance(v, dict) else v for k, v in LINEAR_CASES[case].items()}
    sections["chain"]["grains"] = 8
    scene = make_scene(
        **sections, excitation={"impact": 1e-10}, integrator={"duration": 1.0, "dt": 1e-4}, record={"every": 0.05}
    )
    result = run_scene(scene, "cpu")
    predicted = linear_chain_motion(scene, result.t)
    scale = np.abs(predicted).max(axis=0)
    assert np.all(scale[: -1 if scene.boundary.bottom == "fixed" else None] > 0.01 * scale.max())  # every grain moves
    tolerance = 1e-5 * scale.max()
    np.testing.assert_allclose(result.u[0], predicted, rtol=0, atol=tolerance)
    off = linear_chain_motion(scene, result.t, overlap_factor=1.001)
    assert np.max(np.abs(off - predicted)) > 50 * tolerance


def test_static_sum_rule():
    """Paper eq. 4 (+ load): contact k carries F0 + g Σ_{j<k} m_j = n a_c δ0^(n−1)."""
    scene = make_scene(
        chain={"grains": 100, "gravity": 2.0, "l0": 1e-4}, impurities=[{"grains": [30, 31], "mass": 0.5, "a": 2000.0}]
    )
    st = static_state(scene)
    m = np.ones(100)
    m[[30, 31]] = 0.5
    f0 = 2.5 * 5657.0 * 1e-4**1.5
    expected = f0 + 2.0 * np.concatenate([[0.0], np.cumsum(m)])
    np.testing.assert_allclose(2.5 * st.contact_constant * st.static_overlap**1.5, expected, rtol=1e-13)
    # equal grains give back exactly l0
    plain = static_state(make_scene(chain={"grains": 10, "l0": 1e-4}))
    np.testing.assert_allclose(plain.static_overlap, 1e-4, rtol=1e-15)


def test_harmonic_and_own_contact_rules():
    harmonic = static_state(make_scene(chain={"grains": 5}, impurities=[{"grains": [2], "a": 2000.0}]))
    own = static_state(make_scene(chain={"grains": 5}, impurities=[{"grains": [2], "a": 2000.0, "contact": "own"}]))
    hm = 2 * 5657.0 * 2000.0 / (5657.0 + 2000.0)
    np.testing.assert_allclose(harmonic.contact_constant, [5657, 5657, hm, hm, 5657, 5657])
    np.testing.assert_allclose(own.contact_constant, [5657, 5657, 2000, 2000, 5657, 5657])


def test_energy_conservation_gear4_paper_impact():
    """gear4, dt = 1.25e-4, impact chain: energy error ≤ 1e-6 of the injected energy."""
    for l0 in (0.0, 1e-4):
        scene = make_scene(
            chain={"grains": 200, "l0": l0},
            excitation={"impact": 1e-2},
            integrator={"duration": 5.0, "dt": 1.25e-4},
            record={"every": 0.25},
        )
        result = run_scene(scene, "cpu")
        assert result.energy_error[0] <= 1e-6, (l0, result.energy_error[0])
        assert result.energy_error[0] > 0  # a real measurement, not a stored zero


def test_unused_features_generate_no_code():
    """Gravity and load need no kernel code at all (absorbed in the static state); drive, traces,
    static overlaps, per-grain masses and a general exponent appear only when a chain needs them."""
    lean = Features(method="gear4", surface="free", bottom="free", static="none")
    full = Features(
        method="gear4", surface="driven", bottom="wall", static="profile", heterogeneous=True, hertz=False, traces=True
    )
    lean_src, full_src = generated_source(step_kernel(lean)), generated_source(step_kernel(full))
    optional = {
        "static_overlap",
        "drive",
        "trace_slot",
        "trace_x",
        "law_parameters",
        "work_in",
        "work_out",
        "power_in",
        "power_out",
    }
    assert optional <= accessed_arrays(full_src)
    assert not optional & accessed_arrays(lean_src)
    for call in ("wp::sin(", "wp::cos(", "wp::pow("):
        assert call in full_src and call not in lean_src, call
    # Hertz uses sqrt, not pow; a chain without walls has no wall-contact code paths
    assert "wp::sqrt(" in lean_src


def test_unused_features_allocate_no_memory():
    model = build_model([impact_scene(chain={"l0": 0.0})], "cpu")
    # l0 = 0: contacts open, so gear4 steps are event-aware (no array of their own)
    assert model.features == Features(static="none", traces=True, event_window=EVENT_WINDOW)
    assert model.static_overlap.size == 0 and model.law_parameters.size == 0 and model.drive.size == 0
    assert model.inverse_mass.shape == (1, 1) and model.contact_constant.shape == (1, 1)
    assert model.state().work.size == 0


def test_energy_error_is_checked_between_records():
    """With records only at t = 0 and the end, the device-side checks every 512 steps must give the
    same energy error and largest overlap as a run that records every 512 steps (computed on the host
    from the stored energies)."""
    base = dict(
        chain={"grains": 30, "l0": 1e-4}, excitation={"impact": 1e-2}, integrator={"duration": 4096 * 2e-4, "dt": 2e-4}
    )
    sparse = run_scene(make_scene(**base), "cpu")
    dense = run_scene(make_scene(**base, record={"every": 512 * 2e-4}), "cpu")
    assert sparse.t.size == 2 and dense.t.size == 9
    from hertzian.core.runner import energy_errors

    from_records = energy_errors(dense.energy, None, dense.scenes[0].injected_energy * np.ones(1))
    np.testing.assert_allclose(sparse.energy_error, from_records, rtol=1e-12)
    np.testing.assert_allclose(dense.energy_error, from_records, rtol=1e-12)
    # the two end-point records alone see less than the checks in between
    ends_only = energy_errors(sparse.energy, None, sparse.scenes[0].injected_energy * np.ones(1))
    assert ends_only[0] < 0.5 * sparse.energy_error[0]
    np.testing.assert_array_equal(sparse.max_overlap, dense.max_overlap)
