"""``hertzian reproduce``: stores, PNGs and a JSON log per figure group; --quick runs on the CPU."""

from __future__ import annotations

import json

import pytest
import xarray as xr
from hertzian.studies.reproduce import GROUPS, default_sweeps_dir, group_of

from tests.helpers import invoke


def test_every_group_has_its_sweep_file_and_figures_known_to_plot():
    from hertzian.plotting.figures import FIGURES

    for name, group in GROUPS.items():
        assert (default_sweeps_dir() / group.sweep).is_file(), name
        assert set(group.figures) <= set(FIGURES), name
    assert group_of("fig10") == "fig9_10" and group_of("fig5_single") == "fig5_single"


def test_paper_groups_take_plain_gear_steps_on_the_fused_kernels_of_a_gpu(monkeypatch):
    # the sweep files take the paper's integrator (plain Gear steps: event-aware ones change no reproduced number
    # beyond 5.2e-5, docs/reproduction.md); on a GPU such a group runs on the calibrated fused kernels, not on the
    # per-step kernel that auto's short-run rule would give it
    import types

    import warp as wp
    from hertzian.studies.reproduce import group_kernel
    from hertzian.sweeping.spec import expand, load_sweep

    for name, group in GROUPS.items():
        scene = expand(load_sweep(default_sweeps_dir() / group.sweep, {})).scene(0)
        assert scene.integrator.events == "off", name
    assert group_kernel("off", "cpu") == "auto" and group_kernel("auto", "cpu") == "auto"
    monkeypatch.setattr(wp, "get_device", lambda device=None: types.SimpleNamespace(is_cpu=False))
    assert group_kernel("off", "cuda") == "fused" and group_kernel("auto", "cuda") == "auto"


def test_quick_group_writes_store_png_and_log(tmp_path):
    out = tmp_path / "out"
    result = invoke("reproduce", "--quick", "--figure", "fig6", "--out-dir", str(out), "--device", "cpu")
    assert result.exit_code == 0, result.output
    log = json.loads((out / "log.json").read_text())
    assert log["quick"] and log["device"] == "cpu" and log["figure_failures"] == 0
    (run,) = log["runs"]
    assert run["name"] == "fig6" and run["figures"] == {"fig6": "fig6.png"}
    assert run["wall_seconds"] > 0 and run["grain_steps_per_second"] > 0
    assert run["grain_steps"] == run["points"] * run["grains"] * run["steps"]
    assert 0 < run["energy_error_max"] < 1e-6  # docs/model.md's bound for a gear4 run at this step
    assert run["status_counts"] == {"0": run["points"]}
    assert (out / "fig6.png").read_bytes()[:4] == b"\x89PNG"
    with xr.open_zarr(out / "fig6.zarr") as ds:
        assert ds.sizes["grain"] == GROUPS["fig6"].quick["chain.grains"]
        assert float(ds.energy_error.max()) == pytest.approx(run["energy_error_max"], rel=0, abs=0)


def test_the_measurement_record_of_groups_in_one_folder_or_one_folder_each(tmp_path):
    """``--json`` after a reproduction writes every group's measurements as the run measured them, and ``--measure
    groups`` finds the same in a folder per group (docs/records/reproduction/measurements.json's layout)."""
    flat, record = tmp_path / "flat", tmp_path / "measurements.json"
    args = ("--quick", "--figure", "fig6", "--figure", "fig3", "--device", "cpu")
    result = invoke("reproduce", *args, "--out-dir", str(flat), "--json", str(record))
    assert result.exit_code == 0, result.output
    found, log = json.loads(record.read_text()), json.loads((flat / "log.json").read_text())
    assert found["command"].startswith("hertzian ") and set(found["comparisons"]) == {"light_heavy_contrast_at_surface"}
    assert list(found["groups"]) == ["fig3", "fig6"]
    for run in log["runs"]:
        entry = found["groups"][run["name"]]
        assert entry["measurements"] == run["measurements"] and entry["figures"] == {
            figure: str(flat / png) for figure, png in run["figures"].items()
        }
        assert entry["run"]["command"] == log["command"] and entry["steps"] == run["steps"]
    for name in ("fig3", "fig6"):
        (tmp_path / "each" / name).mkdir(parents=True)
        (flat / f"{name}.zarr").rename(tmp_path / "each" / name / f"{name}.zarr")
        (tmp_path / "each" / name / "log.json").write_text(
            json.dumps(log | {"runs": [run for run in log["runs"] if run["name"] == name]})
        )
    again = tmp_path / "again.json"
    result = invoke("reproduce", "--measure", "groups", "--out-dir", str(tmp_path / "each"), "--json", str(again))
    assert result.exit_code == 0, result.output
    remeasured = json.loads(again.read_text())
    assert {n: g["measurements"] for n, g in remeasured["groups"].items()} == {
        n: g["measurements"] for n, g in found["groups"].items()
    }


def test_the_measurement_record_may_go_into_the_folder_the_run_makes(tmp_path):
    out = tmp_path / "new"
    result = invoke("reproduce", "--quick", "--figure", "fig6", "--out-dir", out, "--json", out / "m.json")
    assert result.exit_code == 0, result.output
    assert list(json.loads((out / "m.json").read_text())["groups"]) == ["fig6"]


def test_the_measurement_record_replaces_only_a_record(tmp_path):
    mine = tmp_path / "notes.json"
    mine.write_text('{"my": "notes"}')
    out = tmp_path / "out"
    result = invoke("reproduce", "--quick", "--figure", "fig6", "--out-dir", str(out), "--json", str(mine))
    assert result.exit_code == 2 and "--json = " in result.output and len(result.output.strip().splitlines()) == 1
    assert mine.read_text() == '{"my": "notes"}' and not out.exists()


def test_a_store_read_into_memory_measures_as_its_lazy_reading(tmp_path, monkeypatch):
    """The figures and measurements read a store once into memory (each read of a lazy array decompresses its chunks
    again); a store above the size limit stays lazy. Both give the same measurements."""
    from hertzian.studies import reproduce

    out = tmp_path / "out"
    result = invoke("reproduce", "--quick", "--figure", "fig7_8", "--out-dir", str(out), "--device", "cpu")
    assert result.exit_code == 0, result.output
    with reproduce.opened(out / "fig7_8.zarr") as loaded:
        assert loaded.u.chunks is None  # numpy, in memory
        in_memory = reproduce.measure("fig7_8", loaded)
    monkeypatch.setattr(reproduce, "IN_MEMORY_BYTES", 0)
    with reproduce.opened(out / "fig7_8.zarr") as lazy:
        assert lazy.u.chunks is not None
        assert json.dumps(reproduce.measure("fig7_8", lazy), default=str) == json.dumps(in_memory, default=str)


def test_kernel_option_and_the_split_of_each_runs_seconds(tmp_path):
    # --kernel step against --kernel fused (the CPU chain kernel): the option reaches the group's runs
    logs = {}
    for kernel in ("step", "fused"):
        out = tmp_path / kernel
        result = invoke(
            "reproduce", "--quick", "--figure", "fig6", "--kernel", kernel, "--out-dir", str(out), "--device", "cpu"
        )
        assert result.exit_code == 0, result.output
        logs[kernel] = json.loads((out / "log.json").read_text())
        assert f"--kernel {kernel}" in logs[kernel]["command"]
    (auto,), (fused,) = logs["step"]["runs"], logs["fused"]["runs"]
    assert auto["kernel"].startswith("step") and fused["kernel"] == "chain"
    assert fused["energy_error_max"] == pytest.approx(auto["energy_error_max"], rel=1e-6)
    for run in (auto, fused):
        assert set(run["seconds"]) == {"setup", "integrate", "finalize", "figures", "measure"}
        assert run["seconds"]["integrate"] == run["wall_seconds"]
        assert all(v >= 0 for v in run["seconds"].values())


def test_events_option_sets_every_group(tmp_path):
    # --events off: plain Gear steps in every group (the GPU's fast choice), recorded in the log and the store
    out = tmp_path / "off"
    result = invoke(
        "reproduce", "--quick", "--figure", "fig6", "--events", "off", "--out-dir", str(out), "--device", "cpu"
    )
    assert result.exit_code == 0, result.output
    log = json.loads((out / "log.json").read_text())
    assert log["events"] == "off" and "--events off" in log["command"]
    (run,) = log["runs"]
    assert run["events"] == "off"
    with xr.open_zarr(out / "fig6.zarr") as ds:
        assert json.loads(ds.attrs["sweep"])["scene"]["integrator"]["events"] == "off"


@pytest.mark.parametrize(
    "args,message",
    [
        (["--figure", "fig42"], "--figure = 'fig42': allowed:"),
        (["--events", "sometimes"], "--events = 'sometimes': auto or off"),
        (["--sweeps", "nowhere"], "--sweeps = 'nowhere': no paper_fig1.toml there"),
        (["--out-dir", "missing/deeper"], "--out-dir = 'missing/deeper': parent directory does not exist"),
        (["--kernel", "fastest"], "--kernel = 'fastest': one of auto, fused, step, tile, window, chain"),
        (["--kernel", "tile", "--device", "cpu"], "--kernel = 'tile': CUDA kernels; on --device cpu use"),
    ],
)
def test_reproduce_bad_input_is_one_line_exit_2(tmp_path, monkeypatch, args, message):
    monkeypatch.chdir(tmp_path)
    result = invoke("reproduce", "--quick", *args)
    assert result.exit_code == 2 and message in result.output and "Traceback" not in result.output
    assert list(tmp_path.iterdir()) == []


@pytest.mark.slow
def test_quick_reproduces_every_group_on_the_cpu(tmp_path):
    """The whole paper at --quick size (about 20 s on 2 CPU cores): every figure drawn, every run logged."""
    out = tmp_path / "all"
    result = invoke("reproduce", "--quick", "--out-dir", str(out), "--device", "cpu")
    assert result.exit_code == 0, result.output
    log = json.loads((out / "log.json").read_text())
    names = [r["name"] for r in log["runs"]]
    assert [n for n in names if not n.endswith("_dt_check")] == list(GROUPS)
    assert "sec6_lag_dt_check" in names  # the lag study's dt/2 rerun (the chaotic-drive rule)
    for run in log["runs"]:
        assert all(not str(v).startswith("failed") for v in run.get("figures", {}).values()), run
        assert run["energy_error_max"] < 1e-5, run  # driven columns: |E − E0 − W| / max|W| at dt = 1.25e-4
    assert sorted(p.name for p in out.glob("*.png")) == sorted(
        {f"{n}.png" for n, g in GROUPS.items() if len(g.figures) == 1} | {"fig9.png", "fig10.png"}
    )


def test_driven_windows_summed_on_the_device_equal_a_host_loop(device):
    """run_driven keeps its window sums, snapshots and energies on the device; a plain host loop (advance,
    copy v to the host, sum with NumPy) over the same marks gives the same numbers: bit for bit on the CPU, to
    rounding on CUDA (where the compiler may fuse ½ m v² + sum into one multiply-add)."""
    import contextlib

    import numpy as np
    from hertzian.core.model import build_model
    from hertzian.core.runner import Runner
    from hertzian.studies import analysis as an
    from hertzian.studies.reproduce import DRIVE_DT, drive_scenes, read_marks, run_driven

    path = default_sweeps_dir() / GROUPS["fig9_10"].sweep
    centres = np.array([1.0, 2.5, 4.0])  # overlapping edges: a step can sample two windows
    _, scenes = drive_scenes(path, 24, 5.0, DRIVE_DT)
    result = run_driven(scenes, device, centres, coarse_every=0.5)

    model = build_model(list(scenes), device)
    runner = Runner(model)
    marks, coarse_steps = read_marks(centres, model.dt, 0.5)
    chains, grains = model.chain_count, model.grain_count
    ke = np.zeros((chains, len(centres), grains))
    vs = np.zeros((chains, len(centres), grains))
    count = np.zeros(len(centres))
    centre = np.zeros((chains, len(centres), grains))
    coarse = np.zeros((chains, len(coarse_steps), grains), dtype=np.float32)
    energy = []
    step = 0
    for mark in sorted(marks):
        runner.advance(mark - step)
        step = mark
        with model.exact_start(runner.current) if step == 0 else contextlib.nullcontext():  # t = 0 as it is
            runner.recorder.check(runner.current, step)
            energy.append(runner.recorder.energy_now.numpy().copy())
            v = runner.current.x.numpy()[1] / model.dt
        for kind, index in marks[mark]:
            if kind == "sample":
                ke[:, index] += an.kinetic_energy(v)
                vs[:, index] += v
                count[index] += 1
            elif kind == "centre":
                centre[:, index] = v
            else:
                coarse[:, index] = v
    exact = 0 if device == "cpu" else 1e-14
    np.testing.assert_allclose(result["ke_window"], ke / count[None, :, None], rtol=exact, atol=0)
    np.testing.assert_allclose(result["v_window"], vs / count[None, :, None], rtol=exact, atol=0)
    np.testing.assert_array_equal(result["v_centre"], centre)
    np.testing.assert_array_equal(result["v_coarse"], coarse)
    np.testing.assert_array_equal(result["energy"], np.array(energy).T)
    # the drive has reached the bottom by the last window (the last grain sits on the floor): not zeros
    assert (np.abs(result["v_centre"][:, -1, -3:-1]) > 0).all()
    assert result["ke_window"][:, -1, -2].min() > 1e-6 * result["ke_window"][:, -1].max()


def test_figures_drawn_in_worker_processes_equal_those_drawn_inline(tmp_path):
    """On a GPU the figures and measurements of a group are made in worker processes while the next group
    integrates: the log's numbers and the PNGs are the same as when they are made in line."""
    from hertzian.studies.reproduce import finite, reproduce

    logs = {}
    for background in (False, True):
        out = tmp_path / str(background)
        logs[background] = reproduce(
            out,
            groups=["fig6", "depth", "fig9_10"],
            quick=True,
            device="cpu",
            background=background,
            say=lambda line: None,
        )
        assert [run["name"] for run in logs[background]["runs"]] == ["fig6", "depth", "fig9_10"]
        assert logs[background]["figures_in_background"] is background
        assert logs[background]["figure_failures"] == 0
    for inline, pooled in zip(logs[False]["runs"], logs[True]["runs"]):
        assert pooled["name"] == inline["name"] and pooled["figures"] == inline["figures"]
        if pooled["name"] == "fig9_10":  # run first when in the background; no measurements
            assert pooled["standing_wave"] and finite(pooled["standing_wave"]) == finite(inline["standing_wave"])
            assert pooled["figures"] == inline["figures"] == {"fig9": "fig9.png", "fig10": "fig10.png"}
            continue
        assert pooled["measurements"] == inline["measurements"] and pooled["measurements"]
        assert set(pooled["seconds"]) == {"setup", "integrate", "finalize", "figures", "measure"}
        for png in pooled["figures"].values():
            assert (tmp_path / "True" / png).stat().st_size > 10_000
    assert logs[True]["figure_wait_seconds"] >= 0
