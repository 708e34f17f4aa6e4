"""Compare two `hertzian reproduce` logs number by number (e.g. the default event-aware steps against
`--events off`): for every run present in both, the largest relative difference over its numeric
measurements, the quantity where it occurs, and both runs' energy errors and wall seconds.

    python docs/logs/reproduce_events_compare.py AUTO/log.json OFF/log.json > docs/logs/reproduce_events_gpu.txt
"""

import json
import math
import sys


def leaves(x, prefix=""):
    if isinstance(x, dict):
        for k, v in x.items():
            yield from leaves(v, f"{prefix}.{k}" if prefix else str(k))
    elif isinstance(x, list):
        for i, v in enumerate(x):
            yield from leaves(v, f"{prefix}[{i}]")
    elif isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x):
        yield prefix, float(x)


def main(a_path, b_path):
    a, b = json.load(open(a_path)), json.load(open(b_path))
    runs_b = {r["name"]: r for r in b["runs"]}
    print(f"A: {a_path} ({a.get('command')}, {a.get('date')}, {a.get('device_name')})")
    print(f"B: {b_path} ({b.get('command')}, {b.get('date')}, {b.get('device_name')})")
    print("| run | numbers compared | largest relative difference | where | median | energy error A → B | wall s A → B |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for ra in a["runs"]:
        rb = runs_b.get(ra["name"])
        if rb is None:
            continue
        la = dict(leaves(ra.get("measurements", {})))
        lb = dict(leaves(rb.get("measurements", {})))
        diffs = []
        for k in la.keys() & lb.keys():
            x, y = la[k], lb[k]
            scale = max(abs(x), abs(y))
            if scale > 0:
                diffs.append((abs(x - y) / scale, k))
        diffs.sort()
        worst = diffs[-1] if diffs else (math.nan, "—")
        median = diffs[len(diffs) // 2][0] if diffs else math.nan
        print(f"| {ra['name']} | {len(diffs)} | {worst[0]:.2g} | {worst[1]} | {median:.2g} | "
              f"{ra.get('energy_error_max', math.nan):.2g} → {rb.get('energy_error_max', math.nan):.2g} | "
              f"{ra.get('wall_seconds', math.nan):.1f} → {rb.get('wall_seconds', math.nan):.1f} |")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
