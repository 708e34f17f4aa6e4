"""Static CUDA code of the tile kernel's event path, without a GPU: NVRTC (Warp's) -> PTX for sm_90,
``ptxas -v`` (registers, stack, spill bytes), ``nvdisasm`` (SASS instructions, calls of the event step,
local-memory spill instructions inside / outside the event path, by the line info's inline chains).

Static counts only: they say how large the code is and where the compiler spilled, not how fast it runs.
Needs ``ptxas`` on PATH and ``nvdisasm`` on PATH or in $NVDISASM (e.g. ``pip install nvidia-cuda-nvdisasm``).
Usage, from the repository root (REV: the commit before the change, for "before"):

    python docs/logs/tile_events_code.py REV > docs/logs/tile_events_code_cpu.json

Scene of the kernels: gear4 float64, walls, no static overlap, 500 grains (sweeps/gpu_10k.toml's chains),
whole chains of ceil(500 / G) lanes; event window 0.01 ("auto") and 0 ("off").
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time

GRAINS = 500
CASES = [(8, 0.01), (8, 0.0), (16, 0.01), (16, 0.0)]


def package(repo: str, rev: str | None) -> str:
    """A folder with ``hertzian/`` whose kernels are those of ``rev`` (None: the working tree)."""
    root = tempfile.mkdtemp(prefix="tile-events-code-")
    os.makedirs(os.path.join(root, "hertzian"))
    for name in ("ensemble", "sweeps"):
        os.symlink(os.path.join(repo, name), os.path.join(root, "hertzian", name))
    if rev is None:
        os.symlink(os.path.join(repo, "kernels"), os.path.join(root, "hertzian", "kernels"))
    else:
        archive = subprocess.run(["git", "-C", repo, "archive", rev, "kernels"], capture_output=True, check=True).stdout
        subprocess.run(["tar", "-x", "-C", os.path.join(root, "hertzian")], input=archive, check=True)
    return root


def event_path_lines(cu: list[str]) -> set[int]:
    """1-based .cu lines of the event path: the event step's functions, and in the kernel the loop over
    flagged grains (after the change) or each ``if flagged:`` block (before)."""

    def block_end(start: int) -> int:
        depth, opened = 0, False
        for i in range(start, len(cu)):
            for ch in cu[i].split("//")[0]:
                depth += ch == "{"
                depth -= ch == "}"
                opened = opened or ch == "{"
            if opened and depth == 0:
                return i
        raise ValueError("unbalanced braces")

    lines: set[int] = set()
    helpers = r"__locals__(event_step|event_step_call|taylor|acceleration|jerks|excess_force|derivatives)_\d+\($"
    for i, line in enumerate(cu):
        if re.match(r"^static .*" + helpers, line):
            lines.update(range(i + 1, block_end(i) + 2))
        if "// while event_bits != 0:" in line:
            end = next(k for k in range(i, len(cu)) if "end_while_" in cu[k] and "goto" not in cu[k])
            lines.update(range(i + 1, end + 2))
        if re.search(r"// if flagged:\s+<L", line):
            opening = next(k for k in range(i + 1, len(cu)) if "{" in cu[k].split("//")[0])
            lines.update(range(i + 1, block_end(opening) + 2))
    return lines


def sass_counts(cu_path: str, cubin: str) -> dict:
    nvdisasm = os.environ.get("NVDISASM") or shutil.which("nvdisasm")
    sass = subprocess.run([nvdisasm, "-gi", cubin], capture_output=True, text=True, check=True).stdout
    event_lines = event_path_lines(open(cu_path).read().split("\n"))
    counts = {where: {"instructions": 0, "STL": 0, "LDL": 0} for where in ("event_path", "rest")}
    calls = 0
    chain: list[int] = []
    fresh = False
    section = ""
    for line in sass.split("\n"):
        if ".section" in line and ".text." in line:
            section = line
        if line.lstrip().startswith("//## File"):
            if not fresh:
                chain, fresh = [], True
            chain += [int(n) for n in re.findall(r'\.cu", line (\d+)', line)]
            continue
        match = re.match(r"\s+/\*[0-9a-f]{4,}\*/\s+(\S+)(.*)", line)
        if not match or not ("cuda_kernel_forward" in section or "event_step" in section):
            continue
        fresh = False
        op, rest = match.groups()
        if op.startswith("CALL") and "event_step" in rest:
            calls += 1
        where = "event_path" if "event_step" in section or any(n in event_lines for n in chain) else "rest"
        counts[where]["instructions"] += 1
        for kind in ("STL", "LDL"):
            counts[where][kind] += op.startswith(kind)
    return {"sass_instructions": counts, "event_step_call_instructions": calls}


def worker(root: str, inline: str, out_dir: str) -> list[dict]:
    sys.path.insert(0, root)
    import warp as wp

    wp.config.quiet = True
    wp.init()
    import warp._src.build as build
    from warp._src.context import ModuleBuilder, runtime

    import hertzian.kernels.tile
    from hertzian.kernels.features import Features
    from hertzian.kernels.tile import TileShape, tile_kernel

    assert os.path.realpath(hertzian.kernels.tile.__file__).startswith(os.path.realpath(root)) or \
        hertzian.kernels.tile.__file__.startswith(root), hertzian.kernels.tile.__file__

    rows = []
    for G, window in CASES:
        features = Features(method="gear4", surface="wall", bottom="wall", static="none", event_window=window)
        keywords = {} if inline == "default" else {"inline_event_step": inline == "inline"}
        shape = TileShape(G, -(-GRAINS // G), **keywords)
        kernel = tile_kernel(features, shape)
        options = dict(kernel.module.options, block_dim=shape.block_dim)
        source = ModuleBuilder(kernel.module, options, target="cuda").codegen("cuda")
        stem = os.path.join(out_dir, f"tile_G{G}_w{window}_{inline}")
        open(stem + ".cu", "w").write(source)
        started = time.perf_counter()
        build.build_cuda(stem + ".cu", 90, stem + ".ptx", config="release", optimization_level=3,
                         fuse_fp=options["fuse_fp"], lineinfo=True, pch_dir=runtime.get_nvrtc_pch_dir(),
                         use_precompiled_headers=False)
        nvrtc_s = time.perf_counter() - started
        ptx = open(stem + ".ptx").read().replace("\x00", "")
        ptx = re.sub(r"^\.version \S+", ".version 9.0", ptx, flags=re.M)  # an older ptxas reads ISA 9.0
        open(stem + ".ptx", "w").write(ptx)
        started = time.perf_counter()
        log = subprocess.run(["ptxas", "-arch=sm_90", "-O3", "-v", "-lineinfo", stem + ".ptx", "-o", stem + ".cubin"],
                             capture_output=True, text=True, check=True).stderr
        ptxas_s = time.perf_counter() - started
        functions = []
        for name, props, used in re.findall(r"Function properties for (\S+)\n\s*(.*?)\n(?:ptxas info\s*: (Used.*))?",
                                            log):
            functions.append({"function": "kernel" if "cuda_kernel_forward" in name else
                              "event_step" if "event_step" in name else name[-40:], "properties": props.strip(),
                              "used": used.strip()})
        rows.append({"grains_per_lane": G, "lanes": shape.lanes_per_chain, "event_window": window,
                     "ptx_lines": ptx.count("\n"), "ptxas_functions": functions,
                     "nvrtc_s": round(nvrtc_s, 1), "ptxas_s": round(ptxas_s, 1), **sass_counts(stem + ".cu", stem + ".cubin")})
    return rows


def main() -> None:
    if sys.argv[1] == "--worker":
        print(json.dumps(worker(*sys.argv[2:5])))
        return
    before = sys.argv[1]
    repo = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    head = subprocess.run(["git", "-C", repo, "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout
    ptxas = subprocess.run(["ptxas", "--version"], capture_output=True, text=True).stdout.strip().splitlines()[-1]
    result = {"date": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
              "device": "none: code generated and compiled on the development machine's CPU (no GPU); sm_90 = H100",
              "command": f"python docs/logs/tile_events_code.py {before}", "commit": head.strip(),
              "tools": {"warp": __import__("warp").config.version, "ptxas": ptxas}, "variants": {}}
    out_dir = tempfile.mkdtemp(prefix="tile-events-code-out-")
    for label, rev, inline in ((f"before ({before}): event step per grain", before, "default"),
                               ("after: one event step, inlined", None, "inline"),
                               ("after: one event step, out of line (inline_event_step=False)", None, "call")):
        env = dict(os.environ, PYTHONPATH="")
        run = subprocess.run([sys.executable, __file__, "--worker", package(repo, rev), inline, out_dir],
                             capture_output=True, text=True, env=env, check=True)
        result["variants"][label] = json.loads(run.stdout.strip().splitlines()[-1])
    print(json.dumps(result, indent=1))


if __name__ == "__main__":
    main()
