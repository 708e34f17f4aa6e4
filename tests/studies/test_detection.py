"""`hertzian detect`: impurities planted by independent runs of the project's own simulator (their
scenes written here from scratch, at half the detector's step), Gaussian noise added at a stated SNR
(20·log10 of the echo peak max|v − v_clean| over σ), and recovered: class, depth, and a mass ratio
inside the 95 % interval. Also: a clean chain is called `none`, the library cache is reused and
gives the same answer, the closed-form Gaussian integrals match quadrature, and bad signals are
refused with one line and exit code 2."""

import json
import math

import numpy as np
import pytest
from hertzian.core.runner import run_scene
from hertzian.core.scene import SceneError, scene_from_dict
from hertzian.studies.detection import (
    Quadratic,
    detect,
    forward_scene,
    log_normal_mass,
    read_signal,
    signal_from_arrays,
    write_signal_csv,
)

from tests.helpers import assert_refused, hertzian, invoke

GRAINS = 40
SPACING = 0.01
SAMPLES = 551  # t = 0 … 5.5: past the return of the bottom reflection (≈ 4.6)
SNR_DB = 26.0
BASE = {
    "chain": {"grains": GRAINS, "l0": 1e-4},
    "excitation": {"impact": 1e-2},
    "integrator": {"method": "gear4", "dt": 1e-3, "duration": 1.0},
}
BASE_TOML = """
[chain]
grains = 40
l0 = 1e-4
[excitation]
impact = 1e-2
[integrator]
method = "gear4"
dt = 1e-3
duration = 1.0
"""


def truth_velocity(impurity: dict | None) -> np.ndarray:
    """Grain 0's velocity from an independent run: scene written from scratch, step dt/2."""
    data = {
        **BASE,
        "integrator": {"method": "gear4", "dt": 5e-4, "duration": SPACING * (SAMPLES - 1)},
        "record": {"traces": [0], "trace_every": SPACING},
    }
    if impurity is not None:
        data["impurities"] = [impurity]
    result = run_scene(scene_from_dict(data), "cpu")
    assert result.status[0] == 0
    return result.traces["v"][0, :, 0]


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    path = tmp_path_factory.mktemp("detect-cache")
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("HERTZIAN_DETECT_CACHE", str(path))
        yield path


@pytest.fixture(scope="module")
def clean_velocity():
    return truth_velocity(None)


def noisy_signal(velocity, clean, seed, snr_db=SNR_DB, sigma=None):
    peak = float(np.max(np.abs(velocity - clean)))
    sigma = sigma if sigma is not None else peak / 10 ** (snr_db / 20)
    noise = np.random.default_rng(seed).normal(scale=sigma, size=velocity.size)
    return signal_from_arrays(np.arange(SAMPLES) * SPACING, velocity + noise, source="test"), sigma


CASES = [  # (depth, block, mass ratio) — ratios off the library grid (0.25…4, 7 log steps a side)
    (10, 1, 0.5),
    (27, 1, 0.75),
    (6, 1, 2.0),
    (30, 1, 3.0),
    (12, 3, 1.5),
]


@pytest.mark.parametrize("depth,block,mass_ratio", CASES)
def test_recovers_a_planted_impurity(cache, clean_velocity, depth, block, mass_ratio):
    velocity = truth_velocity({"grains": list(range(depth, depth + block)), "mass": mass_ratio})
    signal, sigma = noisy_signal(velocity, clean_velocity, seed=1000 + depth)
    result, _ = detect(signal, scene_from_dict(BASE), block=block, device="cpu")
    expected = "light" if mass_ratio < 1 else "heavy"
    assert result.kind == expected, result.to_dict()
    assert result.class_probability[expected] > 0.99
    assert result.depth == depth, result.to_dict()
    # the 95 % interval misses the truth in 1 case of 20 by design (the study measures its coverage);
    # here: within the matching 3-standard-deviation interval (misses 3 in 1000), and narrow
    lo, hi = result.mass_ratio_interval
    centre, half = 0.5 * math.log(hi * lo), 0.5 * math.log(hi / lo)
    assert abs(math.log(mass_ratio) - centre) <= 3.0 / 1.96 * half, result.to_dict()
    assert hi / lo < 1.5  # an interval that says something
    assert result.depth_interval[0] <= depth <= result.depth_interval[1]
    assert 0.7 < result.noise / sigma < 1.3  # the noise estimate is the noise that was added


def test_clean_chain_is_none(cache, clean_velocity):
    """No impurity: the clean class wins; σ is that of an impurity echo at 26 dB (from a 0.75 block)."""
    echo = truth_velocity({"grains": [20], "mass": 0.75})
    sigma = float(np.max(np.abs(echo - clean_velocity))) / 10 ** (SNR_DB / 20)
    for seed in (1, 2, 3):
        signal, _ = noisy_signal(clean_velocity, clean_velocity, seed=seed, sigma=sigma)
        result, _ = detect(signal, scene_from_dict(BASE), device="cpu")
        assert result.kind == "none", result.to_dict()
        assert result.class_probability["none"] > 0.5
        assert result.depth is None and result.mass_ratio == 1.0


def test_second_signal_reuses_the_library(tmp_path, monkeypatch, clean_velocity):
    """Same BASE and sample times: the second call loads the cached library and gives the same answer."""
    monkeypatch.setenv("HERTZIAN_DETECT_CACHE", str(tmp_path))
    velocity = truth_velocity({"grains": [15], "mass": 0.6})
    signal, _ = noisy_signal(velocity, clean_velocity, seed=7)
    first, first_library = detect(signal, scene_from_dict(BASE), device="cpu", refine=1, iterations=1)
    assert not first.library_from_cache and first.seconds["library"] > 0
    assert [path.name for path in tmp_path.iterdir() if path.is_dir()] == [first_library.key]  # no temporary left
    second, _ = detect(signal, scene_from_dict(BASE), device="cpu", refine=1, iterations=1)
    assert second.library_from_cache and second.seconds["library"] == 0
    assert second.seconds["total"] < first.seconds["total"]
    a, b = first.to_dict(), second.to_dict()
    for d in (a, b):
        d.pop("seconds"), d.pop("library_from_cache")
    assert a == b
    assert np.array_equal(first.best_fit, second.best_fit)


def test_gaussian_integrals_match_quadrature():
    """The closed-form evidence of a quadratic RSS (a truncated Gaussian) against a fine trapezoid sum."""
    assert math.exp(log_normal_mass(-1.0, 1.0)) == pytest.approx(math.erf(1 / math.sqrt(2)), rel=1e-12)
    # far tail: Φ(−40) − Φ(−41) ≈ φ(40)/40 (to 1e-3), where the direct difference underflows
    expected = -0.5 * 40**2 - math.log(40) - 0.5 * math.log(2 * math.pi)
    assert log_normal_mass(-41.0, -40.0) == pytest.approx(expected, abs=2e-3)
    assert log_normal_mass(40.0, 41.0) == pytest.approx(expected, abs=2e-3)
    sigma = 0.3
    for q, lo, hi in [
        (Quadratic(x0=-0.4, rss0=5.0, g=0.6, H=4.0), -1.4, 0.0),
        (Quadratic(x0=0.2, rss0=2.0, g=-3.0, H=9.0), 0.0, 1.4),  # optimum outside the range
        (Quadratic(x0=-0.1, rss0=1.0, g=0.0, H=0.0), -1.0, 0.0),
    ]:  # flat: no sensitivity
        x = np.linspace(lo, hi, 200001)
        rss = q.rss0 - 2 * q.g * (x - q.x0) + q.H * (x - q.x0) ** 2
        f = np.exp(-rss / (2 * sigma**2))
        numeric = math.log(np.sum((f[1:] + f[:-1]) / 2 * np.diff(x)) / (hi - lo))
        assert q.log_integral(lo, hi, sigma) == pytest.approx(numeric, abs=1e-8)
        mid = 0.5 * (lo + hi)
        cdf = np.sum(((f[1:] + f[:-1]) / 2 * np.diff(x))[x[1:] <= mid]) / np.sum((f[1:] + f[:-1]) / 2 * np.diff(x))
        assert q.cdf(mid, lo, hi, sigma) == pytest.approx(cdf, abs=1e-6)


def test_signal_checks(tmp_path):
    t = np.arange(10) * 0.1
    with pytest.raises(SceneError, match="uniform"):
        signal_from_arrays(np.r_[t[:5], t[5:] + 0.01], np.zeros(10))
    with pytest.raises(SceneError, match="finite"):
        signal_from_arrays(t, np.r_[np.zeros(9), np.nan])
    with pytest.raises(SceneError, match="t = 0"):
        signal_from_arrays(t + 0.1, np.zeros(10))
    path = tmp_path / "s.csv"
    write_signal_csv(path, signal_from_arrays(t, np.sin(t)))
    back = read_signal(path)
    assert np.array_equal(back.v, np.sin(t)) and np.allclose(back.t, t, rtol=0, atol=1e-15)


def write_csv(path, rows, header="t,v"):
    path.write_text((header + "\n" if header else "") + "\n".join(f"{t!r},{v!r}" for t, v in rows) + "\n")


def test_cli_bad_signals_exit_2_one_line(tmp_path):
    base = tmp_path / "base.toml"
    base.write_text(BASE_TOML)
    good = [(k * SPACING, 0.0) for k in range(SAMPLES)]
    cases = {
        "no_header.csv": (good, None, "the first line must be the header t,v"),
        "nonuniform.csv": (
            [(t + (0.003 if k > 100 else 0.0), v) for k, (t, v) in enumerate(good)],
            "t,v",
            "samples must be uniform",
        ),
        "nan.csv": (
            [(t, math.nan if k == 7 else v) for k, (t, v) in enumerate(good)],
            "t,v",
            "v[7] = nan: values must be finite",
        ),
        "short.csv": ([(k * SPACING, 0.0) for k in range(5)], "t,v", "shorter than one echo"),
    }
    for name, (rows, header, message) in cases.items():
        path = tmp_path / name
        write_csv(path, rows, header)
        plot = tmp_path / f"{name}.png"
        out = hertzian("detect", str(path), "--scene", str(base), "--device", "cpu", "--plot", str(plot), "--no-cache")
        assert out.returncode == 2, (name, out.stderr)
        lines = [line for line in out.stderr.splitlines() if line.startswith("error")]
        assert len(lines) == 1 and message in lines[0], (name, out.stderr)
        assert "Traceback" not in out.stderr and not plot.exists()
    binary = tmp_path / "signal.npy"
    np.save(binary, np.zeros(SAMPLES))
    out = hertzian("detect", str(binary), "--scene", str(base), "--device", "cpu")
    assert out.returncode == 2 and out.stderr.count("\n") == 1, out.stderr
    assert "not a text file (UnicodeDecodeError): give a CSV file with the header t,v, or a store" in out.stderr
    out = hertzian("detect", str(tmp_path / "nan.csv"))
    assert out.returncode == 2 and "--scene: required" in out.stderr
    impure = tmp_path / "impure.toml"
    impure.write_text(BASE_TOML + "[[impurities]]\ngrains = [3]\nmass = 0.5\n")
    out = hertzian("detect", str(tmp_path / "nonuniform.csv"), "--scene", str(impure))
    assert out.returncode == 2 and "must have no impurities" in out.stderr


DOCS_BASE_TOML = BASE_TOML.replace("dt = 1e-3", "dt = 2.5e-4")
"""docs/detection.md's example host: the step `hertzian check` passes for it and for the planted chain."""


def test_cli_reads_a_store_and_prints_json(tmp_path, cache):
    """docs/detection.md's example: `hertzian run` writes the signal (a store with grain 0 traced); `detect --json`
    finds the impurity. Both scenes pass `hertzian check`."""
    scene = tmp_path / "planted.toml"
    scene.write_text(
        DOCS_BASE_TOML.replace("duration = 1.0", f"duration = {SPACING * (SAMPLES - 1)!r}")
        + f"[record]\ntraces = [0]\ntrace_every = {SPACING}\n[[impurities]]\ngrains = [18]\nmass = 0.4\n"
    )
    store = tmp_path / "planted.zarr"
    assert hertzian("run", str(scene), "--out", str(store), "--device", "cpu").returncode == 0
    base = tmp_path / "base.toml"
    base.write_text(DOCS_BASE_TOML)
    for checked in (scene, base):
        assert "verdict                   ok" in hertzian("check", str(checked)).stdout
    import os

    env = {**os.environ, "HERTZIAN_DETECT_CACHE": str(cache)}
    plot = tmp_path / "fit.png"
    out = hertzian(
        "detect",
        str(store),
        "--scene",
        str(base),
        "--json",
        "--device",
        "cpu",
        "--noise",
        "1e-5",
        "--plot",
        str(plot),
        env=env,
    )
    assert out.returncode == 0, out.stderr
    result = json.loads(out.stdout)
    assert result["class"] == "light" and result["depth"] == 18
    assert result["mass_ratio_interval"][0] <= 0.4 <= result["mass_ratio_interval"][1]
    assert set(result["log_evidence"]) == {"none", "light", "heavy"} and plot.stat().st_size > 0
    first, last = result["depths_searched"]  # every depth between, 7 light and 7 heavy ratios each, and the clean chain
    steps = round(result["window"] / result["dt"])  # over the analysed window
    assert f"library: {1 + (last - first + 1) * 14} chains of {GRAINS} grains, {steps} steps each" in out.stderr
    assert "candidates by Gauss–Newton (2 ensemble runs)" in out.stderr, out.stderr


def test_a_noise_free_trace_of_the_host_itself_is_none(tmp_path, cache):
    """The host's own run as the signal, and its file, records and all, as BASE (as a user who passes the built-in
    example twice would): BASE's traces every 0.01 do not refuse the noise rule's step of 0.02, and σ before the echo,
    exactly 0 here, is floored as everywhere else instead of dividing by it. The answer is the clean chain."""
    import os

    host = tmp_path / "host.toml"
    host.write_text(
        BASE_TOML.replace("duration = 1.0", f"duration = {SPACING * (SAMPLES - 1)!r}")
        + f"[record]\ntraces = [0]\ntrace_every = {SPACING}\n"
    )
    store = tmp_path / "host.zarr"
    assert hertzian("run", str(host), "--out", str(store), "--device", "cpu").returncode == 0
    env = {**os.environ, "HERTZIAN_DETECT_CACHE": str(cache)}
    out = hertzian(
        "detect", str(store), "--scene", str(host), "--json", "--depths", "10:30", "--device", "cpu", env=env
    )
    assert out.returncode == 0, out.stderr
    result = json.loads(out.stdout)
    assert result["class"] == "none" and result["noise_before_echo"] == 0.0, result


def test_forward_scene_samples_on_steps():
    """A sample spacing that the BASE step does not divide: the step shrinks so that samples fall on steps."""
    scene = forward_scene(scene_from_dict(BASE), 0.0125, 101)  # 12.5 steps of 1e-3 → 13 steps of 0.0125/13
    assert scene.trace_stride == 13 and scene.integrator.dt == pytest.approx(0.0125 / 13, rel=1e-15)
    assert scene.integrator.duration == pytest.approx(1.25, rel=1e-15)
    assert scene.step_count == 100 * 13


def test_study_summary_counts():
    """The study's tables from hand-made records: accuracy, depth within ±1 (class right too), coverage."""
    from hertzian.studies.detection.study import summarize

    def record(true_class, kind, true_depth, depth, covered):
        return {
            "host": "h",
            "snr_db": 26.0,
            "true_class": true_class,
            "class": kind,
            "true_depth": true_depth,
            "depth": depth,
            "true_mass_ratio": 0.5 if true_class == "light" else 2.0,
            "depth_fraction": None if true_depth is None else true_depth / 100,
            "class_correct": true_class == kind,
            "depth_error": None if true_depth is None or depth is None else depth - true_depth,
            "mass_ratio_covered": covered,
            "seconds": {"total": 1.0},
        }

    rows = [
        record("light", "light", 10, 10, True),
        record("light", "light", 10, 12, False),
        record("heavy", "light", 50, 50, False),
        record("heavy", "none", 50, None, None),
        record("none", "none", None, None, None),
    ]
    table = summarize(rows)["h"]["26.0"]
    assert table["class_accuracy"] == pytest.approx(3 / 5)
    assert table["depth_within_1"] == pytest.approx(1 / 4)  # 4 impure; the heavy-as-light at d=50 does not count
    assert table["depth_exact"] == pytest.approx(1 / 4)
    assert table["mass_ratio_interval_coverage"] == pytest.approx(1 / 3)
    assert table["confusion"]["heavy"] == {"none": 1, "light": 1, "heavy": 0}
    assert table["confusion"]["none"]["none"] == 1 and table["confusion"]["light"]["light"] == 2
    # Clopper–Pearson lower limits (95 %, two-sided): 3 of 5 → 0.1466 (tabulated); 1 of 4 → 0.00631
    assert table["class_accuracy_lower95"] == pytest.approx(0.1466, abs=1e-4)
    assert table["depth_within_1_lower95"] == pytest.approx(0.00631, abs=1e-5)


def test_binomial_lower_bound_closed_forms():
    """All successes: (α/2)^(1/n); none: 0; half of 10: 0.1871 (tabulated Clopper–Pearson)."""
    from hertzian.studies.detection.study import binomial_lower_bound

    for n in (1, 28, 384):
        assert binomial_lower_bound(n, n) == pytest.approx(0.025 ** (1 / n), rel=1e-9)
    assert binomial_lower_bound(0, 10) == 0.0
    assert binomial_lower_bound(5, 10) == pytest.approx(0.1871, abs=1e-4)


# ---- --fit-a: the impurity's self-constant a as well as its mass -----------------------------------------

FIT_A_TRUTH = (12, 0.5, 3.0)  # depth, mass ratio, a / a_host: off both grids (μ: 7 log steps; a: 9 over 0.25…4)
FIT_A_CASES = [  # (depth, mass ratio, a / a_host, noise seed)
    (*FIT_A_TRUTH, 11),
    (25, 2.0, 0.4, 12),  # with a = a_host the best depth is 26: --fit-a also tries the neighbouring depths
]


def planted_with_a(clean_velocity, depth=FIT_A_TRUTH[0], mass_ratio=FIT_A_TRUTH[1], a_ratio=FIT_A_TRUTH[2], seed=11):
    host_a = scene_from_dict(BASE).chain.a
    velocity = truth_velocity({"grains": [depth], "mass": mass_ratio, "a": a_ratio * host_a})
    return noisy_signal(velocity, clean_velocity, seed=seed)


@pytest.mark.parametrize("depth,mass_ratio,a_ratio,seed", FIT_A_CASES)
def test_fit_a_recovers_the_contact_constant(cache, clean_velocity, depth, mass_ratio, a_ratio, seed):
    """A grain with its own mass and self-constant (contacts by the scene's harmonic rule), planted by an
    independent run at half the step, 26 dB. With a fixed at a_host the best fit (a biased μ — for
    μ = 0.5, a = 3: μ ≈ 0.8, the echo's impedance — or the wrong depth) leaves a residual well above the
    noise; --fit-a finds depth, a and μ inside their intervals and leaves a residual at the noise level."""
    signal, sigma = planted_with_a(clean_velocity, depth, mass_ratio, a_ratio, seed)
    plain, _ = detect(signal, scene_from_dict(BASE), device="cpu")
    fitted, _ = detect(signal, scene_from_dict(BASE), device="cpu", fit_a=True)
    assert "a_ratio" not in plain.to_dict()  # without --fit-a the answer is unchanged
    assert fitted.kind == ("light" if mass_ratio < 1 else "heavy") and fitted.depth == depth, fitted.to_dict()
    assert fitted.fit_a["a_ratio_interval"] is not None, fitted.fit_a  # None: no better than a = a_host
    lo, hi = fitted.fit_a["a_ratio_interval"]
    assert lo <= a_ratio <= hi and hi / lo < 1.5, fitted.fit_a
    mlo, mhi = fitted.mass_ratio_interval
    assert mlo <= mass_ratio <= mhi, fitted.to_dict()
    if (depth, mass_ratio, a_ratio) == FIT_A_TRUTH:  # a fixed: biased μ, the truth outside its interval
        assert not plain.mass_ratio_interval[0] <= mass_ratio <= plain.mass_ratio_interval[1], plain.to_dict()
    n = fitted.best_fit.size
    rss_plain = float(np.sum((signal.v[:n] - plain.best_fit) ** 2))
    rss_fitted = float(np.sum((signal.v[:n] - fitted.best_fit) ** 2))
    # one more parameter lowers χ² by ~1 when it is not needed; here by far more than 3² (measured ≈ 36)
    assert (rss_plain - rss_fitted) / sigma**2 > 9.0, (rss_plain / sigma**2, rss_fitted / sigma**2)
    assert rss_fitted / (n * sigma**2) < 1 + 3 * math.sqrt(2 / n)  # at the noise: χ²/n within 3 sd of 1
    assert fitted.fit_a["rss"] == pytest.approx(rss_fitted, rel=1e-12)


def test_cli_fit_a_json_and_bad_a_range(tmp_path, cache, clean_velocity):
    """--fit-a --json adds a_ratio and its interval; a bad --a-range, or --a-range without --fit-a: one line, exit 2."""
    import os

    signal, _ = planted_with_a(clean_velocity)
    path = tmp_path / "planted.csv"
    write_signal_csv(path, signal)
    base = tmp_path / "base.toml"
    base.write_text(BASE_TOML)
    env = {**os.environ, "HERTZIAN_DETECT_CACHE": str(cache)}
    for args, message in [
        (["--fit-a", "--a-range", "2,4"], "--a-range = '2.0,4.0': must be two numbers a_min < 1 < a_max"),
        (["--fit-a", "--a-range", "0.5"], "--a-range = '0.5': must be written A,B"),
        (["--a-range", "0.5,2"], "--a-range = '0.5,2': only used with --fit-a"),
    ]:
        out = hertzian("detect", str(path), "--scene", str(base), "--device", "cpu", *args, env=env)
        assert out.returncode == 2, (args, out.stderr)
        lines = [line for line in out.stderr.splitlines() if line.strip()]
        assert len(lines) == 1 and message in lines[0] and "Traceback" not in out.stderr, (args, out.stderr)
    out = hertzian("detect", str(path), "--scene", str(base), "--device", "cpu", "--fit-a", "--json", env=env)
    assert out.returncode == 0, out.stderr
    result = json.loads(out.stdout)
    lo, hi = result["a_ratio_interval"]
    assert lo <= FIT_A_TRUTH[2] <= hi and result["rss"] < result["rss_a_host"]


def test_interpolated_rss_equals_the_direct_residuals():
    """detect.interpolated_rss (Gram form, clean chain subtracted) against |s − W m|² formed sample by sample,
    on traces that differ from a clean one by small echoes, as a library's do."""
    from hertzian.studies.detection import interpolated_rss, lagrange_weights

    rng = np.random.default_rng(3)
    samples = 2000
    t = np.linspace(0.0, 20.0, samples)
    clean = np.sin(t) * np.exp(-0.1 * t)
    nodes = np.linspace(-1.4, 0.0, 8)
    models = clean[None] + 1e-3 * np.outer(nodes, np.cos(3 * t)) + 1e-4 * rng.normal(size=(8, samples))
    signal = clean + 1e-3 * -0.7 * np.cos(3 * t) + 1e-5 * rng.normal(size=samples)
    W, _ = lagrange_weights(nodes, np.linspace(nodes[0], nodes[-1], 57))
    direct = np.array([np.sum((signal - w @ models) ** 2) for w in W])
    np.testing.assert_allclose(interpolated_rss(signal, models, clean, W), direct, rtol=1e-9, atol=1e-12 * direct.max())
    assert direct.max() > 10 * direct.min()  # the rows differ: the test can tell them apart


def test_fine_scan_finds_the_needle_of_a_shallow_light_grain(cache, monkeypatch):
    """μ = 0.3 at depth 4 of an 80-grain host: the misfit has a needle-shaped minimum (±1.5 % in μ) beside a broad
    one at μ ≈ 0.34, where the library and Gauss–Newton land, leaving σ ≈ 4× the noise. When the best fit's σ is
    above FINE_SCAN_MISFIT × the noise before the echo, a scan of ln μ every 0.4 % at that depth finds the needle:
    the interval then holds 0.3 and σ is the noise added. Without the scan the same signal gives μ ≈ 0.34."""
    from hertzian.studies.detection import refine as detect_module

    base = {**BASE, "chain": {"grains": 80, "l0": 1e-4}}
    samples = 875

    def planted(impurity):
        data = {
            **base,
            "integrator": {"method": "gear4", "dt": 5e-4, "duration": SPACING * (samples - 1)},
            "record": {"traces": [0], "trace_every": SPACING},
        }
        if impurity:
            data["impurities"] = [impurity]
        return run_scene(scene_from_dict(data), "cpu").traces["v"][0, :, 0]

    velocity, clean = planted({"grains": [4], "mass": 0.3}), planted(None)
    sigma = float(np.max(np.abs(velocity - clean))) / 10 ** (SNR_DB / 20)
    signal = signal_from_arrays(
        np.arange(samples) * SPACING, velocity + np.random.default_rng(5).normal(scale=sigma, size=samples)
    )
    found, _ = detect(signal, scene_from_dict(base), device="cpu", depth_range=(3, 6))
    assert found.kind == "light" and found.depth == 4, found.to_dict()
    assert found.fine_scan["improved"] and found.fine_scan["misfit_before"] > detect_module.FINE_SCAN_MISFIT
    lo, hi = found.mass_ratio_interval
    assert lo <= 0.3 <= hi and hi / lo < 1.01, found.to_dict()
    assert 0.8 < found.noise / sigma < 1.2
    monkeypatch.setattr(detect_module, "FINE_SCAN_MISFIT", math.inf)
    without, _ = detect(signal, scene_from_dict(base), device="cpu", depth_range=(3, 6))
    assert without.fine_scan is None and not without.mass_ratio_interval[0] <= 0.3 <= without.mass_ratio_interval[1]
    assert without.mass_ratio > 0.33


# ---- the library's scores, vectorised over depths, and its cache ------------------------------------------


def small_library(seed=4):
    """A synthetic library on the 40-grain BASE, no simulation: depths 3 … 27 × 3 ratios a side, 551 samples.
    Each candidate's trace is the clean one plus an echo smooth in x = ln μ (and noise 1e-6); the pulse front is
    linear in the grain, with no front at grains ≥ 34 (windows of all samples) and a first-echo window of one
    sample at depth 3. Three candidates did not run (NaN traces): a middle and an end ratio of the light class and,
    at depth 15 (where the heavy class's first echo fits best there), the end ratio of the heavy class. Returns
    (forward, grid, clean, traces, ok, fronts, signal v): the signal is an echo from depth 12 at μ = 0.6 (off the
    grid) with noise σ = 2e-5."""
    from hertzian.studies.detection import make_grid

    rng = np.random.default_rng(seed)
    samples = 551
    forward = forward_scene(scene_from_dict(BASE), SPACING, samples)
    t = np.arange(samples) * SPACING
    grid = make_grid(np.arange(3, 28), mass_steps=3)
    fronts = 0.06 * np.maximum(np.arange(GRAINS) - 13, 0) + 0.0025
    fronts[34:] = np.inf
    clean = 1e-2 * np.exp(-0.5 * t) * np.sin(4 * t)

    def echo(depth, x):
        delay = 0.12 * depth + 0.4
        return 1e-3 * (x + 0.3 * x**2) * np.exp(-(((t - delay) / 0.3) ** 2)) * np.cos(9 * (t - delay))

    traces = np.array([[clean + echo(d, x) for x in grid.log_mass_ratio] for d in grid.depths])
    traces += 1e-6 * rng.normal(size=traces.shape)
    ok = np.ones(traces.shape[:2], dtype=bool)
    for k, m in [(2, 1), (5, 0), (12, len(grid.log_mass_ratio) - 1)]:
        ok[k, m] = False
        traces[k, m] = np.nan
    signal = clean + echo(12, math.log(0.6)) + 2e-5 * rng.normal(size=samples)
    return forward, grid, clean, traces, ok, fronts, signal


def reference_library_scores(signal, t, clean, traces, ok, fronts, grid):
    """The library's scores computed depth by depth from the traces (the reference for the
    vectorised scores): per class, the quadratic of each depth (x0, rss0, g, H; None if no point is
    usable) and the first-echo gain and best x; and the RSS of every candidate (inf where it did not run)."""
    from hertzian.studies.detection import FIRST_ECHO_GRAINS, INTERPOLATION_POINTS, lagrange_weights, quadratic_at

    def rss_of(s, models, c, W):
        e, D = s - c, models - c[None]
        return np.maximum(float(e @ e) - 2.0 * (W @ (D @ e)) + np.einsum("pi,ij,pj->p", W, D @ D.T, W), 0.0)

    scores = {}
    for kind in ("light", "heavy"):
        columns = grid.light if kind == "light" else grid.heavy
        xs = np.concatenate([grid.log_mass_ratio[columns], [0.0]])
        order = np.argsort(xs)
        xs = xs[order]
        fine = np.linspace(xs[0], xs[-1], (xs.size - 1) * INTERPOLATION_POINTS + 1)
        W, dW = lagrange_weights(xs, fine)
        quads, gain, best_x = [], np.full(len(grid.depths), -np.inf), np.zeros(len(grid.depths))
        for k, depth in enumerate(grid.depths):
            node_ok = np.concatenate([ok[k, columns], [True]])[order]
            usable = (np.abs(W) > 0) @ (~node_ok) == 0
            nodes = np.where(node_ok[:, None], np.concatenate([traces[k, columns], clean[None]])[order], 0.0)
            if usable.any():
                rss = np.where(usable, rss_of(signal, nodes, clean, W), np.inf)
                j = int(np.argmin(rss))
                q = quadratic_at(signal, fine[j], W[j] @ nodes, dW[j] @ nodes)
                quads.append((q.x0, q.rss0, q.g, q.H))
            else:
                quads.append(None)
            end = int(np.searchsorted(t, 2 * fronts[min(fronts.size - 1, int(depth) + FIRST_ECHO_GRAINS)]))
            if end >= 2:
                rss = np.where(usable, rss_of(signal[:end], nodes[:, :end], clean[:end], W), np.inf)
                j = int(np.argmin(rss))
                head = signal[:end] - clean[:end]
                gain[k], best_x[k] = float(head @ head) - rss[j], fine[j]
        scores[kind] = quads, gain, best_x
    residual = signal[None, None] - traces
    return scores, np.where(ok, np.einsum("dms,dms->dm", residual, residual), np.inf)


def test_vectorised_library_scores_equal_the_per_depth_formulas():
    """The scores detect takes from the library — per class and depth the Gauss–Newton quadratic at the best
    interpolated point and the first-echo gain, and every candidate's RSS — computed for all depths at once from
    the echoes' projections on the signal and the library's Gram matrices, against the per-depth formulas on the
    traces (reference_library_scores). Same interpolated point (x0, best x: equal); rss0, H, the gain and the
    candidates' RSS to rtol 1e-10; g (J·r, which can be near 0) to 1e-10 of its Cauchy–Schwarz bound √(H rss0)."""
    import hertzian.studies.detection as detect_module

    forward, grid, clean, traces, ok, fronts, signal = small_library()
    library = detect_module.assemble_library("test", grid, forward, clean, traces, ok, fronts)
    t = np.arange(signal.size) * SPACING
    expected, expected_candidates = reference_library_scores(signal, t, clean, traces, ok, fronts, grid)
    residual = signal - clean
    rss_clean = float(residual @ residual)
    projections, first_echo = detect_module._echo_projections(residual, library)
    assert (library.first_echo_ends < 2).any() and (library.first_echo_ends == signal.size).any()
    for kind in ("light", "heavy"):
        quads, gain, best_x = expected[kind]
        found = detect_module._library_quadratics(rss_clean, projections, library, kind)
        assert [q is None for q in found] == [q is None for q in quads]
        x0, rss0, g, H = (np.array([q[i] for q in quads if q is not None]) for i in range(4))
        got = np.array([(q.x0, q.rss0, q.g, q.H) for q in found if q is not None]).T
        np.testing.assert_array_equal(got[0], x0)
        np.testing.assert_allclose(got[1], rss0, rtol=1e-10, atol=0)
        np.testing.assert_allclose(got[3], H, rtol=1e-10, atol=0)
        assert np.all(np.abs(got[2] - g) <= 1e-10 * np.sqrt(H * rss0)), np.max(np.abs(got[2] - g) / np.sqrt(H * rss0))
        found_gain, found_x = detect_module._first_echo_scores(first_echo, library, kind)
        np.testing.assert_array_equal(found_x, best_x)
        np.testing.assert_array_equal(np.isfinite(found_gain), np.isfinite(gain))
        np.testing.assert_allclose(found_gain[np.isfinite(gain)], gain[np.isfinite(gain)], rtol=1e-10, atol=0)
        if kind == "light":  # the data make sense: the echo's depth and ratio fit best, to the noise
            best = int(np.argmin(rss0))
            assert grid.depths[best] == 12 and abs(x0[best] - math.log(0.6)) < 0.03
            assert rss0[best] < 1.1 * signal.size * 2e-5**2 < 0.1 * np.median(rss0)
    candidates = detect_module._candidate_rss(rss_clean, projections, library)
    np.testing.assert_array_equal(np.isfinite(candidates), ok)
    np.testing.assert_allclose(candidates[ok], expected_candidates[ok], rtol=1e-10, atol=0)


def test_library_cache_round_trips_and_refuses_a_damaged_copy(tmp_path, monkeypatch):
    """build_library saves the library as one .npy per array in a directory (nothing temporary left behind); the next
    call maps the same arrays back without simulating. A damaged copy (a truncated or missing file, an array of the
    wrong shape, first-echo windows that differ from FIRST_ECHO_GRAINS's) is not used: a warning, then the library
    is simulated again and saved whole."""
    from hertzian.studies.detection import library as detect_module

    monkeypatch.setenv("HERTZIAN_DETECT_CACHE", str(tmp_path))
    forward, grid, clean, traces, ok, fronts, _ = small_library()
    runs = []

    def simulated(forward, candidates, block, device, batch_size=4096):
        runs.append(len(candidates))
        return np.concatenate([clean[None], traces.reshape(-1, clean.size)]), np.concatenate([[True], ok.ravel()])

    monkeypatch.setattr(detect_module, "run_candidates", simulated)
    built = detect_module.build_library(forward, grid, "cpu", fronts=fronts)
    assert runs == [1 + ok.size] and not built.from_cache
    path = tmp_path / built.key
    assert list(tmp_path.iterdir()) == [path]
    assert sorted(p.name for p in path.iterdir()) == sorted(f"{name}.npy" for name in detect_module.CACHED_ARRAYS)

    def loads_unchanged():
        loaded = detect_module.build_library(forward, grid, "cpu", fronts=fronts)
        assert loaded.from_cache and loaded.build_seconds == 0.0
        for name in detect_module.CACHED_ARRAYS:
            a, b = getattr(loaded, name), getattr(built, name)
            assert a.dtype == b.dtype and np.array_equal(a, b), name
            assert not a.flags.writeable, name  # memory-mapped read-only
        assert np.isnan(traces[~ok]).all() and np.isfinite(loaded.echoes).all()

    loaded_before = len(runs)
    loads_unchanged()
    assert len(runs) == loaded_before

    def truncate(name):
        data = (path / name).read_bytes()
        (path / name).write_bytes(data[: len(data) - 8])

    damages = {
        "truncated echoes": lambda: truncate("echoes.npy"),
        "missing gram": lambda: (path / "gram.npy").unlink(),
        "ok of the wrong shape": lambda: np.save(path / "ok.npy", ok[:-1]),
        "other first-echo windows": lambda: np.save(path / "first_echo_ends.npy", built.first_echo_ends + 1),
    }
    for what, damage in damages.items():
        damage()
        runs_before = len(runs)
        with pytest.warns(UserWarning, match="is not usable"):
            rebuilt = detect_module.build_library(forward, grid, "cpu", fronts=fronts)
        assert len(runs) == runs_before + 1 and not rebuilt.from_cache, what
        loads_unchanged()
        assert list(tmp_path.iterdir()) == [path], what


def test_gpu_note_names_the_event_steps_of_the_candidate_runs(monkeypatch):
    """On a GPU, a BASE whose contacts can open and which keeps event-aware steps gets one note naming
    integrator.events = "off"; plain steps or a CPU get none. (The CUDA check is made on a CPU-built model.)"""
    from hertzian.cli import detect as cli_detect
    from hertzian.core import model as model_module

    real_build = model_module.build_model
    monkeypatch.setattr(model_module, "build_model", lambda scenes, dev: real_build(scenes, "cpu"))
    base = scene_from_dict(BASE)
    assert cli_detect.candidate_events_note(base, "cpu") is None
    note = cli_detect.candidate_events_note(base, "cuda")
    assert note is not None and 'integrator.events = "off"' in note
    plain = base.with_overrides({"integrator.events": "off"})
    assert cli_detect.candidate_events_note(plain, "cuda") is None


def test_cli_detect_study_takes_its_options_and_refuses_a_bad_study(tmp_path):
    """`hertzian detect-study STUDY --out F`: its options are its own (a helper defined between the command's
    decorator and its function once took the command's place), and a study file without hosts is refused with
    one line, exit 2, nothing written."""

    help_text = invoke("detect-study", "--help")
    assert help_text.exit_code == 0 and "--out" in help_text.stdout and "STUDY" in help_text.stdout.upper()
    study = tmp_path / "study.toml"
    study.write_text("[scene]\nchain = { grains = 20, l0 = 1e-4 }\nexcitation = { impact = 1e-2 }\n\n[study]\n")
    out = tmp_path / "out.json"
    assert_refused(invoke("detect-study", str(study), "--out", str(out), "--device", "cpu"), out)


@pytest.mark.parametrize(
    "study, host, key",
    [
        ("window_past_bottom = 3.0", "", "study.window_past_bottom"),
        ("windw = 1.1", "", "study"),
        ("", "noise_trials = 0", "hosts[0].noise_trials"),
        ("", "noise_trials = 2.5", "hosts[0].noise_trials"),
    ],
)
def test_cli_detect_study_refuses_bad_study_keys(tmp_path, study, host, key):
    """[study] and [[hosts]] keys are checked: an unknown key, a window past the bottom outside [1, 2] or noise
    trials that are not a whole number ≥ 1 is one line, exit 2."""

    path = tmp_path / "study.toml"
    path.write_text(
        "[scene]\nchain = { grains = 20, l0 = 1e-4 }\nexcitation = { impact = 1e-2 }\n\n"
        f"[study]\n{study}\n\n[[hosts]]\nsnr_db = [26]\nmass_ratios = [0.5]\ndepth_fractions = [0.5]\n"
        f"{host}\n"
    )
    out = tmp_path / "out.json"
    assert_refused(invoke("detect-study", str(path), "--out", str(out), "--device", "cpu"), out, key)


@pytest.mark.parametrize("gravity, block", [(0.0, 1), (0.0, 3), (1.0, 3)])
def test_library_runs_equal_one_scene_per_candidate(gravity, block):
    """run_candidates builds its ensembles without a scene per candidate (one ChainSet per depth and contact
    constant, mass per chain, the sets stacked; the clean chain in the first set) and prepares the next batch
    while one runs: every candidate's trace and status must be those of the ensemble built from one
    impurity_scene per candidate, bit for bit, in the caller's order, across batches (here of 4 chains). Without
    gravity a group below the grains that move at t = 0 reuses another such group's arrays with its impurity moved
    (depths 10 → 25 here); depth 2 is above them, and gravity or a ≠ a_host forbids the move."""
    from hertzian.core.model import build_model
    from hertzian.core.runner import Runner
    from hertzian.core.scene import apply_overrides
    from hertzian.studies.detection import impurity_scene, run_candidates

    forward = forward_scene(scene_from_dict(apply_overrides(BASE, {"chain.gravity": gravity})), SPACING, 301)
    candidates = [
        (20, 3.0),
        (-1, 1.0),
        (3, 0.5),
        (10, 1.0, 2.0),
        (3, 2.0),
        (10, 0.7),
        (25, 0.3),
        (2, 1.4),
        (10, 0.9, 2.0),
    ]
    traces, ok = run_candidates(forward, candidates, block, "cpu", batch_size=4)
    scenes = [
        forward if depth < 0 else impurity_scene(forward, depth, mu, block, (*rest, 1.0)[0])
        for depth, mu, *rest in candidates
    ]
    reference = Runner(build_model(scenes, "cpu"), kernel="fused").run()
    assert ok.all() and (reference.status == 0).all()
    expected = reference.traces["v"][:, :, 0]
    assert np.max(np.abs(expected - expected[1])) > 1e-4  # the impurities' echoes reached the surface
    np.testing.assert_array_equal(traces, expected)


def test_library_assembled_on_the_device_equals_the_host_path(monkeypatch):
    """On CUDA the library's traces stay on the device, where kernels/library.py forms the echoes and their Gram
    matrices; only the echoes come back. Forced here on the CPU device, that path must give the host path's clean
    trace, echoes and OK flags bit for bit (a candidate marked as failed included: its echo is −clean) and its Gram
    matrices to rounding."""
    from hertzian.core import runner as runner_module
    from hertzian.studies.detection import build_library, front_times, make_grid
    from hertzian.studies.detection import library as detect_module

    forward = forward_scene(scene_from_dict(BASE), SPACING, 301)
    fronts = front_times(forward, "cpu")
    grid = make_grid(np.arange(3, 30, 4), mass_steps=2)
    run = runner_module.Runner.run

    def one_chain_fails(self, *args, **kwargs):
        result = run(self, *args, **kwargs)
        result.status[5] = 1  # the candidate in chain 5 did not run OK
        return result

    monkeypatch.setattr(runner_module.Runner, "run", one_chain_fails)
    libraries = []
    for on_device in (False, True):
        monkeypatch.setattr(detect_module, "ASSEMBLE_ON_DEVICE", on_device)
        libraries.append(build_library(forward, grid, "cpu", fronts=fronts, use_cache=False))
    host, device = libraries
    assert (~host.ok).sum() == 1 and np.max(np.abs(host.echoes)) > 1e-4  # one failed; the echoes reached the surface
    for name in ("clean", "echoes", "ok", "first_echo_ends"):
        np.testing.assert_array_equal(getattr(device, name), getattr(host, name), err_msg=name)
    for name in ("gram", "first_echo_gram"):
        np.testing.assert_allclose(getattr(device, name), getattr(host, name), rtol=1e-12, atol=0, err_msg=name)
        assert np.array_equal(getattr(device, name), getattr(device, name).transpose(0, 2, 1))
    assert np.max(host.first_echo_gram) > 0 and np.any(host.first_echo_gram != host.gram)


def test_large_library_arrays_are_saved_by_threads_as_np_save_would(tmp_path, monkeypatch):
    """A library array over SAVE_PIECE_BYTES is copied into its .npy file's memory map by several threads: the file
    must be byte for byte the one np.save writes (here with pieces of 1 KiB, so 7 threads share 3 × 5 × 101 rows)."""
    from hertzian.studies.detection import library as detect_module

    monkeypatch.setattr(detect_module, "SAVE_PIECE_BYTES", 1024)
    array = np.random.default_rng(3).standard_normal((21, 5, 101))
    detect_module._save_array(tmp_path / "threads.npy", array)
    np.save(tmp_path / "reference.npy", array)
    assert (tmp_path / "threads.npy").read_bytes() == (tmp_path / "reference.npy").read_bytes()
    detect_module._save_array(tmp_path / "strided.npy", array[:, ::2])  # not contiguous: np.save itself
    np.testing.assert_array_equal(np.load(tmp_path / "strided.npy"), array[:, ::2])


def test_study_draws_noise_trials_per_planted_case(tmp_path):
    """`noise_trials = 2`: each planted case is detected twice, with independent noise of the same σ (a small study
    on a 30-grain host, run on the CPU)."""
    from hertzian.studies.detection.study import run_study

    path = tmp_path / "study.toml"
    path.write_text(
        "[scene]\nchain = { grains = 30, l0 = 1e-4 }\nexcitation = { impact = 1e-2 }\n"
        'integrator = { method = "gear4", dt = 1e-3, duration = 1.0, events = "off" }\n\n'
        "[study]\nspacing = 0.01\nseed = 7\nmass_steps = 2\nrefine = 1\niterations = 1\n"
        "probe_duration = 10.0\n\n"
        "[[hosts]]\nsnr_db = [26]\nmass_ratios = [0.4]\ndepth_fractions = [0.3]\nclean_trials = 1\n"
        "noise_trials = 2\n"
    )
    result = run_study(path, "cpu")
    records = result["records"]
    assert [r["true_class"] for r in records] == ["light", "light", "none"]
    assert records[0]["sigma"] == records[1]["sigma"] > 0
    assert records[0]["noise"] != records[1]["noise"]  # two draws of the noise: two estimates of σ
    assert result["summary"]["g0-block1"]["26.0"]["detections"] == 3


def test_wide_scan_finds_the_other_class_a_few_grains_off():
    """:func:`wide_scan` from a depth 3 grains off (where a heavy grain at 10 had been taken for a light one at 13):
    scanning both classes at the depths around finds the heavy class at depth 10, its best point within a scan step
    of μ = 2 (a noise-free planted signal on a 40-grain host)."""
    from hertzian.studies.detection import forward_scene, make_grid, run_candidates, wide_scan
    from hertzian.studies.detection.scoring import _class_bounds

    forward = forward_scene(scene_from_dict(BASE), SPACING, 301)
    truth, _ = run_candidates(forward, [(10, 2.0)], 1, "cpu")
    grid = make_grid(np.arange(2, 35))
    kind, depth, rss, points = wide_scan(truth[0], forward, 1, 13, grid.depths, _class_bounds(grid), "cpu")
    assert (kind, depth) == ("heavy", 10)
    assert points == 2 * 9 * 138  # both classes, depths 9 … 17, ln μ every 0.01 inside (0, ln 4)
    near, _ = run_candidates(forward, [(10, 2.0 * math.exp(0.006))], 1, "cpu")
    assert rss <= float(np.sum((truth[0] - near[0]) ** 2))  # at least as close as a point 0.6 % off in μ
