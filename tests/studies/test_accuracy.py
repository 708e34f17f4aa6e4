"""`hertzian accuracy`: the study machinery (record interval, Richardson estimate, error norm) against closed
forms, and a small study against the known orders of the methods. Also: every run reports its energy error
next to its run time (store and summarize)."""

import json
import time
from fractions import Fraction

import numpy as np
import pytest
from hertzian.core.runner import run_scene
from hertzian.core.scene import SceneError
from hertzian.studies.accuracy import common_record_interval, relative_error, richardson_estimate, work_precision
from hertzian.sweeping.store import summary_records
from hertzian.sweeping.sweep_store import write_result

from tests.helpers import assert_refused, hertzian, invoke, make_scene, slope


def test_record_interval_is_a_common_multiple():
    dts = [1.6e-3, 8e-4, 2.5e-5, 6.25e-6]
    every = common_record_interval(dts, 20.0)
    for dt in dts:
        assert Fraction(repr(every)) / Fraction(repr(dt)) == round(every / dt)
    assert 20.0 / every == round(20.0 / every)  # divides the duration when it can
    assert common_record_interval([1e-4, 5e-5], 1.0, preferred=0.3) == 0.3
    assert common_record_interval([1e-4, 3e-5], 1.0, preferred=0.25) != 0.25  # 3e-5 does not divide 0.25
    with pytest.raises(SceneError, match="no common multiple"):
        common_record_interval([3e-3, 7e-3], 0.01)


def test_relative_error_helper():
    ref = np.array([[0.0, 2.0], [-4.0, 1.0]])
    assert relative_error(ref, ref) == 0.0
    assert relative_error(ref + [[0.0, 0.0], [0.4, 0.0]], ref) == pytest.approx(0.1)
    assert relative_error(np.where(ref > 1, np.nan, ref), ref) == np.inf
    with pytest.raises(ValueError):
        relative_error(ref[:1], ref)


@pytest.mark.parametrize("order", [2.0, 4.0, 6.0])
def test_richardson_estimate_recovers_a_known_error(order):
    """u_h = exact + C h^p g: the estimate from h, 2h, 4h equals the true error of u_h, and p is observed."""
    rng = np.random.default_rng(1)
    exact = rng.normal(size=(5, 7))
    shape = rng.normal(size=(5, 7))
    h = 1e-2
    runs = [exact + 3.0 * (f * h) ** order * shape for f in (1, 2, 4)]
    estimate, observed = richardson_estimate(*runs)
    assert observed == pytest.approx(order, abs=1e-6)
    assert estimate == pytest.approx(relative_error(runs[0], exact), rel=1e-3)
    # round-off: differences stop shrinking, the estimate falls back to the difference itself
    noise = [exact + 1e-14 * rng.normal(size=exact.shape) for _ in range(3)]
    estimate, _ = richardson_estimate(*noise)
    assert estimate == pytest.approx(relative_error(noise[1], noise[0]), rel=1e-12)


def smooth_scene():
    """A strongly precompressed chain: no contact opens, the force is smooth, methods show their order."""
    return make_scene(
        chain={"grains": 20, "l0": 1e-2},
        excitation={"impact": 1e-4},
        integrator={"dt": 1e-3, "duration": 1.0},
        record={"every": 0.25},
    )


def test_small_study_shows_the_orders():
    dts = [2e-3, 1e-3, 5e-4]
    started = time.perf_counter()
    records, reference, every = work_precision(
        smooth_scene(), ["gear4", "verlet"], dts, ["float64", "float32"], device="cpu"
    )
    elapsed = time.perf_counter() - started
    assert every == 0.25
    assert len(records) == 2 * 2 * 3
    by = {(r.method, r.precision, r.dt): r for r in records}
    for method, order in (("gear4", 4.0), ("verlet", 2.0)):
        errors = [by[method, "float64", dt].error for dt in dts]
        assert abs(slope(dts, errors) - order) < 0.3, (method, errors)
        assert min(errors) > 100 * reference.error_estimate  # the reference resolves them
    assert not any(r.reference_limited for r in records if r.precision == "float64")
    assert 4 < reference.observed_order < 7
    for r in records:
        assert r.status == 0 and np.isfinite(r.error) and r.energy_error < 1e-2
        # timed by the study itself, so each run's seconds lie within the wall time of the whole study
        assert 0 < r.seconds < elapsed and r.grain_steps_per_second > 20 * r.steps / elapsed
        assert r.steps == round(1.0 / r.dt)
    # float32 cannot beat its own rounding: at the finest step gear4 float32 is worse than float64
    assert by["gear4", "float32", 5e-4].error > 10 * by["gear4", "float64", 5e-4].error


def test_run_reports_energy_error_next_to_wall_seconds(tmp_path):
    """Store and summarize carry the energy error (docs/model.md §5, recomputed here from the stored energy) and seconds."""
    scene = make_scene(
        chain={"grains": 10, "l0": 1e-4},
        excitation={"impact": 1e-2},
        integrator={"dt": 2e-4, "duration": 0.2},
        record={"every": 0.02},
    )
    result = run_scene(scene, "cpu")
    write_result(tmp_path / "r.zarr", result)
    [record] = summary_records(tmp_path / "r.zarr")
    import xarray as xr

    ds = xr.open_zarr(tmp_path / "r.zarr")
    energy = ds.energy.values
    expected = np.max(np.abs(energy - energy[0])) / (0.5 * 1.0 * 1e-2**2)
    assert record["energy_error"] == pytest.approx(expected, rel=1e-12)
    assert float(ds.energy_error) == pytest.approx(expected, rel=1e-12)
    assert record["wall_seconds"] == pytest.approx(result.wall_seconds) and result.wall_seconds > 0
    assert record["status_name"] == "OK"


def test_cli_accuracy(tmp_path):
    scene = tmp_path / "s.toml"
    scene.write_text("[chain]\ngrains = 10\nl0 = 1e-4\n[excitation]\nimpact = 1e-2\n[integrator]\nduration = 0.1\n")
    out = hertzian(
        "accuracy",
        str(scene),
        "--methods",
        "gear4,verlet",
        "--dt",
        "4e-4,2e-4",
        "--precision",
        "both",
        "--json",
        "--plot",
        str(tmp_path / "wp.png"),
        "--device",
        "cpu",
        cwd=tmp_path,
    )
    assert out.returncode == 0, out.stderr
    records = json.loads(out.stdout)
    assert {(r["method"], r["precision"]) for r in records} == {
        (m, p) for m in ("gear4", "verlet") for p in ("float64", "float32")
    }
    for r in records:
        assert {
            "method",
            "dt",
            "precision",
            "error",
            "energy_error",
            "seconds",
            "grain_steps_per_second",
            "reference_error",
        } <= set(r)
    assert (tmp_path / "wp.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    table = hertzian(
        "accuracy", str(scene), "--methods", "gear5,yoshida4", "--dt", "2e-4", "--device", "cpu", cwd=tmp_path
    )
    assert table.returncode == 0 and "reference: gear6" in table.stdout, table.stderr
    assert "gear5" in table.stdout and "yoshida4" in table.stdout


@pytest.mark.parametrize(
    "args, message",
    [
        (["--methods", "gear7"], "error: --methods = 'gear7': allowed: gear4, gear5, gear6, verlet"),
        (["--dt", "abc"], "error: --dt = 'abc': must be a number"),
        (["--dt", "-1e-4"], "error: --dt = '-1e-4': must be > 0"),
        (["--dt", "3e-2,7e-2"], "no common multiple"),
        (["--precision", "float16"], "error: --precision = 'float16'"),
    ],
)
def test_cli_accuracy_bad_input(tmp_path, args, message):
    scene = tmp_path / "s.toml"
    scene.write_text("[chain]\ngrains = 4\n[excitation]\nimpact = 1e-2\n[integrator]\nduration = 0.1\n")
    out = hertzian("accuracy", str(scene), *args, "--plot", str(tmp_path / "p.png"), cwd=tmp_path)
    assert out.returncode == 2
    error_lines = [line for line in out.stderr.splitlines() if line.startswith("error:")]
    assert len(error_lines) == 1 and message in error_lines[0], out.stderr
    assert "Traceback" not in out.stderr and not (tmp_path / "p.png").exists()


# --- time to accuracy: `hertzian accuracy --target` ------------------------------------------------------------

TARGET_SCENE = "[chain]\ngrains = 20\nl0 = 1e-4\n[excitation]\nimpact = 1e-2\n[integrator]\nduration = 0.5\n"
TARGETS = (1e-6, 1e-8, 1e-30)


def largest_meeting(records, method, precision, target, key):
    """The selection written out independently: the largest dt whose run ended OK with ``key`` ≤ target."""
    best = None
    for r in records:
        if r["method"] == method and r["precision"] == precision and r["status"] == 0 and r[key] <= target:
            if best is None or r["dt"] > best["dt"]:
                best = r
    return best


def test_cli_accuracy_target_picks_the_largest_dt_meeting_it(tmp_path):

    scene = tmp_path / "s.toml"
    scene.write_text(TARGET_SCENE)
    out = invoke(
        "accuracy",
        scene,
        "--methods",
        "gear4,verlet",
        "--dt",
        "4e-4,2e-4,1e-4",
        "--precision",
        "both",
        "--target",
        "1e-6,1e-8",
        "--target",
        "1e-30",
        "--json",
        "--quiet",
        "--device",
        "cpu",
    )
    assert out.exit_code == 0, out.output
    data = json.loads(out.stdout)
    records, targets = data["records"], data["targets"]
    groups = {(r["method"], r["precision"]) for r in records}
    assert len(records) == 12 and len(groups) == 4
    assert len(targets) == len(TARGETS) * len(groups)
    by = {(t["target"], t["method"], t["precision"]): t for t in targets}
    chosen = []
    for target in TARGETS:
        for method, precision in groups:
            row = by[target, method, precision]
            assert row["measure"] == "energy"
            best = largest_meeting(records, method, precision, target, "energy_error")
            if best is None:
                assert row["dt"] is None and row["seconds"] is None
            else:
                assert (row["dt"], row["seconds"], row["error"], row["energy_error"]) == (
                    best["dt"],
                    best["seconds"],
                    best["error"],
                    best["energy_error"],
                )
                chosen.append(row["dt"])
        # ranked by the run's own seconds, rows that meet nothing last
        rows = [t for t in targets if t["target"] == target]
        seconds = [t["seconds"] for t in rows if t["seconds"] is not None]
        assert seconds == sorted(seconds)
        assert [t["seconds"] is None for t in rows] == sorted(t["seconds"] is None for t in rows)
    # the case discriminates: at 1e-6 some group meets it only at a smaller dt, another at several dts
    assert 4e-4 in chosen and min(chosen) < 4e-4
    assert any(
        len([r for r in records if r["method"] == m and r["precision"] == p and r["energy_error"] <= 1e-6]) > 1
        for m, p in groups
    )
    # no run reaches 1e-30: "none" for every method and precision
    assert all(by[1e-30, m, p]["dt"] is None for m, p in groups)

    # the position error as the measure, on the same records
    from hertzian.studies.accuracy import AccuracyRecord, time_to_target

    runs = [
        AccuracyRecord(**{k: v for k, v in r.items() if not k.startswith("reference_") or k == "reference_limited"})
        for r in records
    ]
    for row in time_to_target(runs, [1e-6, 1e-9], "error"):
        best = largest_meeting(records, row.method, row.precision, row.target, "error")
        assert row.dt == (best["dt"] if best else None) and row.measure == "error"


def test_time_to_target_skips_failed_runs():
    """A run that did not end OK (or is not finite) never meets a target, however small its numbers."""
    from hertzian.studies.accuracy import AccuracyRecord, time_to_target

    def record(dt, energy_error, status=0):
        return AccuracyRecord(
            method="gear4",
            dt=dt,
            precision="float64",
            error=1e-9,
            energy_error=energy_error,
            seconds=1.0 / dt,
            grain_steps_per_second=1.0,
            steps=1,
            steps_per_contact_time=1.0,
            status=status,
            status_name="X",
            reference_limited=False,
        )

    runs = [record(4e-4, 0.0, status=1), record(2e-4, float("nan")), record(1e-4, 5e-7), record(5e-5, 1e-9)]
    [row] = time_to_target(runs, [1e-6])
    assert (row.dt, row.seconds) == (1e-4, 1e4)


@pytest.mark.parametrize(
    "args, key",
    [
        (["--target", "0"], "--target = '0'"),
        (["--target", "-1e-6"], "--target = '-1e-6'"),
        (["--target", "1e-6,nan"], "--target = 'nan'"),
        (["--target", "inf"], "--target = 'inf'"),
        (["--target", "abc"], "--target = 'abc'"),
        (["--target", ","], "--target = ','"),
        (["--target", "1e-6", "--measure", "position"], "--measure = 'position': allowed: energy, error"),
    ],
)
def test_cli_accuracy_target_refusals(tmp_path, args, key):

    scene = tmp_path / "s.toml"
    scene.write_text(TARGET_SCENE)
    plot = tmp_path / "p.png"
    result = invoke("accuracy", scene, *args, "--plot", plot, "--device", "cpu")
    assert_refused(result, plot, key)


RING = """
[chain]
grains = 16
potential = "harmonic"
a = 1.0
mass = 1.0

[boundary]
surface = "periodic"
bottom = "periodic"

[excitation]
modes = [3]
mode_energy = 0.01

[integrator]
method = "verlet"
dt = 0.05
duration = 20.0
"""


def test_default_steps_are_the_scenes_and_show_the_orders(tmp_path):
    """Without --dt a study takes twice, once and half the scene's dt. On a harmonic ring (ω ≤ 2, dt = 0.05) the
    errors then fall at verlet's order 2 and yoshida4's 4 (closed forms). The paper chain's steps (2e-4 … 5e-5,
    and a reference at 1.25e-5) would take 10⁶ steps here, their errors buried in round-off."""
    ring = tmp_path / "ring.toml"
    ring.write_text(RING)
    out = hertzian("accuracy", ring, "--methods", "verlet,yoshida4", "--json", "--device", "cpu", cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    records = json.loads(out.stdout)
    for method, order in (("verlet", 2.0), ("yoshida4", 4.0)):
        rows = sorted((r for r in records if r["method"] == method), key=lambda r: r["dt"])
        assert [r["dt"] for r in rows] == [0.025, 0.05, 0.1]
        assert abs(slope([r["dt"] for r in rows], [r["error"] for r in rows]) - order) < 0.2, (method, rows)
    tolerance = tmp_path / "tolerance.toml"
    tolerance.write_text(RING.replace("dt = 0.05", "tolerance = 1e-6").replace('"verlet"', '"auto"'))
    refused = hertzian("accuracy", tolerance, "--device", "cpu", cwd=tmp_path)
    assert refused.returncode == 2 and refused.stderr.startswith("error: --dt = None: required for a scene run to")
    given = hertzian("accuracy", tolerance, "--methods", "verlet", "--dt", "0.1,0.05", "--device", "cpu", cwd=tmp_path)
    assert given.returncode == 0 and "verlet" in given.stdout, given.stderr


def test_a_study_is_written_into_its_record_with_its_command(tmp_path):
    """python -m hertzian.studies.accuracy: every run of the study under parts.NAME with the command that made it;
    a second part leaves the first in place. The errors are those hertzian accuracy --json prints."""
    from hertzian.studies.accuracy import main

    out = tmp_path / "record.json"
    args = ["--out", str(out), "--set", "chain.grains=12", "--set", "integrator.duration=0.2", "--methods", "verlet"]
    main([*args, "--part", "a", "--dt", "2e-4,1e-4", "--target", "1,1e-300"])
    main([*args, "--part", "b", "--dt", "2e-4", "--precision", "both"])
    parts = json.loads(out.read_text())["parts"]
    assert [len(parts["a"]["records"]), len(parts["b"]["records"])] == [2, 2]
    assert parts["a"]["overrides"] == ["chain.grains=12", "integrator.duration=0.2"]
    command = f"python -m hertzian.studies.accuracy --out {out} --set chain.grains=12 --set integrator.duration=0.2"
    assert parts["a"]["command"] == f"{command} --methods verlet --part a --dt 2e-4,1e-4 --target 1,1e-300"
    assert parts["a"]["device"] == "cpu"
    printed = hertzian(
        "accuracy",
        "--set",
        "chain.grains=12",
        "--set",
        "integrator.duration=0.2",
        "--methods",
        "verlet",
        "--dt",
        "2e-4,1e-4",
        "--target",
        "1,1e-300",
        "--json",
        "--device",
        "cpu",
        cwd=tmp_path,
    )
    assert printed.returncode == 0, printed.stderr
    study = json.loads(printed.stdout)
    for mine, theirs in zip(parts["a"]["records"], study["records"], strict=True):
        assert (mine["dt"], mine["error"], mine["energy_error"]) == (
            theirs["dt"],
            theirs["error"],
            theirs["energy_error"],
        )
    keys = ("target", "method", "dt", "energy_error")
    assert [[t[k] for k in keys] for t in parts["a"]["targets"]] == [[t[k] for k in keys] for t in study["targets"]]
    assert [t["dt"] for t in parts["a"]["targets"]] == [2e-4, None] and "targets" not in parts["b"]
    mine = tmp_path / "mine.json"
    mine.write_text('{"my": 1}')
    with pytest.raises(SceneError, match="hertzian did not write it"):
        main(["--out", str(mine), "--part", "a", "--dt", "2e-4"])
    assert mine.read_text() == '{"my": 1}'


def test_energy_errors_across_a_key_are_those_of_each_chain_run_alone(tmp_path):
    """--across KEY=V1,V2: per configuration, the energy error at each value (one ensemble), equal to the same
    chain's run on its own; the values keep their order."""
    from hertzian.core.model import build_model
    from hertzian.core.runner import Runner
    from hertzian.core.scene import load_scene, parse_overrides
    from hertzian.core.shipped import example_path
    from hertzian.studies.accuracy import main

    out = tmp_path / "record.json"
    sets = ["chain.grains=16", "integrator.duration=0.5"]
    main(
        ["--out", str(out), "--part", "p", *(f"--set={s}" for s in sets), "--methods", "gear4,verlet"]
        + ["--dt", "2e-3,1e-3", "--events", "off", "--across", "excitation.impact=0.02,0.01,0.03"]
    )
    part = json.loads(out.read_text())["parts"]["p"]
    assert part["key"] == "excitation.impact" and part["values"] == [0.02, 0.01, 0.03] and len(part["rows"]) == 4
    scene = load_scene(example_path("impact"), parse_overrides(sets))
    for row in part["rows"]:
        for value, energy_error in zip(part["values"], row["energy_errors"], strict=True):
            alone = scene.with_overrides(
                {"integrator.method": row["method"], "integrator.dt": row["dt"], "integrator.events": "off"}
                | {"excitation.impact": value, "record.fields": [], "record.traces": [], "record.trace_every": None}
            )
            result = Runner(build_model([alone], "cpu"), kernel=row["kernel"]).run()
            assert float(result.energy_error[0]) == energy_error, (row["method"], row["dt"], value)
            assert energy_error > 0
