"""The Zarr store of a protector design (hertzian.studies.design): per generation every candidate's genome and
objective, the best so far, and the optimizer's state (so that a run resumes where it stopped).

Layout: ``genome`` (generation, candidate, gene), ``objective`` (generation, candidate, objective),
``best_objective`` (generation, objective: each one's best so far), ``best_genome`` (generation, gene: the genome
of the first objective's best so far) and ``seconds`` (generation: wall time), one chunk per generation; the root's
attributes hold the design, the base scene, the gene names, the objective names and ``generations_done``. A generation's rows are written before ``generations_done``
counts it. A run resumes by replaying the stored generations into a new optimizer of the same seed (what it asks
must be what the store holds, bit for bit), so a resumed design is the design run straight through."""

from __future__ import annotations

import json
from dataclasses import asdict, replace
from pathlib import Path

import numpy as np
import zarr
from hertzian._version import __version__
from hertzian.core.errors import OptionError, SceneError
from hertzian.sweeping.storage import PROJECT
from hertzian.sweeping.store_format import StoreDamagedError, chunk_codecs, has_checksums

KIND = "design"
SCHEMA_VERSION = 2
ARRAYS = ("genome", "objective", "best_genome", "best_objective", "seconds")
"""The store's arrays, each along ``generation`` first."""


def spec_dict(spec) -> dict:
    """A DesignSpec as plain data (JSON), the form a store keeps."""
    return {k: list(v) if isinstance(v, tuple) else v for k, v in asdict(spec).items()}


def same_design(stored: dict, spec, scene, stored_scene: dict) -> str | None:
    """Why a store cannot be resumed with ``spec`` and ``scene`` (the generations may grow), else None."""
    now = spec_dict(replace(spec, generations=stored.get("generations", spec.generations)))
    if json.dumps(now, sort_keys=True) != json.dumps(stored, sort_keys=True):
        return "its [design] differs from this one (only design.generations may grow on resume)"
    if json.dumps(scene.to_dict(), sort_keys=True) != json.dumps(stored_scene, sort_keys=True):
        return "its base scene differs from this one"
    return None


def create_store(out: str | Path, scene, spec):
    """A new design store at ``out`` (an existing hertzian store there is replaced: the caller checked it and holds
    its lock)."""
    import shutil

    out = Path(out)
    if out.exists():
        shutil.rmtree(out)
    root = zarr.open_group(out, mode="w")
    genes, size, gens, m = len(spec.gene_names), spec.population, spec.generations, len(spec.objective)
    for name, shape, chunks, dims in (
        ("genome", (gens, size, genes), (1, size, genes), ["generation", "candidate", "gene"]),
        ("objective", (gens, size, m), (1, size, m), ["generation", "candidate", "objective"]),
        ("best_genome", (gens, genes), (1, genes), ["generation", "gene"]),
        ("best_objective", (gens, m), (1, m), ["generation", "objective"]),
        ("seconds", (gens,), (1,), ["generation"]),
    ):
        root.create_array(
            name,
            shape=shape,
            chunks=chunks,
            dtype="float64",
            fill_value=np.nan,
            dimension_names=dims,
            compressors=chunk_codecs(),
        )
    root.attrs.update(
        {
            "project": PROJECT,
            "schema_version": SCHEMA_VERSION,
            "kind": KIND,
            "package_version": __version__,
            "design": spec_dict(spec),
            "scene": scene.to_dict(),
            "genes": spec.gene_names,
            "objectives": list(spec.objective),
            "generations_done": 0,
        }
    )
    return root


def open_for_resume(out: str | Path, scene, spec, new_optimizer):
    """(store, optimizer, generations done) of the design store at ``out``, grown to ``spec.generations``, the
    optimizer (``new_optimizer(spec)``) told every stored generation; refused in one line when it is not a design
    store, holds another design, or its generations do not replay."""
    try:
        root = zarr.open_group(out, mode="r+")
    except Exception:  # noqa: BLE001 (whatever zarr raises for a missing or foreign folder)
        raise OptionError("out", str(out), "is not a design store to resume") from None
    attrs = root.attrs.asdict()
    if attrs.get("kind") != KIND or attrs.get("project") != PROJECT:
        raise OptionError("out", str(out), "is not a design store to resume")
    why = same_design(attrs["design"], spec, scene, attrs["scene"])
    if why:
        raise OptionError("out", str(out), why)
    done = int(attrs["generations_done"])
    if spec.generations < done:
        raise SceneError("design.generations", spec.generations, f"the store holds {done} generations already")
    optimizer = new_optimizer(spec)
    for generation in range(done):
        try:
            genomes, values = root["genome"][generation], root["objective"][generation]
        except Exception as err:  # noqa: BLE001 (a chunk that fails its checksum or no longer decodes)
            raise OptionError(
                "out", str(out), f"generation {generation + 1} is damaged ({type(err).__name__})"
            ) from None
        if not np.array_equal(optimizer.ask(), genomes):
            raise OptionError(
                "out", str(out), f"generation {generation + 1} does not replay (another optimizer version?)"
            )
        optimizer.tell(genomes, values)
    for name in ARRAYS:
        array = root[name]
        array.resize((spec.generations, *array.shape[1:]))
    root.attrs["design"] = {**attrs["design"], "generations": spec.generations}
    return root, optimizer, done


def write_generation(root, generation: int, genomes: np.ndarray, values: np.ndarray, seconds: float) -> np.ndarray:
    """Store one generation (``values``: (candidates, objectives); ``seconds``: its wall time), then count it;
    returns each objective's best so far."""
    root["seconds"][generation] = seconds
    root["genome"][generation] = genomes
    root["objective"][generation] = values
    previous = root["best_objective"][generation - 1] if generation else np.full(values.shape[1], np.inf)
    best = np.minimum(previous, values.min(axis=0))
    k = int(np.argmin(values[:, 0]))
    genome = genomes[k] if generation == 0 or values[k, 0] < previous[0] else root["best_genome"][generation - 1]
    root["best_objective"][generation] = best
    root["best_genome"][generation] = genome
    root.attrs["generations_done"] = generation + 1
    return best


def best_of(root) -> tuple[float, list[float]]:
    """(the first objective's best, its genome) over the generations done."""
    done = int(root.attrs["generations_done"])
    return float(root["best_objective"][done - 1][0]), root["best_genome"][done - 1].tolist()


def read_design(path: str | Path) -> dict:
    """A design store as plain data: its attributes and arrays over the generations done."""
    root = zarr.open_group(path, mode="r")
    attrs = root.attrs.asdict()
    if attrs.get("kind") != KIND:
        raise OptionError("store", str(path), "is not a design store (hertzian design writes one)")
    done = int(attrs["generations_done"])
    arrays = {}
    for name in ARRAYS:
        try:
            arrays[name] = root[name][:done]
        except Exception as err:  # noqa: BLE001 (a chunk that fails its checksum or no longer decodes)
            raise StoreDamagedError(
                f"{path}: {name}: a damaged chunk ({type(err).__name__}); hertzian verify {path} names it"
            ) from None
    return {"attrs": json.loads(json.dumps(attrs)), **arrays}


def is_design_store(path: str | Path) -> bool:
    """Whether ``path`` is a design store (its root metadata says so; nothing else is read)."""
    try:
        attrs = json.loads((Path(path) / "zarr.json").read_text()).get("attributes", {})
    except (OSError, ValueError, AttributeError):
        return False
    return isinstance(attrs, dict) and attrs.get("kind") == KIND


def verify_design(path: str | Path) -> dict:
    """Read every chunk of a design store: {"chunks": how many were read, "damaged": one line per chunk that fails
    its checksum or no longer decodes (array, generation, reason), "unchecked": arrays whose chunks carry no
    checksum (a store written by an older version)}."""
    root = zarr.open_group(path, mode="r")
    done = int(root.attrs["generations_done"])
    out: dict = {"chunks": 0, "damaged": [], "unchecked": []}
    for name in ARRAYS:
        array = root[name]
        if not has_checksums(array):
            out["unchecked"].append(name)
        for generation in range(done):
            out["chunks"] += 1
            try:
                array[generation]
            except Exception as err:  # noqa: BLE001 (any failure to read a chunk is damage, named in one line)
                out["damaged"].append(f"{name}: generation {generation + 1}: {type(err).__name__}")
    return out


def design_dataset(path: str | Path):
    """A design store as a labelled in-memory ``xarray.Dataset`` over the generations done: ``genome`` (generation,
    candidate, gene), ``objectives`` (generation, candidate, objective), ``best_genome``, ``best_objectives`` and
    ``seconds``, with the genes' and objectives' names as coordinates and the store's attributes."""
    import xarray as xr

    data = read_design(path)
    attrs = data["attrs"]
    names = {"objective": "objectives", "best_objective": "best_objectives"}
    dims = {
        "genome": ("generation", "candidate", "gene"),
        "objective": ("generation", "candidate", "objective"),
        "best_genome": ("generation", "gene"),
        "best_objective": ("generation", "objective"),
        "seconds": ("generation",),
    }
    coords = {
        "generation": np.arange(1, len(data["seconds"]) + 1),  # counted from 1, as progress, summarize and plots do
        "gene": list(attrs["genes"]),
        "objective": list(attrs["objectives"]),
    }
    variables = {names.get(name, name): (dims[name], data[name]) for name in ARRAYS}
    return xr.Dataset(variables, coords=coords, attrs=attrs)
