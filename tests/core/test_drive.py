"""Standing-wave drive studies (docs/drive.md): damping, the energy balance E + D − W, response windows
accumulated on the device, and the linear limit against the linearised chain solved in NumPy."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hertzian.core.model import build_model
from hertzian.core.response import ResponseAccumulator
from hertzian.core.runner import Runner, run_scene
from hertzian.core.scene import RESPONSE_MIN_SAMPLES_PER_PERIOD, SceneError, response_stride_of, scene_from_dict
from hertzian.core.solvers import choose_config
from hertzian.core.solvers.calibrate import fused_lacks, step_reason

from tests.helpers import accessed_arrays, assert_refused, generated_source, invoke, toml_text

L0 = 1e-3
A_SELF = 5657.0


def driven(
    grains=16, amplitude=1e-8, period=0.5, duration=15.0, dt=1e-3, damping=("viscous", 2.0), record=None, bottom="fixed"
):
    data = {
        "chain": {"grains": grains, "l0": L0},
        "boundary": {"surface": "driven", "bottom": bottom},
        "excitation": {"drive_amplitude": amplitude, "drive_period": period},
        "integrator": {"duration": duration, "dt": dt},
        "record": record or {},
    }
    if damping is not None:
        data["damping"] = {"model": damping[0], "gamma": damping[1]}
    return scene_from_dict(data)


def linear_response(grains, amplitude, period, model, gamma):
    """V_1 of the linearised chain (contact stiffness F'(δ0) = n(n−1) a δ0^(n−2)), driven grain 0,
    fixed grain N−1: the steady state u_i = Im(U_i e^{iωt}), V_1 = ωU (numpy, independent of the code)."""
    n = 2.5
    stiffness = n * (n - 1) * A_SELF * L0 ** (n - 2)
    omega = 2 * math.pi / period
    contact = stiffness + (1j * omega * gamma if model == "contact" else 0.0)
    own = -(omega**2) + (1j * omega * gamma if model == "viscous" else 0.0)
    m = grains - 2  # grains 1 … N−2 move
    matrix = np.zeros((m, m), complex)
    for j in range(m):
        matrix[j, j] = own + 2 * contact
        if j > 0:
            matrix[j, j - 1] = -contact
        if j < m - 1:
            matrix[j, j + 1] = -contact
    rhs = np.zeros(m, complex)
    rhs[0] = contact * amplitude
    u = np.linalg.solve(matrix, rhs)
    return np.concatenate([[omega * amplitude], omega * u, [0.0]])


@pytest.mark.parametrize("model", ["viscous", "contact"])
def test_linear_limit_matches_the_linearised_chain(model):
    """A ≪ l0, damped: after the transient (viscous γ = 2: e^{−γt/2} ≈ 1e-6 at t = 14; a dashpot damps
    long waves weakly, so 8 grains and γ = 10) the response at k = 1 equals the linear steady state to
    ≤ 1e-4 of its largest amplitude (measured: ~4e-7 for both)."""
    grains, amplitude, period = (16 if model == "viscous" else 8), 1e-8, 0.5
    gamma = 2.0 if model == "viscous" else 10.0
    scene = driven(
        grains,
        amplitude,
        period,
        damping=(model, gamma),
        record={"response_start": 14.0, "response_periods": 2, "harmonics": 2},
    )
    result = run_scene(scene, "cpu")
    v1 = result.response["response"][0, 0, 1]
    expected = linear_response(grains, amplitude, period, model, gamma)
    assert np.abs(expected[1:-1]).min() > 0.1 * np.abs(expected).max()  # every grain moves
    error = np.abs(v1 - expected).max() / np.abs(expected).max()
    assert error <= 1e-4, error
    # harmonics 0 and 2 are absent in the linear limit (second-order terms only: ~A/δ0 = 1e-5 relative)
    assert np.abs(result.response["response"][0, 0, [0, 2]]).max() <= 1e-4 * np.abs(expected).max()


def test_rectangle_rule_over_whole_periods_is_exact_for_harmonics():
    """The accumulator against closed forms: v(t) = b0 + b1 cos(ωt + φ) + b3 sin(3ωt) + b9 cos(9ωt)
    sampled on the device's schedule gives V_0 = b0, V_1 = b1 e^{iφ}, V_3 = −i b3, V_9 = b9 to rounding
    (the rectangle rule over whole periods of uniform samples is exact below the sampling frequency)."""
    scene = driven(
        grains=4,
        period=0.5,
        duration=2.0,
        damping=None,
        record={"response_start": 0.25, "response_periods": 2, "response_windows": 1, "harmonics": 9},
    )
    model = build_model([scene], "cpu")
    acc = ResponseAccumulator(model)
    assert acc.stride == 1  # 500 steps per period < 2 × 256: every step
    state = model.state()
    omega, dt = 2 * math.pi / 0.5, scene.integrator.dt
    b0, b1, phi, b3, b9 = 0.3, 1.2, 0.7, -0.4, 0.05
    for step in acc.sample_steps(-1, scene.step_count):
        t = step * dt
        v = b0 + b1 * math.cos(omega * t + phi) + b3 * math.sin(3 * omega * t) + b9 * math.cos(9 * omega * t)
        x = np.zeros((model.features.values, 1, 4))
        x[1] = v * dt * np.array([1.0, 2.0, 0.0, -1.0])
        state.x.assign(x)
        state.clock.assign(np.array([step], dtype=np.int32))  # the step the kernels read
        acc.sample(state)
    response = acc.result()["response"][0, 0]
    expected = np.zeros(10, complex)
    expected[0], expected[1], expected[3], expected[9] = b0, b1 * np.exp(1j * phi), -1j * b3, b9
    for grain, factor in enumerate([1.0, 2.0, 0.0, -1.0]):
        np.testing.assert_allclose(response[:, grain], factor * expected, rtol=0, atol=1e-12)
    assert acc.result()["window_start"][0, 0] == 0.25


def test_response_stride_gives_whole_samples_per_period():
    assert response_stride_of([80000]) == 250  # τ = 10 at dt = 1.25e-4: 320 samples/period
    assert response_stride_of([8000, 80000]) == 25  # a launch with τ = 1 and 10: 320 and 3200
    assert response_stride_of([100]) == 1
    for periods in ([80000], [8000, 80000], [12345], [4000, 6000]):
        s = response_stride_of(periods)
        assert all(p % s == 0 for p in periods)
        assert min(periods) // s >= RESPONSE_MIN_SAMPLES_PER_PERIOD or s == 1


@pytest.mark.parametrize("model", ["viscous", "contact"])
def test_energy_balance_with_damping_converges(model):
    """E + D − W conserved: the error falls at second order in dt, and D is most of W (so the balance
    would fail by far without D). A = 3e-3 > l0 opens the driver's contact."""
    errors = []
    for dt in (1e-3, 5e-4):
        result = run_scene(
            driven(amplitude=3e-3, duration=3.0, dt=dt, damping=(model, 2.0), record={"every": 0.5}), "cpu"
        )
        assert result.dissipated[0, -1] > 0.5 * np.abs(result.work).max()
        errors.append(float(result.energy_error[0]))
    assert errors[0] < 2e-5 and errors[1] < 5e-6, errors
    assert errors[0] / errors[1] > 3.0, errors


def test_energy_balance_undamped_drive():
    result = run_scene(driven(amplitude=3e-3, duration=3.0, dt=5e-4, damping=None, record={"every": 0.5}), "cpu")
    assert result.dissipated is None
    assert result.energy_error[0] < 1e-5, result.energy_error


def test_response_is_deterministic():
    scene = driven(
        amplitude=3e-3,
        duration=2.0,
        damping=("contact", 1.0),
        record={"response_start": 1.0, "response_periods": 1, "response_windows": 2, "harmonics": 3},
    )
    a, b = run_scene(scene, "cpu"), run_scene(scene, "cpu")
    for name in ("response", "window_ke", "driver_open"):
        assert np.array_equal(a.response[name], b.response[name], equal_nan=False), name
    assert np.array_equal(a.dissipated, b.dissipated)
    assert 0 < a.response["driver_open"].max() < 1  # A > l0: the driver's contact opens part of the time


def test_damping_generates_no_code_when_unused_and_runs_on_the_cpu_sweep():
    from hertzian.kernels.features import Features
    from hertzian.kernels.step import step_kernel

    plain = generated_source(step_kernel(Features(surface="driven", bottom="fixed", static="uniform")))
    damped = generated_source(
        step_kernel(Features(surface="driven", bottom="fixed", static="uniform", damping="contact"))
    )
    assert "dissipated" in accessed_arrays(damped) and "damping" in accessed_arrays(damped)
    assert not {"dissipated", "damping"} & accessed_arrays(plain)
    impact = scene_from_dict(
        {
            "chain": {"grains": 8, "l0": 1e-4},
            "excitation": {"impact": 1e-2},
            "integrator": {"duration": 0.01},
            "damping": {"model": "viscous", "gamma": 1.0},
        }
    )
    model = build_model([impact], "cpu")
    assert model.features.event_window == 0.0  # event steps carry no damping
    # on the CPU the chain kernel carries damping (test_sweep_damping_equals_per_step)
    assert choose_config(model, "auto").kind == "chain"
    assert choose_config(model, "chain").kind == "chain"
    assert step_reason(model) is None
    # both damping models are in the fused kernels too (test_fused_features.py; 8 grains fit no window)
    dashpot = build_model([impact.with_overrides({"damping.model": "contact"})], "cpu")
    for damped in (model, dashpot):
        assert choose_config(damped, "tile").kind == "tile"
        assert fused_lacks(damped.features, is_cpu=False) is None
    # but not the dashpot in compensated float32: refused there, never run undamped
    dashpot32 = build_model(
        [impact.with_overrides({"damping.model": "contact", "integrator.precision": "float32"})], "cpu"
    )
    for fused in ("tile", "window"):
        with pytest.raises(ValueError, match="damping"):
            choose_config(dashpot32, fused)
    assert "damping" in fused_lacks(dashpot32.features, is_cpu=False)  # CUDA: the per-step kernel only
    from hertzian.kernels.cpu import chain_kernel

    sweep_damped = generated_source(
        chain_kernel(Features(surface="driven", bottom="fixed", static="uniform", damping="contact"))
    )
    sweep_plain = generated_source(chain_kernel(Features(surface="driven", bottom="fixed", static="uniform")))
    assert "dissipated" in accessed_arrays(sweep_damped) and "damping" in accessed_arrays(sweep_damped)
    assert not {"dissipated", "damping"} & accessed_arrays(sweep_plain)


@pytest.mark.parametrize(
    "model, bottom", [("viscous", "fixed"), ("viscous", "wall"), ("contact", "fixed"), ("contact", "wall")]
)
def test_sweep_damping_equals_per_step(model, bottom):
    """Damping in the CPU chain kernel is the per-step kernel's, bit for bit: fields, energy, the driver's
    work, the dissipated energy D and the response windows. A = 3e-3 > l0 opens the driver's contact;
    motion must reach the bottom grain that moves, and D must grow."""
    scene = driven(
        grains=16,
        amplitude=3e-3,
        period=0.25,
        duration=1.5,
        damping=(model, 2.0),
        bottom=bottom,
        record={
            "every": 0.25,
            "fields": ["u", "v"],
            "response_start": 0.5,
            "response_periods": 1,
            "response_windows": 2,
            "harmonics": 2,
        },
    )
    chains = build_model([scene], "cpu")
    want = Runner(chains, kernel="step", use_graph=False, monitor_every=7).run()
    got = Runner(chains, kernel="chain", use_graph=False, monitor_every=7).run()
    assert want.kernel.startswith("step") and got.kernel == "chain"
    bottom_moving = -2 if bottom == "fixed" else -1
    v = np.abs(want.fields["v"])
    assert v[..., bottom_moving].max() > 1e-3 * v.max(), "motion never reached the bottom"
    assert want.dissipated[0, -1] > 0 and np.all(np.diff(want.dissipated[0]) > 0)
    assert 0 < want.response["driver_open"].max() < 1  # the driver's contact opens part of the time
    for name in ("u", "v"):
        np.testing.assert_array_equal(got.fields[name], want.fields[name])
    for name in ("energy", "work", "dissipated"):
        np.testing.assert_array_equal(getattr(got, name), getattr(want, name))
    for name in ("response", "window_ke", "driver_open"):
        np.testing.assert_array_equal(got.response[name], want.response[name])
    np.testing.assert_array_equal(got.energy_error, want.energy_error)


@pytest.mark.parametrize("model", ["viscous", "contact"])
def test_sweep_damping_equals_per_step_between_walls(model):
    """The surface wall's dashpot (the contact above grain 0, which no integrated grain owns) in the sweep
    kernel: an impact between walls, sweep vs per-step bit for bit; the impact reaches the bottom wall."""
    scene = scene_from_dict(
        {
            "chain": {"grains": 12, "l0": 1e-4},
            "excitation": {"impact": 1e-2},
            "boundary": {"surface": "wall", "bottom": "wall"},
            "integrator": {"duration": 2.0, "dt": 1e-3},
            "damping": {"model": model, "gamma": 0.5},
            "record": {"every": 0.25, "fields": ["u", "v"]},
        }
    )
    chains = build_model([scene], "cpu")
    want = Runner(chains, kernel="step", use_graph=False, monitor_every=7).run()
    got = Runner(chains, kernel="chain", use_graph=False, monitor_every=7).run()
    assert got.kernel == "chain"
    v = np.abs(want.fields["v"])
    assert v[..., -1].max() > 1e-3 * v.max(), "motion never reached the bottom"
    assert want.dissipated[0, -1] > 0
    for name in ("u", "v"):
        np.testing.assert_array_equal(got.fields[name], want.fields[name])
    for name in ("energy", "dissipated"):
        np.testing.assert_array_equal(getattr(got, name), getattr(want, name))


@pytest.mark.parametrize(
    "key, value, message",
    [
        ("damping.model", "visc", "damping.model = 'visc': must be one of none, viscous, contact"),
        ("damping.gamma", -1.0, "damping.gamma = -1.0: must be ≥ 0"),
        ("record.harmonics", -1, "record.harmonics = -1: must be an integer 0 … 64"),
        ("record.response_windows", 0, "record.response_windows = 0: must be an integer ≥ 1"),
        ("record.response_periods", 0, "record.response_periods = 0: must be an integer ≥ 1"),
        ("record.response_start", 0.0005, "record.response_start = 0.0005: must be a whole number of steps"),
        ("record.response_windows", 100, "record.response_windows = 100: the windows end at t = 51"),
    ],
)
def test_bad_response_and_damping_keys_are_refused(key, value, message):
    base = driven(duration=2.0, damping=None, record={"response_start": 1.0}).to_dict()
    section, name = key.split(".")
    base[section][name] = value
    if section == "damping" and name == "gamma":
        base["damping"]["model"] = "viscous"
    with pytest.raises(SceneError) as err:
        scene_from_dict(base)
    assert str(err.value).startswith(message), str(err.value)


def test_cli_refuses_bad_response_key(tmp_path):

    scene = tmp_path / "s.toml"
    scene.write_text(
        toml_text(
            {
                "chain": {"grains": 8, "l0": 1e-3},
                "boundary": {"surface": "driven"},
                "excitation": {"drive_amplitude": 1e-6, "drive_period": 0.5},
                "integrator": {"duration": 1.0, "dt": 1e-3},
            }
        )
    )
    out = tmp_path / "out.zarr"
    result = invoke(
        "run",
        scene,
        "--out",
        out,
        "--device",
        "cpu",
        "--set",
        "record.response_start=0.5",
        "--set",
        "record.harmonics=100",
    )
    assert_refused(result, out, "record.harmonics = 100")


def test_map_numbers_on_closed_forms():
    """Standing-wave ratio and labels on signals whose answer is known."""
    from hertzian.studies import analysis as an

    z = np.arange(50)
    k = 2 * math.pi / 40
    travelling = np.exp(-1j * k * z)  # |V_1| constant: ratio 1
    assert an.standing_wave_ratio(travelling) == pytest.approx(1.0, abs=1e-12)
    mixed = np.exp(-1j * k * z) + 0.5 * np.exp(1j * k * z)  # (1 + r)/(1 − r) for reflection r = 0.5
    assert an.standing_wave_ratio(mixed) == pytest.approx(3.0, rel=1e-2)
    n = np.arange(200)
    period2 = np.stack([np.where(n % 2, 1.0, -0.5), np.where(n % 2, 0.3, 0.2)], axis=1)
    assert an.LABELS[an.strobe_label(period2)] == "periodic"
    golden = (math.sqrt(5) - 1) / 2  # an irrational rotation: quasi-periodic
    quasi = np.stack([np.cos(2 * math.pi * golden * n), np.sin(2 * math.pi * golden * n)], axis=1)
    assert an.LABELS[an.strobe_label(quasi)] == "quasi-periodic"
    x = np.empty(200)
    x[0] = 0.3
    for j in range(1, 200):  # the logistic map at r = 4: chaotic
        x[j] = 4 * x[j - 1] * (1 - x[j - 1])
    assert an.LABELS[an.strobe_label(x)] == "chaotic"
    assert an.LABELS[an.strobe_label(x[:10])] == "unknown"
    counts, drift = an.node_drift(np.stack([np.abs(np.sin(k * z)) + 1e-3, np.abs(np.sin(k * (z - 2))) + 1e-3]))
    assert list(counts) == [2, 3] and drift[0] == pytest.approx(2.0)  # nodes 20, 40 → 2, 22, 42


def test_response_store_is_readable_by_xarray(tmp_path):
    import xarray as xr
    from hertzian.sweeping.sweep_store import write_result

    scene = driven(
        grains=8,
        amplitude=1e-6,
        duration=1.5,
        damping=("viscous", 1.0),
        record={"every": 0.5, "response_start": 0.5, "response_periods": 1, "response_windows": 2, "harmonics": 2},
    )
    result = run_scene(scene, "cpu")
    write_result(tmp_path / "r.zarr", result)
    ds = xr.open_zarr(tmp_path / "r.zarr")
    assert ds.response.dims == ("window", "harmonic", "grain") and ds.response.dtype == np.complex128
    assert list(ds.harmonic.values) == [0, 1, 2] and list(ds.window_start.values) == [0.5, 1.0]
    assert ds.window_ke.dims == ("window", "grain") and ds.driver_open.dims == ("window",)
    np.testing.assert_array_equal(ds.response.values, result.response["response"][0])
    np.testing.assert_array_equal(ds.dissipated.values, result.dissipated[0])


def test_drive_sweep_points_equal_runs_alone_and_the_map_is_drawn(tmp_path):
    """A τ × A sweep in one launch (windows of different lengths per chain, a common sample stride)
    gives each point the response of its chain run alone, bitwise; `hertzian plot --figure drive_map`
    draws the map and writes its numbers."""
    import json

    import xarray as xr

    sweep = tmp_path / "map.toml"
    sweep.write_text("""
[scene.chain]
grains = 10
l0 = 1e-3
[scene.boundary]
surface = "driven"
bottom = "fixed"
[scene.excitation]
drive_amplitude = 1e-4
drive_period = 0.5
[scene.integrator]
dt = 1e-3
duration = 2.0
[scene.record]
every = 0.5
fields = ["v"]
traces = [2, 5]
trace_every = 0.05
response_start = 0.5
response_periods = 1
response_windows = 2
harmonics = 2
[[axis]]
name = "tau"
key = "excitation.drive_period"
values = [0.25, 0.5]
[[axis]]
name = "A"
key = "excitation.drive_amplitude"
values = [1e-4, 3e-3]
""")
    out = tmp_path / "map.zarr"
    result = invoke("sweep", sweep, "--out", out, "--device", "cpu")
    assert result.exit_code == 0, result.stdout + result.stderr
    ds = xr.open_zarr(out)
    assert ds.response.dims == ("tau", "A", "window", "harmonic", "grain")
    point = ds.sel(tau=0.25, A=3e-3)
    np.testing.assert_array_equal(point.window_start.values, [0.5, 0.75])
    alone = run_scene(
        driven(
            grains=10,
            amplitude=3e-3,
            period=0.25,
            duration=2.0,
            damping=None,
            record={
                "every": 0.5,
                "fields": ["v"],
                "traces": [2, 5],
                "trace_every": 0.05,
                "response_start": 0.5,
                "response_periods": 1,
                "response_windows": 2,
                "harmonics": 2,
            },
        ),
        "cpu",
    )
    np.testing.assert_array_equal(point.response.values, alone.response["response"][0])
    np.testing.assert_array_equal(point.driver_open.values, alone.response["driver_open"][0])
    png = tmp_path / "map.png"
    result = invoke("plot", out, "--figure", "drive_map", "--out", png)
    assert result.exit_code == 0, result.stdout + result.stderr
    numbers = json.loads(png.with_suffix(".json").read_text())["points"]
    assert len(numbers) == 4 and png.stat().st_size > 0
    assert {row["tau"] for row in numbers} == {0.25, 0.5}
    result = invoke("plot", out, "--at", "tau=0.5", "--at", "A=1e-4", "--out", tmp_path / "point.png")
    assert result.exit_code == 0, result.stdout + result.stderr


def test_response_of_a_chain_is_the_same_alone_and_in_an_ensemble_of_other_periods():
    """Each chain samples its windows at its own stride (Scene.response_stride): τ = 1 (1000 steps: stride 2)
    and τ = 1.5 (1500 steps: stride 5) in one ensemble give each chain's sums bit for bit as run alone (a
    stride shared by the ensemble, 2 here, gave the τ = 1.5 chain other samples than alone)."""
    from hertzian.core.runner import run_ensemble

    base = scene_from_dict(
        {
            "chain": {"grains": 16, "l0": 1e-4},
            "boundary": {"surface": "driven"},
            "excitation": {"drive_amplitude": 2e-4, "drive_period": 1.0},
            "integrator": {"dt": 1e-3, "duration": 3.6},
            "record": {
                "every": 0.4,
                "fields": ["v"],
                "response_start": 0.4,
                "response_periods": 1,
                "response_windows": 2,
                "harmonics": 2,
            },
        }
    )
    scenes = [base, base.with_overrides({"excitation.drive_period": 1.5})]
    assert [s.response_stride for s in scenes] == [2, 5]
    together = run_ensemble(scenes, "cpu").response
    for c, scene in enumerate(scenes):
        alone = run_ensemble([scene], "cpu").response
        for key in ("response", "window_ke", "driver_open", "window_start"):
            np.testing.assert_array_equal(together[key][c], alone[key][0], err_msg=key)
    assert np.all(np.abs(together["response"][:, :, 1]) > 0)  # the drive's harmonic was sampled


def test_windows_of_other_lengths_share_one_launch_and_equal_each_chain_alone(tmp_path):
    """Figs. 9–10 run τ = 10 with windows of one period and τ = 1 with windows of ten: record.response_periods
    may differ between the chains of one launch (a [[zip]] with the period). Each point's store equals that
    chain run alone, bit for bit, and its windows start where its own period count puts them."""
    import xarray as xr

    sweep = tmp_path / "both.toml"
    sweep.write_text("""
[scene.chain]
grains = 12
l0 = 1e-3
[scene.boundary]
surface = "driven"
bottom = "fixed"
[scene.excitation]
drive_amplitude = 3e-3
drive_period = 0.5
[scene.integrator]
dt = 1e-3
duration = 2.0
[scene.record]
every = 0.5
fields = ["v"]
response_start = 0.25
response_periods = 1
response_windows = 3
harmonics = 2
[[axis]]
name = "tau"
key = "excitation.drive_period"
values = [0.5, 0.125]
[[axis]]
name = "periods"
key = "record.response_periods"
values = [1, 4]
[[zip]]
axes = ["tau", "periods"]
""")
    out = tmp_path / "both.zarr"
    result = invoke("sweep", sweep, "--out", out, "--device", "cpu", "--dry-run")
    assert "launch groups: 1" in result.stdout, result.stdout
    result = invoke("sweep", sweep, "--out", out, "--device", "cpu")
    assert result.exit_code == 0, result.stdout + result.stderr
    ds = xr.open_zarr(out)
    for tau, periods in ((0.5, 1), (0.125, 4)):
        point = ds.sel(tau=tau)
        np.testing.assert_allclose(point.window_start.values, [0.25, 0.75, 1.25], rtol=0, atol=1e-12)
        alone = run_scene(
            driven(
                grains=12,
                amplitude=3e-3,
                period=tau,
                duration=2.0,
                damping=None,
                record={
                    "every": 0.5,
                    "fields": ["v"],
                    "response_start": 0.25,
                    "response_periods": periods,
                    "response_windows": 3,
                    "harmonics": 2,
                },
            ),
            "cpu",
        )
        np.testing.assert_array_equal(point.response.values, alone.response["response"][0])
        np.testing.assert_array_equal(point.window_ke.values, alone.response["window_ke"][0])
        assert np.abs(point.response.values[:, 1]).max() > 0


@pytest.mark.parametrize("pieces", [5, 64])
def test_response_sampled_in_runs_equals_one_sample_at_a_time(monkeypatch, pieces, device):
    """Runner._advance_sampled takes runs of equally spaced samples in one piece (one CUDA graph on a GPU);
    with device checks interleaved (monitor_every = 37 steps) every sum, energy and trace equals runs of one
    sample each, the order the samples were taken in before (on CUDA: replayed graphs against single pieces)."""
    from hertzian.core import runner as runner_module
    from hertzian.core.model import build_model

    scene = driven(
        grains=12,
        amplitude=3e-3,
        period=0.25,
        duration=1.6,
        damping=None,
        record={
            "every": 0.4,
            "fields": ["v"],
            "traces": [3],
            "trace_every": 0.01,
            "response_start": 0.1,
            "response_periods": 1,
            "response_windows": 4,
            "harmonics": 2,
        },
    )
    results, calls = {}, {}
    for per_graph in (1, pieces):
        monkeypatch.setattr(runner_module, "SAMPLED_PIECES_PER_GRAPH", per_graph)
        runner = runner_module.Runner(build_model([scene], device), monitor_every=37)
        taken = []
        original = runner._advance_sampled
        monkeypatch.setattr(runner, "_advance_sampled", lambda gap, count: taken.append(count) or original(gap, count))
        results[per_graph], calls[per_graph] = runner.run(), taken
    assert max(calls[1]) == 1 and max(calls[pieces]) > 1  # runs were formed
    assert sum(calls[1]) == sum(calls[pieces])  # and no sample was lost
    one, runs = results[1], results[pieces]
    for key in ("response", "window_ke", "driver_open"):
        np.testing.assert_array_equal(runs.response[key], one.response[key], err_msg=key)
    np.testing.assert_array_equal(runs.energy, one.energy)
    np.testing.assert_array_equal(runs.traces["v"], one.traces["v"])
    np.testing.assert_array_equal(runs.fields["v"], one.fields["v"])
    assert np.abs(runs.response["response"][0, :, 1]).max() > 0
