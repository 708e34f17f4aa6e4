#!/usr/bin/env bash
# Eighth session: Nsight Compute warp-stall samples (4 launches each) of the 1000-grain window kernels: the impact, the
# driven as committed, and the driven with the phases in two registers in turn (commit da6a75f, reverted), whose tree
# is rebuilt by: mkdir -p .trees/rot && git archive da6a75f ensemble kernels sweeps docs/bench \
#     docs/gpu_logs/stall_probe.py | tar -x -C .trees/rot     (carry .trees to the GPU host)
# Run from the repository root with Warp importable (PYTHONPATH set as for h100_session.sh); the profiles come back
# as $OUT/prof.tgz.
set -u
SITE="$(python3 -c 'import os, warp; print(os.path.dirname(os.path.dirname(warp.__file__)))')"
mkdir -p /tmp/hz/hertzian /tmp/hzrot/hertzian
for d in ensemble kernels sweeps; do ln -sfn $PWD/$d /tmp/hz/hertzian/$d; ln -sfn $PWD/.trees/rot/$d /tmp/hzrot/hertzian/$d; done
P=/tmp/prof; mkdir -p $P
run() { # name pythonpath script scene
  PYTHONPATH=$2:$SITE python3 $3 --scene $4 --launches 2 > $P/$1_warm.log 2>&1
  PYTHONPATH=$2:$SITE timeout 200 ncu --set full --kernel-name regex:fused --launch-skip 8 --launch-count 4 -f -o $P/$1 python3 $3 --scene $4 --launches 14 > $P/$1_ncu.log 2>&1
  ncu --import $P/$1.ncu-rep --page source --csv --print-source sass > $P/$1_sass.csv 2>$P/$1_sass.err
  gzip -f $P/$1_sass.csv; rm -f $P/$1.ncu-rep
}
run impact /tmp/hz docs/gpu_logs/stall_probe.py impact_1000
run driven /tmp/hz docs/gpu_logs/stall_probe.py driven_1000
run driven_rot /tmp/hzrot .trees/rot/docs/gpu_logs/stall_probe.py driven_1000
ls -la $P; tail -2 $P/*_ncu.log
cd $P && tar czf $OUT/prof.tgz .
