"""How fast the host reads what the GPU copied back (the detection library's 1.2 GB of traces, issue 14).

    python3 docs/logs/detection/host_copy_probe.py [--gib 1]

Times, for a page-locked (Warp ``pinned=True``) and a pageable host array of the same size: the device → host
copy, then numpy dividing it by a scalar into a second array whose pages are already mapped (the recorder's
unpacking), and the same division reading an ordinary numpy array, as a reference.
"""

import argparse
import json
import time

import numpy as np
import warp as wp


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--gib", type=float, default=1.0)
    args = parser.parse_args()
    wp.init()
    count = int(args.gib * (1 << 30)) // 8
    device = wp.empty(count, dtype=wp.float64, device="cuda")
    device.fill_(1.5)
    target = np.empty(count)
    target.fill(0.0)
    out = {"gib": args.gib}
    for pinned in (True, False):
        clock = time.perf_counter()
        host = wp.empty(count, dtype=wp.float64, device="cpu", pinned=pinned)
        allocate = time.perf_counter() - clock
        clock = time.perf_counter()
        wp.copy(host, device)
        wp.synchronize()
        copy = time.perf_counter() - clock
        view = host.numpy()
        clock = time.perf_counter()
        np.divide(view, 0.5, out=target)
        divide = time.perf_counter() - clock
        clock = time.perf_counter()
        np.divide(view, 0.5, out=target)
        again = time.perf_counter() - clock
        out["pinned" if pinned else "pageable"] = {"allocate_s": allocate, "copy_s": copy, "divide_s": divide,
                                                   "divide_again_s": again}
    plain = np.full(count, 1.5)
    clock = time.perf_counter()
    np.divide(plain, 0.5, out=target)
    out["numpy_divide_s"] = time.perf_counter() - clock
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
