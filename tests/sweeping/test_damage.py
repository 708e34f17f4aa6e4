"""Damage never reads back as data. Each damage (a deleted, bit-flipped or truncated file: chunks, completion rows,
flags, coordinates, every kind of metadata file, the manifest) is made on a fresh copy of a finished sweep store, and
then: the project's readers refuse the store or read exactly what the undamaged store holds; ``verify`` names the
damage; ``sweep --resume`` repairs the store bit for bit (data, coordinates and array metadata) or refuses in one
line."""

import json
import random
import shutil

import numpy as np
import pytest
from hertzian.sweeping.integrity import verify_store
from hertzian.sweeping.store import open_dataset, summary_columns
from hertzian.sweeping.sweep_store import differing_arrays

from tests.helpers import GRID_SWEEP, invoke, write_sweep

TIMING = ("wall_seconds", "grain_steps_per_second")
KINDS = ("delete", "flip", "truncate")


@pytest.fixture(scope="module")
def finished(tmp_path_factory):
    folder = tmp_path_factory.mktemp("damage")
    sweep = write_sweep(folder, GRID_SWEEP)
    store = folder / "reference.zarr"
    result = invoke("sweep", sweep, "--out", store, "--device", "cpu", "--quiet", "--batch-size", "2")
    assert result.exit_code == 0, result.stderr
    with open_dataset(store) as dataset:
        loaded = dataset.load()
    return sweep, store, summary_columns(store), loaded


def damages(store):
    """Every file of the store, each with one kind of damage (the kinds taken in turn): ≥ 60 damages."""
    files = sorted(p.relative_to(store).as_posix() for p in store.rglob("*") if p.is_file())
    return [(rel, KINDS[i % len(KINDS)]) for i, rel in enumerate(files)]


def damage(file, kind, *, offset=None, bit=2):
    if kind == "delete":
        file.unlink()
        return
    data = bytearray(file.read_bytes())
    if kind == "flip":
        data[len(data) // 2 if offset is None else offset] ^= 1 << bit
    else:
        data = data[: len(data) // 2]
    file.write_bytes(bytes(data))


def same_columns(columns, reference):
    for name, values in reference.items():
        if name in TIMING:
            continue
        a, b = np.asarray(columns[name]), np.asarray(values)
        assert a.shape == b.shape and np.array_equal(a, b, equal_nan=a.dtype.kind == "f"), name


def read_back_or_refused(store, reference_columns, reference_dataset):
    """The readers refuse ``store`` (an exception) or read what the undamaged store holds."""
    try:
        columns = summary_columns(store)
    except (ValueError, OSError, KeyError):
        columns = None
    if columns is not None:
        same_columns(columns, reference_columns)
    try:
        with open_dataset(store) as dataset:
            loaded = dataset.load()
    except (ValueError, OSError, KeyError, RuntimeError):
        return
    assert set(loaded.variables) == set(reference_dataset.variables)
    for name in reference_dataset.variables:
        if name not in TIMING:
            assert loaded[name].equals(reference_dataset[name]), name
    assert loaded.attrs == reference_dataset.attrs


def array_metadata(store):
    """Every array's and group's zarr.json below the root (the root's provenance holds times and differs)."""
    return {p.relative_to(store).as_posix(): p.read_bytes() for p in store.rglob("zarr.json") if p.parent != store}


def test_every_damage_is_refused_named_and_repaired(finished, tmp_path):
    sweep, reference, columns, dataset = finished
    cases = damages(reference)
    assert len(cases) >= 60 and {kind for _, kind in cases} == set(KINDS)
    kinds_of_file = {rel.split("/")[-1] if rel.endswith(".json") else "chunk" for rel, _ in cases}
    assert kinds_of_file == {"zarr.json", "manifest.json", "chunk"}
    metadata = array_metadata(reference)
    for index, (rel, kind) in enumerate(cases):
        store = tmp_path / f"case{index}.zarr"
        shutil.copytree(reference, store)
        damage(store / rel, kind)
        where = f"{kind} {rel}"
        read_back_or_refused(store, columns, dataset)
        assert verify_store(store).damage, f"verify missed: {where}"
        result = invoke("sweep", sweep, "--out", store, "--device", "cpu", "--quiet", "--resume")
        if result.exit_code == 2:  # refused: one line
            lines = [ln for ln in result.stderr.splitlines() if not ln.startswith(("note: ", "warning: "))]
            assert len(lines) == 1 and lines[0].startswith("error: "), (where, result.stderr)
        else:
            assert result.exit_code == 0, (where, result.stderr, result.exception)
            assert differing_arrays(store, reference) == [], where
            assert array_metadata(store) == metadata, where
            assert not verify_store(store).damage, where
        shutil.rmtree(store)


def test_single_bit_flips_of_the_root_metadata_never_read_silently(finished, tmp_path):
    _, reference, columns, dataset = finished
    size = (reference / "zarr.json").stat().st_size
    picks = random.Random(7).sample(range(size * 8), 40)
    for pick in picks:
        store = tmp_path / "flipped.zarr"
        shutil.copytree(reference, store)
        damage(store / "zarr.json", "flip", offset=pick // 8, bit=pick % 8)
        read_back_or_refused(store, columns, dataset)
        assert verify_store(store).damage, f"bit {pick} of zarr.json"
        shutil.rmtree(store)


def test_a_run_store_names_a_missing_chunk(tmp_path):
    scene = tmp_path / "scene.toml"
    scene.write_text("[chain]\ngrains = 8\n[integrator]\ndt = 1e-4\nduration = 0.01\n[record]\nevery = 0.005\n")
    store = tmp_path / "run.zarr"
    assert invoke("run", scene, "--out", store, "--device", "cpu", "--quiet").exit_code == 0
    chunk = next(p for p in (store / "u").rglob("*") if p.is_file() and p.name != "zarr.json")
    chunk.unlink()
    assert [d.variable for d in verify_store(store).damage] == ["u"]
    with pytest.raises(ValueError, match="is damaged: u: .*missing"):
        open_dataset(store)
    summary = invoke("summarize", store)
    assert summary.exit_code != 0 and "is damaged" in summary.stderr


def test_the_manifest_lists_every_metadata_file(finished):
    _, reference, _, _ = finished
    body = json.loads((reference / "manifest.json").read_text())["body"]
    on_disk = {p.relative_to(reference).as_posix() for p in reference.rglob("zarr.json")}
    assert on_disk <= set(body["files"])
    assert body["finished"] == [[0, 3]]


def test_a_store_being_written_is_not_called_damaged(finished, tmp_path):
    """A reader that meets a store mid-write (its lock held, a metadata file not yet matching its manifest) says it
    is being written, not that it is damaged."""
    from hertzian.sweeping.storage import store_lock

    _, reference, _, _ = finished
    store = tmp_path / "busy.zarr"
    shutil.copytree(reference, store)
    damage(store / "zarr.json", "flip", offset=10)
    with store_lock(store):
        with pytest.raises(ValueError, match="is being written by pid"):
            open_dataset(store)
    with pytest.raises(ValueError, match="is damaged: zarr.json"):
        open_dataset(store)
