#!/usr/bin/env bash
# Where the event-aware steps' extra error comes from at gpu_10k's strongest impact on its loosest chain
# (docs/stability.md §6c), on a 60-grain version (v_imp = 0.1, l0 = 1e-6, t ≤ 0.5, snapshots every 0.05):
# gear4 with event steps at dt = 1e-4, 5e-5, 2.5e-5 with the shipped constants, with 32 Runge–Kutta
# substeps instead of 8 (kernels/events.py SUBSTEPS), and with event windows of 1e-4, 1e-3 and 1e-1
# instead of 1e-2 (kernels/features.py EVENT_WINDOW); each variant runs from a copy of the package with
# that one constant edited. Run from the repository root:  bash docs/accuracy/event_error_probe.sh
set -eu
REPO="$(pwd)"
ARGS=(accuracy docs/accuracy/gpu10k_point.toml --set excitation.impact=0.1 --set chain.l0=1e-6
      --set chain.grains=60 --set integrator.duration=0.5 --set record.every=0.05 --methods gear4
      --dt 1e-4,5e-5,2.5e-5 --device cpu)
variant() {  # variant LABEL FILE SED-EXPRESSION EVENTS
  local work; work="$(mktemp -d)"
  mkdir -p "$work/hertzian"
  for d in ensemble kernels sweeps; do cp -r "$REPO/$d" "$work/hertzian/$d"; done
  [ -n "$2" ] && sed -i "$3" "$work/hertzian/$2"
  echo "== $1 (events $4)"
  HERTZIAN_CACHE="$work/calibration.json" PYTHONPATH="$work" python -m hertzian.ensemble.cli "${ARGS[@]}" --events "$4" 2>&1 \
    | grep -E "│ gear4|reference:" | sed 's/│/|/g'
  rm -rf "$work"
}
date -u; python -c "import warp; print('warp', warp.config.version)"; git -C "$REPO" rev-parse --short HEAD
variant "shipped constants" "" "" both
variant "SUBSTEPS = 32" kernels/events.py 's/^SUBSTEPS = 8$/SUBSTEPS = 32/' auto
for w in 1e-4 1e-3 1e-1; do
  variant "EVENT_WINDOW = $w" kernels/features.py "s/^EVENT_WINDOW = 1e-2$/EVENT_WINDOW = $w/" auto
done
