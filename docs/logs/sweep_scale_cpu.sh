#!/bin/bash
# Measures sweep planning/expansion and a real CPU sweep; prints the raw log kept in
# docs/logs/sweep_scale_cpu.txt. Usage, from the repository root:
#   git archive f3b003b | tar -x -C OLD_DIR        # the code before the change, for "before"
#   bash docs/logs/sweep_scale_cpu.sh "$PWD" OLD_DIR > docs/logs/sweep_scale_cpu.txt
set -u
REPO=$1; OLD=$2
cd "$(mktemp -d)"
# 10^4 and 10^5 points: sweeps/million.toml with 1 and 10 impurity masses
sed 's/logspace = \[-1, 1, 100\]/logspace = [-1, 1, 1]/' "$REPO/sweeps/million.toml" > m10k.toml
sed 's/logspace = \[-1, 1, 100\]/logspace = [-1, 1, 10]/' "$REPO/sweeps/million.toml" > m100k.toml
echo "date: $(date -u +%Y-%m-%dT%H:%M:%SZ)"
echo "device: CPU of the development machine, $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs); shared with other jobs (load average below)"
echo "python: $(python --version 2>&1), numpy $(python -c 'import numpy; print(numpy.__version__)'), zarr $(python -c 'import zarr; print(zarr.__version__)'), warp $(python -c 'import warp; print(warp.config.version)' 2>/dev/null)"
echo "commit: $(git -C $REPO rev-parse --short HEAD) (branch sweeps; before the change: f3b003b)"
echo
T='process wall %e s, user %U s, sys %S s, max RSS %M KiB'
echo "== 1. before: 10^4-point dry run with one Scene per point (code of f3b003b) =="
echo "\$ hertzian sweep m10k.toml --dry-run --device cpu      # sweeps/million.toml with impurity_mass reduced to 1 value"
echo "load average: $(cut -d' ' -f1-3 /proc/loadavg)"
/usr/bin/time -f "$T" env PYTHONPATH=$OLD python -m ensemble.cli sweep m10k.toml --dry-run --device cpu 2>&1 | grep -v CUDA | head -3
/usr/bin/time -f "$T" env PYTHONPATH=$OLD python -m ensemble.cli sweep m10k.toml --dry-run --device cpu 2>&1 | grep "process wall"
echo "\$ hertzian sweep m100k.toml --dry-run --device cpu     # impurity_mass with 10 values: 10^5 points"
echo "load average: $(cut -d' ' -f1-3 /proc/loadavg)"
/usr/bin/time -f "$T" env PYTHONPATH=$OLD python -m ensemble.cli sweep m100k.toml --dry-run --device cpu 2>&1 | grep -v CUDA | grep "points:\|process wall"
echo
echo "== 2. after: the same 10^4-point dry run =="
echo "load average: $(cut -d' ' -f1-3 /proc/loadavg)"
/usr/bin/time -f "$T" env PYTHONPATH=$REPO python -m ensemble.cli sweep m10k.toml --dry-run --device cpu --json 2>&1 | grep -v "CUDA\|^ *[0-9]\|^ *batch \|^  group"
/usr/bin/time -f "$T" env PYTHONPATH=$REPO python -m ensemble.cli sweep m100k.toml --dry-run --device cpu --json 2>&1 | grep -v CUDA | grep "points:\|process wall\|expand\|plan\"\|load\""
echo
echo "== 3. after: 10^6-point dry run (sweeps/million.toml), three times =="
for i in 1 2 3; do
echo "\$ hertzian sweep sweeps/million.toml --dry-run --device cpu --json"
echo "load average: $(cut -d' ' -f1-3 /proc/loadavg)"
/usr/bin/time -f "$T" env PYTHONPATH=$REPO python -m ensemble.cli sweep $REPO/sweeps/million.toml --dry-run --device cpu --json 2>&1 | grep -v "CUDA\|^ *[0-9]\|^ *batch \|^ *…\|^  group"
done
echo
echo "== 4. after: a real 10^5-point sweep on the CPU (sweeps/cpu_100k.toml), twice =="
for i in 1 2; do
rm -rf cpu_100k.zarr
echo "\$ hertzian sweep sweeps/cpu_100k.toml --out cpu_100k.zarr --device cpu --quiet --json"
echo "load average: $(cut -d' ' -f1-3 /proc/loadavg)"
/usr/bin/time -f "$T" env PYTHONPATH=$REPO python -m ensemble.cli sweep $REPO/sweeps/cpu_100k.toml --out cpu_100k.zarr --device cpu --quiet --json 2>&1 | grep -v CUDA
done
echo
echo "== 5. summarize of the 10^5-point store =="
echo "\$ hertzian summarize cpu_100k.zarr --rows 3"
/usr/bin/time -f "$T" env PYTHONPATH=$REPO python -m ensemble.cli summarize cpu_100k.zarr --rows 3 2>&1 | grep -v CUDA
echo "\$ hertzian summarize cpu_100k.zarr --json > /dev/null"
/usr/bin/time -f "$T" env PYTHONPATH=$REPO python -m ensemble.cli summarize cpu_100k.zarr --json 2>&1 >/dev/null | grep -v CUDA
echo "load average at the end: $(cut -d' ' -f1-3 /proc/loadavg)"
