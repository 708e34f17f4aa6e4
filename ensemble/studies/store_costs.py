"""What a store's safety and a sweep's expansion cost on this machine (docs/sweeps.md).

Three measurements, written under ``parts.<part>`` of a JSON record (other parts kept):

* ``checksum``: writing, then reading, one float64 array of about 100 MB (normal random numbers: simulated floats
  barely compress) in ~1 MiB chunks, encoded as every store array is (zstd level 1, then CRC-32C) and without the
  CRC-32C; ``--repeats`` interleaved pairs, each write and read timed;
* ``flips``: the u and v snapshots of a short run of the built-in example, stored in ten chunks without and with the
  CRC-32C; ``--flips`` times one random byte of one random chunk file is XOR-ed with a random nonzero mask, the array
  read back and the byte restored; each flip is counted as raised (zarr refused the chunk), silent (values read back
  wrong, no error) or harmless (values equal);
* ``expansion``: CPU seconds per point of turning ``--sweep``'s points into one validated ``Scene`` each
  (``Sweep.scene_at``, ``--scenes`` points) against ``expand`` and ``SweepPoints.chains`` over every point.

    python -m hertzian.studies.store_costs --out docs/records/bench/cpu.json --part store
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np
import zarr
import zarr.codecs
from hertzian.core.outputs import exit_unless_replaceable, provenance, write_part
from hertzian.sweeping.store_format import DAMAGE_ERRORS, chunk_codecs

CHUNK_VALUES = 1 << 17
"""float64 values per chunk of the timed array: 1 MiB, the size of a store's inner chunks."""


def _codecs(checksum: bool) -> tuple:
    codecs = chunk_codecs()
    return codecs if checksum else tuple(c for c in codecs if not isinstance(c, zarr.codecs.Crc32cCodec))


def _write(folder: Path, data: np.ndarray, checksum: bool, chunk: int) -> None:
    array = zarr.create_array(
        str(folder), shape=data.shape, dtype=data.dtype, chunks=(chunk,), compressors=_codecs(checksum)
    )
    array[...] = data


def checksum_cost(megabytes: float, repeats: int, seed: int) -> dict:
    """Write and read seconds of one array with and without the CRC-32C, ``repeats`` interleaved pairs."""
    data = np.random.default_rng(seed).standard_normal(int(megabytes * 1e6) // 8)
    seconds = {"with_checksum": {"write": [], "read": []}, "without_checksum": {"write": [], "read": []}}
    for _ in range(repeats):
        for label, checksum in (("without_checksum", False), ("with_checksum", True)):
            with tempfile.TemporaryDirectory() as folder:
                path = Path(folder) / "a.zarr"
                start = time.perf_counter()
                _write(path, data, checksum, CHUNK_VALUES)
                seconds[label]["write"].append(time.perf_counter() - start)
                start = time.perf_counter()
                read = zarr.open_array(str(path), mode="r")[...]
                seconds[label]["read"].append(time.perf_counter() - start)
                if read.tobytes() != data.tobytes():
                    raise RuntimeError(f"{path}: the array read back differs from the one written")
    return {"megabytes": data.nbytes / 1e6, "chunk_bytes": CHUNK_VALUES * 8, "repeats": repeats, "seconds": seconds}


def _flip_outcomes(path: Path, data: np.ndarray, flips: int, rng: np.random.Generator) -> dict:
    files = sorted(p for p in path.rglob("*") if p.is_file() and p.name != "zarr.json")
    counts = {"raised": 0, "silent": 0, "harmless": 0}
    for _ in range(flips):
        file = files[rng.integers(len(files))]
        pristine = file.read_bytes()
        damaged = bytearray(pristine)
        damaged[int(rng.integers(len(damaged)))] ^= int(rng.integers(1, 256))
        file.write_bytes(bytes(damaged))
        try:
            read = zarr.open_array(str(path), mode="r")[...]
            counts["silent" if read.tobytes() != data.tobytes() else "harmless"] += 1
        except DAMAGE_ERRORS:
            counts["raised"] += 1
        file.write_bytes(pristine)
    return counts


def simulated_field() -> np.ndarray:
    """u and v snapshots of the built-in example at 200 grains (81 records to t = 40), flattened: data as a store
    holds it, zeros ahead of the pulse included."""
    from hertzian.api import load_scene, run

    scene = load_scene("impact", {"chain.grains": 200, "integrator.duration": 40.0, "record.every": 0.5})
    result = run([scene], device="cpu")
    return np.concatenate([np.asarray(result.u).ravel(), np.asarray(result.v).ravel()])


def flip_outcomes(data: np.ndarray, flips: int, seed: int, chunks: int = 10) -> dict:
    """What ``flips`` random byte flips in the chunk files of ``data`` stored in ``chunks`` chunks do, without and
    with the CRC-32C (the same seed, so the same files, offsets and masks, for both)."""
    chunk = -(-data.size // chunks)
    out = {"data": "u and v of the built-in example, 200 grains, 81 records", "values": data.size}
    out.update({"zero_fraction": float(np.mean(data == 0)), "chunks": chunks, "flips": flips, "seed": seed})
    for label, checksum in (("without_checksum", False), ("with_checksum", True)):
        with tempfile.TemporaryDirectory() as folder:
            path = Path(folder) / "a.zarr"
            _write(path, data, checksum, chunk)
            out[label] = _flip_outcomes(path, data, flips, np.random.default_rng(seed))
    return out


def expansion_cost(sweep_path: str, scenes: int) -> dict:
    """CPU seconds per point: one validated Scene per point (``scenes`` points) against ``expand`` and
    ``SweepPoints.chains`` over every point of the sweep."""
    from hertzian.sweeping.spec import expand, load_sweep

    sweep = load_sweep(sweep_path)
    start = time.process_time()
    for index in list(np.ndindex(*sweep.shape))[:scenes]:
        sweep.scene_at(index)
    per_scene = (time.process_time() - start) / scenes
    start = time.process_time()
    expand(sweep).chains(np.arange(sweep.point_count))
    expanded = time.process_time() - start
    return {
        "sweep": sweep_path,
        "points": sweep.point_count,
        "scene_points": scenes,
        "scene_seconds_per_point": per_scene,
        "expand_seconds": expanded,
        "expand_seconds_per_point": expanded / sweep.point_count,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", required=True, type=Path, help="JSON record (its other parts are kept)")
    parser.add_argument("--part", default="store")
    parser.add_argument("--megabytes", type=float, default=100.0)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--flips", type=int, default=200)
    parser.add_argument("--sweep", default="sweeps/cpu_100k.toml")
    parser.add_argument("--scenes", type=int, default=2000)
    parser.add_argument("--seed", type=int, default=35)
    args = parser.parse_args()
    for name in ("megabytes", "repeats", "flips", "scenes"):
        if not getattr(args, name) > 0:
            parser.exit(2, f"error: --{name} = {getattr(args, name)!r}: must be > 0\n")
    exit_unless_replaceable(args.out, "--out")
    command = (
        f"python -m hertzian.studies.store_costs --out {args.out} --part {args.part} --megabytes {args.megabytes:g} "
        f"--repeats {args.repeats} --flips {args.flips} --sweep {args.sweep} --scenes {args.scenes} --seed {args.seed}"
    )
    record = {"command": command, **provenance("cpu")}
    record["checksum"] = checksum_cost(args.megabytes, args.repeats, args.seed)
    record["flips"] = flip_outcomes(simulated_field(), args.flips, args.seed)
    record["expansion"] = expansion_cost(args.sweep, args.scenes)
    write_part(args.out, args.part, record)


if __name__ == "__main__":
    main()
