"""hertzian.studies.analysis on synthetic profiles with known answers (no simulation)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hertzian.studies import analysis as an


def test_fit_line_exact_and_noisy():
    x = np.linspace(0.0, 10.0, 50)
    exact = an.fit_line(x, 3.0 * x - 2.0)
    assert exact.slope == pytest.approx(3.0, abs=1e-12)
    assert exact.intercept == pytest.approx(-2.0, abs=1e-12)
    assert exact.slope_error == pytest.approx(0.0, abs=1e-12)
    assert exact.r_squared == pytest.approx(1.0)
    # with noise of known size the 1σ error matches σ/√Sxx, and the slope lies within a few σ
    rng = np.random.default_rng(1)
    sigma = 0.5
    noisy = an.fit_line(x, 3.0 * x - 2.0 + rng.normal(0.0, sigma, x.size))
    expected_error = sigma / math.sqrt(np.sum((x - x.mean()) ** 2))
    assert noisy.slope_error == pytest.approx(expected_error, rel=0.3)
    assert abs(noisy.slope - 3.0) < 4 * expected_error


def test_fit_line_degenerate_input_is_nan():
    assert math.isnan(an.fit_line([1.0], [2.0]).slope)
    assert math.isnan(an.fit_line([1.0, 1.0], [2.0, 3.0]).slope)


def test_fit_power_law_recovers_exponent_and_drops_nonpositive():
    x = np.logspace(-3, -1, 7)
    fit = an.fit_power_law(np.r_[x, -1.0], np.r_[41.8 * x**0.2, 5.0])
    assert fit.exponent == pytest.approx(0.2, abs=1e-12)
    assert fit.prefactor == pytest.approx(41.8, rel=1e-12)
    assert fit.points == 7
    assert fit(0.01) == pytest.approx(41.8 * 0.01**0.2)


def test_paper_conventions():
    assert np.array_equal(an.paper_displacement([1.0, -2.0]), [-1.0, 2.0])
    assert np.array_equal(an.paper_label(np.arange(3), 1000), [1000, 999, 998])


def _cos4(grains, centre, width=an.NESTERENKO_SUPPORT):
    s = (np.arange(grains) - centre) * math.pi / width
    return np.where(np.abs(s) < math.pi / 2, np.cos(s) ** 4, 0.0)


def test_pulse_head_subgrain_and_deepest_strong_maximum():
    profile = _cos4(100, 37.3, width=12.0)
    assert an.pulse_head(profile) == pytest.approx(37.3, abs=0.05)
    # a larger bump behind the head (a tail, a second hit) does not capture the head
    profile2 = 0.6 * profile + _cos4(100, 12.0, width=12.0)
    assert an.pulse_head(profile2) == pytest.approx(37.3, abs=0.1)
    # below the fraction it is ignored
    profile3 = 0.3 * profile + _cos4(100, 12.0, width=12.0)
    assert an.pulse_head(profile3) == pytest.approx(12.0, abs=0.1)
    assert math.isnan(an.pulse_head(np.zeros(10)))
    heads = an.head_positions(np.stack([profile, profile2]))
    assert heads.shape == (2,)


def test_pulse_speed_stops_before_reflection():
    t = np.linspace(0.0, 10.0, 41)
    head = 20.0 * t
    head[t > 6] = 240.0 - 20.0 * (t[t > 6] - 6.0)  # reflected at grain 120: would bend the line
    fit = an.pulse_speed(t, head, first_grain=10.0, last_grain=100.0)
    assert fit.slope == pytest.approx(20.0, abs=1e-10)
    centres, speeds = an.speed_history(t[:20], 20.0 * t[:20], window=5)
    assert np.allclose(speeds, 20.0)
    assert centres.size == 16


def test_front_position_and_shock_width_of_a_rectangle():
    u = np.zeros(200)
    u[10:80] = 1.0
    u[80] = 0.5
    u[:10] = np.linspace(0.0, 0.9, 10)
    assert an.front_position(u) == pytest.approx(80.0)
    # rear: grain 5 is the first ≥ 0.5 (u = 0.5); width = 80 - 5 + 1
    assert an.shock_width(u) == pytest.approx(76.0)
    assert an.shock_widths(np.stack([u, u])).shape == (2,)


def test_plateau_tilt():
    flat = np.r_[np.zeros(10), np.ones(30), np.zeros(10)]
    assert an.plateau_tilt(flat) == pytest.approx(0.0, abs=1e-12)
    sloped = np.r_[np.zeros(10), np.linspace(1.0, 0.9, 30), np.zeros(10)]  # higher at the shallow end
    assert an.plateau_tilt(sloped) == pytest.approx(0.1, rel=1e-9)


def test_count_bumps():
    v = _cos4(100, 80, 6.0) + 0.5 * _cos4(100, 60, 6.0) + 0.2 * _cos4(100, 40, 6.0) + 0.05 * _cos4(100, 20, 6.0)
    head = an.pulse_head(v)
    assert an.count_bumps(v, head, fraction=0.1) == 3
    assert an.count_bumps(v, head, fraction=0.3) == 2


def test_tail_decay_recovers_decay_length_through_oscillations():
    grains = np.arange(400)
    head = 300.0
    z = head - grains
    envelope = 2e-4 * np.exp(-z / 60.0)
    u = np.where(z >= 0, envelope * np.cos(2.4 * z) ** 2, 0.0)  # oscillating tail, compressive envelope
    fit = an.tail_decay(u, head, envelope=11)
    assert fit.decay_length == pytest.approx(60.0, rel=0.05)
    assert fit.r_squared > 0.99
    clean = an.tail_decay(np.where(z >= 0, envelope, 0.0), head, envelope=1)
    assert clean.decay_length == pytest.approx(60.0, rel=1e-9)
    assert an.running_max([0.0, 3.0, 1.0, 0.0, 2.0], 3).tolist() == [3.0, 3.0, 3.0, 2.0, 2.0]


def test_backscatter_sign_amplitude_arrival():
    t = np.linspace(0.0, 20.0, 2001)
    reference = np.exp(-(((t - 2.0) / 0.2) ** 2))  # incident pulse, same in both chains
    echo = 0.3 * np.exp(-(((t - 12.0) / 0.2) ** 2)) - 0.5 * np.exp(-(((t - 12.6) / 0.2) ** 2))
    b = an.backscatter(t, reference + echo, reference, after=5.0)
    assert b.leading_sign == 1 and b.peak_sign == -1
    assert b.amplitude == pytest.approx(0.5, rel=1e-3)
    assert b.peak_time == pytest.approx(12.6, abs=0.02)
    assert 11.5 < b.arrival_time < 12.0
    none = an.backscatter(t, reference, reference, after=5.0)
    assert none.leading_sign == 0 and math.isnan(none.arrival_time)


def test_column_sound_speed_closed_form():
    a, g = 5657.0, 1.0
    z = np.array([99.0, 999.0])
    overlap = (g * (z + 1.0) / (2.5 * a)) ** (2.0 / 3.0)
    expected = np.sqrt(3.75 * a * np.sqrt(overlap))
    assert np.allclose(an.column_sound_speed(z, gravity=g, a=a), expected, rtol=1e-14)
    big = np.logspace(4, 6, 5)
    assert an.fit_power_law(big, an.column_sound_speed(big, gravity=g)).exponent == pytest.approx(1 / 6, abs=1e-3)


def test_depth_law_on_a_synthetic_head():
    # head(t) of a pulse with c(z) = C z^(1/6): z(t) = ((5/6) C t)^(6/5)
    t = np.linspace(0.1, 10.0, 400)
    head = ((5.0 / 6.0) * 30.0 * t) ** 1.2
    fit = an.depth_law(t, head, first_grain=20.0, last_grain=900.0)
    assert fit.exponent == pytest.approx(1 / 6, abs=2e-3)
    assert fit.prefactor == pytest.approx(30.0, rel=0.02)


def test_window_average():
    t = np.arange(0.0, 10.0, 0.1)
    field = np.stack([np.full(3, x) for x in t])  # (record, grain)
    avg = an.window_average(t, field, [2.0, 5.0], 1.0)
    assert avg.shape == (2, 3)
    assert np.allclose(avg[:, 0], [2.0, 5.0])
    assert np.isnan(an.window_average(t, field, [50.0], 1.0)).all()


def test_standing_wave_measure_separates_standing_from_travelling():
    z = np.arange(2000)
    k, omega = 2 * math.pi / 200.0, 2 * math.pi / 10.0
    times = np.arange(8) * 1.5
    standing = np.array([np.sin(k * z) ** 2 * (0.2 + np.cos(omega * t) ** 2) for t in times])
    travelling = np.array([np.sin(k * z - omega * t) ** 2 for t in times])
    sw = an.standing_wave_measure(standing)
    assert np.all(sw.correlation > 0.99)
    assert np.nanmax(sw.node_shift) < 0.02
    assert sw.node_spacing == pytest.approx(100.0, abs=1.0)
    assert len(sw.nodes[0]) == pytest.approx(20, abs=1)
    tw = an.standing_wave_measure(travelling)
    assert np.nanmin(tw.correlation[1:]) < 0.0
    assert np.nanmax(tw.node_shift[1:]) > 0.2


def test_nesterenko_speed_solves_the_long_wave_equation():
    """ψ = ψ_m cos⁴(√(2/5) s) with v_m = c ψ_m and c = nesterenko_speed(v_m) solves Nesterenko's
    travelling-wave equation m c² ψ = k [ψ^{3/2} + (1/10) ψ^{1/4} (ψ^{5/4})''] (k = 5a/2, grain units)."""
    a, m, psi_m = 5657.0, 1.0, 3e-4
    k = 2.5 * a
    # c from the closed form: solve c = nesterenko_speed(c ψ_m) by fixed point
    c = 10.0
    for _ in range(200):
        c = float(an.nesterenko_speed(c * psi_m, a=a, mass=m))
    s = np.linspace(-2.0, 2.0, 4001)
    h = s[1] - s[0]
    psi = psi_m * np.cos(math.sqrt(0.4) * s) ** 4
    w = psi**1.25
    second = (w[2:] - 2 * w[1:-1] + w[:-2]) / h**2
    lhs = m * c**2 * psi[1:-1]
    rhs = k * (psi[1:-1] ** 1.5 + 0.1 * psi[1:-1] ** 0.25 * second)
    assert np.max(np.abs(lhs - rhs)) / np.max(lhs) < 1e-5
    assert float(an.nesterenko_speed(1.0, a=a, mass=m)) == pytest.approx((2 * a / m) ** 0.4)


def test_nesterenko_widths():
    s = np.linspace(-4, 4, 80001)
    profile = np.where(np.abs(math.sqrt(0.4) * s) < math.pi / 2, np.cos(math.sqrt(0.4) * s) ** 4, 0.0)
    assert an.full_width_half_maximum(s, profile) == pytest.approx(an.NESTERENKO_FWHM, rel=1e-6)
    support = s[profile > 0]
    assert support[-1] - support[0] == pytest.approx(an.NESTERENKO_SUPPORT, rel=1e-4)
    assert an.NESTERENKO_SUPPORT == pytest.approx(4.967, abs=1e-3)


def test_linear_chain_modes_closed_forms():
    """A uniform chain between walls: ω_k = 2√(K/m) sin(kπ/(2(n+1))). A light mass m' in it (same springs)
    has one mode above the band, localised, at ω² = 4Km/(m'(2m − m')) (infinite-chain closed form)."""
    n, stiffness = 201, 212.0
    omega, shapes = an.linear_chain_modes(np.ones(n), np.full(n + 1, stiffness))
    exact = 2 * math.sqrt(stiffness) * np.sin(np.arange(1, n + 1) * math.pi / (2 * (n + 1)))
    np.testing.assert_allclose(omega, exact, rtol=1e-10)
    masses = np.ones(n)
    masses[100] = 0.5
    omega, shapes = an.linear_chain_modes(masses, np.full(n + 1, stiffness))
    assert omega[-1] == pytest.approx(math.sqrt(4 * stiffness / (0.5 * 1.5)), rel=1e-10)
    assert omega[-2] < 2 * math.sqrt(stiffness)
    assert shapes[100, -1] ** 2 > 0.5  # localised at the light mass
    # two unequal masses between walls, three unequal springs: the 2×2 closed form
    k0, k1, k2, m0, m1 = 3.0, 5.0, 7.0, 2.0, 0.5
    trace, det = (k0 + k1) / m0 + (k1 + k2) / m1, ((k0 + k1) * (k1 + k2) - k1**2) / (m0 * m1)
    roots = np.sqrt([(trace - math.sqrt(trace**2 - 4 * det)) / 2, (trace + math.sqrt(trace**2 - 4 * det)) / 2])
    np.testing.assert_allclose(an.linear_chain_modes([m0, m1], [k0, k1, k2])[0], roots, rtol=1e-12)
    assert an.hertz_stiffness(5657.0, 2.5 * 5657.0 * 1e-6) == pytest.approx(3.75 * 5657.0 * 1e-2, rel=1e-12)


def test_echo_contrast_and_power_spectrum():
    t = np.linspace(0.0, 10.0, 1001)
    reference = np.sin(t)
    echo = np.exp(-(((t - 5.0) / 0.3) ** 2))
    assert an.echo_contrast(t, reference + echo, reference + echo, reference) == 0.0
    assert an.echo_contrast(t, reference + echo, reference - echo, reference) == pytest.approx(1.0, rel=1e-12)
    assert an.echo_contrast(t, reference + echo, reference - echo, reference, after=6.0) < 1.0 + 1e-12
    freq, power = an.power_spectrum(t, np.sin(2 * math.pi * 3.0 * t))
    assert freq[np.argmax(power)] == pytest.approx(3.0, abs=0.1)


def test_overlap_behind_head_and_rear_level():
    u = np.zeros(300)
    u[:200] = np.linspace(2e-3, 1e-3, 200)  # displaced region, docs/model.md's sign (+ into the chain)
    u[195:200] = np.linspace(1e-3 + 8e-4, 1e-3, 5)  # a step at the head: overlap 2e-4 per contact there
    u[200:] = 0.0
    assert an.overlaps(u, 1e-4)[199] == pytest.approx(1e-4 + 1e-3, rel=1e-12)
    # behind the head the dynamic overlap is the ramp's 5e-6 per contact; at the head 1e-3
    assert an.overlap_behind_head(u, 199.5, l0=1e-4) == pytest.approx(5.025e-6 / 1e-3, rel=1e-2)
    u[50] += 5e-3  # one strongly compressed contact far behind the head
    assert an.overlap_behind_head(u, 199.5) > 1.0
    assert math.isnan(an.overlap_behind_head(u, math.nan))
    assert an.rear_level(np.r_[np.full(10, 3e-5), np.zeros(20)]) == pytest.approx(3e-5)
    fit = an.tail_decay(
        3e-5 + np.where(np.arange(300) <= 250, 1e-4 * np.exp(-(250 - np.arange(300)) / 40.0), 0.0),
        250.0,
        envelope=1,
        baseline=3e-5,
    )
    assert fit.decay_length == pytest.approx(40.0, rel=1e-6)
