"""What does one record cost the device on the driven 10 000-grain columns (issue 11, Figs. 9-10)?

    python3 docs/gpu_logs/record_probe.py [--device cuda] [--repeats 200] [--out record_probe.json]

Builds the two columns of sweeps/paper_fig9_10.toml (driven, g = 1, fixed bottom, events off, v recorded) on the
kernel the runner picks, then times on the device (CUDA events around ``repeats`` repetitions, nothing else
queued): the record's check kernels alone, its copies to the host alone, a whole ``Recorder.record`` (check,
copies, unpacking of the record two back), the one-stage reduction of record_parts alone (the recorder takes
the two-stage one for chains this long), and one advance of 2000 steps (the gap between two records).
"""

import argparse
import json
import time

import warp as wp

from hertzian.ensemble.model import build_model
from hertzian.ensemble.runner import Runner
from hertzian.ensemble.scene import scene_from_dict

SCENE = {
    "chain": {"grains": 10000, "gravity": 1.0},
    "boundary": {"surface": "driven", "bottom": "fixed"},
    "excitation": {"drive_amplitude": 2.0, "drive_period": 10.0},
    "integrator": {"method": "gear4", "events": "off", "dt": 1.25e-4, "duration": 500.0},
    "record": {"every": 0.25, "fields": ["v"]},
}


def device_seconds(device, repeats, action) -> tuple[float, float]:
    """(device seconds, host seconds) per repetition of ``action()``."""
    action()
    wp.synchronize_device(device)
    if not device.is_cuda:  # the CPU runs each action as it is called
        clock = time.perf_counter()
        for _ in range(repeats):
            action()
        return (time.perf_counter() - clock) / repeats, (time.perf_counter() - clock) / repeats
    stream = wp.get_stream(device)
    start = stream.record_event(wp.Event(device, enable_timing=True))
    clock = time.perf_counter()
    for _ in range(repeats):
        action()
    host = time.perf_counter() - clock
    end = stream.record_event(wp.Event(device, enable_timing=True))
    wp.synchronize_device(device)
    return wp.get_event_elapsed_time(start, end) / 1e3 / repeats, host / repeats


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--device", default="cuda")
    parser.add_argument("--repeats", type=int, default=200)
    parser.add_argument("--out", default="record_probe.json")
    args = parser.parse_args()
    wp.init()
    device = wp.get_device(args.device)
    model = build_model([scene_from_dict(SCENE), scene_from_dict({**SCENE, "excitation": {
        "drive_amplitude": 2.0, "drive_period": 1.0}})], args.device)
    runner = Runner(model)
    rec, state = runner.recorder, runner.current
    rec.load()
    wp.load_module(rec.kernels.parts.module, device=device)  # the one-stage reduction, timed for comparison
    buf = rec.staging[0]
    rows = {"device": str(device), "kernel": runner.solver.describe(), "repeats": args.repeats}

    def copies():  # a record's copies: the state rows the scene keeps (v here), energy and work
        wp.copy(buf["energy"], rec.energy_now)
        wp.copy(buf["work"], rec.work_now)
        for row, name in enumerate(("u", "v")):
            if name in buf:
                wp.copy(buf[name], state.x[row])

    counter = iter(range(10 ** 9))

    def record():
        r = next(counter) % 2000
        rec.record(state, r, 2000 * r)

    for name, action in [("check", lambda: rec.check(state, 2000)),
                         ("parts_kernel", lambda: wp.launch(rec.kernels.parts, dim=rec.parts.shape[:2], block_dim=32, inputs=[
                             state.x, model.inverse_mass, model.contact_constant, model.static_overlap,
                             model.exponent, model.dt, state.dissipated], outputs=[rec.parts], device=device)),
                         ("copies", copies),
                         ("record", record),
                         ("advance_2000", lambda: runner.advance(2000))]:
        repeats = args.repeats if name != "advance_2000" else max(args.repeats // 10, 5)
        dev, host = device_seconds(device, repeats, action)
        rows[name] = {"device_ms": dev * 1e3, "host_ms": host * 1e3}
        print(f"{name}: device {dev * 1e3:.4f} ms, host {host * 1e3:.4f} ms per repetition", flush=True)
    rec.pending = [None] * rec.depth
    with open(args.out, "w") as f:
        json.dump(rows, f, indent=1)


if __name__ == "__main__":
    main()
