"""Chains of unequal grains (``chain.radii``, docs/heterogeneous.md): tapered, decorated (pattern) and random radii.

The kernels are compared with the independent NumPy reference (tests/reference.py), given the radii as a list
computed here from the forms' formulas; the fused kernels with the per-step kernel; the static state with the
force balance of every grain; a ChainSet (sweep) with the per-scene path, bit for bit.
"""

from __future__ import annotations

import numpy as np
import pytest
from hertzian.core.chains import ChainSet
from hertzian.core.model import build_model, features_of, prepare_model
from hertzian.core.runner import run_scene
from hertzian.core.scene import SceneError, scene_from_dict
from hertzian.core.static import static_arrays, static_state, validity_scale
from hertzian.kernels.tile import plan_tile

from tests.helpers import assert_every_window_moved, fused, invoke, make_scene, per_step, sweep, window_ranges
from tests.reference import reference_run

GRAINS = 12
R0 = 50.0
"""Half the default diameter (100)."""
MOVING = 1e-2


def radii_of(form: dict, n: int = GRAINS) -> np.ndarray:
    """Radii [length] of a ``chain.radii`` table form, from docs/heterogeneous.md's formulas."""
    i = np.arange(n)
    if "taper" in form:
        q = form["taper"]
        return R0 * (1 - q * i) if form.get("kind") == "linear" else R0 * (1 - q) ** i
    if "pattern" in form:
        return R0 * np.array([form["pattern"][k % len(form["pattern"])] for k in i])
    return R0 * (1 + form["spread"] * np.random.default_rng(form["seed"]).uniform(-1, 1, n))


IMPACT = dict(chain={"l0": 1e-4}, excitation={"impact": 1e-2})
CASES = {
    "taper, walls": ({"taper": 0.05}, IMPACT, 1.5),
    "negative taper, walls": ({"taper": -0.04}, IMPACT, 2.0),
    "linear taper, gravity, free surface": (
        {"taper": 0.04, "kind": "linear"},
        dict(chain={"gravity": 1.0}, boundary={"surface": "free"}, excitation={"impact": 1e-1}),
        1.0,
    ),
    "dimer pattern, surface load": ({"pattern": [1.0, 0.6]}, {**IMPACT, "boundary": {"surface": "load"}}, 1.5),
    "random radii, open contacts": ({"spread": 0.3, "seed": 7}, dict(excitation={"impact": 1e-1}), 1.5),
    "taper, driven surface, fixed bottom, gravity": (
        {"taper": 0.03},
        dict(
            chain={"gravity": 1.0},
            boundary={"surface": "driven", "bottom": "fixed"},
            excitation={"drive_amplitude": 2e-3, "drive_period": 0.1},
        ),
        1.0,
    ),
}


def build(form: dict, sections: dict, duration: float, **chain):
    sections = {k: dict(v) if isinstance(v, dict) else v for k, v in sections.items()}
    sections.setdefault("chain", {}).update(grains=GRAINS, radii=form, **chain)
    sections["integrator"] = {"dt": 5e-4, "duration": duration, "events": "off"}
    sections["record"] = {"every": duration / 20, "traces": [0, GRAINS - 2, GRAINS - 1]}
    return make_scene(**sections)


@pytest.mark.parametrize("case", list(CASES))
def test_radii_match_the_reference_over_a_round_trip(case):
    form, sections, duration = CASES[case]
    scene = build(form, sections, duration)
    data = scene.to_dict()
    data["chain"]["radii"] = radii_of(form).tolist()
    ref = reference_run(data)
    # the pulse reached the bottom early enough to come back up before the end
    speed = np.abs(ref["trace_v"])
    bottom = -2 if scene.boundary.bottom == "fixed" else -1
    arrival = ref["trace_t"][np.argmax(speed[:, bottom] > MOVING * speed.max())]
    assert 0 < arrival and duration >= 2.2 * arrival, arrival
    result = run_scene(scene, device="cpu")
    for name in ("u", "v"):
        got, want = getattr(result, name)[0], ref[name]
        scale = np.abs(want).max(axis=0)
        assert np.all(np.abs(got - want) <= 1e-10 * scale), name


def test_equal_radii_are_the_uniform_chain_bit_for_bit():
    sections = dict(chain={"grains": GRAINS, "l0": 1e-4, "gravity": 1.0}, excitation={"impact": 1e-2})
    uniform = make_scene(**sections)
    want = run_scene(uniform, device="cpu")
    for form in ({"taper": 0.0}, {"pattern": [1.0]}, {"spread": 0.0, "seed": 3}, [R0] * GRAINS):
        scene = make_scene(**{**sections, "chain": {**sections["chain"], "radii": form}})
        assert features_of([scene]) == features_of([uniform])  # same kernel code
        for a, b in zip(static_state(scene).__dict__.values(), static_state(uniform).__dict__.values()):
            np.testing.assert_array_equal(a, b)
        got = run_scene(scene, device="cpu")
        np.testing.assert_array_equal(got.u, want.u)
        np.testing.assert_array_equal(got.energy, want.energy)


def test_static_overlaps_balance_every_grain():
    form = {"spread": 0.4, "seed": 11}
    scene = build(form, dict(chain={"l0": 1e-4, "gravity": 2.0}), 1.0)
    st = static_state(scene)
    r = radii_of(form) / R0
    np.testing.assert_allclose(st.mass, r**3, rtol=1e-15)
    n, a = 2.5, scene.chain.a
    force = n * st.contact_constant * st.static_overlap ** (n - 1)  # padded: contact k above grain k
    np.testing.assert_allclose(force[1:] - force[:-1], 2.0 * st.mass, rtol=1e-12)
    np.testing.assert_allclose(force[0], scene.chain.surface_force, rtol=1e-14)
    np.testing.assert_allclose(st.contact_constant[0], a * np.sqrt(r[0]), rtol=1e-15)
    np.testing.assert_allclose(st.contact_constant[-1], a * np.sqrt(r[-1]), rtol=1e-15)
    np.testing.assert_allclose(
        st.contact_constant[1:-1], a * np.sqrt(2 * r[:-1] * r[1:] / (r[:-1] + r[1:])), rtol=1e-15
    )
    # the validity limit is per contact, 0.1 of the smaller grain's diameter (a wall contact: the grain's own)
    R = r * R0
    limits = 0.1 * 2 * np.concatenate([[R[0]], np.minimum(R[:-1], R[1:]), [R[-1]]])
    np.testing.assert_allclose(scene.chain.validity_overlap / validity_scale(r), limits, rtol=1e-15)


def test_a_chain_set_of_seeds_and_tapers_equals_its_scenes():
    base = build({"spread": 0.2, "seed": 0}, IMPACT, 1.0)
    seeds = ChainSet.of(base, {"chain.radii.seed": [0, 5, 5, 9]}, 4)
    taper = build({"taper": 0.0}, dict(chain={"gravity": 1.0}, excitation={"impact": 1e-2}), 1.0)
    tapers = ChainSet.of(taper, {"chain.radii.taper": [0.0, 0.1, -0.05]}, 3)
    for chains in (seeds, tapers):
        arrays = static_arrays(chains)
        prepared = prepare_model(chains)
        assert prepared.features.heterogeneous and prepared.features.static == "profile"
        per_scene = build_model(list(chains), "cpu")
        for name in ("inverse_mass", "contact_constant", "static_overlap", "validity_overlap", "validity_scale"):
            np.testing.assert_array_equal(prepared.arrays[name], getattr(per_scene, name).numpy(), err_msg=name)
        for c in range(len(chains)):
            st = static_state(chains[c])
            np.testing.assert_array_equal(arrays.mass[c], st.mass)
            np.testing.assert_array_equal(arrays.static_overlap[c], st.static_overlap)
    assert not np.array_equal(static_arrays(seeds).mass[0], static_arrays(seeds).mass[1])


def _scenes(count: int, **sections):
    base = make_scene(**sections)
    return [base.with_overrides({"chain.radii.seed": s}) for s in range(count)]


def test_chain_and_tile_kernels_equal_the_per_step_kernel():
    sections = dict(
        chain={"grains": 50, "l0": 1e-4, "gravity": 1.0, "radii": {"spread": 0.3, "seed": 0}},
        boundary={"bottom": "fixed"},
        excitation={"impact": 1e-2},
        integrator={"dt": 5e-4, "duration": 10.0},
    )
    model = build_model(_scenes(2, **sections), "cpu")
    assert model.features.heterogeneous
    steps = 2501
    want = per_step(model, steps)
    plan = plan_tile(
        model.features,
        model.grain_count,
        model.chain_count,
        grains_per_lane=4,
        lanes_per_chain=8,
        steps_per_launch=6,
        windowed=True,
    )
    assert_every_window_moved(want, window_ranges(plan, model.grain_count), held_bottom=True)
    np.testing.assert_array_equal(fused(model, plan, steps), want)
    np.testing.assert_array_equal(sweep(model, steps, steps_per_launch=7), want)


def test_random_radii_are_reproducible_and_bounded():
    def ratios(**form):
        return make_scene(chain={"grains": 2000, "radii": form}).chain.radius_ratios

    np.testing.assert_array_equal(ratios(spread=0.2, seed=4), ratios(spread=0.2, seed=4))
    assert not np.array_equal(ratios(spread=0.2, seed=4), ratios(spread=0.2, seed=5))
    normal = ratios(spread=0.3, seed=1, distribution="normal")
    assert np.all(np.abs(normal - 1) <= 0.3 * 3) and abs(np.std(normal) - 0.3) < 0.03
    lognormal = ratios(spread=0.5, seed=1, distribution="lognormal")
    assert abs(np.std(np.log(lognormal)) - 0.5) < 0.05


def test_impurities_override_their_grains():
    scene = build({"taper": 0.1}, {**IMPACT, "impurities": [{"grains": [4], "mass": 3.0}]}, 1.0)
    mass = static_state(scene).mass
    assert mass[4] == 3.0 and mass[5] == pytest.approx(0.9**15)


@pytest.mark.parametrize(
    "radii, key",
    [
        ({"taper": 1.0}, "chain.radii.taper"),
        ({"taper": 0.2, "kind": "linear"}, "chain.radii.taper"),
        ({"taper": 0.1, "kind": "cubic"}, "chain.radii.kind"),
        ({"pattern": [1.0, 0.0]}, "chain.radii.pattern"),
        ({"spread": 1.0}, "chain.radii.spread"),
        ({"spread": -0.1}, "chain.radii.spread"),
        ({"spread": 0.34, "distribution": "normal"}, "chain.radii.spread"),
        ({"spread": 0.1, "distribution": "cauchy"}, "chain.radii.distribution"),
        ({"spread": 0.1, "seed": -1}, "chain.radii.seed"),
        ({"taper": 0.1, "spread": 0.1}, "chain.radii"),
        ({"tapper": 0.1}, "chain.radii.tapper"),
        ([50.0] * 5, "chain.radii"),
        ([50.0] * (GRAINS - 1) + [-1.0], "chain.radii"),
        ("missing.npy", "chain.radii"),
    ],
)
def test_bad_radii_are_one_clear_line(radii, key):
    with pytest.raises(SceneError) as err:
        scene_from_dict({"chain": {"grains": GRAINS, "radii": radii}, "integrator": {"duration": 1.0}})
    assert err.value.key == key and "\n" not in str(err.value)


SEED_SWEEP = """
[scene.chain]
grains = 12
l0 = 1e-4
radii = { spread = 0.3, seed = 0 }

[scene.excitation]
impact = 1e-2

[scene.integrator]
dt = 5e-4
duration = 0.5

[scene.record]
every = 0.25

[[axis]]
name = "seed"
key = "chain.radii.seed"
values = [0, 1, 2, 3, 4, 5]

[[axis]]
name = "taper"
key = "chain.radii.taper"
values = [0.0, 0.1]
"""


def _sweep_counting_scenes(tmp_path, monkeypatch, text: str, name: str):
    """Run a sweep file on the CPU; return the store's path and how many Scene objects were built."""
    from hertzian.core import scene as scene_module

    path = tmp_path / f"{name}.toml"
    path.write_text(text)
    built = []
    monkeypatch.setattr(scene_module.Scene, "__post_init__", lambda s: built.append(1) or scene_module._validate(s))
    result = invoke("sweep", str(path), "--out", str(tmp_path / f"{name}.zarr"), "--device", "cpu")
    assert result.exit_code == 0, result.stderr + result.stdout
    monkeypatch.undo()
    return tmp_path / f"{name}.zarr", len(built)


def test_a_seed_sweep_stores_radius_and_mass_and_each_point_reruns_alone(tmp_path, monkeypatch):
    import xarray as xr
    from hertzian.sweeping.spec import load_sweep

    seeds = SEED_SWEEP.split('[[axis]]\nname = "taper"')[0]
    out, built = _sweep_counting_scenes(tmp_path, monkeypatch, seeds, "six")
    _, built_more = _sweep_counting_scenes(
        tmp_path, monkeypatch, seeds.replace("[0, 1, 2, 3, 4, 5]", str(list(range(60)))), "sixty"
    )
    assert built_more == built  # the points run as per-chain arrays, not one scene each
    ds = xr.open_zarr(out)
    assert ds.radius.dims == ("seed", "grain") and ds.mass.dims == ("seed", "grain")
    sweep = load_sweep(tmp_path / "six.toml")
    for k, seed in enumerate(ds.seed.values.tolist()):
        scene = sweep.scene_at((k,))
        np.testing.assert_array_equal(ds.radius.values[k], radii_of({"spread": 0.3, "seed": seed}))
        np.testing.assert_array_equal(ds.mass.values[k], static_state(scene).mass)
        alone = run_scene(scene, device="cpu")
        np.testing.assert_array_equal(ds.u.values[k], alone.u[0])
    assert not np.array_equal(ds.radius.values[0], ds.radius.values[1])


def test_a_taper_sweep_stores_radius(tmp_path, monkeypatch):
    import xarray as xr

    taper = SEED_SWEEP.replace("{ spread = 0.3, seed = 0 }", "{ taper = 0.0 }").split("[[axis]]")
    out, _ = _sweep_counting_scenes(tmp_path, monkeypatch, taper[0] + "[[axis]]" + taper[2], "taper")
    radius = xr.open_zarr(out).radius.values
    np.testing.assert_array_equal(radius[0], np.full(GRAINS, R0))
    np.testing.assert_allclose(radius[1], radii_of({"taper": 0.1}), rtol=1e-15)


def test_uniform_sweeps_store_no_grain_variables(tmp_path):
    import xarray as xr

    path = tmp_path / "plain.toml"
    path.write_text(
        SEED_SWEEP.replace("radii = { spread = 0.3, seed = 0 }\n", "").split("[[axis]]")[0]
        + '[[axis]]\nname = "speed"\nkey = "excitation.impact"\nvalues = [1e-2, 2e-2]\n'
    )
    result = invoke("sweep", str(path), "--out", str(tmp_path / "p.zarr"), "--device", "cpu")
    assert result.exit_code == 0, result.stderr + result.stdout
    assert "radius" not in xr.open_zarr(tmp_path / "p.zarr")


def _synthetic_store(lengths, grains: int = 20):
    """A store whose every point's leading pulse decays as exp(−z/λ) exactly (λ per seed), reaching grain z at
    record z."""
    import xarray as xr

    z = np.arange(grains)
    v = np.zeros((len(lengths), grains, grains))
    for s, length in enumerate(lengths):
        v[s, z, z] = np.exp(-z / length)
    return xr.Dataset(
        {"v": (("seed", "record", "grain"), v)}, coords={"seed": np.arange(len(lengths)), "t": ("record", 0.5 * z)}
    )


def test_statistics_over_seeds_match_closed_forms():
    from hertzian.studies.realisations import statistics

    lengths = np.array([4.0, 6.0, 9.0, 13.0])
    stats = statistics(_synthetic_store(lengths), "seed")
    np.testing.assert_allclose(stats["decay_length"]["mean"], lengths.mean(), rtol=1e-12)
    np.testing.assert_allclose(stats["decay_length"]["std"], lengths.std(ddof=1), rtol=1e-12)
    np.testing.assert_allclose(stats["decay_length"]["q50"], np.median(lengths), rtol=1e-12)
    bottom = 0.5 * np.exp(-2 * 19 / lengths)
    np.testing.assert_allclose(stats["bottom_energy"]["q95"], np.quantile(bottom, 0.95), rtol=1e-12)
    np.testing.assert_allclose(stats["bottom_fraction"]["mean"], bottom.mean() / 0.5, rtol=1e-12)
    np.testing.assert_allclose(stats["arrival_time"]["mean"], 0.5 * 19, rtol=1e-12)
    np.testing.assert_allclose(stats["leading_amplitude"]["mean"][5], np.exp(-5 / lengths).mean(), rtol=1e-12)


def test_summarize_over_seed_and_distribution_plot(tmp_path, monkeypatch):
    import json

    out, _ = _sweep_counting_scenes(tmp_path, monkeypatch, SEED_SWEEP.split('[[axis]]\nname = "taper"')[0], "s")
    result = invoke("summarize", str(out), "--over", "seed")
    assert result.exit_code == 0, result.stderr
    numbers = json.loads(result.stdout)
    assert numbers["realisations"] == 6 and numbers["observables"]["bottom_energy"]["count"] == 6
    bad = invoke("summarize", str(out), "--over", "sed")
    assert bad.exit_code == 2 and "sed" in bad.stderr and "Traceback" not in bad.stderr + bad.stdout
    png = tmp_path / "d.png"
    result = invoke("plot", str(out), "--figure", "distribution", "--of", "arrival_time", "--out", str(png))
    assert result.exit_code == 0 and png.stat().st_size > 0, result.stderr
    bad = invoke("plot", str(out), "--figure", "distribution", "--of", "nothing", "--out", str(png))
    assert bad.exit_code == 2 and "nothing" in bad.stderr


def test_scene_rebuilt_from_its_dict_keeps_an_impurity_grains_radius_scaling():
    """An impurity that sets only its contact constant keeps its grain's radius-scaled mass when the scene goes
    through ``to_dict`` (stores, overrides, a chain set's member): the chain's mass is not filled in for it."""
    scene = scene_from_dict(
        {
            "chain": {"grains": 12, "radii": {"taper": 0.05}},
            "impurities": [{"grains": [7], "a": 3000.0}],
            "excitation": {"impact": 0.01},
            "integrator": {"dt": 1e-4, "duration": 0.01},
        }
    )
    rebuilt = scene.with_overrides({})
    assert static_state(scene).mass[7] == pytest.approx((1 - 0.05) ** 21, rel=1e-12)  # m (R_7/R0)^3
    np.testing.assert_array_equal(static_state(rebuilt).mass, static_state(scene).mass)
    np.testing.assert_array_equal(static_state(rebuilt).contact_constant, static_state(scene).contact_constant)
