"""Claims of Sen, Manciu & Wright (1998) checked on reduced chains (CPU, seconds each).

Each test runs short chains at the paper's parameters (program units, gear4, dt = 1.25e-4 — ten
times the paper's step; the energy error of every run is checked) and compares what
hertzian.studies.analysis measures with something independent: an exact scaling law, a closed form
(sound speed of a compressed chain or column, Nesterenko's soliton), linear acoustics, or the
paper's claim where no theory exists. docs/reproduction.md has the full-size numbers.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hertzian.core.runner import run_ensemble
from hertzian.core.scene import scene_from_dict
from hertzian.studies import analysis as an

from tests.helpers import invoke

DT = 1.25e-4
A = 5657.0
_cache: dict = {}


def _run(key: str, device: str, scenes):
    """Run once per (key, device); every test sharing a run reads the same result."""
    if (key, device) not in _cache:
        result = run_ensemble(scenes, device)
        assert np.all(result.status == 0), result.status
        assert np.max(result.energy_error) < 1e-6, result.energy_error
        _cache[key, device] = result
    return _cache[key, device]


def _scene(**sections):
    data = {"integrator": {"dt": DT}}
    for name, values in sections.items():
        data.setdefault(name, {}).update(values)
    return scene_from_dict(data)


# ---- Sec. III A: shock-like regime --------------------------------------------------------

HORIZONTAL = [
    (0.0, 1e-3),
    (0.0, 1e-2),
    (0.0, 1e-1),
    (1e-6, 1e-3),
    (1e-6, 1e-2),
    (1e-6, 1e-1),
    (1e-4, 1e-3),
    (1e-4, 1e-1),
]
"""(l0, v_imp) of the 200-grain horizontal chains."""


def _horizontal(device):
    scenes = [
        _scene(
            chain={"grains": 200, "l0": l0},
            excitation={"impact": v},
            integrator={"duration": 16.0},
            record={"every": 0.25},
        )
        for l0, v in HORIZONTAL
    ]
    return _run("horizontal", device, scenes)


def _speeds(result):
    heads = an.head_positions(result.v)
    return np.array([an.pulse_speed(result.t, h, first_grain=30, last_grain=170).slope for h in heads])


def test_alpha_is_one_fifth(device):
    """c ∝ v_imp^α: at l0 = 0 the Hertz chain is scale invariant (u → λu, t → λ^(-1/4) t), so α = 1/5
    exactly; at the paper's l0 = 1e-6 the paper finds α ≈ 0.2."""
    result = _horizontal(device)
    c = _speeds(result)
    v = np.array([x for _, x in HORIZONTAL])
    no_load = an.speed_exponent(v[:3], c[:3])
    assert no_load.exponent == pytest.approx(0.2, abs=2e-3)
    paper = an.speed_exponent(v[3:6], c[3:6])
    assert paper.exponent == pytest.approx(0.2, abs=0.01)


def test_speed_independent_of_l0_only_in_the_shock_regime(device):
    """At v_imp = 0.1 the speed hardly depends on l0 (1e-6 vs 1e-4: < 3 %); at v_imp = 1e-3 and
    l0 = 1e-4 the pulse is a near-linear wave at the closed-form sound speed √(K/m),
    K = (15/4) a l0^(1/2), and 1.5x faster than at l0 = 1e-6."""
    result = _horizontal(device)
    c = dict(zip(HORIZONTAL, _speeds(result)))
    assert c[1e-4, 1e-1] == pytest.approx(c[1e-6, 1e-1], rel=0.03)
    sound = math.sqrt(3.75 * A * math.sqrt(1e-4))
    assert c[1e-4, 1e-3] == pytest.approx(sound, rel=0.01)
    assert c[1e-4, 1e-3] > 1.4 * c[1e-6, 1e-3]


def test_shock_width_grows_linearly(device):
    """W(t) ∝ t (paper eq. 5): ln W against ln t has slope 1, and dW/dt equals the head speed."""
    result = _horizontal(device)
    for index in (HORIZONTAL.index((1e-6, 1e-2)), HORIZONTAL.index((1e-6, 1e-1))):
        heads = an.head_positions(result.v[index])
        widths = an.shock_widths(result.u[index])
        stop = np.flatnonzero(heads > 170)[0]
        sel = (np.arange(result.t.size) < stop) & (result.t >= 2.0)
        assert an.fit_power_law(result.t[sel], widths[sel]).exponent == pytest.approx(1.0, abs=0.03)
        speed = an.pulse_speed(result.t, heads, first_grain=30, last_grain=170).slope
        assert an.fit_line(result.t[sel], widths[sel]).slope == pytest.approx(speed, rel=0.03)


def test_nesterenko_soliton_speed_and_width(device):
    """The pulse at l0 = 0 against Nesterenko's long-wave solitary wave: speed (2a/m)^(2/5) v_m^(1/5)
    within 2 % (the discrete chain's is ~0.8 % slower), full width at half maximum within 20 %."""
    scene = _scene(
        chain={"grains": 80},
        excitation={"impact": 1e-2},
        integrator={"duration": 5.0},
        record={"every": 1.0, "traces": [30, 60]},
    )
    result = _run("nesterenko", device, [scene])
    t, v = result.trace_t, result.traces["v"][0]
    peak_times = []
    for column in range(2):
        k = int(np.argmax(v[:, column]))
        peak_times.append(t[k] + (an._parabolic_peak(v[:, column], k) - k) * (t[1] - t[0]))
    speed = 30.0 / (peak_times[1] - peak_times[0])
    peak_velocity = v[:, 1].max()
    assert speed / float(an.nesterenko_speed(peak_velocity)) == pytest.approx(1.0, abs=0.02)
    width = an.full_width_half_maximum(t, v[:, 1]) * speed
    assert width == pytest.approx(an.NESTERENKO_FWHM, rel=0.2)


# ---- Sec. III B: compressive regime ------------------------------------------------------


def test_compressive_tail_is_exponential_and_stretches_with_time(device):
    """l0 = 1e-3, v_imp = 1e-2 (Fig. 3(b)): the compressive tail behind the head is exponential in depth
    (R² > 0.8 on its envelope) with a decay length that grows about linearly in t."""
    scene = _scene(
        chain={"grains": 300, "l0": 1e-3},
        excitation={"impact": 1e-2},
        integrator={"duration": 10.0},
        record={"every": 0.5},
    )
    result = _run("tail", device, [scene])
    heads = an.head_positions(result.v[0])
    fits = {}
    for time in (5.0, 10.0):
        r = int(np.argmin(np.abs(result.t - time)))
        fits[time] = an.tail_decay(result.u[0, r], heads[r])
        assert fits[time].r_squared > 0.8
    ratio = fits[10.0].decay_length / fits[5.0].decay_length
    assert 1.6 < ratio < 2.2
    speed = an.pulse_speed(result.t, heads, first_grain=30, last_grain=280).slope
    assert 0.1 < fits[10.0].decay_length / (speed * 10.0) < 0.5


# ---- Sec. V: columns under gravity ---------------------------------------------------------


def test_pulse_speed_grows_as_depth_to_the_one_sixth(device):
    """c(z) ∝ z^(1/6) in a column compacted by gravity, and equal (within 2 %) to the closed-form long-wave
    speed √(K(z)/m) of the static overlaps of paper eq. 4."""
    scene = _scene(
        chain={"grains": 300, "gravity": 1.0},
        boundary={"surface": "free"},
        excitation={"impact": 1e-2},
        integrator={"duration": 4.5},
        record={"every": 0.05},
    )
    result = _run("depth", device, [scene])
    heads = an.head_positions(result.v[0])
    fit = an.depth_law(result.t, heads, first_grain=30, last_grain=270)
    assert fit.exponent == pytest.approx(1 / 6, abs=0.01)
    centres, speeds = an.speed_history(result.t, heads, window=5)
    depth = np.interp(centres, result.t, heads)
    sel = (depth > 30) & (depth < 270)
    ratio = speeds[sel] / an.column_sound_speed(depth[sel], gravity=1.0)
    assert np.all(np.abs(ratio - 1.0) < 0.02)


def test_more_tail_bumps_and_smaller_displacements_at_larger_gravity(device):
    """Fig. 6: after the same time, the pulse at g = 10 has more bumps and smaller displacements than at
    g = 0.1 (the paper's claim; counted by count_bumps, largest displacement below the surface grains)."""
    scenes = [
        _scene(
            chain={"grains": 200, "gravity": g},
            boundary={"surface": "free"},
            excitation={"impact": 0.1},
            integrator={"duration": 1.6},
            record={"every": 0.4},
        )
        for g in (0.1, 10.0)
    ]
    result = _run("gravity", device, scenes)
    bumps, largest = [], []
    for k in range(2):
        v, u = result.v[k, -1], result.u[k, -1]
        bumps.append(an.count_bumps(v, an.pulse_head(v), fraction=0.1))
        largest.append(np.max(u[3:]))
    assert bumps[1] > bumps[0]
    assert largest[1] < largest[0]


def _column_with_impurities(device):
    """300-grain g = 1 column struck with v_imp = 0.1; five impurities around grain 150; surface trace."""
    blocks = [
        ("light", 0.5, 2000.0, "harmonic"),
        ("light", 0.5, 2000.0, "own"),
        ("heavy", 2.0, 1e4, "harmonic"),
        ("heavy", 2.0, 1e4, "own"),
        ("clean", 1.0, A, "harmonic"),
    ]
    scenes = []
    for _, mass, a, contact in blocks:
        data = {
            "chain": {"grains": 300, "gravity": 1.0},
            "boundary": {"surface": "free"},
            "impurities": [{"grains": [148, 149, 150, 151, 152], "mass": mass, "a": a, "contact": contact}],
            "excitation": {"impact": 0.1},
            "integrator": {"dt": DT, "duration": 6.5},
            "record": {"every": 0.5, "traces": [0, 50], "trace_every": 0.005},
        }
        scenes.append(scene_from_dict(data))
    return blocks, _run("column_impurities", device, scenes)


def test_backscatter_leading_sign_light_vs_heavy_in_a_column(device):
    """Sec. V: the echo's leading part moves grains into the column (the original pulse's direction) for
    light impurities and toward the surface for heavy ones, with both contact rules, and the light echo
    is larger. Independent reference: linear acoustics at the impurities' depth, where the column is
    linear — the velocity reflection coefficient (Z_host − Z_imp)/(Z_host + Z_imp), Z = √(K m), has the
    sign of the leading lobe. The sign is read where |echo| first reaches 5, 10, 20 or 30 % of its largest
    value (the full-size runs: the first lobe is 35–45 % of the largest, docs/reproduction.md)."""
    blocks, result = _column_with_impurities(device)
    t = result.trace_t
    clean = result.traces["v"][-1]
    overlap = (1.0 * 150 / (2.5 * A)) ** (2 / 3)  # static overlap at depth 150 (g m z = 2.5 a δ^1.5)
    z_host = math.sqrt(3.75 * A * math.sqrt(overlap) * 1.0)
    amplitudes = {}
    for k, (kind, mass, a, contact) in enumerate(blocks[:-1]):
        a_contact = a if contact == "own" else 2 * a * A / (a + A)
        # the impurity contacts carry about the same force: δ ∝ a_c^(-2/3), K = (15/4) a_c δ^(1/2)
        stiffness = 3.75 * a_contact * math.sqrt(overlap * (A / a_contact) ** (2 / 3))
        predicted = int(np.sign(z_host - math.sqrt(stiffness * mass)))
        for column in range(2):
            for fraction in (0.05, 0.1, 0.2, 0.3):
                echo = an.backscatter(
                    t, result.traces["v"][k][:, column], clean[:, column], after=2.5, fraction=fraction
                )
                assert echo.leading_sign == predicted, (kind, contact, column, fraction, echo)
        amplitudes[kind, contact] = echo.amplitude
    for contact in ("harmonic", "own"):
        assert amplitudes["light", contact] > amplitudes["heavy", contact]


def test_backscatter_in_a_weakly_loaded_chain_is_compressive(device):
    """Sec. IV regime (g = 0, l0 = 1e-4, v_imp = 1e-2, v_imp/l0 = 100): a nearly tension-free chain carries
    compression pulses only, so the echo from light and from heavy impurities alike first moves the
    surface grain toward the surface (sign −1); the heavy block answers earlier."""
    scenes = []
    for mass, a in ((0.5, 2000.0), (2.0, 1e4), (1.0, A)):
        data = {
            "chain": {"grains": 160, "l0": 1e-4},
            "impurities": [{"grains": [78, 79, 80, 81, 82], "mass": mass, "a": a}],
            "excitation": {"impact": 1e-2},
            "integrator": {"dt": DT, "duration": 12.0},
            "record": {"every": 0.5, "traces": [0], "trace_every": 0.01},
        }
        scenes.append(scene_from_dict(data))
    result = _run("horizontal_impurities", device, scenes)
    t, v = result.trace_t, result.traces["v"]
    light = an.backscatter(t, v[0][:, 0], v[2][:, 0], after=6.0)
    heavy = an.backscatter(t, v[1][:, 0], v[2][:, 0], after=6.0)
    assert light.leading_sign == -1 and heavy.leading_sign == -1
    assert heavy.arrival_time < light.arrival_time


# ---- hertzian plot ------------------------------------------------------------------------


def test_plot_cli_draws_a_figure_and_refuses_bad_input(tmp_path):
    """`hertzian plot` writes a PNG from a store shaped like paper_fig1.toml's, and answers bad input
    with one line and exit code 2."""
    from hertzian.sweeping.sweep_store import write_result

    speeds = [1e-3, 1e-2, 1e-1]
    scenes = [
        _scene(
            chain={"grains": 40, "l0": 1e-6},
            excitation={"impact": v},
            integrator={"duration": 2.0},
            record={"every": 0.25},
        )
        for v in speeds
    ]
    store = write_result(tmp_path / "fig1.zarr", run_ensemble(scenes, "cpu"), axes={"v_imp": np.array(speeds)})
    out = tmp_path / "fig1.png"
    result = invoke("plot", str(store), "--figure", "fig1", "--out", str(out))
    assert result.exit_code == 0, result.output
    assert out.stat().st_size > 10_000
    bad = invoke("plot", str(store), "--figure", "fig42", "--out", str(out))
    assert bad.exit_code == 2 and "fig42" in bad.output
    wrong = invoke("plot", str(store), "--figure", "fig5", "--out", str(tmp_path / "x.png"))
    assert wrong.exit_code == 2 and "impurity_mass" in wrong.output
    assert not (tmp_path / "x.png").exists()
