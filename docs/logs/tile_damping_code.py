"""Does the fused kernel with viscous damping compile for CUDA, and what does damping cost in registers? Without a
GPU: Warp's CUDA code generation, NVRTC to PTX for sm_90, ``ptxas -v`` (registers, stack frame, spill bytes).

    python docs/logs/tile_damping_code.py > docs/logs/tile_damping_code_cpu.txt

Kernels: the driven 10 000-grain column of Figs. 9-10 (gravity, bottom fixed, events off, gear4 float64) on its
calibrated window shape (G = 4, 32 lanes) and gpu_10k's chains (walls, 500 grains, tile G = 4, 125 lanes),
each undamped, with viscous damping and with the contact dashpot, and the column struck instead of driven. Static
counts only: they say that the code builds and how large it is,
not how fast it runs.
"""

import os
import re
import subprocess
import tempfile
from dataclasses import replace
from datetime import datetime, timezone

import warp as wp

wp.config.quiet = True
wp.init()
import warp._src.build as build  # noqa: E402
from warp._src.context import ModuleBuilder, runtime  # noqa: E402

from hertzian.kernels.features import Features  # noqa: E402
from hertzian.kernels.tile import TileShape, tile_kernel  # noqa: E402

CASES = {
    "driven column, window G=4 lanes=32": (Features(method="gear4", surface="driven", bottom="fixed", static="profile"),
                                           TileShape(4, 32, windowed=True)),
    "gpu_10k chains, tile G=4 lanes=125": (Features(method="gear4", surface="wall", bottom="wall", static="uniform"),
                                           TileShape(4, 125)),
    # the same column struck instead of driven: what the drive adds (issue 11: its window kernel is 1.5x slower)
    "struck column, window G=4 lanes=32": (Features(method="gear4", surface="free", bottom="fixed", static="profile"),
                                           TileShape(4, 32, windowed=True)),
}

print(f"# {datetime.now(timezone.utc).isoformat(timespec='seconds')}, Warp {wp.__version__}, NVRTC -> PTX sm_90, "
      f"{subprocess.run(['ptxas', '--version'], capture_output=True, text=True).stdout.strip().splitlines()[-1]}")
print("# case | damping | registers | stack frame B | spill stores B | spill loads B | PTX lines")
out_dir = tempfile.mkdtemp(prefix="tile-damping-code-")
for name, (features, shape) in CASES.items():
    for damping in ("none", "viscous", "contact"):
        kernel = tile_kernel(replace(features, damping=damping), shape)
        options = dict(kernel.module.options, block_dim=shape.block_dim)
        source = ModuleBuilder(kernel.module, options, target="cuda").codegen("cuda")
        stem = os.path.join(out_dir, f"{len(name)}_{damping}")
        open(stem + ".cu", "w").write(source)
        build.build_cuda(stem + ".cu", 90, stem + ".ptx", config="release", optimization_level=3,
                         fuse_fp=options["fuse_fp"], lineinfo=False, pch_dir=runtime.get_nvrtc_pch_dir(),
                         use_precompiled_headers=False)
        ptx = open(stem + ".ptx").read().replace("\x00", "")
        ptx = re.sub(r"^\.version \S+", ".version 9.0", ptx, flags=re.M)  # an older ptxas reads ISA 9.0
        open(stem + ".ptx", "w").write(ptx)
        log = subprocess.run(["ptxas", "-arch=sm_90", "-O3", "-v", stem + ".ptx", "-o", stem + ".cubin"],
                             capture_output=True, text=True, check=True).stderr
        registers = re.findall(r"Used (\d+) registers", log)
        frame = re.findall(r"(\d+) bytes stack frame, (\d+) bytes spill stores, (\d+) bytes spill loads", log)
        print(f"{name} | {damping} | {registers[-1] if registers else '?'} | "
              f"{' | '.join(frame[-1]) if frame else '? | ? | ?'} | {ptx.count(chr(10))}", flush=True)
