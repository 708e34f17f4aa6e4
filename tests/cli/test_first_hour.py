"""What a newcomer meets in the first hour, from README and docs alone: the documented options work, a run that
blew up exits non-zero, wrong files and wrong stores are named in one line, shipped names are found by every
command, and the Python API refuses as the command line does."""

import shutil

import hertzian as hz
import numpy as np
import pytest
from hertzian.core.errors import OptionError
from hertzian.core.scene import SceneError
from hertzian.core.status import Status

from tests.helpers import GRID_SWEEP, invoke, write_sweep

AUTO_SCENE = """
[chain]
grains = 20

[excitation]
impact = 1e-2

[integrator]
method = "auto"
tolerance = 1e-4
duration = 0.4

[record]
every = 0.1
"""

SMALL = ("--set", "chain.grains=30", "--set", "integrator.duration=0.5", "--set", "record.every=0.1")


def errors(result) -> list[str]:
    return [line for line in result.stderr.splitlines() if line.startswith("error: ")]


def test_method_auto_with_a_tolerance_runs_everywhere(tmp_path):
    scene = tmp_path / "auto.toml"
    scene.write_text(AUTO_SCENE)
    checked = invoke("check", scene)
    assert checked.exit_code == 0 and "pilot runs pick the method and dt" in checked.stdout, checked.stdout
    out = tmp_path / "auto.zarr"
    ran = invoke("run", scene, "--out", out, "--device", "cpu", "--quiet")
    assert ran.exit_code in (0, 3) and out.exists(), (ran.stderr, ran.exception)
    result = hz.run(hz.load_scene(scene), "cpu")
    assert result.scenes[0].integrator.method in ("gear4", "gear5", "gear6", "verlet")
    assert result.error_estimate is not None
    # summarize says what the pilot chose, from the store's own attributes
    import zarr

    attrs = zarr.open_group(str(out), mode="r").attrs
    choice, pilot = attrs["tolerance_choice"], attrs["tolerance_pilot"]
    summary = invoke("summarize", out).stdout
    expected = f"tolerance 0.0001: {choice['method']}, events {choice['events']}, dt {choice['dt']:g}, chosen by "
    assert f"{expected}{len(pilot)} pilot runs" in " ".join(summary.split()), summary


def test_a_run_that_blew_up_exits_3_and_names_the_count(tmp_path):
    out = tmp_path / "blown.zarr"
    # a taper far too steep for the step: the smallest grains' contacts are unstable at dt = 5e-5
    result = invoke("run", "--out", out, "--device", "cpu", "--quiet", *SMALL, "--set", "chain.radii={taper=0.3}")
    assert result.exit_code == 3, (result.stdout, result.stderr)
    assert errors(result) == [errors(result)[0]] and "1 of 1 chains did not end OK (NON_FINITE 1" in result.stderr
    assert out.exists()  # written: the status is the record of what went wrong


def test_a_sweep_with_a_blown_up_point_exits_3(tmp_path):
    text = GRID_SWEEP.replace(
        "values = [0.0, 1e-4]",
        'values = [0.0, 1e-4]\n\n[[axis]]\nname = "taper"\nkey = "chain.radii.taper"\nvalues = [0.0, 0.5]',
    )
    sweep = write_sweep(
        tmp_path, text.replace("[scene.chain]\ngrains = 12", "[scene.chain]\ngrains = 12\nradii = { taper = 0.0 }")
    )
    out = tmp_path / "grid.zarr"
    result = invoke("sweep", sweep, "--out", out, "--device", "cpu", "--quiet")
    assert result.exit_code == 3, (result.stdout, result.stderr, result.exception)
    assert "of 12 chains did not end OK" in errors(result)[0]


def test_the_readme_taper_passes_its_check():
    result = invoke("check", "--set", "chain.radii={taper=0.001}")
    assert result.exit_code == 0 and "verdict                   ok" in result.stdout, result.stdout


def test_plot_of_another_figures_store_is_one_line(tmp_path):
    out = tmp_path / "grid.zarr"
    assert invoke("sweep", write_sweep(tmp_path, GRID_SWEEP), "--out", out, "--device", "cpu", "--quiet").exit_code == 0
    for figure in ("fig3", "fig1", "drive_map", "standing"):
        result = invoke("plot", out, "--figure", figure, "--out", tmp_path / "x.png")
        assert result.exit_code == 2 and result.exception is None or isinstance(result.exception, SystemExit)
        text = result.stderr.strip()
        assert len(text.splitlines()) == 1 and "Traceback" not in text, text
        assert "sweep axes v_imp (3), l0 (2)" in text, text


def test_plot_at_a_value_off_the_axis_says_which_point_it_drew(tmp_path):
    out = tmp_path / "grid.zarr"
    assert invoke("sweep", write_sweep(tmp_path, GRID_SWEEP), "--out", out, "--device", "cpu", "--quiet").exit_code == 0
    outside = invoke("plot", out, "--at", "v_imp=5", "--out", tmp_path / "a.png")
    assert outside.exit_code == 0 and "warning: --at v_imp=5 is not on the axis" in outside.stderr
    assert "v_imp=0.1 (the axis runs from 0.001 to 0.1)" in outside.stderr
    inside = invoke("plot", out, "--at", "v_imp=0.011", "--out", tmp_path / "b.png")
    assert (
        inside.exit_code == 0
        and "note: --at v_imp=0.011 is not on the axis: drew the nearest point, v_imp=0.01" in inside.stderr
    )
    exact = invoke("plot", out, "--at", "v_imp=0.01", "--out", tmp_path / "c.png")
    assert exact.exit_code == 0 and "not on the axis" not in exact.stderr


@pytest.mark.parametrize("command", [["warmup", "example.toml", "--dry-run"], ["warmup", "impact", "--dry-run"]])
def test_shipped_names_are_found_by_every_command(command):
    result = invoke(*command, "--device", "cpu")
    assert result.exit_code == 0, (result.stdout, result.stderr)
    assert "no such file" not in result.stdout + result.stderr


def test_estimates_finds_a_shipped_sweep(monkeypatch):
    import hertzian.studies.estimates as estimates

    seen = {}
    monkeypatch.setattr(estimates, "estimate_check", lambda scenes, **kw: seen.setdefault("n", len(scenes)) and {})
    result = invoke("estimates", "estimate_check.toml", "--device", "cpu")
    assert "no such file" not in result.stdout + result.stderr
    assert seen.get("n", 0) > 0, (result.stdout, result.stderr, result.exception)


@pytest.mark.parametrize(
    ("name", "kind", "commands"),
    [
        ("protector", "design", [["run"], ["check"], ["sweep"], ["warmup"], ["estimates"]]),
        ("example", "sweep", [["design"], ["detect-study"]]),
        ("impact", "scene", [["design"], ["sweep"], ["detect-study"]]),
        ("detect_study", "detection study", [["run"], ["sweep"], ["design"]]),
    ],
)
def test_every_command_names_the_kind_of_a_file_it_does_not_take(tmp_path, name, kind, commands):
    """A shipped design, sweep or scene given to a command of another kind: one line saying what it is and which
    command takes it, exit 2, nothing written."""
    takes = {
        "design": "give it to hertzian design",
        "sweep": "give it to hertzian sweep",
        "scene": "give it to hertzian run",
        "detection study": "give it to hertzian detect-study",
    }
    for command in commands:
        out = ["--out", tmp_path / "x.zarr"] if command[0] in ("run", "sweep", "design") else []
        result = invoke(*command, name, *out)
        assert result.exit_code == 2, (command, result.stderr)
        assert errors(result) == result.stderr.splitlines(), result.stderr
        assert f"is a {kind} file" in result.stderr and takes[kind] in result.stderr, (command, result.stderr)
    assert not list(tmp_path.iterdir())


def test_python_names_the_kind_of_a_file_it_does_not_take(tmp_path):
    with pytest.raises(SceneError, match=r"^sweep file = .*protector\.toml': is a design file .*hertzian\.design"):
        hz.sweep("protector", out=tmp_path / "x.zarr")
    with pytest.raises(SceneError, match=r"^design file = .*example\.toml': is a sweep file .*hertzian\.sweep"):
        hz.design("example", out=tmp_path / "x.zarr")
    with pytest.raises(SceneError, match=r"^scene file = .*protector\.toml': is a design file"):
        hz.load_scene("protector")


def test_a_sweep_file_given_to_run_and_a_scene_given_to_sweep_are_named(tmp_path):
    sweep = write_sweep(tmp_path, GRID_SWEEP)
    for command in (["run", sweep, "--out", tmp_path / "x.zarr"], ["check", sweep]):
        result = invoke(*command)
        assert result.exit_code == 2 and "is a sweep file" in result.stderr and "hertzian sweep" in result.stderr
    scene = tmp_path / "scene.toml"
    scene.write_text(AUTO_SCENE)
    result = invoke("sweep", scene, "--out", tmp_path / "y.zarr")
    assert result.exit_code == 2 and "is a scene file" in result.stderr and "hertzian run" in result.stderr


def test_python_refusals_name_the_key(tmp_path):
    small = {"integrator.duration": 0.02, "record.every": 0.01}
    mixed = [hz.load_scene("impact", {"chain.grains": n, **small}) for n in (10, 12)]
    with pytest.raises(SceneError, match=r"^chain\.grains = \['10', '12'\]: chains in one ensemble must share"):
        hz.run(mixed, "cpu")
    with pytest.raises(OptionError, match="^devce = 'cpu': not an option of sweep \\(did you mean device\\?\\)"):
        hz.sweep(write_sweep(tmp_path, GRID_SWEEP), tmp_path / "z.zarr", devce="cpu")
    (tmp_path / "folder").mkdir()
    with pytest.raises(ValueError, match="not a hertzian store"):
        hz.open_store(tmp_path / "folder")
    with pytest.raises(FileNotFoundError):
        hz.open_store(tmp_path / "missing.zarr")


def test_summarize_shows_the_error_estimate(tmp_path):
    out = tmp_path / "e.zarr"
    ran = invoke("run", "--out", out, "--device", "cpu", "--quiet", *SMALL, "--error-estimate")
    assert ran.exit_code == 0, ran.stderr
    result = invoke("summarize", out, "--json")
    assert result.exit_code == 0
    import json

    (row,) = json.loads(result.stdout)
    assert 0 < row["error_estimate"] < 1e-3


def test_progress_lines_when_stderr_is_not_a_terminal(tmp_path, monkeypatch):
    monkeypatch.setenv("HERTZIAN_PROGRESS_SECONDS", "0")
    out = tmp_path / "grid.zarr"
    result = invoke("sweep", write_sweep(tmp_path, GRID_SWEEP), "--out", out, "--device", "cpu", "--batch-size", "2")
    assert result.exit_code == 0, result.stderr
    lines = [ln for ln in result.stderr.splitlines() if ln.startswith("sweep: ")]
    assert lines[0] == f"sweep: 0/3 batches done; {12 * 200 * 6:.3g} grain-steps to run", (
        lines
    )  # grains × steps × points
    assert lines[-1].startswith("sweep: 3/3 batches, 100 % of the grain-steps")


def test_an_interrupt_counts_the_batches_in_the_store(tmp_path, monkeypatch):
    import hertzian.sweeping.pipeline as pipeline

    sweep = write_sweep(tmp_path, GRID_SWEEP)
    out = tmp_path / "grid.zarr"
    real = pipeline.run_serial

    def interrupted(
        jobs, *args, on_done=None, **kwargs
    ):  # the third batch is written, then Ctrl-C before it is counted
        real(jobs[:3], *args, on_done=lambda job, record: None, **kwargs)
        raise KeyboardInterrupt

    monkeypatch.setattr(pipeline, "run_serial", interrupted)
    result = invoke("sweep", sweep, "--out", out, "--device", "cpu", "--quiet", "--batch-size", "1")
    assert result.exit_code == 130
    assert "interrupted with 3/6 batches in the store" in result.stderr, result.stderr


def test_resume_with_other_overrides_says_they_are_part_of_the_sweep(tmp_path):
    sweep = write_sweep(tmp_path, GRID_SWEEP)
    out = tmp_path / "grid.zarr"
    assert invoke("sweep", sweep, "--out", out, "--device", "cpu", "--quiet", "--set", "chain.l0=1e-5").exit_code == 0
    shutil.rmtree(out / "u" / "c", ignore_errors=True)
    result = invoke("sweep", sweep, "--out", out, "--device", "cpu", "--quiet", "--resume")
    assert result.exit_code == 2 and "the same --set overrides, which are part of the sweep" in result.stderr


def test_failure_line_counts_by_code():
    from hertzian.core.status import failure_line

    status = np.array([0, 1, 1, 3, 5])
    assert failure_line(status).startswith("3 of 5 chains did not end OK (NON_FINITE 2, ENERGY_DRIFT 1;")
    assert failure_line(np.array([0, int(Status.ESTIMATE_UNCERTAIN)])) is None


def test_a_dry_run_estimates_seconds_on_this_device(tmp_path):
    import json

    sweep = write_sweep(tmp_path, GRID_SWEEP)
    result = invoke("sweep", sweep, "--dry-run", "--device", "cpu", "--json")
    assert result.exit_code == 0, result.stderr
    estimate = json.loads(result.stdout)["estimate"]
    assert estimate["seconds"] > 0 and estimate["bound"] == "estimate"
    assert "estimated integration: roughly" in result.stderr and " s on cpu" in result.stderr
    assert not (tmp_path / "sweep.zarr").exists()


def test_every_option_the_readme_and_docs_show_exists():
    """Each `hertzian COMMAND … --option` written in README.md or docs/*.md (continuation lines joined) names an
    option of that command."""
    import re
    from pathlib import Path

    import typer
    from hertzian.cli.app import app

    commands = typer.main.get_command(app).commands
    root = Path(__file__).resolve().parents[2]
    unknown, seen = [], 0
    for doc in [root / "README.md", *sorted((root / "docs").glob("*.md"))]:
        text = doc.read_text().replace("\\\n", " ")  # a command continued on the next line
        for line in re.finditer(r"hertzian ([a-z-]+)((?:[ \t]+[^\s`|]+)*)", text):
            if line.group(1) not in commands:
                continue  # prose ("hertzian integrates …")
            options = {o for p in commands[line.group(1)].params for o in (*p.opts, *p.secondary_opts)} | {"--help"}
            for option in re.findall(r"(?<![\w-])(--[a-z][a-z0-9-]*)", line.group(2)):
                seen += 1
                if option not in options:
                    unknown.append(f"{doc.name}: hertzian {line.group(1)} {option}")
    assert seen > 100 and unknown == [], unknown


def test_every_option_the_docs_give_a_study_module_exists():
    """Each `python -m hertzian.studies.MODULE … --option` in README.md or docs/*.md (the commands that regenerate
    the docs' records, continuation lines joined) names an option that the module's --help lists."""
    import re
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    pattern = re.compile(r"python -m (hertzian\.studies\.[a-z_]+)((?:[ \t]+[^\s`|]+)*)")
    found = []
    for doc in [root / "README.md", *sorted((root / "docs").glob("*.md"))]:
        text = doc.read_text().replace("\\\n", " ")
        found += [(doc.name, m.group(1), m.group(2)) for m in pattern.finditer(text)]
    options = {}
    for module in sorted({module for _, module, _ in found}):
        shown = subprocess.run([sys.executable, "-m", module, "--help"], capture_output=True, text=True)
        assert shown.returncode == 0, (module, shown.stderr[-500:])
        options[module] = set(re.findall(r"--[a-z][a-z0-9-]*", shown.stdout)) | {"--help"}
    written = [
        (doc, module, o) for doc, module, args in found for o in re.findall(r"(?<![\w-])(--[a-z][a-z0-9-]*)", args)
    ]
    assert len(options) >= 7 and len(written) > 40
    assert [w for w in written if w[2] not in options[w[1]]] == []


def test_the_dry_run_shown_in_sweeps_md_is_what_the_command_prints():
    """docs/sweeps.md's `--dry-run` of gpu_10k.toml on a GPU: the lines that do not depend on the device are the
    CPU's dry run with the same batches, and the estimate is the planner's conservative GPU rate."""
    import re
    from pathlib import Path

    from hertzian.sweeping.planner import SAFE_RATE

    text = (Path(__file__).resolve().parents[2] / "docs" / "sweeps.md").read_text()
    block = re.search(r"\$ hertzian sweep sweeps/gpu_10k.toml --dry-run --device cuda\n(.*?)```", text, re.S)
    shown = block.group(1).splitlines()
    result = invoke(
        "sweep", "sweeps/gpu_10k.toml", "--out", "unused.zarr", "--dry-run", "--device", "cpu", "--batch-size", "5000"
    )
    assert result.exit_code == 0, result.stderr
    printed = result.stdout.splitlines() + result.stderr.splitlines()
    for line in shown:
        if line.startswith("batches: "):
            assert line.split(" on ")[0] in "\n".join(printed), line
        elif line.startswith("estimated integration: "):
            assert line.startswith(f"estimated integration: at most about {5e11 / SAFE_RATE['cuda']:.3g} s on cuda")
        elif line.endswith("..."):
            assert any(p.startswith(line.removesuffix("...")) for p in printed), line
        else:
            assert line in printed, line
    assert len(shown) == 9
