"""The peak force reaching the bottom (``hertzian.studies.realisations.bottom_peak_force``): against the Hertz
closed form of a sphere striking a rigid body, and against the force computed from the independent NumPy
reference's trajectory (tests/reference.py) for walls, a fixed bottom, loads, gravity and tapered radii."""

from __future__ import annotations

import json

import numpy as np
import pytest
import xarray as xr
from hertzian.core.runner import run_scene
from hertzian.studies.realisations import NotRecorded, bottom_peak_force, statistics
from hertzian.sweeping.spec import sweep_from_dict
from hertzian.sweeping.sweep_store import write_result

from tests.helpers import invoke, make_scene, run_store
from tests.reference import contact_constants, reference_run, static_overlaps

R0 = 50.0
"""Half the default diameter (100)."""
GRAINS = 10
REFERENCE_SWEEP = f"""
[scene.chain]
grains = {GRAINS}
l0 = 1e-4
gravity = 0.1
radii = {{ taper = 0.0 }}

[scene.excitation]
impact = 5e-2

[scene.integrator]
dt = 5e-4
duration = 1.5
events = "off"

[scene.record]
every = 0.075
fields = ["u", "v"]
traces = [{GRAINS - 2}, {GRAINS - 1}]

[[axis]]
name = "bottom"
key = "boundary.bottom"
values = ["wall", "fixed"]

[[axis]]
name = "taper"
key = "chain.radii.taper"
values = [0.0, 0.05]
"""
"""Loaded chains under gravity, wall or fixed bottom, equal or tapered grains, traced and snapshotted."""
REFERENCE_AGREEMENT = 1e-10
"""The kernels' agreement with the reference (tests/core/test_radii.py), relative."""


def _closed_form_store(tmp_path, trace_every: float):
    """Grain 0 (radius 0.8 R0) struck at v against grain 1 (1.2 R0) held fixed: a Hertz sphere hitting a rigid
    body. Returns (store, F_max, sampling bound [force]) with F_max from ½ m v² = a_c δ^n, F = n a_c δ^(n−1),
    and the bound ½ |F''| (h/2)², F'' = −(n − 1) F_max² / (m δ_max) at the peak (δ'' = −F/m)."""
    r, v, n, a = np.array([0.8, 1.2]), 0.1, 2.5, 5657.0
    scene = make_scene(
        chain={"grains": 2, "radii": (R0 * r).tolist()},
        boundary={"surface": "free", "bottom": "fixed"},
        excitation={"impact": v},
        integrator={"method": "gear5", "dt": 1e-4, "duration": 0.2},
        record={"every": 0.01, "fields": ["u"], "traces": [0, 1], "trace_every": trace_every},
    )
    mass, contact = r[0] ** 3, a * np.sqrt(2 * r[0] * r[1] / (r[0] + r[1]))
    deepest = (0.5 * mass * v * v / contact) ** (1 / n)
    peak = n * contact * deepest ** (n - 1)
    bound = 0.5 * (n - 1) * peak**2 / (mass * deepest) * (trace_every / 2) ** 2
    out = write_result(tmp_path / "impact.zarr", run_scene(scene, device="cpu"))
    return xr.open_zarr(out), peak, bound


def test_peak_force_of_a_sphere_striking_a_rigid_body_is_the_hertz_closed_form(tmp_path):
    ds, peak, bound = _closed_form_store(tmp_path, trace_every=1e-3)
    got = float(bottom_peak_force(ds))
    assert bound < 1e-3 * peak  # the check is tight
    assert peak - bound <= got <= peak * (1 + 1e-9), (got, peak, bound)


def _reference_force(scene, u: np.ndarray) -> float:
    """The largest force on the bottom grain from below, from the reference's constants, static overlaps and
    displacements ``u`` (time, grain)."""
    data = scene.to_dict()
    data["chain"]["radii"] = (R0 * (1 - scene.chain.radii.taper) ** np.arange(GRAINS)).tolist()
    _, inner, wall = contact_constants(data)
    _, inner_overlap, wall_overlap = static_overlaps(data)
    n = scene.chain.exponent
    if scene.boundary.bottom == "wall":
        constant, delta = wall, wall_overlap + u[:, -1]
    else:
        constant, delta = inner[-1], inner_overlap[-1] + u[:, -2] - u[:, -1]
    return float((n * constant * np.maximum(delta, 0.0) ** (n - 1)).max())


@pytest.fixture(scope="module")
def reference_store(tmp_path_factory):
    return xr.open_zarr(run_store(tmp_path_factory.mktemp("reference"), REFERENCE_SWEEP))


def test_peak_force_matches_the_reference_trajectory(reference_store):
    ds = reference_store
    data = json.loads(ds.attrs["sweep"])
    sweep = sweep_from_dict({k: data[k] for k in ("scene", "axis")})
    from_traces = bottom_peak_force(ds)
    from_snapshots = bottom_peak_force(ds.drop_vars(["trace_u", "trace_v"]))
    for index in np.ndindex(*sweep.shape):
        scene = sweep.scene_at(index)
        data = scene.to_dict()
        data["chain"]["radii"] = (R0 * (1 - scene.chain.radii.taper) ** np.arange(GRAINS)).tolist()
        ref = reference_run(data)
        static = _reference_force(scene, np.zeros((1, GRAINS)))
        for got, u in ((from_traces, ref["trace_u"]), (from_snapshots, ref["u"])):
            want = _reference_force(scene, u)
            assert want > 1.5 * static  # the pulse, not the static load, sets the peak
            assert abs(got[index] - want) <= REFERENCE_AGREEMENT * (want - static), (index, got[index], want)
        assert from_snapshots[index] < from_traces[index]  # snapshots under-sample the peak


def test_statistics_over_a_dimension_include_the_peak_force(reference_store):
    stats = statistics(reference_store, "taper")["bottom_peak_force"]
    values = bottom_peak_force(reference_store)
    np.testing.assert_array_equal(stats["count"], [2, 2])
    np.testing.assert_allclose(stats["mean"], values.mean(axis=1), rtol=1e-15)


def test_over_names_the_sweep_dimensions_only(reference_store):
    """Record, grain, trace and mode dimensions are not sweep dimensions; a single run has none."""
    axes = ", ".join(reference_store["status"].dims)
    with pytest.raises(
        ValueError, match=rf"^--over = 'record': not a sweep dimension of the store \(its sweep dimensions: {axes}\)$"
    ):
        statistics(reference_store, "record")
    single = reference_store.isel({d: 0 for d in reference_store["status"].dims})
    with pytest.raises(ValueError, match=r"\(a single run: no sweep dimensions\)$"):
        statistics(single, "grain")


def test_a_store_without_displacements_is_refused_in_one_line(tmp_path, reference_store):
    bare = reference_store.drop_vars(["trace_u", "trace_v", "u"])
    with pytest.raises(NotRecorded, match=r"^bottom_peak_force: the store records neither traces of grain\(s\) 9"):
        bottom_peak_force(bare)
    store = run_store(
        tmp_path,
        REFERENCE_SWEEP.replace('fields = ["u", "v"]', 'fields = ["v"]').replace(
            f"traces = [{GRAINS - 2}, {GRAINS - 1}]\n", ""
        ),
    )
    png = tmp_path / "f.png"
    result = invoke("plot", str(store), "--figure", "distribution", "--of", "bottom_peak_force", "--out", str(png))
    assert result.exit_code == 2 and not png.exists(), result.stdout
    assert result.stderr.strip().count("\n") == 0 and "record.fields must include u" in result.stderr
    result = invoke("summarize", str(store), "--over", "taper")
    assert result.exit_code == 0 and "bottom_peak_force" not in result.stdout, result.stderr


TAPER_40 = """
[scene.chain]
grains = 40
radii = {{ taper = 0.0 }}
[scene.boundary]
bottom = "wall"
[scene.excitation]
impact = 0.1
[scene.integrator]
method = "gear5"
dt = {dt}
duration = 3.0
events = "off"
[scene.record]
every = 0.02
fields = ["v"]
traces = [39]
trace_every = {dt}
[[axis]]
name = "taper"
key = "chain.radii.taper"
values = [0.0, 0.04]
"""


def test_the_bottom_energy_is_read_from_the_bottom_grains_trace_and_survives_halving_dt(tmp_path):
    """The bottom grain's pulse is short (at q = 0.04 its smallest grains touch for a few steps' time): its largest
    kinetic energy comes from its trace, sampled every step, not from the snapshots every 0.02."""
    from hertzian.studies.realisations import observables

    fractions = []
    for dt in (5e-5, 2.5e-5):
        out = run_store(tmp_path, TAPER_40.format(dt=dt), "--quiet", name=f"taper_{dt}.zarr")
        with xr.open_zarr(out) as ds:
            found = observables(ds)
            mass, trace, v = ds.mass.values, np.abs(ds.trace_v.values[..., 0]), np.abs(ds.v.values)
        injected = 0.5 * mass[:, 0] * 0.1**2
        from_trace = 0.5 * mass[:, -1] * (trace**2).max(axis=-1) / injected
        from_snapshots = 0.5 * mass[:, -1] * (v[:, :, -1] ** 2).max(axis=-1) / injected
        np.testing.assert_array_equal(found["bottom_fraction"], from_trace)
        assert np.all(from_trace >= from_snapshots)  # the snapshots' times are among the trace's samples
        fractions.append(from_trace)
    np.testing.assert_allclose(fractions[0], fractions[1], rtol=1e-4)
