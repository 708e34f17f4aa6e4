"""Bad input is refused up front: exit code 2, one line naming key, value and what is allowed, nothing
written, no traceback.

Includes a property-based fuzz test (hypothesis) over scene and sweep files: random keys set to random
values (wrong types, non-finite and extreme numbers, unknown keys, broken TOML).
"""

from __future__ import annotations

import math
import time

import numpy as np
import pytest
from hertzian.core.runner import run_scene
from hertzian.core.scene import MAX_STEPS, SceneError, load_scene
from hertzian.sweeping.spec import MAX_POINTS, load_sweep, sweep_scenes
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from tests.helpers import assert_refused, invoke, make_scene, toml_text

BASE = {
    "chain": {"grains": 8, "l0": 1e-4},
    "excitation": {"impact": 1e-2},
    "integrator": {"duration": 0.01, "dt": 2.5e-4},
    "record": {"every": 0.005},
}


# ---- refused up front, before any run ---------------------------------------------------------------

REFUSED = [
    ("chain.grains=1000000000000", "chain.grains = 1000000000000: the run needs"),
    ("integrator.duration=1e12", "integrator.duration = 1000000000000.0: needs 4e+15 steps"),
    ("record.every=1e-9", "record.every = 1e-09: must be ≥ integrator.dt"),
    ("record.trace_every=1e-9", "record.trace_every = 1e-09: must be ≥ integrator.dt"),
    (
        "record.trace_every=0.000375",
        "record.trace_every = 0.000375: must be a whole number of steps of integrator.dt = 0.00025 (here 1.5;",
    ),
    ("record.trace_every=0.0006", "record.trace_every = 0.0006: must be a whole number of steps"),
    ("chain.l0=nan", "chain.l0 = nan: must be a finite number"),
    ("excitation.impact=inf", "excitation.impact = inf: must be a finite number"),
    ("excitation.impact=1e200", "excitation.impact = 1e+200: too large"),
    ("integrator.dt=1e-320", "integrator.duration = 0.01: needs inf steps"),
    ("record.every=0.0001", "record.every = 0.0001: must be ≥ integrator.dt"),
    ("=5", "--set = '=5': must be written key=value"),
    (" =5", "--set = ' =5': must be written key=value"),
]


@pytest.mark.parametrize("override, message", REFUSED)
def test_run_refuses_up_front(tmp_path, override, message):
    scene = tmp_path / "s.toml"
    scene.write_text(toml_text({**BASE, "record": {"every": 0.005, "traces": [0]}}))
    out = tmp_path / "out.zarr"
    started = time.perf_counter()
    result = invoke("run", scene, "--out", out, "--device", "cpu", "--set", override)
    assert time.perf_counter() - started < 1.0
    assert_refused(result, out, message)


EXTREME = [
    ({"integrator": {"duration": 0.01, "tolerance": 1e-30}}, "integrator.tolerance = 1e-30: must be a relative error"),
    ({"chain": {"grains": 8, "radii": [1e-300] * 8}}, "chain.radii = 1e-300: gives a radius of 2e-302 R0"),
    ({"record": {"every": 0.005, "fields": ["u", "u"]}}, "record.fields = ['u', 'u']: fields must not repeat"),
]


@pytest.mark.parametrize("change, message", EXTREME)
def test_extreme_values_are_refused_up_front(tmp_path, change, message):
    data = {section: {**BASE.get(section, {}), **values} for section, values in {**BASE, **change}.items()}
    if "tolerance" in data["integrator"]:
        del data["integrator"]["dt"]
    scene = tmp_path / "s.toml"
    scene.write_text(toml_text(data))
    out = tmp_path / "out.zarr"
    assert_refused(invoke("run", scene, "--out", out, "--device", "cpu"), out, message)


def test_step_counter_limit_is_the_int32_clock():
    just = make_scene(integrator={"duration": MAX_STEPS * 1e-3, "dt": 1e-3})
    assert just.step_count == MAX_STEPS
    with pytest.raises(SceneError, match="int32"):
        make_scene(integrator={"duration": (MAX_STEPS + 1) * 1e-3, "dt": 1e-3})


def test_sweep_size_is_refused_before_expanding(tmp_path):
    sweep = tmp_path / "big.toml"
    out = tmp_path / "big.zarr"
    sweep.write_text(
        toml_text({"scene": BASE}) + '\n[[axis]]\nname = "v_imp"\nkey = "excitation.impact"\n'
        "linspace = [1e-3, 1e-2, 1e10]\n"
    )
    started = time.perf_counter()
    assert_refused(invoke("sweep", sweep, "--out", out, "--device", "cpu"), out, "axis[0].linspace = 10000000000")
    # three axes of 10^3: 10^9 points, each axis small; counted from the axis lengths
    axes = "".join(
        f'\n[[axis]]\nname = "a{k}"\nkey = "{key}"\nlinspace = [1.0, 2.0, 1000]\n'
        for k, key in enumerate(("chain.mass", "chain.a", "chain.diameter"))
    )
    sweep.write_text(toml_text({"scene": BASE}) + axes)
    assert_refused(
        invoke("sweep", sweep, "--out", out, "--device", "cpu"),
        out,
        f"sweep points = 1000000000: more than {MAX_POINTS}",
    )
    assert time.perf_counter() - started < 2.0
    assert load_sweep(sweep, max_points=None).point_count == 10**9  # --allow-large lets it through


def test_kernel_option(tmp_path):
    scene = tmp_path / "s.toml"
    scene.write_text(toml_text(BASE))
    out = tmp_path / "out.zarr"
    assert_refused(invoke("run", scene, "--out", out, "--kernel", "fastest"), out, "--kernel = 'fastest'")
    driven = [
        "--set",
        "boundary.surface=driven",
        "--set",
        "excitation.impact=0",
        "--set",
        "excitation.drive_amplitude=1e-3",
    ]
    # a drive runs on the chain kernel (bitwise equality: tests/kernels/test_fused_features.py)
    driven_out = tmp_path / "driven.zarr"
    done = invoke("run", scene, "--out", driven_out, "--device", "cpu", "--kernel", "chain", "--quiet", *driven)
    assert done.exit_code == 0 and "(chain kernel)" in done.stdout, done.output
    done = invoke("run", scene, "--out", out, "--device", "cpu", "--kernel", "chain", "--quiet")
    assert done.exit_code == 0 and "(chain kernel)" in done.stdout, done.output


# ---- fuzzing ---------------------------------------------------------------------------------------------

SCENE_KEYS = [f"chain.{k}" for k in ("grains", "mass", "a", "exponent", "diameter", "l0", "load", "gravity")] + [
    "boundary.surface",
    "boundary.bottom",
    "excitation.impact",
    "excitation.drive_amplitude",
    "excitation.drive_period",
    "integrator.duration",
    "integrator.method",
    "integrator.dt",
    "integrator.precision",
    "record.every",
    "record.fields",
    "record.traces",
    "record.trace_every",
    "record.energy",
    "chain.grain",
    "record.evry",
    "nosuch.key",
    "impurities",
]

BAD_NUMBERS = st.sampled_from(
    [math.nan, math.inf, -math.inf, 0.0, -1.0, 1e-320, 1e308, -1e308, 1e12, 2**63 - 1, -(2**63)]
)
VALUES = st.one_of(
    BAD_NUMBERS,
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(min_value=-(2**63), max_value=2**63 - 1),
    st.booleans(),
    st.text(max_size=8),
    st.lists(st.one_of(BAD_NUMBERS, st.integers(-5, 50)), max_size=3),
    st.just({"x": 1}),
    st.just([{"grains": [1], "mass": -1.0}]),
)


def set_key(data: dict, dotted: str, value) -> None:
    section, _, key = dotted.partition(".")
    if not key:
        data[section] = value
    elif isinstance(data.get(section), dict):
        data[section][key] = value
    else:
        data[section] = {key: value}


def refused_in_process(load) -> bool:
    """Whether the library refuses the file (a SceneError); any other exception fails the test."""
    try:
        load()
    except SceneError as err:
        event(f"refused: {err.key.split('[')[0].split('.')[0]}")
        return True
    event("valid")
    return False


FUZZ = settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])


@FUZZ
@given(
    edits=st.lists(st.tuples(st.sampled_from(SCENE_KEYS), VALUES), min_size=1, max_size=3),
    broken=st.sampled_from([False, False, False, True]),
)
def test_fuzzed_scene_files_are_refused_cleanly(tmp_path, edits, broken):
    data = {k: dict(v) for k, v in BASE.items()}
    for key, value in edits:
        set_key(data, key, value)
    try:
        text = toml_text(data)
    except TypeError:
        return
    if broken:
        text = text.replace("]", "", 1) if "]" in text else text + "= oops\n"
    scene = tmp_path / "fuzz.toml"
    scene.write_text(text)
    out = tmp_path / "fuzz.zarr"

    def load():
        from hertzian.core.check import memory_refusal

        loaded = load_scene(scene)
        if memory_refusal(loaded):
            raise SceneError("memory", None, "refused")

    if not refused_in_process(load):
        return  # a valid scene (the fuzzer found one): nothing to refuse
    assert_refused(invoke("run", scene, "--out", out, "--device", "cpu"), out)
    assert_refused(invoke("check", scene), out)


AXIS_EDITS = st.fixed_dictionaries(
    {},
    optional={
        "name": st.one_of(st.sampled_from(["v", "t", "1x", "", "u"]), VALUES),
        "key": st.one_of(st.sampled_from(SCENE_KEYS + ["impurities.0.mass", "impurities.5.a"]), VALUES),
        "values": st.one_of(st.lists(VALUES, max_size=3), VALUES),
        "linspace": st.one_of(st.lists(st.one_of(BAD_NUMBERS, st.floats(0, 2)), min_size=0, max_size=4), VALUES),
        "logspace": st.lists(st.one_of(BAD_NUMBERS, st.integers(-3, 12)), min_size=3, max_size=3),
        "step": VALUES,
    },
)


@FUZZ
@given(
    axes=st.lists(AXIS_EDITS, min_size=1, max_size=3),
    zipped=st.one_of(st.none(), st.lists(st.sampled_from(["v", "w", "a0", "a1"]), max_size=3)),
    scene_edit=st.one_of(st.none(), st.tuples(st.sampled_from(SCENE_KEYS), VALUES)),
)
def test_fuzzed_sweep_files_are_refused_cleanly(tmp_path, axes, zipped, scene_edit):
    base = {k: dict(v) for k, v in BASE.items()}
    if scene_edit is not None:
        set_key(base, *scene_edit)
    data = {"scene": base, "axis": axes}
    if zipped is not None:
        data["zip"] = [{"axes": zipped}]
    try:
        text = toml_text(data)
    except TypeError:
        return
    path = tmp_path / "fuzz.toml"
    path.write_text(text)
    out = tmp_path / "fuzz.zarr"
    if not refused_in_process(lambda: sweep_scenes(load_sweep(path))):
        return
    assert_refused(invoke("sweep", path, "--out", out, "--device", "cpu"), out)


def test_sweep_points_with_different_record_times_are_refused(tmp_path):
    """dt = 1e-3 records at 0.01, 0.02, …; dt = 3e-3 at the nearest steps 0.009, 0.021, …: one store
    cannot hold both, so the sweep is refused before anything is written."""
    text = (
        toml_text({"scene": {**BASE, "integrator": {"duration": 0.1, "dt": 1e-3}, "record": {"every": 0.01}}})
        + '\n[[axis]]\nname = "step"\nkey = "integrator.dt"\nvalues = [1e-3, 3e-3]\n'
    )
    path = tmp_path / "sweep.toml"
    path.write_text(text)
    out = tmp_path / "sweep.zarr"
    assert_refused(invoke("sweep", path, "--out", out, "--device", "cpu"), out, "record times")


def test_check_takes_precision(tmp_path):
    scene = tmp_path / "s.toml"
    scene.write_text(toml_text(BASE))
    shown = invoke("check", scene, "--precision", "float32")
    assert shown.exit_code == 0 and "(gear4, float32)" in shown.stdout, shown.output
    assert_refused(
        invoke("check", scene, "--precision", "float16"), tmp_path / "none", "integrator.precision = 'float16'"
    )


def test_chain_kernel_option(tmp_path):
    text = toml_text({"scene": BASE}) + '\n[[axis]]\nname = "v_imp"\nkey = "excitation.impact"\nvalues = [1e-2, 2e-2]\n'
    path = tmp_path / "sweep.toml"
    path.write_text(text)
    out = tmp_path / "sweep.zarr"
    # traces run on the chain kernel too
    done = invoke(
        "sweep", path, "--out", out, "--device", "cpu", "--kernel", "chain", "--quiet", "--set", "record.traces=[0]"
    )
    assert done.exit_code == 0, done.output
    import xarray as xr

    alone = run_scene(load_sweep(path).scene_at((1,)), "cpu")  # per-step kernel: the same bits
    np.testing.assert_array_equal(xr.open_zarr(out).u.sel(v_imp=2e-2).values, alone.u[0])


def test_a_chain_too_short_for_windows_is_told_the_shortest_that_fits(tmp_path):
    """--kernel window on a short chain names the shortest chain that takes windows here, and that one does."""
    from hertzian.core.model import build_model
    from hertzian.core.solvers.calibrate import kind_configs

    scene = tmp_path / "s.toml"
    scene.write_text(toml_text(BASE))
    out = tmp_path / "out.zarr"
    result = invoke("run", scene, "--out", out, "--device", "cpu", "--kernel", "window")
    assert_refused(result, out, "--kernel = 'window': no launch shape fits 8 grains (windows need at least ")
    shortest = int(result.stderr.split("windows need at least ")[1].split()[0])
    too_short, long_enough = (
        make_scene(**{**BASE, "chain": {"grains": n, "l0": 1e-4}}) for n in (shortest - 1, shortest)
    )
    with pytest.raises(ValueError, match="windows need at least"):
        kind_configs(build_model([too_short], "cpu"), "window")
    assert kind_configs(build_model([long_enough], "cpu"), "window")
