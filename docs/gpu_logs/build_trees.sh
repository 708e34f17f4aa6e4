#!/usr/bin/env bash
# The package trees that the seventh session's comparison and ablation groups of h100_session.sh time beside the
# working tree (nov29a: old; nov29d: abl; nov29j: abl2; nov29n: abl3), rebuilt from this repository's history and
# the patches committed with their logs. Run on the development machine, from the repository root, before the
# upload (the trees go under .trees/, which git ignores; carry it to the GPU host):
#   bash docs/gpu_logs/build_trees.sh
set -euo pipefail
LOGS=docs/gpu_logs/h100_2026-11-26f
tree() {  # tree NAME COMMIT [PATCH]: the package folders (and the probe scripts) of COMMIT, with PATCH applied
  local name="$1" commit="$2" patch="${3:-}"
  rm -rf ".trees/$name" && mkdir -p ".trees/$name"
  git archive "$commit" ensemble kernels sweeps docs/bench | tar -x -C ".trees/$name"
  mkdir -p ".trees/$name/docs/gpu_logs"
  for f in frontier_events_probe.py event_variants.py scene_probe.py window_probe.py; do
    git show "$commit:docs/gpu_logs/$f" > ".trees/$name/docs/gpu_logs/$f" 2>/dev/null || rm -f ".trees/$name/docs/gpu_logs/$f"
  done
  [ -f ".trees/$name/docs/gpu_logs/frontier_events_probe.py" ] || git show 3e2a631:docs/gpu_logs/frontier_events_probe.py \
    > ".trees/$name/docs/gpu_logs/frontier_events_probe.py"
  if [ -n "$patch" ]; then patch -s -p1 -d ".trees/$name" < "$patch"; fi
}
tree old 0cb09e6                                  # the event path before the seventh session
tree abl f30c0b3 "$LOGS/ablate_tile.patch"        # HZ_ABLATE 0-6
tree abl2 1652f05 "$LOGS/ablate2.patch"           # register caps in the variant names, HZ_ABLATE 7, 8
tree abl3 d49645a "$LOGS/ablate3.patch"           # HZ_ABLATE 9
echo "built: $(ls .trees)"
