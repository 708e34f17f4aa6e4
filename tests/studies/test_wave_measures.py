"""Sec. VI measures against closed forms: the standing fraction of the two-wave fit (pure standing, pure
travelling and mixed waves in a column whose sound speed grows with depth) and the lag correlation of a
travelling pulse, instantaneous against averaged over a window."""

import math

import numpy as np
import pytest
from hertzian.studies import analysis as an


@pytest.fixture(scope="module")
def phase():
    """Phase of a τ = 1 wave down a 3000-grain g = 1 column (wavelength 55–120 grains)."""
    return an.column_wave_phase(2.0 * math.pi, 3000, gravity=1.0)


def test_column_wave_phase_follows_the_discrete_dispersion(phase):
    c = an.column_sound_speed(np.arange(3000), gravity=1.0)
    k = np.diff(phase)
    assert np.allclose(2.0 * c[1:] * np.sin(k / 2.0), 2.0 * math.pi, rtol=1e-12)


@pytest.mark.parametrize("r", [0.0, 0.2, 0.5, 1.0])
def test_standing_fraction_of_a_known_mixture(phase, r):
    """V = e^{−iφ} + r e^{iφ}: s = 2r/(1 + r), i.e. 0 for a travelling wave, 1 for a standing one."""
    fit = an.fit_two_waves(np.exp(-1j * phase) + r * np.exp(1j * (phase + 0.7)), phase)
    assert fit.centre.size > 20
    assert np.allclose(fit.forward, 1.0, atol=1e-12)
    assert np.allclose(fit.backward, r, atol=1e-12)
    assert np.allclose(fit.standing_fraction, 2.0 * r / (1.0 + r), atol=1e-12)
    assert np.all(fit.residual < 1e-12)


def test_standing_fraction_follows_a_reflection_that_changes_with_depth(phase):
    """A backward wave that grows linearly with depth: each stretch reports its own ratio (WKB)."""
    z = np.arange(phase.size)
    r = z / z[-1]
    fit = an.fit_two_waves(np.exp(-1j * phase) + r * np.exp(1j * phase), phase)
    expected = 2.0 * (fit.centre / z[-1]) / (1.0 + fit.centre / z[-1])
    assert np.max(np.abs(fit.standing_fraction - expected)) < 0.01


def test_the_max_min_ratio_cannot_tell_a_travelling_wave_whose_amplitude_varies(phase):
    """Why the standing fraction replaces max|V₁|/min|V₁|: a travelling wave that decays with depth has a large
    ratio (e^5 = 148) and a standing fraction near 0 (not exactly 0: the amplitude falls by up to 20 % within one
    stretch, which the constant F and B of a stretch take partly as a backward wave)."""
    z = np.arange(phase.size)
    v = np.exp(-z / 600.0) * np.exp(-1j * phase)
    assert an.standing_wave_ratio(np.abs(v)) > 100.0
    assert np.nanmax(an.fit_two_waves(v, phase).standing_fraction) < 0.05


def test_lag_correlation_of_a_travelling_pulse_instantaneous_and_averaged():
    """A Gaussian pulse of width σ moving at speed c: the instantaneous profiles correlate as
    exp(−(c L)²/(4σ²)) at lag L; averaged over a window W ≫ σ/c they are boxes of length cW, which correlate
    as their overlap 1 − L/W, less the mean Pearson takes out: the average keeps the shape long after the pulse has moved."""
    grains, c, sigma, width = 4000, 80.0, 1.0, 1.5
    z = np.arange(grains, dtype=float)
    dt = 0.001

    def pulse(t):
        return np.exp(-((z - 1000.0 - c * t) ** 2) / (2.0 * sigma**2))

    lags = np.array([0.0, 0.02, 0.05, 0.3, 0.75, 1.2])
    inst = an.profile_correlation([pulse(L) for L in lags], smooth=1)
    window = np.arange(-0.5 * width, 0.5 * width + 0.5 * dt, dt)
    averaged = an.profile_correlation([np.mean([pulse(L + s) for s in window], axis=0) for L in lags], smooth=1)
    gauss = np.exp(-((c * lags) ** 2) / (4.0 * sigma**2))
    share = (
        c * width / grains
    )  # Pearson subtracts the mean: two boxes overlapping by f correlate as (f − share)/(1 − share)
    box = (1.0 - lags / width - share) / (1.0 - share)
    assert np.allclose(inst, gauss, atol=0.02)
    assert np.allclose(averaged, box, atol=0.02)
    assert inst[3] < 0.01 and averaged[3] > 0.75


def test_the_standing_fractions_null_calls_waves_by_their_kind():
    """Against its phase-randomised null, a pure standing wave is 'standing', a pure travelling wave 'travelling',
    and amplitudes with random phases are not distinguished from the null."""
    from hertzian.studies.analysis import fit_two_waves, standing_verdict, surrogate_fractions

    phase = 0.05 * np.arange(400.0)  # eight local wavelengths and more
    rng = np.random.default_rng(3)
    cases = {
        "standing": np.cos(phase)[None, :] * np.ones((3, 1)),
        "travelling": np.exp(-1j * phase)[None, :] * np.ones((3, 1)),
        "not distinguished from the null": np.exp(2j * np.pi * rng.random((3, 400))),
    }
    for expected, windows in cases.items():
        observed = float(np.nanmedian(np.concatenate([fit_two_waves(row, phase).standing_fraction for row in windows])))
        null = surrogate_fractions(windows, phase, count=100)
        band = np.nanpercentile(null, [2.5, 97.5]).tolist()
        assert 0.5 < np.median(null) < 0.9  # random phases: s is far from 0
        assert standing_verdict(observed, band) == expected, (expected, observed, band)


def test_the_shuffled_null_of_the_share_at_the_drive_frequency_is_2_over_s():
    """Shuffling a window's S samples in time leaves a share at ω of 2σ²/(S (μ² + σ²)) ≤ 2/S in expectation: checked
    by shuffling a driven signal 4000 times (the unshuffled one keeps most of its energy at ω)."""
    rng = np.random.default_rng(5)
    samples = 320
    t = np.arange(samples) / samples  # one period
    v = 0.3 + np.sin(2 * np.pi * t) + 0.2 * rng.standard_normal(samples)

    def share(x):
        v1 = 2.0 / samples * np.sum(x * np.exp(-2j * np.pi * t))
        return 0.5 * abs(v1) ** 2 / np.mean(x**2)

    shuffled = np.mean([share(rng.permutation(v)) for _ in range(4000)])
    expected = 2 * v.var() / (samples * np.mean(v**2))
    assert shuffled == pytest.approx(expected, rel=0.05)
    assert expected <= 2.0 / samples and share(v) > 100 * 2.0 / samples


def test_plot_standing_gives_each_point_the_shuffled_null_of_its_share(tmp_path):
    import json

    from tests.helpers import hertzian

    args = ["--set", "chain.grains=300", "--set", "integrator.duration=20", "--set", "record.every=20"]
    args += ["--set", "record.response_windows=2", "--device", "cpu", "--quiet"]
    made = hertzian("sweep", "paper_sec6_standing.toml", "--out", tmp_path / "s.zarr", *args)
    assert made.returncode == 0, made.stderr
    drawn = hertzian("plot", tmp_path / "s.zarr", "--figure", "standing", "--out", tmp_path / "s.png")
    assert drawn.returncode == 0, drawn.stderr
    points = [p for p in json.loads((tmp_path / "s.json").read_text())["points"] if "fraction_quartiles" in p]
    assert len(points) >= 3  # τ = 1 (a 300-grain column is shorter than half a wavelength at τ = 10)
    for point in points:
        period_steps = round(point["tau"] / 1.25e-4)  # the sweep's dt
        periods = 1 if point["tau"] == 10 else 10  # its zipped response_periods
        stride = 250 if point["tau"] == 10 else 25  # the largest divisor leaving ≥ 256 samples a period
        assert point["ke_share_null"] == pytest.approx(2.0 / (periods * period_steps / stride), rel=1e-12)
        assert point["ke_share_verdict"] in ("above the null", "not above the null")
