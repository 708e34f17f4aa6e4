"""Vectorised sweep expansion (no scene per point) against the per-scene path, bit for bit.

The reference is the per-point path: ``sweep.scene_at`` for every point, then
``build_model(list_of_scenes)``, ``static_state`` and ``initial_nordsieck`` scene by scene. The
vectorised path is ``expand(sweep)`` → ``SweepPoints.chains(points)`` (a template scene and
per-chain arrays) → ``build_model(chain_set)``. Every model array, the initial Nordsieck vector,
the kernel features and the planner's launch groups must be equal, bytes and all.
"""

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from hertzian.core.chains import ChainSet
from hertzian.core.model import build_model, features_of
from hertzian.core.scene import SceneError, read_toml
from hertzian.core.startup import initial_nordsieck, initial_nordsieck_of
from hertzian.core.static import static_arrays, static_state
from hertzian.sweeping.planner import plan_sweep
from hertzian.sweeping.spec import Dimension, expand, load_sweep, sweep_from_dict, sweep_scenes
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from tests.helpers import SWEEPS

SWEEP_FILES = [p for p in sorted(SWEEPS.glob("*.toml")) if "design" not in read_toml(p)]
"""Every shipped sweep file (a design file, which holds a [design] table, is not one)."""

IMPACT_HOST = """
[scene.chain]
grains = 12
l0 = 1e-3
[[scene.impurities]]
grains = [5]
mass = 0.5
[scene.excitation]
impact = 1e-2
[scene.integrator]
method = "gear4"
dt = 1e-4
duration = 0.01
"""
"""A 12-grain chain held closed by l0 = 1e-3 below v_imp ≈ 0.02, with a light impurity (the impact cases)."""

INLINE = {
    # the planner takes an impact-only dimension at its fastest impact (only that one opens a contact
    # here: l0 = 1e-3 holds the contacts closed below v_imp ≈ 0.02), values not sorted; and a dimension
    # zipping the impact with l0, which is scanned at every index
    "impact_opens_only_at_the_fastest": IMPACT_HOST
    + """
[[axis]]
name = "v_imp"
key = "excitation.impact"
values = [1e-3, 0.1, 3e-3]
[[axis]]
name = "imp_mass"
key = "impurities.0.mass"
values = [0.5, 2.0]
""",
    "impact_never_opens": IMPACT_HOST
    + """
[[axis]]
name = "v_imp"
key = "excitation.impact"
values = [1e-3, 1e-2, 3e-3]
[[axis]]
name = "l0"
key = "chain.l0"
values = [1e-3, 3e-3]
""",
    "impact_zipped_with_l0": IMPACT_HOST
    + """
[[axis]]
name = "v_imp"
key = "excitation.impact"
values = [0.1, 1e-3]
[[axis]]
name = "l0"
key = "chain.l0"
values = [1e-2, 1e-6]
[[zip]]
axes = ["v_imp", "l0"]
""",
    # per-chain keys the sweep files do not vary, a load instead of l0, gravity with a free... wall top
    "load_mass_diameter": """
[scene.chain]
grains = 9
gravity = 0.5
[scene.boundary]
surface = "load"
bottom = "fixed"
[[scene.impurities]]
grains = [0, 4]
mass = 3.0
contact = "own"
[scene.excitation]
impact = 1e-2
[scene.integrator]
method = "gear6"
dt = 1e-4
duration = 0.01
[[axis]]
name = "load"
key = "chain.load"
values = [0.0, 10.0, 2.5]
[[axis]]
name = "mass"
key = "chain.mass"
values = [1.0, 0.25]
[[axis]]
name = "diameter"
key = "chain.diameter"
values = [100.0, 7.0]
[[axis]]
name = "imp_a"
key = "impurities.0.a"
values = [5657.0, 100.0]
[[axis]]
name = "method"
key = "integrator.method"
values = ["gear5", "gear4"]
""",
    # a driven surface in float32 with gravity: drive parameters per chain, a long chain (cut Taylor window)
    "driven_float32": """
[scene.chain]
grains = 30
gravity = 1.0
[scene.boundary]
surface = "driven"
bottom = "fixed"
[scene.excitation]
drive_amplitude = 1e-3
drive_period = 5.0
[scene.integrator]
method = "gear5"
precision = "float32"
dt = 1e-4
duration = 0.01
[[axis]]
name = "amplitude"
key = "excitation.drive_amplitude"
values = [1e-3, 3e-4]
[[axis]]
name = "period"
key = "excitation.drive_period"
values = [5.0, 0.7, 2.0]
""",
    # a zip of a structural and a per-chain key, exponents that differ per chain
    "zip_structural": """
[scene.chain]
grains = 7
l0 = 1e-4
[scene.excitation]
impact = 1e-3
[scene.integrator]
method = "gear5"
dt = 1e-4
duration = 0.01
[[axis]]
name = "grains"
key = "chain.grains"
values = [7, 7, 7]
[[axis]]
name = "exponent"
key = "chain.exponent"
values = [2.5, 3.0, 2.0]
[[axis]]
name = "v_imp"
key = "excitation.impact"
values = [0.0, 1e-2]
[[zip]]
axes = ["exponent", "grains"]
""",
}


def reduced(sweep, keep=3):
    """The sweep with at most ``keep`` values per dimension (first, middle, last; zips stay paired)."""
    dims = []
    for d in sweep.dimensions:
        picks = sorted({0, d.size // 2, d.size - 1})[:keep]
        dims.append(Dimension(axes=tuple(replace(a, values=tuple(a.values[i] for i in picks)) for a in d.axes)))
    return replace(sweep, dimensions=tuple(dims))


def cases():
    # sweep files only (a detection study file has a [study] table of its own: tests/studies/test_detection.py)
    out = [pytest.param(path, id=path.stem) for path in SWEEP_FILES if not path.stem.startswith("detect_study")]
    out += [pytest.param(name, id=name) for name in INLINE]
    return out


def load_case(case, tmp_path):
    if isinstance(case, Path):
        return reduced(load_sweep(case))
    path = tmp_path / f"{case}.toml"
    path.write_text(INLINE[case])
    return load_sweep(path)


def model_arrays(model):
    return {
        "inverse_mass": model.inverse_mass.numpy(),
        "contact_constant": model.contact_constant.numpy(),
        "static_overlap": model.static_overlap.numpy(),
        "law_parameters": model.law_parameters.numpy(),
        "drive": model.drive.numpy(),
        "trace_slot": model.trace_slot.numpy(),
        "validity_overlap": model.validity_overlap.numpy(),
        "validity_scale": model.validity_scale.numpy(),
        "injected_energy": model.injected_energy,
        "initial_nordsieck": model.initial_state().x.numpy(),
    }


def assert_bitwise(a: np.ndarray, b: np.ndarray, what: str):
    assert a.dtype == b.dtype and a.shape == b.shape, (what, a.dtype, b.dtype, a.shape, b.shape)
    assert a.tobytes() == b.tobytes(), f"{what}: differs (max |Δ| {np.max(np.abs(a - b)) if a.size else 0})"


@pytest.mark.parametrize("case", cases())
def test_vectorised_model_equals_per_scene_model_bitwise(case, tmp_path):
    sweep = load_case(case, tmp_path)
    expanded = expand(sweep)
    points = np.arange(sweep.point_count)
    templates = expanded.template_index(points)
    for template in np.unique(templates):
        members = points[templates == template]
        chains = expanded.chains(members)
        scenes = [
            sweep.scene_at(tuple(int(i) for i in np.unravel_index(p, sweep.shape))) if sweep.shape else sweep.base
            for p in members
        ]
        # the ChainSet's scenes are the sweep's scenes
        assert [chains[i] for i in range(len(chains))] == scenes
        # static state and Taylor start, chain by chain
        st = static_arrays(chains)
        for c, scene in enumerate(scenes):
            ref = static_state(scene)
            for name in ("mass", "self_constant", "contact_constant", "carried_force", "static_overlap"):
                assert_bitwise(getattr(st, name)[c], getattr(ref, name), f"{name} of chain {c}")
        # the static state of the first grains only is the leading columns of the whole one
        for window in (2, 5):
            part = static_arrays(chains, grains=window)
            for name in ("mass", "self_constant"):
                assert_bitwise(getattr(part, name), getattr(st, name)[:, :window], f"{name}[:{window}]")
            for name in ("contact_constant", "carried_force", "static_overlap"):
                assert_bitwise(getattr(part, name), getattr(st, name)[:, : window + 1], f"{name}[:{window + 1}]")
        for values in (3, 5, 6, 7):
            vec = initial_nordsieck_of(chains, values, scenes[0].integrator.dt)
            for c, scene in enumerate(scenes):
                assert_bitwise(
                    vec[:, c],
                    initial_nordsieck(scene, values, scene.integrator.dt),
                    f"Nordsieck ({values} values) of chain {c}",
                )
        # the whole model, with the features each path derives itself
        reference, vectorised = build_model(scenes, "cpu"), build_model(chains, "cpu")
        assert vectorised.features == reference.features == features_of(scenes)
        ref_arrays, vec_arrays = model_arrays(reference), model_arrays(vectorised)
        for name in ref_arrays:
            assert_bitwise(vec_arrays[name], ref_arrays[name], name)


@pytest.mark.parametrize("case", cases())
def test_planner_groups_and_features_equal_per_scene_features(case, tmp_path):
    sweep = load_case(case, tmp_path)
    expanded = expand(sweep)
    plan = plan_sweep(sweep, expanded, "cpu")
    scenes = [
        sweep.scene_at(tuple(int(i) for i in np.unravel_index(p, sweep.shape))) if sweep.shape else sweep.base
        for p in range(sweep.point_count)
    ]
    flat_groups = plan.point_group.reshape(-1)
    for g, group in enumerate(plan.groups):
        members = [s for s, pg in zip(scenes, flat_groups) if pg == g]
        assert group.point_count == len(members)
        assert group.features == features_of(members)
    # points with equal launch keys share a group, others do not
    keys = [
        tuple(get(s) for _, get in __import__("hertzian.core.model", fromlist=["SHARED_KEYS"]).SHARED_KEYS)
        for s in scenes
    ]
    for p in range(len(scenes)):
        for q in range(len(scenes)):
            assert (keys[p] == keys[q]) == (flat_groups[p] == flat_groups[q])


def test_chain_set_refuses_keys_that_are_not_per_chain(tmp_path):
    sweep = load_case("zip_structural", tmp_path)
    with pytest.raises(ValueError, match="not a per-chain key"):
        ChainSet.of(sweep.base, {"chain.grains": [7.0]}, 1)


def test_a_bad_value_inside_a_parameter_axis_is_refused_naming_the_point():
    data = {
        "scene": {"chain": {"grains": 5}, "integrator": {"duration": 0.01, "dt": 1e-4}},
        "axis": [
            {"name": "v_imp", "key": "excitation.impact", "values": [1e-3, -1.0, 1e-2]},
            {"name": "l0", "key": "chain.l0", "values": [0.0, 1e-4]},
        ],
    }
    with pytest.raises(SceneError, match=r"excitation.impact = -1.0.*at sweep point v_imp=-1.0"):
        expand(sweep_from_dict(data))


def test_zipped_axes_are_checked_at_each_axis_extremes_not_only_the_leading_ones():
    # the leading axis is fine everywhere; the companion exponent is ≤ 1 at point 1 only (same signs)
    data = {
        "scene": {"chain": {"grains": 5}, "integrator": {"duration": 0.01, "dt": 1e-4}},
        "axis": [
            {"name": "v_imp", "key": "excitation.impact", "values": [1e-3, 2e-3, 3e-3]},
            {"name": "exponent", "key": "chain.exponent", "values": [2.5, 1.0, 3.0]},
        ],
        "zip": [{"axes": ["v_imp", "exponent"]}],
    }
    with pytest.raises(SceneError, match=r"chain.exponent = 1.0.*at sweep point v_imp=0.002, exponent=1.0"):
        expand(sweep_from_dict(data))


# ---- validation by corners equals validation of every point --------------------------------------


PARAMETER_VALUES = {
    "chain.l0": [0.0, 1e-4, -1e-5, 2e-4],
    "chain.load": [0.0, 3.0, -1.0],
    "chain.gravity": [0.0, 0.5, -0.1],
    "chain.mass": [1.0, 0.5, 0.0, 2.0],
    "chain.exponent": [2.5, 1.5, 1.0, 3.0],
    "excitation.impact": [0.0, 1e-2, -1e-3, 5e-2],
    "excitation.drive_amplitude": [0.0, 1e-3, -1e-3],
    "excitation.drive_period": [5.0, 0.0, 2.0],
    "impurities.0.mass": [1.0, 0.0, 3.0],
}


@st.composite
def small_sweeps(draw):
    keys = draw(st.lists(st.sampled_from(sorted(PARAMETER_VALUES)), min_size=1, max_size=3, unique=True))
    size = draw(st.integers(1, 3))
    axes = []
    for k, key in enumerate(keys):
        values = draw(st.lists(st.sampled_from(PARAMETER_VALUES[key]), min_size=size, max_size=size))
        axes.append({"name": f"a{k}", "key": key, "values": values})
    zip_them = len(axes) > 1 and draw(st.booleans())
    if not zip_them:
        for axis in axes:  # a store dimension's values must not repeat
            axis["values"] = list(dict.fromkeys(axis["values"]))
    else:
        # the zip's first axis labels the dimension (distinct values); the others pair up with it
        axes.insert(0, {"name": "lead", "key": "chain.diameter", "values": [100.0 + i for i in range(size)]})
    surfaces = draw(st.lists(st.sampled_from(["wall", "free", "driven", "load"]), min_size=1, max_size=2, unique=True))
    axes.append({"name": "surface", "key": "boundary.surface", "values": surfaces})
    data = {
        "scene": {
            "chain": {"grains": 6},
            "impurities": [{"grains": [2], "mass": 1.0}],
            "excitation": {"drive_period": 5.0},
            "integrator": {"duration": 0.01, "dt": 1e-4},
        },
        "axis": axes,
    }
    if zip_them:
        data["zip"] = [{"axes": [a["name"] for a in axes[:-1]]}]
    return data


ZIP_WITH_A_BAD_MIDDLE = {
    "scene": {"chain": {"grains": 6}, "integrator": {"duration": 0.01, "dt": 1e-4}},
    "axis": [
        {"name": "lead", "key": "chain.diameter", "values": [100.0, 101.0, 102.0]},
        {"name": "a0", "key": "excitation.impact", "values": [0.0, -1e-3, 0.0]},
    ],
    "zip": [{"axes": ["lead", "a0"]}],
}


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(small_sweeps())
@example(ZIP_WITH_A_BAD_MIDDLE)
def test_validation_by_corners_refuses_exactly_the_grids_with_a_bad_point(data):
    try:
        sweep = sweep_from_dict(data)
    except SceneError:
        return  # refused while parsing (both paths share it)
    try:
        sweep_scenes(sweep)  # every point's scene
        every_point = None
    except SceneError as err:
        every_point = err
    try:
        expand(sweep)
        corners = None
    except SceneError as err:
        corners = err
    assert (every_point is None) == (corners is None), (data, every_point, corners)
