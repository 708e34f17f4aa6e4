"""Seconds to write one batch of a gpu_10k-sized sweep variable into its Zarr layout, by codec option.

One batch of sweeps/gpu_10k.toml is 5 000 points × 11 records × 500 grains of float64 (220 MB) per snapshot
variable (u, v). The layout is the store's own (hertzian.ensemble.sweep_store.chunk_layout: one shard per batch
block, inner chunks of a few points). Data: a random walk along the grain axis with the last 40 % exactly zero
(grains the pulse has not reached). Options: compressors "auto" (Zarr's default, zstd) or None; write_empty_chunks
False (Zarr's default: each inner chunk compared with the fill value first) or True. Median of 3 writes each.
Run from the repository root: python docs/logs/store/store_write_bench.py > docs/logs/store/store_write_bench_cpu.txt
"""
import os
import platform
import shutil
import statistics
import subprocess
import tempfile
import time
from datetime import datetime, timezone

import numpy as np
import zarr

from hertzian.ensemble.sweep_store import chunk_layout

rng = np.random.default_rng(0)
data = np.cumsum(rng.standard_normal((50, 100, 11, 500)) * 1e-6, axis=-1)
data[..., 300:] = 0.0
chunks, shards = chunk_layout((50, 100), (11, 500), 8)
print(f"# {datetime.now(timezone.utc).isoformat(timespec='seconds')} {platform.machine()} cpus={os.cpu_count()} "
      f"zarr {zarr.__version__}; {data.nbytes / 1e6:.0f} MB; chunks {chunks} shards {shards}")
print("# compressors write_empty_chunks median_s runs_s MB_on_disk")
root = tempfile.mkdtemp(prefix="zbench-")
for compressors in ("auto", None):
    for write_empty in (False, True):
        runs = []
        for _ in range(3):
            path = os.path.join(root, "s.zarr")
            shutil.rmtree(path, ignore_errors=True)
            group = zarr.open_group(path, mode="w")
            array = group.create_array("u", shape=(100, 100, 11, 500), dtype="f8", chunks=chunks, shards=shards,
                                       compressors=compressors, fill_value=np.nan,
                                       config={"write_empty_chunks": write_empty})
            start = time.perf_counter()
            array[:50] = data
            runs.append(time.perf_counter() - start)
        size = subprocess.run(["du", "-sm", path], capture_output=True, text=True).stdout.split()[0]
        print(compressors, write_empty, f"{statistics.median(runs):.3f}", " ".join(f"{r:.3f}" for r in runs), size)
shutil.rmtree(root)
