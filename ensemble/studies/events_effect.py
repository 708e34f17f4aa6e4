"""How much the reproduction's numbers move with event-aware steps (docs/reproduction.md).

The figure groups of a measurements record (``hertzian reproduce … --json RECORD``, whose groups take the sweep files'
plain Gear steps) are run again with ``--events auto`` on the same device, into a temporary folder, and every number
the two records' measurements share is compared: how many there are, the largest relative change and where, and per
group the median change, the largest energy error with each setting and the wall seconds with each. The result is
written under ``parts.<part>`` of ``--out`` (other parts kept):

    python -m hertzian.studies.events_effect docs/records/reproduction/measurements.json \\
        --out docs/records/reproduction/measurements.json --part events_auto
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
import tempfile
from pathlib import Path
from statistics import median

from hertzian.core.outputs import exit_unless_replaceable, provenance, write_part


def numbers(value, path: str = "") -> dict[str, float]:
    """Every finite number (booleans left out) in a nested measurement, by its path."""
    if isinstance(value, dict):
        return {k: v for key, item in value.items() for k, v in numbers(item, f"{path}/{key}").items()}
    if isinstance(value, list):
        return {k: v for i, item in enumerate(value) for k, v in numbers(item, f"{path}[{i}]").items()}
    if isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value):
        return {path: float(value)}
    return {}


def relative_change(a: float, b: float) -> float:
    """|a − b| / max(|a|, |b|), 0 where both are 0."""
    scale = max(abs(a), abs(b))
    return abs(a - b) / scale if scale else 0.0


def compare(plain: dict, auto: dict) -> dict:
    """The measurements of the groups both records hold, number by number (:func:`numbers`), and per group."""
    groups, largest, count = {}, (0.0, ""), 0
    for name, group in plain["groups"].items():
        if name not in auto["groups"]:
            continue
        before = numbers(group["measurements"])
        after = numbers(auto["groups"][name]["measurements"])
        changes = {path: relative_change(before[path], after[path]) for path in before.keys() & after.keys()}
        count += len(changes)
        worst = max(changes.items(), key=lambda item: item[1], default=("", 0.0))
        largest = max(largest, (worst[1], f"{name}{worst[0]}"))
        groups[name] = {
            "numbers": len(changes),
            "median_change": median(changes.values()) if changes else 0.0,
            "largest_change": worst[1],
            "largest_at": worst[0],
            "energy_error_max": {"off": group["energy_error_max"], "auto": auto["groups"][name]["energy_error_max"]},
            "wall_seconds": {"off": group["wall_seconds"], "auto": auto["groups"][name]["wall_seconds"]},
        }
    return {"numbers": count, "largest_change": largest[0], "largest_at": largest[1], "groups": groups}


def run_with_events(plain: dict, device: str, folder: Path) -> dict:
    """The plain record's figure groups again with ``--events auto``, measured into a record in ``folder``."""
    figures = [a for name in plain["groups"] for a in ("--figure", name)]
    record = folder / "auto.json"
    command = [sys.executable, "-m", "hertzian.cli", "reproduce", *figures, "--events", "auto", "--device", device]
    subprocess.run([*command, "--out-dir", str(folder / "out"), "--json", str(record)], check=True)
    return json.loads(record.read_text())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("plain", type=Path, help="a measurements record of plain steps (hertzian reproduce --json)")
    parser.add_argument("--out", required=True, type=Path, help="JSON record (its other parts are kept)")
    parser.add_argument("--part", default="events_auto")
    parser.add_argument("--device", default="cpu")
    args = parser.parse_args()
    if not args.plain.is_file():
        parser.exit(2, f"error: PLAIN = {str(args.plain)!r}: no such file\n")
    plain = json.loads(args.plain.read_text())
    if "groups" not in plain or "--events" in plain.get("command", ""):
        parser.exit(2, f"error: PLAIN = {str(args.plain)!r}: not a measurements record of the sweep files' steps\n")
    exit_unless_replaceable(args.out, "--out")
    with tempfile.TemporaryDirectory() as folder:
        auto = run_with_events(plain, args.device, Path(folder))
    result = {
        "command": f"python -m hertzian.studies.events_effect {args.plain} --out {args.out} --part {args.part}"
        + (f" --device {args.device}" if args.device != "cpu" else ""),
        **provenance(args.device),
        "plain_date": plain["date"],
        **compare(plain, auto),
    }
    write_part(args.out, args.part, result)
    print(
        f"wrote {args.out} (part {args.part}): {result['numbers']} numbers, largest change {result['largest_change']:.2g}"
    )


if __name__ == "__main__":
    main()
