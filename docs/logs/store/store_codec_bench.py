"""Seconds to write one gpu_10k batch of a snapshot variable (5 000 points x 11 records x 500 grains, float64,
the store's own shard layout) by compressor, and u + v written one after the other or from two threads.
Median of 3. Run from the repository root: python docs/logs/store/store_codec_bench.py > docs/logs/store/store_codec_bench_cpu.txt
"""
import os, platform
from datetime import datetime, timezone
import time, statistics, tempfile, shutil, numpy as np, zarr
from concurrent.futures import ThreadPoolExecutor
from zarr.codecs import BloscCodec, ZstdCodec
from hertzian.ensemble.sweep_store import chunk_layout
rng = np.random.default_rng(0)
data = np.cumsum(rng.standard_normal((50, 100, 11, 500)) * 1e-6, axis=-1); data[..., 300:] = 0.0
chunks, shards = chunk_layout((50, 100), (11, 500), 8)
print(f"# {datetime.now(timezone.utc).isoformat(timespec='seconds')} {platform.machine()} cpus={os.cpu_count()} zarr {zarr.__version__}; {data.nbytes / 1e6:.0f} MB; chunks {chunks} shards {shards}")
def mk(d, name, comp):
    g = zarr.open_group(d, mode='a')
    return g.create_array(name, shape=data.shape, dtype='f8', chunks=chunks, shards=shards, compressors=comp, fill_value=np.nan)
opts = {"zstd default": "auto", "zstd 1": [ZstdCodec(level=1)], "blosc lz4 shuffle": [BloscCodec(cname="lz4", clevel=5, shuffle="shuffle", typesize=8)],
        "blosc zstd1 shuffle": [BloscCodec(cname="zstd", clevel=1, shuffle="shuffle", typesize=8)]}
for label, comp in opts.items():
    runs=[]; size=0
    for r in range(3):
        d = tempfile.mkdtemp()
        a = mk(d, 'u', comp).with_config({"write_empty_chunks": True})
        t=time.perf_counter(); a[...] = data; runs.append(time.perf_counter()-t)
        import subprocess; size=subprocess.run(['du','-sm',d],capture_output=True,text=True).stdout.split()[0]
        shutil.rmtree(d)
    print(f"{label:22s} one array {statistics.median(runs):.3f} s  {size} MB", flush=True)
for label in ("zstd default", "blosc lz4 shuffle"):
    comp = opts[label]
    for mode in ("sequential", "threads"):
        runs=[]
        for r in range(3):
            d = tempfile.mkdtemp()
            arrs = [mk(d, n, comp).with_config({"write_empty_chunks": True}) for n in ("u","v")]
            t=time.perf_counter()
            if mode=="sequential":
                for a in arrs: a[...] = data
            else:
                with ThreadPoolExecutor(2) as ex: list(ex.map(lambda a: a.__setitem__(Ellipsis, data), arrs))
            runs.append(time.perf_counter()-t); shutil.rmtree(d)
        print(f"{label:22s} u+v {mode:10s} {statistics.median(runs):.3f} s", flush=True)
