"""``--overwrite`` deletes only a store hertzian wrote: decoy folders, the home and the current folder, symlinks to
them and stores holding foreign files are refused in one line with every file left in place; a store that another
process is writing is refused too (every writer takes the lock)."""

import pytest
from hertzian.sweeping.storage import store_lock

from tests.helpers import GRID_SWEEP, invoke, write_sweep

TINY_SCENE = """
[chain]
grains = 8

[excitation]
impact = 1e-2

[integrator]
method = "verlet"
dt = 1e-4
duration = 0.01

[record]
every = 0.005
"""


def one_line(result, *expected):
    lines = (result.stdout + result.stderr).strip().splitlines()
    text = "\n".join(line for line in lines if not line.startswith(("warning: ", "note: ")))
    assert result.exit_code == 2, (result.exit_code, text, result.exception)
    assert "Traceback" not in text and len(text.splitlines()) == 1, text
    assert text.startswith("error: --out"), text
    for part in expected:
        assert part in text, text


@pytest.fixture
def scene(tmp_path):
    path = tmp_path / "tiny.toml"
    path.write_text(TINY_SCENE)
    return path


@pytest.fixture
def store(tmp_path, scene):
    out = tmp_path / "store.zarr"
    result = invoke("run", scene, "--out", out, "--device", "cpu", "--quiet")
    assert result.exit_code == 0, result.stderr
    return out


def decoy(folder):
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "thesis.tex").write_text("\\documentclass{article}")
    (folder / ".ssh").mkdir(exist_ok=True)
    (folder / ".ssh" / "id_ed25519").write_text("secret")
    return folder


def intact(folder):
    return (folder / "thesis.tex").read_text().startswith("\\documentclass") and (folder / ".ssh/id_ed25519").exists()


def run_over(scene, out):
    return invoke("run", scene, "--out", out, "--device", "cpu", "--quiet", "--overwrite")


def sweep_over(tmp_path, out):
    return invoke("sweep", write_sweep(tmp_path, GRID_SWEEP), "--out", out, "--device", "cpu", "--quiet", "--overwrite")


@pytest.mark.parametrize("command", ["run", "sweep"])
def test_a_folder_that_is_not_a_store_is_never_replaced(tmp_path, scene, command):
    folder = decoy(tmp_path / "decoy")
    result = run_over(scene, folder) if command == "run" else sweep_over(tmp_path, folder)
    one_line(result, "not a hertzian store")
    assert intact(folder)


def test_a_forged_store_holding_foreign_files_is_not_replaced(tmp_path, scene, store):
    (store / "thesis.tex").write_text("\\documentclass{article}")
    one_line(run_over(scene, store), "holds files a hertzian store does not", "thesis.tex")
    assert (store / "thesis.tex").exists()


def test_home_and_the_current_folder_are_never_replaced(tmp_path, scene, store, monkeypatch):
    home = decoy(tmp_path / "home")
    monkeypatch.setenv("HOME", str(home))
    one_line(run_over(scene, home), "is the home folder")
    assert intact(home)
    monkeypatch.chdir(store)  # even a store is not replaced while it is the current folder
    one_line(run_over(scene, "."), "is the current folder")
    one_line(sweep_over(tmp_path, "."), "is the current folder")
    monkeypatch.chdir(store / "u")
    one_line(run_over(scene, ".."), "holds the current folder")  # `..` is resolved: it holds the current folder
    assert (store / "zarr.json").exists() and (store / "u" / "zarr.json").exists()


def test_symlinks_are_resolved(tmp_path, scene, store):
    folder = decoy(tmp_path / "decoy")
    link = tmp_path / "link.zarr"
    link.symlink_to(folder)
    one_line(run_over(scene, link), "not a hertzian store")
    assert intact(folder) and link.is_symlink()
    to_store = tmp_path / "to_store.zarr"
    to_store.symlink_to(store)
    result = run_over(scene, to_store)
    assert result.exit_code == 0, result.stderr


@pytest.mark.parametrize("command", ["run", "sweep"])
def test_a_store_is_replaced(tmp_path, scene, store, command):
    before = (store / "zarr.json").stat().st_mtime_ns
    result = run_over(scene, store) if command == "run" else sweep_over(tmp_path, store)
    assert result.exit_code == 0, result.stderr
    assert (store / "zarr.json").stat().st_mtime_ns != before


def test_a_store_being_written_is_not_replaced(tmp_path, scene, store):
    before = sorted(p.relative_to(store) for p in store.rglob("*"))
    with store_lock(store):  # another writer (a sweep) holds the store
        one_line(run_over(scene, store), "is being written by")
        one_line(sweep_over(tmp_path, store), "is being written by")
    assert sorted(p.relative_to(store) for p in store.rglob("*")) == before


def test_a_folder_that_cannot_be_written_is_refused_before_the_run(tmp_path, scene):
    # /sys refuses new files to every user, root included (a chmod'ed folder would not stop root)
    one_line(invoke("run", scene, "--out", "/sys/x.zarr", "--device", "cpu"), "not writable")
    one_line(
        invoke("sweep", write_sweep(tmp_path, GRID_SWEEP), "--out", "/sys/x.zarr", "--device", "cpu"), "not writable"
    )


def test_a_store_from_before_the_project_attribute_is_replaced(tmp_path, scene, store):
    import json

    meta = json.loads((store / "zarr.json").read_text())
    del meta["attributes"]["project"]  # as written before: the package named in the provenance only
    (store / "zarr.json").write_text(json.dumps(meta))
    (store / "manifest.json").unlink()
    assert meta["attributes"]["provenance"]["package"] == "hertzian"
    result = run_over(scene, store)
    assert result.exit_code == 0, result.stderr
    assert json.loads((store / "zarr.json").read_text())["attributes"]["project"] == "hertzian"
