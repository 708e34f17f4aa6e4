"""Write speed and size of a sharded float64 array with zarr's default zstd and with no compressor.

Shapes of one gpu_10k.toml batch of 2000 points (11 records × 500 grains, inner chunks of 20 points).
Run: python docs/logs/zarr_compression_cpu.py > docs/logs/zarr_compression_cpu.txt
"""

import datetime
import os
import platform
import shutil
import subprocess
import tempfile
import time

import numpy as np
import zarr

print(f"date: {datetime.datetime.now(datetime.timezone.utc).isoformat(timespec='seconds')}")
print(f"device: CPU, {os.cpu_count()} cores, {platform.processor() or platform.machine()}; load average "
      f"{os.getloadavg()[0]:.2f} (shared machine); zarr {zarr.__version__}, numpy {np.__version__}")
rng = np.random.default_rng(0)
cases = {"random normal": rng.standard_normal((2000, 11, 500)),
         "smooth (cumulative sums of 1e-6 steps)": np.cumsum(rng.standard_normal((2000, 11, 500)) * 1e-6, axis=2)}
for compressor in ("zstd (default)", "none"):
    for name, data in cases.items():
        for repeat in range(2):
            tmp = tempfile.mkdtemp()
            extra = {} if compressor.startswith("zstd") else {"compressors": None}
            array = zarr.create_array(f"{tmp}/a.zarr", shape=data.shape, dtype=data.dtype, chunks=(20, 11, 500),
                                      shards=(2000, 11, 500), **extra)
            start = time.perf_counter()
            array[...] = data
            seconds = time.perf_counter() - start
            size = int(subprocess.run(["du", "-sb", tmp], capture_output=True, text=True).stdout.split()[0])
            print(f"{compressor:15} {name:40} write {seconds:.2f} s, {size / 2**20:.1f} MiB on disk "
                  f"({data.nbytes / 2**20:.1f} MiB raw)")
            shutil.rmtree(tmp)
