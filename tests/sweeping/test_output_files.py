"""Figures and JSON records are written only where nothing is, or over a file hertzian wrote (a PNG's Software text
chunk, a record's command): a user's file, a folder or a link in the way is refused in one line, before anything
runs, and left as it was. ``hertzian reproduce`` checks every store and file it would write in its folder."""

import json

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pytest  # noqa: E402
from hertzian.core.outputs import SOFTWARE, png_software, why_not_replaceable, written_by_hertzian  # noqa: E402

from tests.helpers import invoke  # noqa: E402

SMALL = ("--set", "chain.grains=20", "--set", "integrator.duration=0.2", "--set", "record.every=0.05")


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    out = tmp_path_factory.mktemp("run") / "r.zarr"
    result = invoke("run", *SMALL, "--device", "cpu", "--out", out)
    assert result.exit_code == 0, result.stderr
    return out


def user_files(folder):
    """A text file, a plain matplotlib PNG and a JSON of the user's, each named as hertzian would name its own."""
    (folder / "notes.png").write_text("not a picture")
    fig = plt.figure()
    fig.savefig(folder / "mine.png")
    plt.close(fig)
    (folder / "mine.json").write_text(json.dumps({"command": "my own analysis"}))
    return {path: path.read_bytes() for path in folder.iterdir()}


def test_a_png_hertzian_draws_names_it_and_a_users_does_not(tmp_path, store):
    user_files(tmp_path)
    assert (png_software(tmp_path / "mine.png") or "").startswith("Matplotlib")
    assert png_software(tmp_path / "notes.png") is None
    drawn = invoke("plot", store, "--out", tmp_path / "r.png")
    assert drawn.exit_code == 0, drawn.stderr
    assert png_software(tmp_path / "r.png") == SOFTWARE and written_by_hertzian(tmp_path / "r.png")
    again = invoke("plot", store, "--out", tmp_path / "r.png")
    assert again.exit_code == 0, again.stderr
    assert not written_by_hertzian(tmp_path / "mine.json") and not written_by_hertzian(tmp_path / "mine.png")
    (tmp_path / "link.png").symlink_to(tmp_path / "r.png")
    (tmp_path / "folder.png").mkdir()
    for name in ("link.png", "folder.png", "mine.png", "notes.png"):
        assert why_not_replaceable(tmp_path / name), name
    assert why_not_replaceable(tmp_path / "nothing.png") is None


def refused(result, option):
    text = result.stderr.strip()
    assert result.exit_code == 2, (result.exit_code, text, result.exception)
    assert len(text.splitlines()) == 1 and text.startswith(f"error: {option} = "), text
    return text


@pytest.mark.parametrize(
    ("command", "option", "name"),
    [
        (["plot", "STORE", "--out"], "--out", "mine.png"),
        (["plot", "STORE", "--out"], "--out", "notes.png"),
        (["accuracy", "--device", "cpu", "--set", "chain.grains=10", "--plot"], "--plot", "mine.png"),
        (["detect", "SIGNAL", "--device", "cpu", "--scene", "impact", "--plot"], "--plot", "notes.png"),
        (["estimates", "example", "--device", "cpu", "--json"], "--json", "mine.json"),
        (["detect-study", "detect_study", "--device", "cpu", "--overwrite", "--out"], "--out", "mine.json"),
    ],
)
def test_every_writer_refuses_a_users_file(tmp_path, store, command, option, name):
    before = user_files(tmp_path)
    signal = tmp_path / "signal.npy"
    args = [str(store) if a == "STORE" else str(signal) if a == "SIGNAL" else a for a in command]
    refused(invoke(*args, tmp_path / name), option)
    assert {path: path.read_bytes() for path in tmp_path.iterdir()} == before


def test_a_users_file_is_not_offered_overwrite(tmp_path):
    """Without --overwrite, a user's file is refused for what it is: --overwrite would not replace it either."""
    before = user_files(tmp_path)
    text = refused(invoke("detect-study", "detect_study", "--device", "cpu", "--out", tmp_path / "mine.json"), "--out")
    assert "hertzian did not write it" in text and "pass --overwrite" not in text
    assert {path: path.read_bytes() for path in tmp_path.iterdir()} == before


def test_reproduce_refuses_a_folder_holding_what_it_did_not_write_and_replaces_its_own(tmp_path):
    folder = tmp_path / "out"
    folder.mkdir()
    run = ("reproduce", "--quick", "--figure", "fig1", "--device", "cpu", "--out-dir", folder)
    for name, make in (
        ("log.json", lambda p: p.write_text("{}")),
        ("fig1.png", lambda p: p.write_text("mine")),
        ("fig1.zarr", lambda p: (p.mkdir(), (p / "data.txt").write_text("mine"))),
    ):
        make(folder / name)
        text = refused(invoke(*run), "--out-dir")
        assert name in text, text
        assert sorted(p.name for p in folder.iterdir()) == [name]
        (folder / name).unlink() if (folder / name).is_file() else __import__("shutil").rmtree(folder / name)
    for _ in range(2):  # its own stores, figures and log are replaced
        done = invoke(*run)
        assert done.exit_code == 0, done.stderr
    assert json.loads((folder / "log.json").read_text())["command"].startswith("hertzian reproduce")
    assert png_software(folder / "fig1.png") == SOFTWARE


@pytest.mark.parametrize(
    "module, args",
    [
        ("accuracy", ["--out", "mine.json", "--part", "p"]),
        ("design_record", ["--out", "mine.json", "--part", "p", "--design", "protector"]),
        ("lattices", ["--out", "mine.json"]),
        ("thresholds", ["--out", "mine.json", "--methods", "yoshida4", "--ratios", "400"]),
        ("fixed_costs", ["--out", "mine.json"]),
        ("heterogeneous", ["mine.json"]),
    ],
)
def test_the_record_writers_of_the_docs_leave_a_users_file_alone(tmp_path, module, args):
    """python -m hertzian.studies.…: a JSON of the user's at the output path is refused in one line, exit 2,
    before anything runs, and left as it was; a record that hertzian wrote (a command in it) may be replaced."""
    import subprocess
    import sys

    mine = tmp_path / "mine.json"
    mine.write_text('{"my": 1}')
    done = subprocess.run(
        [sys.executable, "-m", f"hertzian.studies.{module}", *args], cwd=tmp_path, capture_output=True, text=True
    )
    errors = [line for line in done.stderr.splitlines() if line.startswith("error:")]
    assert done.returncode == 2 and errors == [f"error: {errors[0][7:]}"] and "hertzian did not write it" in errors[0]
    assert mine.read_text() == '{"my": 1}'


def test_a_record_counts_as_hertzians_by_any_command_inside_it(tmp_path):
    from hertzian.core.outputs import why_not_replaceable

    cases = {
        "top.json": {"command": "hertzian run"},
        "parts.json": {"parts": {"a": {"command": "python -m hertzian.studies.accuracy"}}},
        "runs.json": {"parts": {"a": {"runs": [{"command": "hertzian bench"}]}}},
        "items.json": {"items": {"x": {"command": "hertzian reproduce --measure x"}}},
        "env.json": {"parts": {"a": {"command": "HERTZIAN_COMPILE_WORKERS=2 hertzian warmup --paper"}}},
        "mine.json": {"my": {"command": "make all"}},
        "pip.json": {"command": "pip install hertzian"},
        "none.json": {"my": 1},
    }
    for name, data in cases.items():
        (tmp_path / name).write_text(json.dumps(data))
    assert [n for n in cases if why_not_replaceable(tmp_path / n) is None] == [
        "top.json",
        "parts.json",
        "runs.json",
        "items.json",
        "env.json",
    ]
