#!/usr/bin/env bash
# CPU timing of `hertzian detect` on the 150-grain planted signal with the library cached, before (BEFORE:
# a git revision, run from a copy of its package) and after (the working tree), interleaved three times.
# Used twice: 62ba50e → 50c104c (the refinement's candidate runs moved from the per-step kernel to the
# sweep kernel, trace samples written inside its launch) and 50c104c → later (the library RSS in Gram form).
# Run from the repository root:
#   bash docs/logs/detection/refine_launches.sh BEFORE
set -eu
BEFORE="$1"; REPO="$(pwd)"; D=docs/logs/detection
export HERTZIAN_DETECT_CACHE="$(mktemp -d)"
OLD="$(mktemp -d)"; mkdir -p "$OLD/hertzian"
git -C "$REPO" archive "$BEFORE" ensemble kernels sweeps | tar -x -C "$OLD/hertzian"
date -u; echo "cores: $(nproc); load average: $(cut -d' ' -f1-3 /proc/loadavg); after: $(git rev-parse --short HEAD); before: $BEFORE"
hertzian run $D/planted150.toml --out /tmp/planted150.zarr --overwrite --device cpu 2>&1 | tail -1
DETECT=(detect /tmp/planted150.zarr --scene $D/base150.toml --noise 1e-5 --device cpu)
hertzian "${DETECT[@]}" 2>&1 | grep searched   # builds the library
for k in 1 2 3; do
  echo "## round $k"
  echo -n "before: "; PYTHONPATH="$OLD" python -m hertzian.ensemble.cli "${DETECT[@]}" 2>&1 | grep -o "refinement [0-9.]* s, total [0-9.]* s"
  echo -n "after:  "; hertzian "${DETECT[@]}" 2>&1 | grep -o "refinement [0-9.]* s, total [0-9.]* s"
done
echo "load average after: $(cut -d' ' -f1-3 /proc/loadavg)"
rm -rf "$OLD"
