"""The static state of chains that share configurations, solved once per configuration and gathered per chain
only where read (hertzian.core.static.SharedStatic), gives the bits of gathering every field at once (the
function kept here) and of each chain's own ``static_state``; ``prepare_model``'s arrays, derived on the
configurations before the gather, equal the per-scene ``build_model``'s byte for byte; the per-configuration
opening bound gives each scene's own ``contact_can_open``.

The sets mix gravity, precompression or a load, impurities (a mass and a contact constant) and random radii.
"""

from __future__ import annotations

import numpy as np
import pytest
from hertzian.core.chains import ChainSet
from hertzian.core.model import build_model, chains_can_open, contact_can_open, prepare_model
from hertzian.core.scene import scene_from_dict
from hertzian.core.startup import initial_nordsieck_of
from hertzian.core.static import (
    FIELDS,
    SharedStatic,
    StaticArrays,
    _static_arrays,
    distinct_static_rows,
    static_arrays,
    static_state,
)

BASE = {
    "chain": {"grains": 10, "l0": 1e-4, "gravity": 0.5, "radii": {"spread": 0.2, "seed": 3}},
    # both values given: a scene rebuilt from its dict (ChainSet[i]) fills an unset impurity value with the
    # chain's, which loses the radius scaling of that grain
    "impurities": [{"grains": [4], "mass": 2.0, "a": 4000.0}, {"grains": [7, 8], "mass": 0.8, "a": 0.5}],
    "excitation": {"impact": 1e-2},
    "integrator": {"method": "gear5", "dt": 2e-4, "duration": 0.02, "events": "auto"},
    "record": {"every": 0.01, "fields": ["u"]},
}


def gathered_at_once(chains, grains=None) -> StaticArrays:
    """static_arrays as it was before fields were gathered on reading: every field gathered at once."""
    shared = distinct_static_rows(chains) if len(chains) > 1 else None
    if shared is None:
        return _static_arrays(chains, grains)
    first, inverse = shared
    one = _static_arrays(chains.take(first), grains)
    return StaticArrays(
        **{name: None if getattr(one, name) is None else getattr(one, name)[inverse] for name in FIELDS}
    )


def chain_sets() -> dict[str, ChainSet]:
    """Sets of 24 chains: 4 impact speeds (not read by the static state) × 6 static configurations."""
    template = scene_from_dict(BASE)
    impact = np.repeat([1e-4, 1e-3, 1e-2, 1e-1], 6)
    tile = lambda values: np.tile(values, 4)  # noqa: E731
    return {
        "l0, gravity, impurities": ChainSet.of(
            template,
            {
                "excitation.impact": impact,
                "chain.l0": tile([0.0, 1e-5, 1e-3, 0.0, 1e-5, 1e-3]),
                "chain.gravity": tile([0.0, 0.0, 0.0, 0.5, 0.5, 2.0]),
                "impurities.0.mass": tile([2.0, 0.5, 2.0, 0.5, 2.0, 0.5]),
                "impurities.1.a": tile([0.5, 0.5, 3.0, 3.0, 0.5, 3.0]),
            },
            24,
        ),
        "load, radii": ChainSet.of(
            scene_from_dict({**BASE, "chain": {**BASE["chain"], "l0": 0.0, "load": 1e-3}}),
            {
                "excitation.impact": impact,
                "chain.load": tile([0.0, 1e-6, 1e-3, 0.0, 1e-6, 1e-3]),
                "chain.radii.seed": tile([3.0, 3.0, 3.0, 8.0, 8.0, 8.0]),
            },
            24,
        ),
    }


@pytest.mark.parametrize("name", list(chain_sets()))
def test_shared_fields_equal_every_field_gathered_and_each_scene(name):
    chains = chain_sets()[name]
    st, old = static_arrays(chains), gathered_at_once(chains)
    assert isinstance(st, SharedStatic) and len(st.configurations.mass) == 6
    for field in FIELDS:
        assert getattr(st, field).tobytes() == getattr(old, field).tobytes(), field
    for c in range(len(chains)):
        ref = static_state(chains[c])
        for field in ("mass", "self_constant", "contact_constant", "carried_force", "static_overlap"):
            assert getattr(st, field)[c].tobytes() == getattr(ref, field).tobytes(), (c, field)
    for grains in (3, 6):
        part, want = st.leading(grains), gathered_at_once(chains, grains)
        for field in FIELDS:
            assert getattr(part, field).tobytes() == getattr(want, field).tobytes(), (grains, field)


@pytest.mark.parametrize("name", list(chain_sets()))
def test_prepared_arrays_equal_the_per_scene_model_byte_for_byte(name):
    chains = chain_sets()[name]
    prepared = prepare_model(chains)
    per_scene = build_model(list(chains), "cpu")
    assert prepared.features == per_scene.features
    for array in (
        "inverse_mass",
        "contact_constant",
        "static_overlap",
        "law_parameters",
        "validity_overlap",
        "validity_scale",
    ):
        assert prepared.arrays[array].tobytes() == getattr(per_scene, array).numpy().tobytes(), array
    assert prepared.injected_energy.tobytes() == per_scene.injected_energy.tobytes()
    values, dt = prepared.features.nordsieck_values, chains.template.integrator.dt
    start = initial_nordsieck_of(chains, values, dt, gathered_at_once(chains), whole=False)
    assert prepared.start.tobytes() == np.ascontiguousarray(start).tobytes()


@pytest.mark.parametrize("name", list(chain_sets()))
def test_opening_bound_per_configuration_equals_each_scene(name):
    chains = chain_sets()[name]
    got = chains_can_open(chains, static_arrays(chains))
    want = np.array([contact_can_open(chains[c], static_state(chains[c])) for c in range(len(chains))])
    assert got.any() and not got.all()  # the bound decides both ways
    np.testing.assert_array_equal(got, want)
