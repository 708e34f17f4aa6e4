"""Bead materials (hertzian.core.materials): masses and Hertz constants from E, ν and ρ in SI, converted to program
units; checked against the NumPy reference (which computes them in SI itself), against closed forms, and the
vectorised chain-set path against the per-scene one, bit for bit."""

from __future__ import annotations

import math

import numpy as np
import pytest
import xarray as xr
from hertzian.core.chains import ChainSet
from hertzian.core.materials import MATERIALS, PRESSURE_PA
from hertzian.core.model import build_model, features_of, prepare_model
from hertzian.core.runner import run_scene
from hertzian.core.scene import SceneError, scene_from_dict
from hertzian.core.static import static_arrays, static_state

from tests.helpers import hertzian, make_scene
from tests.reference import reference_run

HARD = {"E": 193e9, "nu": 0.3, "rho": 8000.0}
SOFT = {"E": 1.46e9, "nu": 0.46, "rho": 2200.0}
MIDDLE = {"E": 110e9, "nu": 0.35, "rho": 8500.0}
TABLE = {"hard": HARD, "soft": SOFT, "middle": MIDDLE}
GRAINS = 12
MOVING = 1e-2

CASES = {
    "hard-soft dimer, hard walls": (
        dict(chain={"material": ["hard", "soft"]}, boundary={"wall_material": "hard"}, excitation={"impact": 1e-2}),
        0.8,
    ),
    "three materials, radii pattern, gravity, free surface, own walls": (
        dict(
            chain={"material": ["soft", "middle", "hard"], "radii": {"pattern": [1.0, 0.7]}, "gravity": 1.0},
            boundary={"surface": "free"},
            excitation={"impact": 5e-2},
        ),
        0.45,
    ),
    "soft chain under a load, fixed bottom": (
        dict(
            chain={"material": "soft", "load": 10.0},
            boundary={"surface": "load", "bottom": "fixed"},
            excitation={"impact": 1e-2},
        ),
        0.2,
    ),
}


def build(sections: dict, duration: float, dt: float = 2e-5):
    sections = {k: dict(v) for k, v in sections.items()}
    sections["chain"]["grains"] = GRAINS
    sections["materials"] = TABLE
    sections["integrator"] = {"dt": dt, "duration": duration, "events": "off"}
    sections["record"] = {"every": duration / 20, "traces": [0, GRAINS - 2, GRAINS - 1]}
    return make_scene(**sections)


def _radii(scene) -> list[float]:
    ratios = scene.chain.radius_ratios
    return (0.5 * scene.chain.diameter * (np.ones(scene.chain.grains) if ratios is None else ratios)).tolist()


@pytest.mark.parametrize("case", list(CASES))
def test_materials_match_the_reference_over_a_round_trip(case):
    scene = build(*CASES[case])
    data = scene.to_dict()
    data["chain"]["radii"] = _radii(scene)  # the reference reads radii as a list
    ref = reference_run(data)
    speed = np.abs(ref["trace_v"])
    arrival = ref["trace_t"][np.argmax(speed[:, -2] > MOVING * speed.max())]
    assert 0 < arrival and scene.integrator.duration >= 2.2 * arrival, arrival  # there and back
    result = run_scene(scene, device="cpu")
    for name in ("u", "v"):
        got, want = getattr(result, name)[0], ref[name]
        scale = np.abs(want).max(axis=0)
        assert np.all(np.abs(got - want) <= 1e-10 * scale), name


def test_two_steel_beads_have_the_closed_form_mass_and_constant():
    """1 mm stainless-steel beads (the shipped values): m = ρ (4/3) π R³, a = (8/15) E* √(R/2),
    E* = E / (2 (1 − ν²)); against a flat steel wall a = (8/15) E* √R."""
    scene = make_scene(chain={"grains": 4, "material": "stainless_steel"}, excitation={"impact": 1e-2})
    steel = MATERIALS["stainless_steel"]
    radius_m = 0.5e-3
    mass = steel.density * 4 / 3 * math.pi * radius_m**3 / 2.36e-5
    e_star = steel.youngs_modulus / (2 * (1 - steel.poisson_ratio**2)) / PRESSURE_PA
    st = static_state(scene)
    np.testing.assert_allclose(st.mass, mass, rtol=1e-14)
    np.testing.assert_allclose(st.contact_constant[1:-1], 8 / 15 * e_star * math.sqrt(25.0), rtol=1e-14)
    np.testing.assert_allclose(st.contact_constant[[0, -1]], 8 / 15 * e_star * math.sqrt(50.0), rtol=1e-14)
    assert math.isclose(PRESSURE_PA, 2.36e-5 / (1e-5 * 1.0102e-3**2), rel_tol=1e-15)


def test_an_aluminium_glass_dimer_has_the_cited_values_and_the_unlike_bead_law():
    """The shipped aluminium (6061-T6) and soda-lime glass carry their cards' SI values (FreeCAD's standard material
    library); between them a = (8/15) E* √R* with 1/E* = (1 − ν_Al²)/E_Al + (1 − ν_g²)/E_g, and a glass wall."""
    cards = {"aluminium": (69e9, 0.33, 2700.0), "glass": (72e9, 0.22, 2520.0)}
    for name, (e, nu, rho) in cards.items():
        got = MATERIALS[name]
        assert (got.youngs_modulus, got.poisson_ratio, got.density) == (e, nu, rho), name
        assert "FreeCAD" in got.source, name
    scene = make_scene(
        chain={"grains": 4, "material": ["aluminium", "glass"]},
        boundary={"wall_material": "glass"},
        excitation={"impact": 1e-2},
    )
    radius = 0.5e-3 / 1e-5  # program lengths
    compliance = {k: (1 - nu**2) / (e / PRESSURE_PA) for k, (e, nu, _) in cards.items()}
    mass = {k: rho * 4 / 3 * math.pi * 0.5e-3**3 / 2.36e-5 for k, (_, _, rho) in cards.items()}
    st = static_state(scene)
    np.testing.assert_allclose(st.mass, [mass["aluminium"], mass["glass"]] * 2, rtol=1e-14)
    inner = 8 / 15 * math.sqrt(radius / 2) / (compliance["aluminium"] + compliance["glass"])
    np.testing.assert_allclose(st.contact_constant[1:-1], inner, rtol=1e-14)
    top = 8 / 15 * math.sqrt(radius) / (compliance["aluminium"] + compliance["glass"])
    bottom = 8 / 15 * math.sqrt(radius) / (2 * compliance["glass"])
    np.testing.assert_allclose(st.contact_constant[[0, -1]], [top, bottom], rtol=1e-14)


def test_a_chain_set_of_diameters_equals_its_scenes_bit_for_bit():
    base = build(CASES["three materials, radii pattern, gravity, free surface, own walls"][0], 0.1)
    chains = ChainSet.of(base, {"chain.diameter": [100.0, 60.0, 140.0]}, 3)
    arrays = static_arrays(chains)
    prepared = prepare_model(chains)
    assert prepared.features == features_of(list(chains)) and prepared.features.heterogeneous
    per_scene = build_model(list(chains), "cpu")
    for name in ("inverse_mass", "contact_constant", "static_overlap"):
        np.testing.assert_array_equal(prepared.arrays[name], getattr(per_scene, name).numpy(), err_msg=name)
    for c in range(len(chains)):
        st = static_state(chains[c])
        for name in ("mass", "contact_constant", "static_overlap"):
            np.testing.assert_array_equal(getattr(arrays, name)[c], getattr(st, name), err_msg=name)
    assert arrays.mass[2, 0] / arrays.mass[1, 0] == pytest.approx((140 / 60) ** 3, rel=1e-14)


def test_a_run_stores_each_grains_material_radius_and_mass(tmp_path):
    path = tmp_path / "scene.toml"
    path.write_text(
        '[chain]\ngrains = 6\nmaterial = ["stainless_steel", "ptfe", "glassy"]\n'
        "[materials.glassy]\nE = 63e9\nnu = 0.2\nrho = 2500.0\n"
        "[excitation]\nimpact = 1e-2\n[integrator]\ndt = 1e-5\nduration = 0.01\n"
    )
    run = hertzian("run", path, "--device", "cpu", "--out", tmp_path / "o.zarr", "--quiet")
    assert run.returncode == 0, run.stderr
    ds = xr.open_zarr(tmp_path / "o.zarr")
    names = ds.material.attrs["flag_meanings"].split()
    assert [names[i] for i in ds.material.values] == ["stainless_steel", "ptfe", "glassy"] * 2
    scene = scene_from_dict(
        {
            "chain": {"grains": 6, "material": ["stainless_steel", "ptfe", "glassy"]},
            "materials": {"glassy": {"E": 63e9, "nu": 0.2, "rho": 2500.0}},
            "integrator": {"duration": 0.01},
        }
    )
    np.testing.assert_array_equal(ds.mass.values, static_state(scene).mass)
    np.testing.assert_array_equal(ds.radius.values, np.full(6, 50.0))


@pytest.mark.parametrize(
    "data, key",
    [
        ({"chain": {"material": "steel"}}, "chain.material"),
        ({"chain": {"material": "ptfe", "mass": 2.0}}, "chain.mass"),
        ({"chain": {"material": "ptfe", "l0": 1e-4}}, "chain.l0"),
        ({"chain": {"material": "ptfe", "exponent": 2.0}}, "chain.exponent"),
        ({"chain": {"material": ["ptfe"] * 11}}, "chain.material"),
        ({"boundary": {"wall_material": "ptfe"}}, "boundary.wall_material"),
        ({"chain": {"material": "x"}, "materials": {"x": {"E": 1e9, "nu": 0.6, "rho": 1000.0}}}, "materials.x.nu"),
        ({"chain": {"material": "x"}, "materials": {"x": {"E": 1e9, "rho": 1000.0}}}, "materials.x.nu"),
        ({"materials": {"ptfe": {"E": 1e9, "nu": 0.3, "rho": 1000.0}}}, "materials.ptfe"),
        ({"chain": {"material": "ptfe"}, "impurities": [{"grains": [1], "mass": 2.0}]}, "impurities"),
    ],
)
def test_bad_materials_are_one_clear_line(data, key):
    data = {**data, "chain": {"grains": 10, **data.get("chain", {})}, "integrator": {"duration": 0.01}}
    with pytest.raises(SceneError) as err:
        scene_from_dict(data)
    assert str(err.value).startswith(f"{key} = ") and "\n" not in str(err.value), str(err.value)


def test_a_scene_without_materials_keeps_its_plain_data():
    """Scenes of the paper's grains serialise as before: no material keys, ``mass`` and ``a`` kept."""
    plain = make_scene(chain={"grains": 10}).to_dict()
    assert "materials" not in plain and "material" not in plain["chain"] and "wall_material" not in plain["boundary"]
    assert plain["chain"]["mass"] == 1.0 and plain["chain"]["a"] == 5657.0
    with_materials = build(CASES["hard-soft dimer, hard walls"][0], 0.1)
    again = scene_from_dict(with_materials.to_dict())
    assert again == with_materials


SWEEP = """
[scene.chain]
grains = 12
material = "stainless_steel"
[scene.boundary]
wall_material = "ptfe"
[scene.excitation]
impact = 1e-2
[scene.integrator]
dt = 2e-5
duration = 0.05
[scene.record]
every = 0.01

[[axis]]
name = "{name}"
key = "chain.material"
values = ["stainless_steel", "ptfe"]

[[axis]]
name = "size"
key = "chain.diameter"
values = [100.0, 200.0]
"""


def test_a_sweep_over_materials_and_sizes_equals_each_chain_run_alone(tmp_path):
    sweep = tmp_path / "sweep.toml"
    sweep.write_text(SWEEP.format(name="bead"))
    done = hertzian("sweep", sweep, "--out", tmp_path / "s.zarr", "--device", "cpu", "--quiet")
    assert done.returncode == 0, done.stderr
    ds = xr.open_zarr(tmp_path / "s.zarr")
    for i, material in enumerate(("stainless_steel", "ptfe")):
        for j, diameter in enumerate((100.0, 200.0)):
            scene = make_scene(
                chain={"grains": 12, "material": material, "diameter": diameter},
                boundary={"wall_material": "ptfe"},
                excitation={"impact": 1e-2},
                integrator={"dt": 2e-5, "duration": 0.05},
                record={"every": 0.01},
            )
            alone = run_scene(scene, device="cpu")
            np.testing.assert_array_equal(ds.u.values[i, j], alone.u[0])
            np.testing.assert_array_equal(ds.mass.values[i, j], static_state(scene).mass)


def test_an_axis_named_like_a_store_variable_is_refused_in_one_line(tmp_path):
    sweep = tmp_path / "sweep.toml"
    sweep.write_text(SWEEP.format(name="material"))
    refused = hertzian("sweep", sweep, "--out", tmp_path / "s.zarr", "--device", "cpu")
    assert refused.returncode == 2 and refused.stderr.count("\n") == 1, refused.stderr
    assert "material" in refused.stderr and not (tmp_path / "s.zarr").exists()
