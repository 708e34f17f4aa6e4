"""``hertzian reproduce --measure``: the measures of hertzian.studies.measures against closed forms and synthetic
signals of known answer, the controlled pair of Sec. VII (only g differs), and bad input."""

import math

import numpy as np
import pytest
from hertzian.studies import measures as ms
from hertzian.studies.reproduce import GROUPS, default_sweeps_dir

from tests.helpers import invoke


def test_local_slopes_of_a_power_law_are_its_exponent():
    v = np.geomspace(1e-3, 1e-1, 7)
    slopes = ms.local_slopes(v, 3.0 * v**0.2)
    assert np.allclose(slopes["slope"], 0.2, atol=1e-12)
    assert np.allclose(slopes["v_imp_midpoints"], np.sqrt(v[1:] * v[:-1]), rtol=1e-12)


def test_ripple_scale_is_half_the_wavelength_at_the_hertz_column_speed():
    """c = √(K/m), K = (15/4) a δ0^(1/2), δ0 = (g m (z + 1) / ((5/2) a))^(2/3) (paper eq. 4), τ = 1."""
    z = np.array(ms.RIPPLE_DEPTHS)
    overlap = ((z + 1.0) / (2.5 * 5657.0)) ** (2.0 / 3.0)
    expected = np.sqrt(3.75 * 5657.0 * np.sqrt(overlap)) / 2.0
    assert np.allclose(ms.drive_ripple_scale(None, "cpu")["c_tau_over_2_grains"], expected, rtol=1e-12)


def test_soliton_numbers_of_a_travelling_cos4_pulse():
    """v(t) at grains 40 and 80 of Nesterenko's profile moving at c: speed, v_m and FWHM come back."""
    v_m, c = 0.05, float(ms.an.nesterenko_speed(0.05))
    t = np.arange(0.0, 5.0, 1e-4)
    phase = np.sqrt(0.4) * (np.array(ms.NESTERENKO_GRAINS)[None, :] - c * (t[:, None] - 0.5))
    v = np.where(np.abs(phase) < math.pi / 2, v_m * np.cos(phase) ** 4, 0.0)
    numbers = ms.soliton_numbers(t, v, 0.1)
    assert numbers["speed"] == pytest.approx(c, rel=1e-6)
    assert numbers["speed_over_nesterenko"] == pytest.approx(1.0, rel=1e-6)
    assert numbers["v_m_over_v_imp"] == pytest.approx(0.5, rel=1e-6)
    assert numbers["fwhm_grains"] == pytest.approx(ms.an.NESTERENKO_FWHM, rel=1e-5)


def test_energy_history_finds_a_jump_and_measures_around_it():
    t = np.linspace(0.0, 10.0, 101)
    work = 100.0 * t
    energy = work + np.where(t > 7.05, 0.5, 0.0)  # E − E0 − W jumps by 0.5 between t = 7.0 and 7.1
    history = ms.energy_history(t, energy, work)
    assert history["largest_jump"]["between_t"] == pytest.approx([7.0, 7.1])
    assert history["largest_jump"]["relative"] == pytest.approx(0.5 / 1000.0, rel=1e-12)
    assert history["energy_error_before_it"] == pytest.approx(0.0, abs=1e-15)
    assert history["energy_error_after_it"] == pytest.approx(0.0, abs=1e-15)
    assert len(history["jumps_over_1e-6"]) == 1


def test_record_changes_are_percentiles_of_the_unsigned_balance_changes():
    """E − E0 − W changes by (−1)^k k between records k and k + 1 (k = 1 … 100), max|W| = 1000: the changes'
    magnitudes are 1 … 100, so their median is 50.5 / 1000 and the largest jump is the last one."""
    t = np.arange(101.0)
    work = 10.0 * t
    steps = np.array([(-1.0) ** k * k for k in range(1, 101)])
    energy = work + np.concatenate([[0.0], np.cumsum(steps)])
    changes = ms.record_changes(t, energy, work)
    assert changes["change_percentiles (50, 90, 99 %)"][0] == pytest.approx(50.5 / 1000.0, rel=1e-12)
    assert changes["largest_jump"]["between_t"] == pytest.approx([99.0, 100.0])
    assert changes["largest_jump"]["relative"] == pytest.approx(100.0 / 1000.0, rel=1e-12)


def test_mean_power_and_parting_time():
    t = np.linspace(0.0, 5000.0, 10001)
    assert ms.mean_power(t, 3.0 * t + 7.0, 1000.0, 2500.0) == pytest.approx(3.0, rel=1e-12)
    assert math.isnan(ms.mean_power(t, t, 6000.0, 7000.0))
    v = np.sin(t)[:, None] * np.ones((1, 4))
    w = v.copy()
    w[4000:, 2] += 0.03  # 1.5 % of the range 2 from t = 2000 on
    assert ms.parting_time(t, v, w) == pytest.approx(2000.0)
    assert ms.parting_time(t, v, v) is None


def test_finite_g_pair_differs_only_in_gravity():
    """Sec. VII's controlled pair: every scene at g = 0 has a twin at g = 1 that is the same in every other key."""
    from hertzian.sweeping.spec import load_sweep, sweep_scenes

    path = default_sweeps_dir() / GROUPS["finite_g"].sweep
    for overrides in ({}, GROUPS["finite_g"].quick):
        scenes = [s.to_dict() for s in sweep_scenes(load_sweep(path, overrides))]
        by_g = {g: [s for s in scenes if s["chain"]["gravity"] == g] for g in (0.0, 1.0)}
        assert len(by_g[0.0]) == len(by_g[1.0]) == len(scenes) // 2 == 6
        for zero, one in zip(by_g[0.0], by_g[1.0]):
            one["chain"]["gravity"] = 0.0
            assert zero == one


@pytest.mark.parametrize(
    "args, message",
    [
        (["--measure", "bogus", "--json", "x.json"], "--measure = 'bogus': one of daggers, groups, fig1d_local_slopes"),
        (["--measure", "nesterenko"], "--measure: needs --json"),
        (["--measure", "groups", "--json", "x.json"], "--out-dir = 'reproduce_out': no figure-group stores"),
        (["--measure", "groups", "--measure", "fig4", "--json", "x.json"], "--measure = 'groups': alone"),
        (["--measure", "nesterenko", "--json", "no/such/dir/x.json"], "--json = 'no/such/dir/x.json': parent"),
    ],
)
def test_measure_bad_input_is_one_line_exit_2(tmp_path, monkeypatch, args, message):
    monkeypatch.chdir(tmp_path)
    result = invoke("reproduce", *args, "--device", "cpu")
    assert result.exit_code == 2
    assert message in result.output and len(result.output.strip().splitlines()) == 1
    assert list(tmp_path.iterdir()) == []


def test_window_medians_skip_infinite_ratios_and_stop_at_count():
    windows = {"swr": [1.0, math.inf, 3.0, 100.0], "node_drift": [0, 2, 4, 6]}
    windows |= {"ke_correlation_next": [0.1, 0.2, 0.3], "driver_open": [0.0, 0.5, 1.0, 1.0]}
    assert ms.window_medians(windows) == {
        "swr": 3.0,
        "node_drift": 3.0,
        "ke_correlation_next": 0.2,
        "driver_open": 0.75,
    }
    assert ms.window_medians(windows, 2)["swr"] == 1.0
