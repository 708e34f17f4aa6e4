"""The protector study's raw record (docs/design.md): each part is a design run to its end and compared with plain
protectors (hertzian.studies.design.compare, as ``hertzian plot DESIGN.zarr`` writes it), merged under its name into
one JSON file.

``python -m hertzian.studies.design_record --out docs/records/design/protector_cpu.json --part beads_20
--design sweeps/protector.toml [--set design.population=6400 --set scene.chain.grains=40 ...] [--store DIR] [--resume]`` (``--resume``: finish
or reuse a stopped store of the same design, which equals running it straight through).
"""

from __future__ import annotations

import argparse
import json
import platform
from pathlib import Path

from hertzian.core.outputs import exit_unless_replaceable


def design_part(design: str, overrides: dict, scene_overrides: dict, store: Path, device: str, resume: bool) -> dict:
    """Run (or finish) the design into ``store`` and return its comparison, the traces left out."""
    from hertzian.core.shipped import shipped_file
    from hertzian.studies.design import compare, load_design, optimise

    scene, spec = load_design(shipped_file(design), overrides, scene_overrides)
    optimise(scene, spec, store, device=device, resume=resume and store.exists())
    summary = compare(store, device)
    return {k: v for k, v in summary.items() if k != "traces"}


def main() -> None:
    from hertzian.core.scene import parse_overrides
    from hertzian.studies.design import split_overrides

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", required=True, type=Path)
    parser.add_argument("--part", required=True, help="the name this design is recorded under")
    parser.add_argument("--design", required=True, help="a design file (or a shipped one's name)")
    parser.add_argument("--set", action="append", default=[], help="design.KEY=VALUE or scene.SECTION.KEY=VALUE")
    parser.add_argument("--store", type=Path, help="the design store (default: PART.zarr here)")
    parser.add_argument("--resume", action="store_true")
    parser.add_argument("--device", default="cpu")
    args = parser.parse_args()
    exit_unless_replaceable(args.out, "--out")
    overrides, scene_overrides = split_overrides(parse_overrides(args.set))
    store = args.store or Path(f"{args.part}.zarr")
    part = {
        "command": "python -m hertzian.studies.design_record "
        f"--out {args.out} --part {args.part} --design {args.design}" + "".join(f" --set {item}" for item in args.set),
        "platform": platform.platform(),
        **design_part(args.design, overrides, scene_overrides, store, args.device, args.resume),
    }
    record = json.loads(args.out.read_text()) if args.out.exists() else {}
    record[args.part] = part
    args.out.write_text(json.dumps(record, indent=1) + "\n")


if __name__ == "__main__":
    main()
