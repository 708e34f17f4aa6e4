"""Sweeps of what the vectorised chain sets do not build (a lattice law, a modal or thermal start, mode records):
each point runs as a scene of its own, and equals that scene run alone, bit for bit (docs/lattices.md §3)."""

from __future__ import annotations

import numpy as np
import pytest
from hertzian import load_scene, open_store, run

from tests.helpers import invoke, toml_text

FPUT = {
    "chain": {"grains": 12, "potential": "fput", "a": 1.0, "alpha": 0.0, "beta": 1.0},
    "excitation": {"thermal": 0.1, "thermal_modes": [1, 3], "seed": 0},
    "integrator": {"method": "yoshida6", "dt": 0.05, "duration": 10.0},
    "record": {"every": 2.5, "modes": True},
}
"""A β-FPUT chain between walls, thermal phases in modes 1–3, its mode energies recorded."""

LAWS = {
    "chain": {"grains": 10, "a": 1.0},
    "excitation": {"impact": 0.2},
    "integrator": {"method": "gear5", "dt": 0.01, "duration": 3.0, "events": "off"},
    "record": {"every": 1.0},
}
"""An impact on 10 grains; the law is the sweep's axis."""


def _swept(tmp_path, base: dict, axes: list[dict], *options) -> object:
    path = tmp_path / "sweep.toml"
    path.write_text(toml_text({"scene": base, "axis": axes}))
    out = tmp_path / "out.zarr"
    result = invoke("sweep", path, "--out", out, "--device", "cpu", *options)
    assert result.exit_code == 0, (result.stdout, result.stderr, result.exception)
    verified = invoke("verify", out)
    assert verified.exit_code == 0 and "0 damaged" in verified.stdout, verified.stdout
    return open_store(out)


def _with(base: dict, **keys) -> dict:
    data = {section: dict(values) for section, values in base.items()}
    for key, value in keys.items():
        section, name = key.split("__")
        data[section][name] = value
    return data


def _assert_point_equals_its_run(point, scene: dict, names: list[str]) -> None:
    alone = run(load_scene(scene), device="cpu").to_xarray()
    for name in names:
        np.testing.assert_array_equal(point[name].values, alone[name].values.squeeze(), err_msg=name)


def test_thermal_fput_sweep_equals_each_realisation_run_alone(tmp_path):
    """Energy density × seed of thermal β-FPUT chains with mode records, in batches of 2: every point's positions,
    energy, mode energies, entropy and participation equal its own run's."""
    axes = [
        {"name": "eps", "key": "excitation.thermal", "values": [0.05, 0.2]},
        {"name": "realisation", "key": "excitation.seed", "values": [0, 1, 2]},
    ]
    store = _swept(tmp_path, FPUT, axes, "--batch-size", "2")
    assert store.sizes["mode"] == 12
    names = ["u", "v", "energy", "mode_energy", "spectral_entropy", "participation"]
    for eps in (0.05, 0.2):
        for seed in (0, 1, 2):
            point = store.sel(eps=eps, realisation=seed)
            _assert_point_equals_its_run(point, _with(FPUT, excitation__thermal=eps, excitation__seed=seed), names)
    # different seeds are different realisations
    assert not np.array_equal(store.u.sel(eps=0.2, realisation=0).values, store.u.sel(eps=0.2, realisation=1).values)


@pytest.mark.parametrize("laws", [["hertz", "harmonic", "toda"]])
def test_a_sweep_over_the_law_equals_each_law_run_alone(tmp_path, laws):
    """An axis over chain.potential joins a Hertz launch group (chain sets) and lattice ones (a scene per point)."""
    axes = [
        {"name": "law", "key": "chain.potential", "values": laws},
        {"name": "v_imp", "key": "excitation.impact", "values": [0.1, 0.2]},
    ]
    store = _swept(tmp_path, LAWS, axes)
    assert len(np.unique(store.launch_group.values)) == len(laws)
    for law in laws:
        for v in (0.1, 0.2):
            scene = _with(LAWS, chain__potential=law, excitation__impact=v)
            _assert_point_equals_its_run(store.sel(law=law, v_imp=v), scene, ["u", "v", "energy"])
