#!/usr/bin/env bash
# The measurements of one GPU session, in groups that each fit a 10-minute call:
#   bash docs/gpu_logs/h100_session.sh GROUP [GROUP ...]
#   (GROUP: env tests kernels e2e off nofma warm drive fig910 repro detect events fixes next first drive2 probe drive3 drive4 frontier scenes settle final nov24 nov26a nov26b nov26c nov26d nov26e nov26f next27 nov26g nov26h nov26i nov26j nov26k nov26l nov26m nov26n nov26o nov26p nov26q nov26r nov26s nov26t nov26u nov26v nov26w nov26x nov26y nov26z nov26final nov26rec nov26rec2 nov27a nov27b nov27c nov27d nov27e nov27f nov27g nov27h nov27i nov27j nov27k nov27l nov27m nov27n nov27o nov27p nov28a nov28b nov28c nov28d nov28e nov28f nov28g nov28h nov28i nov28j nov28k nov28l nov29a nov29b nov29c nov29d nov29e nov29f nov29g nov29h nov29i nov29j nov29k nov29l nov29m nov29n nov29o nov29p nov29q nov30a nov30b nov30c nov30d nov30e nov30f nov30g nov30h nov30i)
# Every command's output goes to $LOGS/<name>.log (stdout JSON to <name>.json where the command prints
# one), with its wall time and exit code in $LOGS/summary.tsv. Each command has its own time limit, so one
# slow command does not lose the others. On a machine without a package index the package runs from the
# working tree: the folders are linked under one import name `hertzian` and put on PYTHONPATH.
set -u
LOGS="${LOGS:-/tmp/hzlogs}"
mkdir -p "$LOGS"
REPO="$(pwd)"
if ! python3 -c "import hertzian.ensemble" 2>/dev/null; then
  mkdir -p /tmp/hz/hertzian
  for d in ensemble kernels sweeps; do ln -sfn "$REPO/$d" "/tmp/hz/hertzian/$d"; done
  export PYTHONPATH="/tmp/hz:${PYTHONPATH:-}"
fi
export PYTHONUNBUFFERED=1
HZ="python3 -m hertzian.ensemble.cli"
WORK=/tmp/hzwork
mkdir -p "$WORK"
# the folder that holds the staged Warp (and zarr) packages, for the groups that run another package tree beside it
SITE="$(python3 -c 'import os, warp; print(os.path.dirname(os.path.dirname(warp.__file__)))' 2>/dev/null || true)"

step() {  # step NAME SECONDS COMMAND...   (stdout → NAME.json when it starts with [ or {, else NAME.log)
  local name="$1" limit="$2"; shift 2
  local t0 t1 rc
  t0=$(date +%s%N)
  echo "== $name: $*" | tee -a "$LOGS/commands.txt"
  timeout "$limit" bash -c "$*" >"$LOGS/$name.out" 2>"$LOGS/$name.err"
  rc=$?
  t1=$(date +%s%N)
  local ms=$(( (t1 - t0) / 1000000 ))
  printf "%s\t%s\t%d.%03d\t%s\n" "$name" "$rc" $((ms / 1000)) $((ms % 1000)) "$(date -u +%FT%TZ)" >>"$LOGS/summary.tsv"
  echo "   rc=$rc wall=$((ms / 1000)).$((ms % 1000 / 100)) s; stderr tail:"; tail -n 4 "$LOGS/$name.err"
  head -c 1 "$LOGS/$name.out" | grep -q '[[{]' && mv "$LOGS/$name.out" "$LOGS/$name.json"
}

scene_runs() {  # scene_runs TAG SCENE...: issue 11's 1000-grain scenes end to end (6e6 steps, events off), one run
  # then three more (warm), as steps e2e_SCENE_off_TAG and e2e_SCENE_off_TAG2 ... TAG4
  local tag="$1" s r; shift
  for s in "$@"; do
    step "e2e_${s}_off_${tag}" 150 "$HZ bench --device cuda --scene docs/bench/$s.toml --set integrator.duration=300 --set integrator.events=off --json"
    for r in 2 3 4; do
      step "e2e_${s}_off_${tag}$r" 100 "$HZ bench --device cuda --scene docs/bench/$s.toml --set integrator.duration=300 --set integrator.events=off --json"
    done
  done
}

# the logs come back as one archive; a watchdog packs what is there before the call's limit
WATCHDOG_PID=""
if [ -n "${OUT:-}" ]; then
  (sleep "${WATCHDOG:-550}"; tar czf "$OUT/partial.tgz" -C "$LOGS" .) >/dev/null 2>&1 &
  WATCHDOG_PID=$!
fi
for group in "$@"; do
case "$group" in
env)
  step env 60 "nvidia-smi; python3 -c 'import warp as wp; wp.init(); print(wp.__version__, wp.get_cuda_device())'; nproc; date -u"
  ;;
tests)
  # the device-fixture tests on CUDA (fused drive/traces/events against the per-step kernel, determinism, ...)
  step pytest_cuda 420 "python3 -m pytest -q -p no:cacheprovider -k cuda tests 2>&1"
  ;;
kernels)
  step bench_kernels 300 "$HZ bench --device cuda --chains 16384,16384,1,1 --grains 1000,4096,1000,10240 --repeats 3 --json"
  ;;
e2e)
  step e2e_gpu10k_cold 180 "$HZ bench --device cuda --cold --sweep sweeps/gpu_10k.toml --json"
  step e2e_gpu10k 120 "$HZ bench --device cuda --sweep sweeps/gpu_10k.toml --json"
  step e2e_gpu10k_notraces 120 "$HZ bench --device cuda --sweep sweeps/gpu_10k.toml --set 'record.traces=[]' --json"
  for s in impact_1000 impact_1000_traces driven_1000; do
    step "e2e_$s" 90 "$HZ bench --device cuda --scene docs/bench/$s.toml --json"
  done
  step million 180 "$HZ sweep sweeps/million.toml --out $WORK/million.zarr --overwrite --device cuda --quiet --json"
  ;;
drive)
  step e2e_fig9_10_t500 200 "$HZ bench --device cuda --sweep sweeps/paper_fig9_10.toml --json"
  step drive_map ${MAP_LIMIT:-240} "$HZ sweep sweeps/drive_map_gpu.toml --out $WORK/drive_map.zarr --overwrite --device cuda --quiet --json && $HZ plot $WORK/drive_map.zarr --figure drive_map --out $LOGS/drive_map_gpu.png"
  ;;
fig910)
  step fig9_10_tau10 300 "$HZ sweep sweeps/drive_fig9_10_gpu.toml --out $WORK/f910_tau10.zarr --overwrite --device cuda --quiet --json"
  step fig9_10_tau1 300 "$HZ sweep sweeps/drive_fig9_10_gpu.toml --set excitation.drive_period=1.0 --set record.response_periods=10 --out $WORK/f910_tau1.zarr --overwrite --device cuda --quiet --json"
  ;;
off)
  # the same workloads with plain Gear steps (integrator.events = "off"), the fast path measured on 2026-11-23
  step e2e_gpu10k_off 120 "$HZ bench --device cuda --sweep sweeps/gpu_10k.toml --set integrator.events=off --json"
  step e2e_gpu10k_notraces_off 90 "$HZ bench --device cuda --sweep sweeps/gpu_10k.toml --set 'record.traces=[]' --set integrator.events=off --json"
  step e2e_fig9_10_t500_off 150 "$HZ bench --device cuda --sweep sweeps/paper_fig9_10.toml --set integrator.events=off --json"
  step million_off 200 "$HZ sweep sweeps/million.toml --out $WORK/million.zarr --overwrite --device cuda --quiet --json --set integrator.events=off"
  ;;
nofma)
  # with HERTZIAN_FUSE_FP=0 (no FMA contraction) the fused kernels should equal the per-step kernel bit for bit
  step pytest_cuda_nofma 150 "HERTZIAN_FUSE_FP=0 python3 -m pytest -q -p no:cacheprovider tests/test_tile.py tests/test_fused_features.py -k 'cuda and (padded or (tile_traces and False) or (tile_drive and traces and False))' 2>&1"
  ;;
warm)
  step e2e_gpu10k 170 "$HZ bench --device cuda --sweep sweeps/gpu_10k.toml --json"
  step e2e_gpu10k_notraces 70 "$HZ bench --device cuda --sweep sweeps/gpu_10k.toml --set 'record.traces=[]' --json"
  step e2e_fig9_10_t500 130 "$HZ bench --device cuda --sweep sweeps/paper_fig9_10.toml --json"
  ;;
events)
  # the tile kernel's event-step variants on gpu_10k's chains (off / inline / out of line, G = 8 and 4)
  step event_variants 480 "python3 docs/gpu_logs/event_variants.py --out $LOGS/event_variants_table.json"
  ;;
fixes)
  # after the record reductions in parts and the out-of-line event step (second session of 2026-11-23)
  step e2e_fig9_10_t500_off 120 "$HZ bench --device cuda --sweep sweeps/paper_fig9_10.toml --set integrator.events=off --json"
  step e2e_fig9_10_t500 150 "$HZ bench --device cuda --sweep sweeps/paper_fig9_10.toml --json"
  step e2e_gpu10k 150 "$HZ bench --device cuda --sweep sweeps/gpu_10k.toml --json"
  step e2e_gpu10k_notraces 90 "$HZ bench --device cuda --sweep sweeps/gpu_10k.toml --set 'record.traces=[]' --json"
  ;;
next)
  # what the evening of 2026-11-23 changed without a GPU to measure it: in-launch traces of the tile/window
  # kernels (gpu_10k with traces, warm; the CUDA tests), the response windows (per-chain strides, phases per
  # chain), the planner, the warm reproduction, the build of a million-point batch
  step e2e_gpu10k_next 120 "$HZ bench --device cuda --sweep sweeps/gpu_10k.toml --json; $HZ bench --device cuda --sweep sweeps/gpu_10k.toml --json"
  step pytest_cuda_next 420 "python3 -m pytest -q -p no:cacheprovider -k cuda tests 2>&1"
  step drive_map_next 200 "$HZ sweep sweeps/drive_map_gpu.toml --out $WORK/drive_map.zarr --overwrite --device cuda --quiet --json"
  step reproduce_warm 400 "$HZ reproduce --device cuda --out-dir $WORK/repro >/dev/null 2>&1; $HZ reproduce --device cuda --out-dir $WORK/repro2"
  step profile_build 120 "python3 docs/gpu_logs/profile_build.py --batches 3"
  step million_next 120 "$HZ sweep sweeps/million.toml --out $WORK/million.zarr --overwrite --device cuda --quiet --json"
  ;;
first)
  # first call of the session of 2026-11-23 (night): what the evening changed, before new code
  step e2e_gpu10k_a 150 "$HZ bench --device cuda --sweep sweeps/gpu_10k.toml --json"
  step e2e_gpu10k_b 60 "$HZ bench --device cuda --sweep sweeps/gpu_10k.toml --json"
  step million_first 90 "$HZ sweep sweeps/million.toml --out $WORK/million.zarr --overwrite --device cuda --quiet --json"
  step drive_map_first 150 "$HZ sweep sweeps/drive_map_gpu.toml --out $WORK/drive_map.zarr --overwrite --device cuda --quiet --json"
  step profile_build_first 60 "python3 docs/gpu_logs/profile_build.py --batches 3"
  step detect_first ${DETECT_LIMIT:-200} "$HZ detect-study sweeps/detect_study_1000.toml --out $LOGS/study_1000_gpu.json --overwrite --device cuda"
  ;;
drive2)
  # the drive's sines and cosines from a shared table, one-warp windows among the calibration's candidates
  step pytest_cuda_drive 240 "python3 -m pytest -q -p no:cacheprovider tests/test_fused_features.py tests/test_tile.py -k cuda 2>&1"
  step e2e_fig9_10_t500_cold 200 "$HZ bench --device cuda --sweep sweeps/paper_fig9_10.toml --json"
  step e2e_fig9_10_t500_warm 100 "$HZ bench --device cuda --sweep sweeps/paper_fig9_10.toml --json"
  step drive_map_drive2 150 "$HZ sweep sweeps/drive_map_gpu.toml --out $WORK/drive_map.zarr --overwrite --device cuda --quiet --json"
  ;;
probe)
  # the window kernel alone on 10 000-grain columns, one feature changed at a time (docs/gpu_logs/window_probe.py)
  step window_probe_2 300 "python3 docs/gpu_logs/window_probe.py --chains 2 --out $LOGS/window_probe_2.json"
  step window_probe_64 150 "python3 docs/gpu_logs/window_probe.py --chains 64 --variants 0,4 --out $LOGS/window_probe_64.json"
  ;;
drive3)
  # the drive without run-time register indices (selects over the static positions)
  step window_probe3_2 120 "python3 docs/gpu_logs/window_probe.py --chains 2 --variants 0,4 --out $LOGS/window_probe3_2.json"
  step window_probe3_64 120 "python3 docs/gpu_logs/window_probe.py --chains 64 --variants 0 --out $LOGS/window_probe3_64.json"
  step e2e_fig9_10_t500_cold3 200 "$HZ bench --device cuda --sweep sweeps/paper_fig9_10.toml --json"
  step e2e_fig9_10_t500_warm3 100 "$HZ bench --device cuda --sweep sweeps/paper_fig9_10.toml --json"
  step drive_map3 150 "$HZ sweep sweeps/drive_map_gpu.toml --out $WORK/drive_map.zarr --overwrite --device cuda --quiet --json"
  ;;
drive4)
  # no dynamic loop in driver_work (range(G - 1) was not unrolled: the lane's matrices lived in local memory)
  step window_probe4_2 120 "python3 docs/gpu_logs/window_probe.py --chains 2 --variants 0,3 --out $LOGS/window_probe4_2.json"
  step window_probe4_64 120 "python3 docs/gpu_logs/window_probe.py --chains 64 --variants 0,3 --out $LOGS/window_probe4_64.json"
  step e2e_fig9_10_t500_cold4 200 "$HZ bench --device cuda --sweep sweeps/paper_fig9_10.toml --json"
  step e2e_fig9_10_t500_warm4 100 "$HZ bench --device cuda --sweep sweeps/paper_fig9_10.toml --json"
  step drive_map4 150 "$HZ sweep sweeps/drive_map_gpu.toml --out $WORK/drive_map.zarr --overwrite --device cuda --quiet --json"
  ;;
frontier)
  # time to energy error <= 1e-8 with 16 384 chains (issue 15): each method at its largest studied dt meeting it
  # on the CPU study docs/accuracy/frontier_methods_cpu.json (1000 grains, t = 20)
  F="$HZ bench --device cuda --sweep sweeps/frontier_16384.toml --json"
  step frontier_gear4_off_2e-4 150 "$F --set integrator.method=gear4 --set integrator.dt=2e-4 --set integrator.events=off"
  step frontier_gear6_off_2e-4 150 "$F --set integrator.method=gear6 --set integrator.dt=2e-4 --set integrator.events=off"
  step frontier_gear6_auto_8e-4 200 "$F --set integrator.method=gear6 --set integrator.dt=8e-4 --set integrator.events=auto"
  step frontier_gear4_auto_4e-4 200 "$F --set integrator.method=gear4 --set integrator.dt=4e-4 --set integrator.events=auto"
  ;;
scenes)
  for s in impact_1000 impact_1000_traces driven_1000; do
    step "e2e_$s" 60 "$HZ bench --device cuda --scene docs/bench/$s.toml --json"
  done
  ;;
settle)
  # Figs. 9-10 at full size to t = 5000 (both tau, A = 2, 0.2, 0.02) and at dt/2 over the response windows
  # (t <= 1000), reduced by docs/logs/fig9_10_settle.py; pictures of the A = 2 points
  S="$HZ sweep sweeps/drive_fig9_10_gpu.toml --device cuda --quiet --json --overwrite"
  T1="--set excitation.drive_period=1.0 --set record.response_periods=10"
  H="--set integrator.dt=6.25e-5 --set integrator.duration=1000 --set record.every=50"
  step settle_tau10 200 "$S --out $WORK/tau10.zarr"
  step settle_tau1 200 "$S $T1 --out $WORK/tau1.zarr"
  step settle_tau10_half 150 "$S $H --out $WORK/tau10_half.zarr"
  step settle_tau1_half 150 "$S $T1 $H --out $WORK/tau1_half.zarr"
  step settle_reduce 120 "python3 docs/logs/fig9_10_settle.py $WORK/tau10.zarr $WORK/tau1.zarr --half $WORK/tau10_half.zarr $WORK/tau1_half.zarr"
  step settle_plots 120 "$HZ plot $WORK/tau10.zarr --at A=2 --field v --out $LOGS/tau10_A2.png; $HZ plot $WORK/tau1.zarr --at A=2 --field v --out $LOGS/tau1_A2.png"
  ;;
final)
  # the last call of the night: the kernels on CUDA (bitwise), gpu_10k with and without traces, million with
  # the overlapped batch build, the reproduction cold and warm (plain Gear steps where the option exists)
  step pytest_cuda_final 200 "python3 -m pytest -q -p no:cacheprovider tests/test_fused_features.py tests/test_tile.py -k cuda 2>&1"
  step e2e_gpu10k_final_cold 120 "$HZ bench --device cuda --sweep sweeps/gpu_10k.toml --json"
  step e2e_gpu10k_final 60 "$HZ bench --device cuda --sweep sweeps/gpu_10k.toml --json"
  step e2e_gpu10k_notraces_final 60 "$HZ bench --device cuda --sweep sweeps/gpu_10k.toml --set 'record.traces=[]' --json"
  step million_final 90 "$HZ sweep sweeps/million.toml --out $WORK/million.zarr --overwrite --device cuda --quiet --json"
  EV=""; $HZ reproduce --help 2>/dev/null | grep -q -- "--events" && EV="--events off"
  step reproduce_final_cold ${REPRO_LIMIT:-200} "$HZ reproduce --device cuda $EV --out-dir $WORK/repro"
  cp "$WORK"/repro/log.json "$LOGS"/reproduce_cold_log.json 2>/dev/null
  step reproduce_final_warm ${REPRO_WARM_LIMIT:-120} "$HZ reproduce --device cuda $EV --out-dir $WORK/repro2"
  cp "$WORK"/repro2/log.json "$LOGS"/reproduce_warm_log.json 2>/dev/null
  ;;
nov24)
  # what 2026-11-24 (a session without a GPU) changed, measured in one call: the CUDA tests of the new paths
  # (device window sums, graphs of sampled runs), the reproduction cold and warm (--events off: fused kernels for
  # the short groups, windows summed on the device, figures in worker processes), the driven column end to end,
  # Figs. 9-10 to t = 5000 for tau = 1 (response samples every ~25 steps, now in replayed graphs)
  step pytest_cuda_nov24 200 "python3 -m pytest -q -p no:cacheprovider tests/test_drive.py tests/test_reproduce.py tests/test_solvers.py -k 'cuda or sampled_in_runs or host_loop' 2>&1"
  step reproduce_nov24_cold ${REPRO_LIMIT:-200} "$HZ reproduce --device cuda --events off --out-dir $WORK/repro"
  cp "$WORK"/repro/log.json "$LOGS"/reproduce_nov24_cold_log.json 2>/dev/null
  step reproduce_nov24_warm ${REPRO_WARM_LIMIT:-100} "$HZ reproduce --device cuda --events off --out-dir $WORK/repro2"
  cp "$WORK"/repro2/log.json "$LOGS"/reproduce_nov24_warm_log.json 2>/dev/null
  step e2e_fig9_10_t500_nov24 90 "$HZ bench --device cuda --sweep sweeps/paper_fig9_10.toml --json"
  step settle_tau1_nov24 120 "$HZ sweep sweeps/drive_fig9_10_gpu.toml --device cuda --quiet --json --overwrite --set excitation.drive_period=1.0 --set record.response_periods=10 --out $WORK/tau1.zarr"
  ;;
nov26a)
  # 2026-11-26 (an H200 was lent): issue 17's warm gpu_10k outside the GPU, the million sweep, issue 12's
  # Figs. 9-10 with both tau in one run (6 columns to t = 5000) and the 64-column response map
  step e2e_gpu10k_cold 150 "$HZ bench --device cuda --sweep sweeps/gpu_10k.toml --json"
  step e2e_gpu10k_warm 60 "$HZ bench --device cuda --sweep sweeps/gpu_10k.toml --json"
  step sweep_gpu10k_warm 60 "$HZ sweep sweeps/gpu_10k.toml --out $WORK/gpu10k.zarr --overwrite --device cuda --quiet --json"
  step million_nov26 120 "$HZ sweep sweeps/million.toml --out $WORK/million.zarr --overwrite --device cuda --quiet --json"
  step fig9_10_both 150 "$HZ sweep sweeps/drive_fig9_10_both_gpu.toml --out $WORK/both.zarr --overwrite --device cuda --quiet --json"
  step drive_map_nov26 150 "$HZ sweep sweeps/drive_map_gpu.toml --out $WORK/drive_map.zarr --overwrite --device cuda --quiet --json"
  ;;
nov26b)
  # the warm reproduction with its figures, and the detection study's target cases (1000 grains, 26 dB)
  step reproduce_nov26_warm ${REPRO_WARM_LIMIT:-120} "$HZ reproduce --device cuda --events off --out-dir $WORK/repro3"
  mkdir -p "$LOGS"/repro_nov26 && cp "$WORK"/repro3/log.json "$WORK"/repro3/*.png "$WORK"/repro3/*.json "$LOGS"/repro_nov26/ 2>/dev/null
  step detect_target ${DETECT_LIMIT:-400} "$HZ detect-study sweeps/detect_study_1000_target.toml --out $LOGS/study_1000_target_gpu.json --overwrite --device cuda"
  ;;
nov26c)
  # 2026-11-26 on an H100: issue 17 and the driven column on the card the targets name, one cached detection
  # profiled (issue 14), the weak-damping control of Figs. 9-10 (issue 12)
  step e2e_gpu10k_cold_h100 150 "$HZ bench --device cuda --sweep sweeps/gpu_10k.toml --json"
  step e2e_gpu10k_warm_h100 60 "$HZ bench --device cuda --sweep sweeps/gpu_10k.toml --json"
  step sweep_gpu10k_warm_h100 60 "$HZ sweep sweeps/gpu_10k.toml --out $WORK/gpu10k.zarr --overwrite --device cuda --quiet --json"
  step million_h100 120 "$HZ sweep sweeps/million.toml --out $WORK/million.zarr --overwrite --device cuda --quiet --json"
  step e2e_fig9_10_t500_h100 90 "$HZ bench --device cuda --sweep sweeps/paper_fig9_10.toml --json"
  step e2e_fig9_10_t500_h100_warm 60 "$HZ bench --device cuda --sweep sweeps/paper_fig9_10.toml --json"
  step detect_profile 200 "python3 docs/logs/detection/profile_detect.py --device cuda"
  step damped_control ${DAMPED_LIMIT:-150} "$HZ sweep sweeps/drive_fig9_10_damped_gpu.toml --out $WORK/damped.zarr --overwrite --device cuda --quiet --json"
  step damped_reduce 60 "python3 docs/logs/fig9_10_settle.py $WORK/damped.zarr"
  ;;
nov26d)
  # two GPUs of one host: the 10^4-point grid (duration 2) on one GPU, then one Dask worker per GPU
  S2="$HZ sweep sweeps/gpu_10k.toml --set integrator.duration=2.0 --device cuda --quiet --json --overwrite"
  step two_gpu_warmup 150 "$S2 --out $WORK/one0.zarr"
  step two_gpu_one 60 "$S2 --out $WORK/one.zarr"
  step two_gpu_two 150 "$S2 --workers 2 --out $WORK/two.zarr"
  step two_gpu_two_again 90 "$S2 --workers 2 --out $WORK/two2.zarr"
  step two_gpu_compare 60 "python3 -c \"import zarr, numpy as np; a = zarr.open_group('$WORK/one.zarr', mode='r'); b = zarr.open_group('$WORK/two.zarr', mode='r'); names = [k for k in a.array_keys() if k not in ('wall_seconds', 'grain_steps_per_second', 'batch_done')]; bad = [k for k in names if not np.array_equal(np.asarray(a[k][...]), np.asarray(b[k][...]), equal_nan=True)]; print('compared', len(names), 'arrays; differ:', bad)\""
  ;;
nov26e)
  # the detection target study with plain Gear steps for the detector's runs (planted signals still event-aware
  # at dt/2), Figs. 9-10 both tau in one run on the H100, the damped control at dt/2 to t = 500 (chaos check)
  step detect_target_off ${DETECT_LIMIT:-300} "$HZ detect-study sweeps/detect_study_1000_target_off.toml --out $LOGS/study_1000_target_off_gpu.json --overwrite --device cuda"
  step fig9_10_both_h100 150 "$HZ sweep sweeps/drive_fig9_10_both_gpu.toml --out $WORK/both.zarr --overwrite --device cuda --quiet --json"
  step damped_control_full 150 "$HZ sweep sweeps/drive_fig9_10_damped_gpu.toml --out $WORK/damped.zarr --overwrite --device cuda --quiet --json"
  step damped_control_half 150 "$HZ sweep sweeps/drive_fig9_10_damped_gpu.toml --set integrator.dt=6.25e-5 --set integrator.duration=500 --set record.response_windows=50 --out $WORK/damped_half.zarr --overwrite --device cuda --quiet --json"
  step damped_reduce_half 60 "python3 docs/logs/fig9_10_settle.py $WORK/damped.zarr --half $WORK/damped_half.zarr"
  ;;
nov26f)
  # after the detector's memory-mapped library and vectorised scoring, and the store's Blosc LZ4: one cached
  # detection profiled (plain steps for the detector, then event-aware), gpu_10k warm
  step detect_profile_off 200 "python3 docs/logs/detection/profile_detect.py --device cuda --study sweeps/detect_study_1000_target_off.toml"
  step e2e_gpu10k_cold_f 150 "$HZ bench --device cuda --sweep sweeps/gpu_10k.toml --json"
  step e2e_gpu10k_warm_f 60 "$HZ bench --device cuda --sweep sweeps/gpu_10k.toml --json"
  step sweep_gpu10k_warm_f 60 "$HZ sweep sweeps/gpu_10k.toml --out $WORK/gpu10k.zarr --overwrite --device cuda --quiet --json"
  step e2e_gpu10k_warm_f2 60 "$HZ bench --device cuda --sweep sweeps/gpu_10k.toml --json"
  step detect_profile_auto ${DETECT_LIMIT:-200} "python3 docs/logs/detection/profile_detect.py --device cuda"
  ;;
next27)
  # for the next GPU session: what 2026-11-26 built without device time left to measure it. The CUDA variants of
  # the fused kernels' viscous damping (bitwise on the CPU), the damped Figs. 9-10 control on the fused kernels
  # (52 s on the per-step kernel before), a first detection on a warm machine with plain steps
  step pytest_cuda_damping 200 "python3 -m pytest -q -p no:cacheprovider tests/test_fused_features.py -k 'cuda and (damping or dashpot)' 2>&1"
  step damped_control_fused 150 "$HZ sweep sweeps/drive_fig9_10_damped_gpu.toml --out $WORK/damped.zarr --overwrite --device cuda --quiet --json"
  step detect_profile_off_next 200 "python3 docs/logs/detection/profile_detect.py --device cuda --study sweeps/detect_study_1000_target_off.toml"
  ;;
nov26g)
  # 2026-11-26, third session, first call: next27's commands, then where a first detection's seconds go (new host chain
  # on a warm machine, profiled)
  step pytest_cuda_damping 200 "python3 -m pytest -q -p no:cacheprovider tests/test_fused_features.py -k 'cuda and (damping or dashpot)' 2>&1"
  step damped_control_fused 150 "$HZ sweep sweeps/drive_fig9_10_damped_gpu.toml --out $WORK/damped.zarr --overwrite --device cuda --quiet --json"
  step detect_first_profile 330 "python3 docs/logs/detection/profile_first.py --device cuda --study sweeps/detect_study_1000_target_off.toml"
  ;;
nov26h)
  # first detections after the library's ensembles were built without a scene per candidate (one batch on a GPU,
  # traces unpacked from views): the study's 7 ratios a side, then 4; the target study with 4 ratios a side
  step detect_first_m7 240 "python3 docs/logs/detection/profile_first.py --device cuda --study sweeps/detect_study_1000_target_off.toml"
  step detect_first_m4 200 "python3 docs/logs/detection/profile_first.py --device cuda --study sweeps/detect_study_1000_target_off.toml --mass-steps 4"
  step detect_study_m4 ${DETECT_LIMIT:-300} "$HZ detect-study sweeps/detect_study_1000_target_m4.toml --out $LOGS/study_1000_target_m4_gpu.json --overwrite --device cuda"
  ;;
nov26i)
  # a first detection after the library's host costs were cut (fronts on the fused kernels, v-only traces into
  # pageable memory, groups with the impurity moved), then warm gpu_10k end to end with the batch's arrays written
  # from 4 threads, and in turn (STORE_WRITE_THREADS = 1) on the same machine (the threaded write was reverted after
  # this: sweep_store no longer has STORE_WRITE_THREADS, and SERIAL's setting of it is then a no-op)
  SERIAL="python3 -c 'import sys, hertzian.ensemble.sweep_store as s; s.STORE_WRITE_THREADS = 1; from hertzian.ensemble.cli import main; sys.argv[0] = \"hertzian\"; main()'"
  step detect_first_m7b 200 "python3 docs/logs/detection/profile_first.py --device cuda --study sweeps/detect_study_1000_target_off.toml"
  step e2e_gpu10k_cold_i 120 "$HZ bench --device cuda --sweep sweeps/gpu_10k.toml --json"
  step e2e_gpu10k_warm_i 60 "$HZ bench --device cuda --sweep sweeps/gpu_10k.toml --json"
  step e2e_gpu10k_warm_i_serial 60 "$SERIAL bench --device cuda --sweep sweeps/gpu_10k.toml --json"
  step e2e_gpu10k_warm_i2 60 "$HZ bench --device cuda --sweep sweeps/gpu_10k.toml --json"
  step e2e_gpu10k_warm_i_serial2 60 "$SERIAL bench --device cuda --sweep sweeps/gpu_10k.toml --json"
  step sweep_gpu10k_warm_i 60 "$HZ sweep sweeps/gpu_10k.toml --out $WORK/gpu10k.zarr --overwrite --device cuda --quiet --json"
  step sweep_gpu10k_warm_i_serial 60 "$SERIAL sweep sweeps/gpu_10k.toml --out $WORK/gpu10k_s.zarr --overwrite --device cuda --quiet --json"
  ;;
nov26j)
  # warm gpu_10k with the kernels loading while the store is created; the pipeline's tail (the last batch's write)
  # against the batch size: 2 batches (the planner's), 3 (4194 + 4194 + 1612 points) and 4 (2500 each)
  CAP="python3 -c 'import sys, hertzian.ensemble.planner as p; p.MAX_GRAIN_THREADS = int(sys.argv.pop(1)); from hertzian.ensemble.cli import main; sys.argv[0] = \"hertzian\"; main()'"
  B10K="bench --device cuda --sweep sweeps/gpu_10k.toml --json"
  S10K="sweep sweeps/gpu_10k.toml --out $WORK/gpu10k.zarr --overwrite --device cuda --quiet --json"
  step e2e_gpu10k_cold_j 120 "$HZ $B10K"
  step e2e_gpu10k_warm_j 60 "$HZ $B10K"
  step e2e_gpu10k_warm_j2 60 "$HZ $B10K"
  step e2e_gpu10k_cap3_j 60 "$CAP 2097152 $B10K"
  step e2e_gpu10k_cap3_j2 60 "$CAP 2097152 $B10K"
  step e2e_gpu10k_cap4_j 60 "$CAP 1250000 $B10K"
  step e2e_gpu10k_cap4_j2 60 "$CAP 1250000 $B10K"
  step sweep_gpu10k_warm_j 60 "$HZ $S10K"
  step sweep_gpu10k_b3334_j 60 "$HZ $S10K --batch-size 3334"
  step sweep_gpu10k_b2500_j 60 "$HZ $S10K --batch-size 2500"
  ;;
nov26k)
  # result arrays at zstd level 1; a first detection with the library's trace copy page-locked again and the host
  # arrays mapped while the device finishes; the changed paths' CUDA tests
  B10K="bench --device cuda --sweep sweeps/gpu_10k.toml --json"
  S10K="sweep sweeps/gpu_10k.toml --out $WORK/gpu10k.zarr --overwrite --device cuda --quiet --json"
  step e2e_gpu10k_cold_k 120 "$HZ $B10K"
  step e2e_gpu10k_warm_k 60 "$HZ $B10K"
  step e2e_gpu10k_warm_k2 60 "$HZ $B10K"
  step e2e_gpu10k_warm_k3 60 "$HZ $B10K"
  step sweep_gpu10k_warm_k 60 "$HZ $S10K"
  step sweep_gpu10k_warm_k2 60 "$HZ $S10K"
  step detect_first_m7c 200 "python3 docs/logs/detection/profile_first.py --device cuda --study sweeps/detect_study_1000_target_off.toml"
  step pytest_cuda_k 200 "python3 -m pytest -q -p no:cacheprovider tests/test_records.py tests/test_sweep.py tests/test_vectorised.py -k cuda 2>&1"
  ;;
nov26l)
  # the driver's work without a branch around it (driver_step): window kernel alone, driven against struck, and the
  # driven Figs. 9-10 columns end to end; the CUDA tests of the fused drive; how fast the host reads a copied GB
  step pytest_cuda_drive 240 "python3 -m pytest -q -p no:cacheprovider tests/test_fused_features.py tests/test_drive.py -k cuda 2>&1"
  step window_probe_l_2 150 "python3 docs/gpu_logs/window_probe.py --chains 2 --variants 0,3 --out $LOGS/window_probe_l_2.json"
  step window_probe_l_64 150 "python3 docs/gpu_logs/window_probe.py --chains 64 --variants 0,3 --out $LOGS/window_probe_l_64.json"
  step e2e_fig9_10_t500_cold_l 200 "$HZ bench --device cuda --sweep sweeps/paper_fig9_10.toml --json"
  step e2e_fig9_10_t500_warm_l 100 "$HZ bench --device cuda --sweep sweeps/paper_fig9_10.toml --json"
  step host_copy_probe 60 "python3 docs/logs/detection/host_copy_probe.py --gib 1"
  ;;
nov26m)
  # the trace ring unpacked as one or two views where it wraps (it was gathered): a first detection, warm gpu_10k
  # end to end and as `sweep`, and the recorder's CUDA tests
  B10K="bench --device cuda --sweep sweeps/gpu_10k.toml --json"
  S10K="sweep sweeps/gpu_10k.toml --out $WORK/gpu10k.zarr --overwrite --device cuda --quiet --json"
  step detect_first_m7d 200 "python3 docs/logs/detection/profile_first.py --device cuda --study sweeps/detect_study_1000_target_off.toml"
  step e2e_gpu10k_cold_m 120 "$HZ $B10K"
  step e2e_gpu10k_warm_m 60 "$HZ $B10K"
  step e2e_gpu10k_warm_m2 60 "$HZ $B10K"
  step e2e_gpu10k_warm_m3 60 "$HZ $B10K"
  step sweep_gpu10k_warm_m 60 "$HZ $S10K"
  step sweep_gpu10k_warm_m2 60 "$HZ $S10K"
  step pytest_cuda_m 200 "python3 -m pytest -q -p no:cacheprovider tests/test_records.py tests/test_detect.py -k cuda 2>&1"
  ;;
nov26n)
  # the detection study's noise axis on the 1000-grain host (g = 0, single grains, SNR 40 … 6 dB, depths 5 … 95 %)
  step detect_study_snr 330 "$HZ detect-study sweeps/detect_study_1000_snr_off.toml --out $LOGS/study_1000_snr_off_gpu.json --overwrite --device cuda"
  ;;
nov26o)
  # the driver's work back in the driver's lane only (the every-lane form cost 13 % on 64 columns), with the lane's
  # branchless contact law: the driven window kernel alone on its calibrated shapes for 2 and 64 columns
  step window_probe_o 100 "python3 docs/gpu_logs/window_probe.py --chains 2,64 --variants 0 --configs 'G=4 lanes=32 K=32,lanes=244 K=32' --out $LOGS/window_probe_o.json"
  ;;
nov26p)
  # where warm gpu_10k's time outside the GPU goes: a timeline by thread of the bench and of the CLI sweep, with the
  # GPU's busy intervals from CUDA events on the same clock; the driver-work form of nov26o (not run then)
  B10K="bench --device cuda --sweep sweeps/gpu_10k.toml --json"
  step e2e_gpu10k_cold_p 120 "$HZ $B10K"
  step timeline_bench_p1 60 "python3 docs/logs/sweep_timeline.py sweeps/gpu_10k.toml --device cuda --json $LOGS/timeline_bench_p1.json"
  step timeline_bench_p2 60 "python3 docs/logs/sweep_timeline.py sweeps/gpu_10k.toml --device cuda --json $LOGS/timeline_bench_p2.json"
  step timeline_cli_p1 60 "python3 docs/logs/sweep_timeline.py sweeps/gpu_10k.toml --device cuda --cli --json $LOGS/timeline_cli_p1.json"
  step window_probe_p 100 "python3 docs/gpu_logs/window_probe.py --chains 2,64 --variants 0 --configs 'G=4 lanes=32 K=32,lanes=244 K=32' --out $LOGS/window_probe_p.json"
  ;;
nov26q)
  # gpu_10k after: records written while their batch runs (shards per record), the store created by the store
  # thread during the first batch, host pages mapped in a background thread, the stepping kernel the batches use
  # warmed instead of the per-step kernel; bench --sweep (the measure), timelines, the CLI sweep; the
  # million-point sweep (no regression), the changed paths' CUDA tests, a first detection (pages mapped earlier)
  B10K="bench --device cuda --sweep sweeps/gpu_10k.toml --json"
  S10K="sweep sweeps/gpu_10k.toml --out $WORK/gpu10k.zarr --overwrite --device cuda --quiet --json"
  step e2e_gpu10k_cold_q 120 "$HZ $B10K"
  step e2e_gpu10k_warm_q 60 "$HZ $B10K"
  step e2e_gpu10k_warm_q2 60 "$HZ $B10K"
  step e2e_gpu10k_warm_q3 60 "$HZ $B10K"
  step timeline_bench_q1 60 "python3 docs/logs/sweep_timeline.py sweeps/gpu_10k.toml --device cuda --json $LOGS/timeline_bench_q1.json"
  step timeline_cli_q1 60 "python3 docs/logs/sweep_timeline.py sweeps/gpu_10k.toml --device cuda --cli --json $LOGS/timeline_cli_q1.json"
  step sweep_gpu10k_warm_q 60 "$HZ $S10K"
  step sweep_gpu10k_warm_q2 60 "$HZ $S10K"
  step million_q 120 "$HZ sweep sweeps/million.toml --out $WORK/million.zarr --overwrite --device cuda --quiet --json"
  step pytest_cuda_q 200 "python3 -m pytest -q -p no:cacheprovider tests/test_records.py tests/test_host_costs.py tests/test_sweep.py tests/test_detect.py -k cuda 2>&1"
  step detect_first_q 200 "python3 docs/logs/detection/profile_first.py --device cuda --study sweeps/detect_study_1000_target_off.toml"
  ;;
nov26r)
  # a first detection with the trace ring's page-locked copy allocated in the background and the library assembled
  # and projected in threads (BASE dt 1e-3, then 2e-3: half the library's grain-steps); the accuracy of the target
  # cases (26 dB) and of the noise axis at dt 2e-3; the recorder's and detector's CUDA tests
  step pytest_cuda_r 200 "python3 -m pytest -q -p no:cacheprovider tests/test_records.py tests/test_detect.py tests/test_host_costs.py -k cuda 2>&1"
  step detect_first_r 200 "python3 docs/logs/detection/profile_first.py --device cuda --study sweeps/detect_study_1000_target_off.toml"
  step detect_first_dt2_r 200 "python3 docs/logs/detection/profile_first.py --device cuda --study sweeps/detect_study_1000_target_dt2.toml --repeat"
  step detect_study_target_dt2 200 "$HZ detect-study sweeps/detect_study_1000_target_dt2.toml --out $LOGS/study_1000_target_dt2_gpu.json --overwrite --device cuda"
  ;;
nov26s)
  # the noise axis (SNR 40 … 6 dB, depths 5 … 95 %) at BASE dt 2e-3
  step detect_study_snr_dt2 400 "$HZ detect-study sweeps/detect_study_1000_snr_dt2.toml --out $LOGS/study_1000_snr_dt2_gpu.json --overwrite --device cuda"
  ;;
nov26t)
  # a run that keeps traces but no snapshots copies the traced grains at t = 0 (not the whole state): the recorder's
  # CUDA tests; a first detection at BASE dt 2e-3 timed twice, and its timeline by thread with the GPU's busy time
  step pytest_cuda_t 200 "python3 -m pytest -q -p no:cacheprovider tests/test_records.py tests/test_detect.py -k cuda 2>&1"
  step detect_first_dt2_t 200 "python3 docs/logs/detection/profile_first.py --device cuda --study sweeps/detect_study_1000_target_dt2.toml --repeat"
  step timeline_detect_dt2_t 200 "python3 docs/logs/sweep_timeline.py sweeps/detect_study_1000_target_dt2.toml --device cuda --detect --json $LOGS/timeline_detect_dt2_t.json"
  ;;
nov26u)
  # the detection library assembled on the device (echoes and Gram matrices from the trace ring; only the echoes
  # come back, into page-locked memory allocated while the run executes), the trace ring's copy allocated at record 1
  # again: CUDA tests; first detections at BASE dt 2e-3 (twice) and 1e-3; the timeline at 2e-3; the target cases again
  step pytest_cuda_u 200 "python3 -m pytest -q -p no:cacheprovider tests/test_records.py tests/test_detect.py -k cuda 2>&1"
  step detect_first_dt2_u 200 "python3 docs/logs/detection/profile_first.py --device cuda --study sweeps/detect_study_1000_target_dt2.toml --repeat"
  step timeline_detect_dt2_u 200 "python3 docs/logs/sweep_timeline.py sweeps/detect_study_1000_target_dt2.toml --device cuda --detect --json $LOGS/timeline_detect_dt2_u.json"
  step detect_first_u 200 "python3 docs/logs/detection/profile_first.py --device cuda --study sweeps/detect_study_1000_target_off.toml"
  step detect_study_target_dt2_u 200 "$HZ detect-study sweeps/detect_study_1000_target_dt2.toml --out $LOGS/study_1000_target_dt2_gpu_u.json --overwrite --device cuda"
  ;;
nov26v)
  # a large library array saved by threads into its .npy's memory map: the detector's CUDA tests, first detections
  # at BASE dt 2e-3; issue 14's accuracy target with 384 planted detections (16 depths ≤ 800 × 6 mass ratios × 4
  # noise draws) and 32 clean chains at 26 dB
  step pytest_cuda_v 200 "python3 -m pytest -q -p no:cacheprovider tests/test_detect.py -k cuda 2>&1"
  step detect_first_dt2_v 200 "python3 docs/logs/detection/profile_first.py --device cuda --study sweeps/detect_study_1000_target_dt2.toml --repeat"
  step detect_study_target_dt2_400 330 "$HZ detect-study sweeps/detect_study_1000_target_dt2_400.toml --out $LOGS/study_1000_target_dt2_400_gpu.json --overwrite --device cuda"
  ;;
nov26w)
  # the wide scan (both classes at the depths around when the fine scan leaves the fit poor): the depth-100 heavy
  # case at dt 1e-3 and 2e-3, then the 416-detection target study again
  step detect_study_depth10 200 "$HZ detect-study sweeps/detect_study_1000_depth10.toml --out $LOGS/study_1000_depth10_gpu.json --overwrite --device cuda"
  step detect_study_target_dt2_400_w 360 "$HZ detect-study sweeps/detect_study_1000_target_dt2_400.toml --out $LOGS/study_1000_target_dt2_400_gpu_w.json --overwrite --device cuda"
  ;;
nov26x)
  # the study's other hosts at 1000 grains, 26 dB: g = 1 (dt 1e-3) and 5-grain blocks (g = 0 at dt 2e-3, g = 1 at 1e-3)
  step detect_study_hosts 560 "$HZ detect-study sweeps/detect_study_1000_hosts.toml --out $LOGS/study_1000_hosts_gpu.json --overwrite --device cuda"
  ;;
nov26y)
  # the driven 10 000-grain columns (Figs. 9-10 to t = 500) end to end after this session's sweep pipeline changes,
  # and their timeline by thread
  B910="bench --device cuda --sweep sweeps/paper_fig9_10.toml --json"
  step e2e_fig9_10_cold_y 200 "$HZ $B910"
  step e2e_fig9_10_warm_y 100 "$HZ $B910"
  step e2e_fig9_10_warm_y2 100 "$HZ $B910"
  step timeline_fig9_10_y 100 "python3 docs/logs/sweep_timeline.py sweeps/paper_fig9_10.toml --device cuda --json $LOGS/timeline_fig9_10_y.json"
  ;;
nov26z)
  # records grouped into shards of >= 8 MB (one per record for gpu_10k, 53 for the driven columns, whose 2001
  # one-record shards had cost the store thread 4 s in nov26y): both end to end again
  B910="bench --device cuda --sweep sweeps/paper_fig9_10.toml --json"
  B10K="bench --device cuda --sweep sweeps/gpu_10k.toml --json"
  S10K="sweep sweeps/gpu_10k.toml --out $WORK/gpu10k.zarr --overwrite --device cuda --quiet --json"
  step e2e_fig9_10_cold_z 200 "$HZ $B910"
  step e2e_fig9_10_warm_z 100 "$HZ $B910"
  step e2e_fig9_10_warm_z2 100 "$HZ $B910"
  step e2e_gpu10k_cold_z 120 "$HZ $B10K"
  step e2e_gpu10k_warm_z 60 "$HZ $B10K"
  step e2e_gpu10k_warm_z2 60 "$HZ $B10K"
  step e2e_gpu10k_warm_z3 60 "$HZ $B10K"
  step sweep_gpu10k_warm_z 60 "$HZ $S10K"
  step sweep_gpu10k_warm_z2 60 "$HZ $S10K"
  ;;
nov26final)
  # the submitted state: CUDA tests of the changed paths, a first detection at BASE dt 2e-3, warm gpu_10k end to end
  B10K="bench --device cuda --sweep sweeps/gpu_10k.toml --json"
  step pytest_cuda_final 300 "python3 -m pytest -q -p no:cacheprovider tests/test_records.py tests/test_host_costs.py tests/test_sweep.py tests/test_detect.py tests/test_fused_features.py -k cuda 2>&1"
  step detect_first_dt2_final 200 "python3 docs/logs/detection/profile_first.py --device cuda --study sweeps/detect_study_1000_target_dt2.toml --repeat"
  step e2e_gpu10k_cold_final 120 "$HZ $B10K"
  step e2e_gpu10k_warm_final 60 "$HZ $B10K"
  step e2e_gpu10k_warm_final2 60 "$HZ $B10K"
  ;;
nov26rec)
  # what a record costs the driven columns: Figs. 9-10 to t = 500 with v recorded every 0.25 (2001 records, as
  # shipped), every 2.5 (201) and every 25 (21); the response windows unchanged
  B910="bench --device cuda --sweep sweeps/paper_fig9_10.toml --json"
  step e2e_fig9_10_cold_rec 200 "$HZ $B910"
  step e2e_fig9_10_every025 100 "$HZ $B910"
  step e2e_fig9_10_every2p5 100 "$HZ $B910 --set record.every=2.5"
  step e2e_fig9_10_every25 100 "$HZ $B910 --set record.every=25"
  step e2e_fig9_10_every025_b 100 "$HZ $B910"
  ;;
nov26rec2)
  # shards of whole ~1 MiB inner chunks (65 records a shard for the driven columns, was 53 one-record chunks): the
  # driven columns with 2001 and 21 records, warm gpu_10k
  B910="bench --device cuda --sweep sweeps/paper_fig9_10.toml --json"
  B10K="bench --device cuda --sweep sweeps/gpu_10k.toml --json"
  step e2e_fig9_10_cold_rec2 200 "$HZ $B910"
  step e2e_fig9_10_every025_rec2 100 "$HZ $B910"
  step e2e_fig9_10_every025_rec2b 100 "$HZ $B910"
  step e2e_fig9_10_every25_rec2 100 "$HZ $B910 --set record.every=25"
  step e2e_gpu10k_cold_rec2 120 "$HZ $B10K"
  step e2e_gpu10k_warm_rec2 60 "$HZ $B10K"
  step e2e_gpu10k_warm_rec2b 60 "$HZ $B10K"
  ;;
nov27a)
  # what the drive costs the window kernel (kernel variants that leave parts of the drive out: timing only, wrong
  # results; HZ_EXP is read by an uncommitted experiment build of kernels/tile.py) and what a record costs the device
  P910="python3 docs/gpu_logs/window_probe.py --chains 2 --configs 'G=4 lanes=32 K=32'"
  step probe_a_base 120 "$P910 --variants 0,3 --out $LOGS/probe_a_base.json"
  for e in nowork nofill nok0 nowork,nofill; do
    step "probe_a_$e" 90 "HZ_EXP=$e $P910 --variants 0 --out $LOGS/probe_a_$e.json"
  done
  step record_probe_a 200 "python3 docs/gpu_logs/record_probe.py --out $LOGS/record_probe_a.json"
  ;;
nov27b)
  # the same, with the driven column's amplitude 2 and 1e-4 (variants 0, 1), and the sqrt without its fast path
  P910="python3 docs/gpu_logs/window_probe.py --chains 2 --configs 'G=4 lanes=32 K=32'"
  step probe_b_base 120 "$P910 --variants 0,1,2,3 --out $LOGS/probe_b_base.json"
  for e in nok0 nofill sqrtrn nowork; do
    step "probe_b_$e" 90 "HZ_EXP=$e $P910 --variants 0,1 --out $LOGS/probe_b_$e.json"
  done
  ;;
nov27c)
  # the driver's phases from a device table filled before the launches (no sine in the step loop), long chains'
  # records reduced in two stages: the window kernel alone, a record's device cost, the driven columns end to end,
  # and the CUDA tests of the changed paths
  P910="python3 docs/gpu_logs/window_probe.py --configs 'G=4 lanes=32 K=32'"
  B910="bench --device cuda --sweep sweeps/paper_fig9_10.toml --json"
  step probe_c_2 120 "$P910 --chains 2 --variants 0,1,3 --out $LOGS/probe_c_2.json"
  step probe_c_64 120 "$P910 --chains 64 --variants 0,3 --out $LOGS/probe_c_64.json"
  step record_probe_c 200 "python3 docs/gpu_logs/record_probe.py --out $LOGS/record_probe_c.json"
  step e2e_fig9_10_cold_c 200 "$HZ $B910"
  step e2e_fig9_10_warm_c 100 "$HZ $B910"
  step e2e_fig9_10_warm_c2 100 "$HZ $B910"
  step e2e_fig9_10_every25_c 100 "$HZ $B910 --set record.every=25"
  step pytest_cuda_c 300 "python3 -m pytest -q -p no:cacheprovider -k 'cuda and (drive or record or refilled)' tests 2>&1"
  ;;
nov27d)
  # the driver's phases loaded by every lane one step ahead from the device table (no shared table, no refill in
  # the loop); the same kernel with the driver held at u = 0 (HZ_EXP=zerophase: is the cost in the data?); the
  # shared-table form of nov27c (exp/tile_sharedtable.py, not committed) on the same machine
  P910="python3 docs/gpu_logs/window_probe.py --configs 'G=4 lanes=32 K=32'"
  step probe_d_2 120 "$P910 --chains 2 --variants 0,1,3 --out $LOGS/probe_d_2.json"
  step probe_d_zero 120 "HZ_EXP=zerophase $P910 --chains 2 --variants 0 --out $LOGS/probe_d_zero.json"
  if [ -f exp/tile_sharedtable.py ]; then
    cp kernels/tile.py /tmp/tile_direct.py && cp exp/tile_sharedtable.py kernels/tile.py
    step probe_d_shared 120 "$P910 --chains 2 --variants 0 --out $LOGS/probe_d_shared.json"
    step probe_d_shared_zero 120 "HZ_EXP=zerophase $P910 --chains 2 --variants 0 --out $LOGS/probe_d_shared_zero.json"
    cp /tmp/tile_direct.py kernels/tile.py
  fi
  step probe_d_64 120 "$P910 --chains 64 --variants 0 --out $LOGS/probe_d_64.json"
  ;;
nov27e)
  # cycles each block spends in its step loop (one launch; clock64 from an uncommitted experiment build,
  # exp/tile_clock.py): does the driver's window set the pace, or is every window of the driven kernel slower?
  P910="python3 docs/gpu_logs/window_probe.py --configs 'G=4 lanes=32 K=32' --chains 2"
  step tools_e 20 "which ncu nsys nvdisasm cuobjdump; ls /usr/local/cuda/bin 2>&1 | head -50"
  if [ -f exp/tile_clock.py ]; then
    cp kernels/tile.py /tmp/tile_keep.py && cp exp/tile_clock.py kernels/tile.py
    step clock_e_driven 120 "HZ_EXP=clock $P910 --variants 0 --out $LOGS/clock_e_driven.json"
    step clock_e_struck 120 "HZ_EXP=clock $P910 --variants 3 --out $LOGS/clock_e_struck.json"
    cp /tmp/tile_keep.py kernels/tile.py
  fi
  ;;
nov27f)
  # the driver's work evaluated after the step loop from a per-step log (one step per lane), and the driver's
  # selects without a branch; the deferred work with the branches (exp/tile_deferred.py, not committed), same machine
  P910="python3 docs/gpu_logs/window_probe.py --configs 'G=4 lanes=32 K=32'"
  B910="bench --device cuda --sweep sweeps/paper_fig9_10.toml --json"
  step probe_f_2 120 "$P910 --chains 2 --variants 0,1,3 --out $LOGS/probe_f_2.json"
  step probe_f_64 120 "$P910 --chains 64 --variants 0,3 --out $LOGS/probe_f_64.json"
  if [ -f exp/tile_deferred.py ]; then
    cp kernels/tile.py /tmp/tile_keep.py && cp exp/tile_deferred.py kernels/tile.py
    step probe_f_branches_2 120 "$P910 --chains 2 --variants 0 --out $LOGS/probe_f_branches_2.json"
    cp /tmp/tile_keep.py kernels/tile.py
  fi
  step e2e_fig9_10_cold_f 200 "$HZ $B910"
  step e2e_fig9_10_warm_f 100 "$HZ $B910"
  step e2e_fig9_10_warm_f2 100 "$HZ $B910"
  ;;
nov27g)
  # cycles per block of the nov27f kernel (loop; after it), exp/tile_clock2.py (not committed); a timeline of the
  # warm driven columns (host threads and GPU busy intervals)
  P910="python3 docs/gpu_logs/window_probe.py --configs 'G=4 lanes=32 K=32' --chains 2"
  if [ -f exp/tile_clock2.py ]; then
    cp kernels/tile.py /tmp/tile_keep.py && cp exp/tile_clock2.py kernels/tile.py
    step clock_g_driven 120 "HZ_EXP=clock $P910 --variants 0 --out $LOGS/clock_g_driven.json"
    step clock_g_struck 120 "HZ_EXP=clock $P910 --variants 3 --out $LOGS/clock_g_struck.json"
    cp /tmp/tile_keep.py kernels/tile.py
  fi
  B910="bench --device cuda --sweep sweeps/paper_fig9_10.toml --json"
  step e2e_fig9_10_cold_g 200 "$HZ $B910"
  step timeline_fig9_10_g 100 "python3 docs/logs/sweep_timeline.py sweeps/paper_fig9_10.toml --device cuda --json $LOGS/timeline_fig9_10_g.json"
  ;;
nov27h)
  # the driver's log stored without a branch (a scratch row per block); the window kernel, the driven columns end to
  # end (cold: a fresh calibration), and the 64-column response map
  P910="python3 docs/gpu_logs/window_probe.py --configs 'G=4 lanes=32 K=32'"
  B910="bench --device cuda --sweep sweeps/paper_fig9_10.toml --json"
  step probe_h_2 120 "$P910 --chains 2 --variants 0,1,3 --out $LOGS/probe_h_2.json"
  step probe_h_64 120 "$P910 --chains 64 --variants 0,3 --out $LOGS/probe_h_64.json"
  step e2e_fig9_10_cold_h 200 "$HZ $B910"
  step e2e_fig9_10_warm_h 100 "$HZ $B910"
  step e2e_fig9_10_warm_h2 100 "$HZ $B910"
  step timeline_fig9_10_h 100 "python3 docs/logs/sweep_timeline.py sweeps/paper_fig9_10.toml --device cuda --json $LOGS/timeline_fig9_10_h.json"
  ;;
nov27i)
  # the driver's higher Nordsieck values left to its corrector (zeroed at the write-back), its log one vec2d a step,
  # the long chains' record sums with four loads in flight: the window kernel, a record's device cost, the driven
  # columns end to end (cold: calibration), the 64-column response map, the CUDA tests of the changed paths
  P910="python3 docs/gpu_logs/window_probe.py --configs 'G=4 lanes=32 K=32'"
  B910="bench --device cuda --sweep sweeps/paper_fig9_10.toml --json"
  step probe_i_2 120 "$P910 --chains 2 --variants 0,1,3 --out $LOGS/probe_i_2.json"
  step probe_i_64 120 "$P910 --chains 64 --variants 0,3 --out $LOGS/probe_i_64.json"
  step record_probe_i 200 "python3 docs/gpu_logs/record_probe.py --out $LOGS/record_probe_i.json"
  step e2e_fig9_10_cold_i 200 "$HZ $B910"
  step e2e_fig9_10_warm_i 100 "$HZ $B910"
  step e2e_fig9_10_warm_i2 100 "$HZ $B910"
  step e2e_fig9_10_every25_i 100 "$HZ $B910 --set record.every=25"
  step timeline_fig9_10_i 100 "python3 docs/logs/sweep_timeline.py sweeps/paper_fig9_10.toml --device cuda --json $LOGS/timeline_fig9_10_i.json"
  step drive_map_i 240 "$HZ sweep sweeps/drive_map_gpu.toml --out $WORK/drive_map_i.zarr --overwrite --device cuda --quiet --json"
  step pytest_cuda_i 300 "python3 -m pytest -q -p no:cacheprovider -k 'cuda and (drive or record or refilled or fused)' tests 2>&1"
  ;;
nov27j)
  # the driver's displacement A·sin ωt as a product that no kernel contracts (__dmul_rn): the CUDA tests of the fused
  # and driven paths (nov27i: compensated float32, viscous, driven differed from the per-step kernel by 6e-7), the
  # same with contraction off (bit for bit), the window kernel and the driven columns end to end
  step pytest_cuda_j 300 "python3 -m pytest -q -p no:cacheprovider -k 'cuda and (drive or record or refilled or fused)' tests 2>&1"
  step pytest_cuda_j_nofma 200 "HERTZIAN_FUSE_FP=0 python3 -m pytest -q -p no:cacheprovider -k 'cuda and damping' tests/test_fused_features.py 2>&1"
  P910="python3 docs/gpu_logs/window_probe.py --configs 'G=4 lanes=32 K=32'"
  B910="bench --device cuda --sweep sweeps/paper_fig9_10.toml --json"
  step probe_j_2 120 "$P910 --chains 2 --variants 0,3 --out $LOGS/probe_j_2.json"
  step e2e_fig9_10_cold_j 200 "$HZ $B910"
  step e2e_fig9_10_warm_j 100 "$HZ $B910"
  step e2e_fig9_10_warm_j2 100 "$HZ $B910"
  ;;
nov27k)
  # the submitted driven kernels (the driver's column no longer overwritten each step): the window kernel alone, the
  # CUDA tests of the fused/driven/record paths, the driven columns end to end, the response map, the same-size
  # impact and driven 1000-grain scenes long enough for the fused kernels (6e9 grain-steps), warm gpu_10k
  P910="python3 docs/gpu_logs/window_probe.py --configs 'G=4 lanes=32 K=32'"
  B910="bench --device cuda --sweep sweeps/paper_fig9_10.toml --json"
  B10K="bench --device cuda --sweep sweeps/gpu_10k.toml --json"
  step probe_k_2 120 "$P910 --chains 2 --variants 0,1,3 --out $LOGS/probe_k_2.json"
  step probe_k_64 120 "$P910 --chains 64 --variants 0,3 --out $LOGS/probe_k_64.json"
  step e2e_fig9_10_cold_k 200 "$HZ $B910"
  step e2e_fig9_10_warm_k 100 "$HZ $B910"
  step e2e_fig9_10_warm_k2 100 "$HZ $B910"
  step e2e_fig9_10_warm_k3 100 "$HZ $B910"
  step e2e_fig9_10_every25_k 100 "$HZ $B910 --set record.every=25"
  step timeline_fig9_10_k 100 "python3 docs/logs/sweep_timeline.py sweeps/paper_fig9_10.toml --device cuda --json $LOGS/timeline_fig9_10_k.json"
  for s in impact_1000 driven_1000; do
    step "e2e_${s}_300_k" 120 "$HZ bench --device cuda --scene docs/bench/$s.toml --set integrator.duration=300 --json"
    step "e2e_${s}_300_k2" 120 "$HZ bench --device cuda --scene docs/bench/$s.toml --set integrator.duration=300 --json"
  done
  step drive_map_k 240 "$HZ sweep sweeps/drive_map_gpu.toml --out $WORK/drive_map_k.zarr --overwrite --device cuda --quiet --json"
  step e2e_gpu10k_cold_k 120 "$HZ $B10K"
  step e2e_gpu10k_warm_k 60 "$HZ $B10K"
  step pytest_cuda_k 300 "python3 -m pytest -q -p no:cacheprovider -k 'cuda and (drive or record or refilled or fused)' tests 2>&1"
  ;;
nov27l)
  # up to 8 staging buffers (the host may run 8 records ahead), only the kept rows copied: the driven columns end to
  # end and their timeline; the same-size 1000-grain impact, traced impact and driven scenes with plain Gear steps
  # (events off; nov27k's default event-aware steps spent the driven scene's time in event steps), 6e9 grain-steps
  B910="bench --device cuda --sweep sweeps/paper_fig9_10.toml --json"
  step e2e_fig9_10_cold_l 200 "$HZ $B910"
  step e2e_fig9_10_warm_l 100 "$HZ $B910"
  step e2e_fig9_10_warm_l2 100 "$HZ $B910"
  step e2e_fig9_10_warm_l3 100 "$HZ $B910"
  step timeline_fig9_10_l 100 "python3 docs/logs/sweep_timeline.py sweeps/paper_fig9_10.toml --device cuda --json $LOGS/timeline_fig9_10_l.json"
  for s in impact_1000 impact_1000_traces driven_1000; do
    step "e2e_${s}_off_l" 150 "$HZ bench --device cuda --scene docs/bench/$s.toml --set integrator.duration=300 --set integrator.events=off --json"
    step "e2e_${s}_off_l2" 100 "$HZ bench --device cuda --scene docs/bench/$s.toml --set integrator.duration=300 --set integrator.events=off --json"
  done
  ;;
nov27m)
  # the driver's work summed with four loads in flight (the submitted state): the window kernel, the driven columns
  # end to end, the same-size 1000-grain impact and driven scenes (events off), the CUDA tests of the changed paths
  P910="python3 docs/gpu_logs/window_probe.py --configs 'G=4 lanes=32 K=32'"
  B910="bench --device cuda --sweep sweeps/paper_fig9_10.toml --json"
  step probe_m_2 120 "$P910 --chains 2 --variants 0,3 --out $LOGS/probe_m_2.json"
  step e2e_fig9_10_cold_m 200 "$HZ $B910"
  step e2e_fig9_10_warm_m 100 "$HZ $B910"
  step e2e_fig9_10_warm_m2 100 "$HZ $B910"
  step e2e_fig9_10_warm_m3 100 "$HZ $B910"
  for s in impact_1000 driven_1000; do
    step "e2e_${s}_off_m" 150 "$HZ bench --device cuda --scene docs/bench/$s.toml --set integrator.duration=300 --set integrator.events=off --json"
    step "e2e_${s}_off_m2" 100 "$HZ bench --device cuda --scene docs/bench/$s.toml --set integrator.duration=300 --set integrator.events=off --json"
  done
  step pytest_cuda_m 300 "python3 -m pytest -q -p no:cacheprovider -k 'cuda and (drive or record or refilled or fused)' tests 2>&1"
  ;;
nov27n)
  # the submitted state with the drive table filled only for the rows an advance reads: the CUDA tests of the driven
  # paths, the driven columns end to end, and the whole reproduction twice (a fresh machine compiles everything the
  # first time; issue 11's <= 30 s is the second)
  B910="bench --device cuda --sweep sweeps/paper_fig9_10.toml --json"
  step pytest_cuda_n 300 "python3 -m pytest -q -p no:cacheprovider -k 'cuda and (drive or refilled)' tests 2>&1"
  step e2e_fig9_10_cold_n 200 "$HZ $B910"
  step e2e_fig9_10_warm_n 100 "$HZ $B910"
  step e2e_fig9_10_warm_n2 100 "$HZ $B910"
  step reproduce_cold_n 300 "$HZ reproduce --device cuda --out-dir $WORK/repro_cold"
  cp "$WORK"/repro_cold/log.json "$LOGS"/reproduce_cold_n_log.json 2>/dev/null
  step reproduce_warm_n 120 "$HZ reproduce --device cuda --out-dir $WORK/repro_warm"
  cp "$WORK"/repro_warm/log.json "$LOGS"/reproduce_warm_n_log.json 2>/dev/null
  ;;
nov27o)
  # a chain's record parts summed with four loads in flight: the driven columns end to end; then the same with shards
  # of 2 MB of records instead of 8 (exp/sweep_store_2mb.py, not committed: a shorter last shard write?); CUDA tests
  # of the record paths
  B910="bench --device cuda --sweep sweeps/paper_fig9_10.toml --json"
  step e2e_fig9_10_cold_o 200 "$HZ $B910"
  step e2e_fig9_10_warm_o 100 "$HZ $B910"
  step e2e_fig9_10_warm_o2 100 "$HZ $B910"
  step e2e_fig9_10_warm_o3 100 "$HZ $B910"
  step timeline_fig9_10_o 100 "python3 docs/logs/sweep_timeline.py sweeps/paper_fig9_10.toml --device cuda --json $LOGS/timeline_fig9_10_o.json"
  if [ -f exp/sweep_store_2mb.py ]; then
    cp ensemble/sweep_store.py /tmp/sweep_store_keep.py && cp exp/sweep_store_2mb.py ensemble/sweep_store.py
    step e2e_fig9_10_2mb_o 100 "$HZ $B910"
    step e2e_fig9_10_2mb_o2 100 "$HZ $B910"
    step e2e_fig9_10_2mb_o3 100 "$HZ $B910"
    step timeline_fig9_10_2mb_o 100 "python3 docs/logs/sweep_timeline.py sweeps/paper_fig9_10.toml --device cuda --json $LOGS/timeline_fig9_10_2mb_o.json"
    cp /tmp/sweep_store_keep.py ensemble/sweep_store.py
  fi
  step pytest_cuda_o 200 "python3 -m pytest -q -p no:cacheprovider -k 'cuda and record' tests 2>&1"
  ;;
nov27p)
  # after the review: the phase table sized to what the launches read (two rows past an advance's start, not a
  # block's lanes), one per-grain function for both record reductions; the CUDA tests of the changed paths, the
  # window kernel, the driven columns end to end
  P910="python3 docs/gpu_logs/window_probe.py --configs 'G=4 lanes=32 K=32'"
  B910="bench --device cuda --sweep sweeps/paper_fig9_10.toml --json"
  step pytest_cuda_p 300 "python3 -m pytest -q -p no:cacheprovider -k 'cuda and (drive or record or refilled or fused)' tests 2>&1"
  step probe_p_2 120 "$P910 --chains 2 --variants 0,3 --out $LOGS/probe_p_2.json"
  step e2e_fig9_10_cold_p 200 "$HZ $B910"
  step e2e_fig9_10_warm_p 100 "$HZ $B910"
  step e2e_fig9_10_warm_p2 100 "$HZ $B910"
  ;;
nov28a)
  # the driver's powers summed from shared memory (not global), the trace step found by a comparison (not a modulo):
  # the CUDA tests of those paths; the kernel alone on the 1000-grain bench scenes (every shape the calibration
  # considers) and on the driven 10 000-grain columns, then the same with the previous kernel (exp/tile_head.py and
  # exp/solver_tile_head.py, the committed state before the change) on the same machine
  P910="python3 docs/gpu_logs/window_probe.py --configs 'G=4 lanes=32 K=32' --chains 2 --variants 0,3"
  PS="python3 docs/gpu_logs/scene_probe.py"
  step pytest_cuda_a 300 "python3 -m pytest -q -p no:cacheprovider -k 'cuda and (drive or trace or refilled)' tests/test_fused_features.py 2>&1"
  step scenes_a 200 "$PS --out $LOGS/scenes_a.json"
  step probe910_a 100 "$P910 --out $LOGS/probe910_a.json"
  if [ -f exp/tile_head.py ]; then
    cp kernels/tile.py /tmp/tile_keep.py && cp ensemble/solvers/tile.py /tmp/solver_keep.py
    cp exp/tile_head.py kernels/tile.py && cp exp/solver_tile_head.py ensemble/solvers/tile.py
    step scenes_a_head 150 "$PS --configs 'lanes=66,lanes=33' --out $LOGS/scenes_a_head.json"
    step probe910_a_head 100 "$P910 --out $LOGS/probe910_a_head.json"
    cp /tmp/tile_keep.py kernels/tile.py && cp /tmp/solver_keep.py ensemble/solvers/tile.py
  fi
  ;;
nov28b)
  # end to end, warm: the driven 10 000-grain columns (the first run calibrates) and the 1000-grain bench scenes
  B910="bench --device cuda --sweep sweeps/paper_fig9_10.toml --json"
  step e2e_fig9_10_cold_b 200 "$HZ $B910"
  step e2e_fig9_10_warm_b 100 "$HZ $B910"
  step e2e_fig9_10_warm_b2 100 "$HZ $B910"
  step e2e_fig9_10_warm_b3 100 "$HZ $B910"
  for s in impact_1000 impact_1000_traces driven_1000; do
    step "e2e_${s}_off_b" 150 "$HZ bench --device cuda --scene docs/bench/$s.toml --set integrator.duration=300 --set integrator.events=off --json"
    step "e2e_${s}_off_b2" 100 "$HZ bench --device cuda --scene docs/bench/$s.toml --set integrator.duration=300 --set integrator.events=off --json"
  done
  ;;
nov28c)
  # which part of the driven code costs the driver's window its step at 1000 grains: an ablation build
  # (exp/tile_ablate.py, not committed; HZ_EXP drops the phase loads, the log's stores, the driver's select or the
  # work after the loop: timing only, the results are wrong), on the impact's shape; registers and spills of the
  # fused kernels compiled on this machine (cuobjdump -res-usage)
  PS="python3 docs/gpu_logs/scene_probe.py --configs 'G=4 lanes=32 K=32'"
  P910="python3 docs/gpu_logs/window_probe.py --configs 'G=4 lanes=32 K=32' --chains 2"
  step scenes_c 100 "$PS --scenes impact_1000,driven_1000 --out $LOGS/scenes_c.json"
  if [ -f exp/tile_ablate.py ]; then
    cp kernels/tile.py /tmp/tile_keep.py && cp exp/tile_ablate.py kernels/tile.py
    for v in noload nolog nosel noafter noload,nolog noload,nolog,nosel,noafter; do
      step "scenes_c_$v" 60 "HZ_EXP=$v $PS --scenes driven_1000 --out $LOGS/scenes_c_$v.json"
    done
    step probe910_c_all 60 "HZ_EXP=noload,nolog,nosel,noafter $P910 --variants 0 --out $LOGS/probe910_c_all.json"
    step probe910_c_noload 60 "HZ_EXP=noload $P910 --variants 0 --out $LOGS/probe910_c_noload.json"
    cp /tmp/tile_keep.py kernels/tile.py
  fi
  step resusage_c 60 "for f in \$(ls -t ~/.cache/warp/*/*fused*/*.cubin | head -40); do echo \$f; /usr/local/cuda/bin/cuobjdump -res-usage \$f | grep -E 'Function|REG'; done"
  ;;
nov28d)
  # a windowed driven chain's other windows on a plain step loop (only the window holding grain 0 runs the driver's
  # code; commit 1c9a29c, measured and then reverted: no gain): CUDA tests of the driven and traced fused paths; the
  # kernel alone on the driven 10 000-grain columns and the 1000-grain scenes, then the same with the previous kernel
  # (exp/tile_nosplit.py: the committed ba5fc80); the driven columns end to end
  P910="python3 docs/gpu_logs/window_probe.py --configs 'G=4 lanes=32 K=32' --chains 2 --variants 0,3"
  PS="python3 docs/gpu_logs/scene_probe.py --configs 'G=4 lanes=32 K=32,G=2 lanes=32 K=16'"
  B910="bench --device cuda --sweep sweeps/paper_fig9_10.toml --json"
  step probe910_d 100 "$P910 --out $LOGS/probe910_d.json"
  step scenes_d 100 "$PS --out $LOGS/scenes_d.json"
  if [ -f exp/tile_nosplit.py ]; then
    cp kernels/tile.py /tmp/tile_keep.py && cp exp/tile_nosplit.py kernels/tile.py
    step probe910_d_nosplit 100 "$P910 --variants 0 --out $LOGS/probe910_d_nosplit.json"
    step scenes_d_nosplit 100 "$PS --scenes driven_1000 --out $LOGS/scenes_d_nosplit.json"
    cp /tmp/tile_keep.py kernels/tile.py
  fi
  step probe910_d2 100 "$P910 --out $LOGS/probe910_d2.json"
  step pytest_cuda_d 300 "python3 -m pytest -q -p no:cacheprovider -k 'cuda and (drive or trace or refilled)' tests/test_fused_features.py 2>&1"
  step e2e_fig9_10_cold_d 200 "$HZ $B910"
  step e2e_fig9_10_warm_d 100 "$HZ $B910"
  step e2e_fig9_10_warm_d2 100 "$HZ $B910"
  step e2e_fig9_10_warm_d3 100 "$HZ $B910"
  ;;
nov28e)
  # after reverting the split: the fused kernel's module made for its launch's block size (one source hash, not two);
  # the driven columns end to end and a timeline with the store's opens and row writes; each record kernel's device
  # time (ncu, 40 repetitions of the record probe); the 1000-grain bench scenes end to end
  B910="bench --device cuda --sweep sweeps/paper_fig9_10.toml --json"
  step e2e_fig9_10_cold_e 200 "$HZ $B910"
  step e2e_fig9_10_warm_e 100 "$HZ $B910"
  step e2e_fig9_10_warm_e2 100 "$HZ $B910"
  step e2e_fig9_10_warm_e3 100 "$HZ $B910"
  step timeline_fig9_10_e 100 "python3 docs/logs/sweep_timeline.py sweeps/paper_fig9_10.toml --device cuda --json $LOGS/timeline_fig9_10_e.json"
  step ncu_record_e 200 "/usr/local/cuda/bin/ncu --metrics gpu__time_duration.sum --csv -k regex:record python3 docs/gpu_logs/record_probe.py --repeats 40 --out $LOGS/record_probe_e.json"
  for s in impact_1000 impact_1000_traces driven_1000; do
    step "e2e_${s}_off_e" 150 "$HZ bench --device cuda --scene docs/bench/$s.toml --set integrator.duration=300 --set integrator.events=off --json"
    step "e2e_${s}_off_e2" 100 "$HZ bench --device cuda --scene docs/bench/$s.toml --set integrator.duration=300 --set integrator.events=off --json"
  done
  ;;
nov28f)
  # a record's serial sums with 16 grains' (8 parts') loads in flight instead of 4; the collector's full passes kept off
  # the run's objects (gc.freeze for the run): CUDA tests of the record and driven paths, each record kernel's device
  # time (ncu), the driven columns end to end and a timeline (with the collector's full passes), the 1000-grain scenes
  B910="bench --device cuda --sweep sweeps/paper_fig9_10.toml --json"
  step pytest_cuda_f 300 "python3 -m pytest -q -p no:cacheprovider -k 'cuda and (record or drive or refilled)' tests 2>&1"
  step ncu_record_f 200 "/usr/local/cuda/bin/ncu --metrics gpu__time_duration.sum --csv -k regex:record python3 docs/gpu_logs/record_probe.py --repeats 20 --out $LOGS/record_probe_f_ncu.json"
  step record_probe_f 100 "python3 docs/gpu_logs/record_probe.py --out $LOGS/record_probe_f.json"
  step e2e_fig9_10_cold_f 200 "$HZ $B910"
  step e2e_fig9_10_warm_f 100 "$HZ $B910"
  step e2e_fig9_10_warm_f2 100 "$HZ $B910"
  step e2e_fig9_10_warm_f3 100 "$HZ $B910"
  step e2e_fig9_10_warm_f4 100 "$HZ $B910"
  step timeline_fig9_10_f 100 "python3 docs/logs/sweep_timeline.py sweeps/paper_fig9_10.toml --device cuda --json $LOGS/timeline_fig9_10_f.json"
  for s in impact_1000 impact_1000_traces driven_1000; do
    step "e2e_${s}_off_f" 150 "$HZ bench --device cuda --scene docs/bench/$s.toml --set integrator.duration=300 --set integrator.events=off --json"
    step "e2e_${s}_off_f2" 100 "$HZ bench --device cuda --scene docs/bench/$s.toml --set integrator.duration=300 --set integrator.events=off --json"
  done
  ;;
nov28g)
  # the record's serial sums back to four loads in flight (16 were slower, nov28f) and launched in blocks of 32 threads
  # (spread over SMs, not one block of 256); the run's loop with a 0.5 ms thread switch interval: CUDA tests of the
  # record paths; each record kernel's device time (ncu) now and with the previous kernels and launches
  # (exp/records_old.py, exp/recorder_old.py: blocks of 256); the driven columns end to end and a timeline, then with
  # Python's 5 ms switch interval (exp/runner_noswitch.py)
  B910="bench --device cuda --sweep sweeps/paper_fig9_10.toml --json"
  NCU="/usr/local/cuda/bin/ncu --metrics gpu__time_duration.sum --csv -k regex:record"
  step pytest_cuda_g 300 "python3 -m pytest -q -p no:cacheprovider -k 'cuda and (record or drive)' tests/test_records.py tests/test_fused_features.py tests/test_host_costs.py 2>&1"
  step ncu_record_g 200 "$NCU python3 docs/gpu_logs/record_probe.py --repeats 20 --out $LOGS/record_probe_g_ncu.json"
  if [ -f exp/records_old.py ]; then
    cp kernels/records.py /tmp/records_keep.py && cp ensemble/recorder.py /tmp/recorder_keep.py
    cp exp/records_old.py kernels/records.py && cp exp/recorder_old.py ensemble/recorder.py
    step ncu_record_g_old 200 "$NCU python3 docs/gpu_logs/record_probe.py --repeats 20 --out $LOGS/record_probe_g_old_ncu.json"
    cp /tmp/records_keep.py kernels/records.py && cp /tmp/recorder_keep.py ensemble/recorder.py
  fi
  step e2e_fig9_10_cold_g 200 "$HZ $B910"
  step e2e_fig9_10_warm_g 100 "$HZ $B910"
  step e2e_fig9_10_warm_g2 100 "$HZ $B910"
  step e2e_fig9_10_warm_g3 100 "$HZ $B910"
  step e2e_fig9_10_warm_g4 100 "$HZ $B910"
  step timeline_fig9_10_g 100 "python3 docs/logs/sweep_timeline.py sweeps/paper_fig9_10.toml --device cuda --json $LOGS/timeline_fig9_10_g.json"
  if [ -f exp/runner_noswitch.py ]; then
    cp ensemble/runner.py /tmp/runner_keep.py && cp exp/runner_noswitch.py ensemble/runner.py
    step e2e_fig9_10_noswitch_g 100 "$HZ $B910"
    step e2e_fig9_10_noswitch_g2 100 "$HZ $B910"
    step e2e_fig9_10_noswitch_g3 100 "$HZ $B910"
    cp /tmp/runner_keep.py ensemble/runner.py
  fi
  step e2e_fig9_10_warm_g5 100 "$HZ $B910"
  step e2e_fig9_10_warm_g6 100 "$HZ $B910"
  ;;
nov28h)
  # the submitted state of the sixth session: CUDA tests of the fused, record and drive paths; the kernels' bench (no
  # regression); the driven columns, the 1000-grain bench scenes and gpu_10k end to end, warm
  B910="bench --device cuda --sweep sweeps/paper_fig9_10.toml --json"
  B10K="bench --device cuda --sweep sweeps/gpu_10k.toml --json"
  step pytest_cuda_h 400 "python3 -m pytest -q -p no:cacheprovider -k 'cuda and (record or drive or fused or tile or trace)' tests 2>&1"
  step bench_kernels_h 200 "$HZ bench --device cuda --chains 16384,1 --grains 1000,1000 --repeats 3 --json"
  step e2e_fig9_10_cold_h 200 "$HZ $B910"
  step e2e_fig9_10_warm_h 100 "$HZ $B910"
  step e2e_fig9_10_warm_h2 100 "$HZ $B910"
  step e2e_fig9_10_warm_h3 100 "$HZ $B910"
  for s in impact_1000 impact_1000_traces driven_1000; do
    step "e2e_${s}_off_h" 150 "$HZ bench --device cuda --scene docs/bench/$s.toml --set integrator.duration=300 --set integrator.events=off --json"
    step "e2e_${s}_off_h2" 100 "$HZ bench --device cuda --scene docs/bench/$s.toml --set integrator.duration=300 --set integrator.events=off --json"
  done
  step e2e_gpu10k_cold_h 200 "$HZ $B10K"
  step e2e_gpu10k_warm_h 100 "$HZ $B10K"
  ;;
nov28i)
  # a long chain's record sums copied to shared memory by a block before one thread adds them in order
  # (record_parts_of_grains: a block per part; record_long: a block per chain): CUDA tests of the record paths, each
  # record kernel's device time (ncu), the driven columns end to end and a timeline
  B910="bench --device cuda --sweep sweeps/paper_fig9_10.toml --json"
  NCU="/usr/local/cuda/bin/ncu --metrics gpu__time_duration.sum --csv -k regex:record"
  step pytest_cuda_i 300 "python3 -m pytest -q -p no:cacheprovider -k 'cuda' tests/test_records.py tests/test_host_costs.py tests/test_drive.py 2>&1"
  step ncu_record_i 200 "$NCU python3 docs/gpu_logs/record_probe.py --repeats 20 --out $LOGS/record_probe_i_ncu.json"
  step record_probe_i 100 "python3 docs/gpu_logs/record_probe.py --out $LOGS/record_probe_i.json"
  step e2e_fig9_10_cold_i 200 "$HZ $B910"
  step e2e_fig9_10_warm_i 100 "$HZ $B910"
  step e2e_fig9_10_warm_i2 100 "$HZ $B910"
  step e2e_fig9_10_warm_i3 100 "$HZ $B910"
  step e2e_fig9_10_warm_i4 100 "$HZ $B910"
  step timeline_fig9_10_i 100 "python3 docs/logs/sweep_timeline.py sweeps/paper_fig9_10.toml --device cuda --json $LOGS/timeline_fig9_10_i.json"
  ;;
nov28j)
  # the host arrays mapped in blocks along the record axis (an unpack waits only for its own rows), the collector's
  # objects frozen during a run (a full pass stopped the host 85 ms mid-run in nov28i), the store's arrays opened
  # while the batch runs: CUDA tests of the record paths, the driven columns end to end and a timeline, the 1000-grain
  # scenes, gpu_10k
  B910="bench --device cuda --sweep sweeps/paper_fig9_10.toml --json"
  B10K="bench --device cuda --sweep sweeps/gpu_10k.toml --json"
  step pytest_cuda_j 300 "python3 -m pytest -q -p no:cacheprovider -k 'cuda' tests/test_records.py tests/test_host_costs.py tests/test_drive.py tests/test_sweep.py 2>&1"
  step e2e_fig9_10_cold_j 200 "$HZ $B910"
  step e2e_fig9_10_warm_j 100 "$HZ $B910"
  step e2e_fig9_10_warm_j2 100 "$HZ $B910"
  step e2e_fig9_10_warm_j3 100 "$HZ $B910"
  step e2e_fig9_10_warm_j4 100 "$HZ $B910"
  step e2e_fig9_10_warm_j5 100 "$HZ $B910"
  step timeline_fig9_10_j 100 "python3 docs/logs/sweep_timeline.py sweeps/paper_fig9_10.toml --device cuda --json $LOGS/timeline_fig9_10_j.json"
  for s in impact_1000 impact_1000_traces driven_1000; do
    step "e2e_${s}_off_j" 150 "$HZ bench --device cuda --scene docs/bench/$s.toml --set integrator.duration=300 --set integrator.events=off --json"
    step "e2e_${s}_off_j2" 100 "$HZ bench --device cuda --scene docs/bench/$s.toml --set integrator.duration=300 --set integrator.events=off --json"
  done
  step e2e_gpu10k_cold_j 200 "$HZ $B10K"
  step e2e_gpu10k_warm_j 100 "$HZ $B10K"
  ;;
nov28k)
  # the bench makes the device ready before its clock (the CUDA context, reported as "startup", outside "total"):
  # the driven columns, the 1000-grain scenes and gpu_10k end to end (warm), a timeline; the CUDA tests of the bench
  B910="bench --device cuda --sweep sweeps/paper_fig9_10.toml --json"
  B10K="bench --device cuda --sweep sweeps/gpu_10k.toml --json"
  step pytest_cuda_k 200 "python3 -m pytest -q -p no:cacheprovider tests/test_bench.py 2>&1"
  step e2e_fig9_10_cold_k 200 "$HZ $B910"
  step e2e_fig9_10_warm_k 100 "$HZ $B910"
  step e2e_fig9_10_warm_k2 100 "$HZ $B910"
  step e2e_fig9_10_warm_k3 100 "$HZ $B910"
  step e2e_fig9_10_warm_k4 100 "$HZ $B910"
  step e2e_fig9_10_warm_k5 100 "$HZ $B910"
  step timeline_fig9_10_k 100 "python3 docs/logs/sweep_timeline.py sweeps/paper_fig9_10.toml --device cuda --json $LOGS/timeline_fig9_10_k.json"
  for s in impact_1000 impact_1000_traces driven_1000; do
    step "e2e_${s}_off_k" 150 "$HZ bench --device cuda --scene docs/bench/$s.toml --set integrator.duration=300 --set integrator.events=off --json"
    step "e2e_${s}_off_k2" 100 "$HZ bench --device cuda --scene docs/bench/$s.toml --set integrator.duration=300 --set integrator.events=off --json"
    step "e2e_${s}_off_k3" 100 "$HZ bench --device cuda --scene docs/bench/$s.toml --set integrator.duration=300 --set integrator.events=off --json"
  done
  step e2e_gpu10k_cold_k 200 "$HZ $B10K"
  step e2e_gpu10k_warm_k 100 "$HZ $B10K"
  step e2e_gpu10k_warm_k2 100 "$HZ $B10K"
  ;;
nov28l)
  # the submitted state of the sixth session: the CUDA tests of the changed paths; the whole reproduction with plain Gear steps
  # (--events off), fresh (it compiles) and warm (issue 11's <= 30 s is the warm one)
  step pytest_cuda_l 200 "python3 -m pytest -q -p no:cacheprovider -k 'cuda and (record or drive or fused or trace or sweep)' tests 2>&1"
  step reproduce_cold_l 200 "$HZ reproduce --device cuda --events off --out-dir $WORK/repro_cold"
  cp "$WORK"/repro_cold/log.json "$LOGS"/reproduce_cold_l_log.json 2>/dev/null
  step reproduce_warm_l 60 "$HZ reproduce --device cuda --events off --out-dir $WORK/repro_warm"
  cp "$WORK"/repro_warm/log.json "$LOGS"/reproduce_warm_l_log.json 2>/dev/null
  ;;
repro)
  step reproduce ${REPRO_LIMIT:-560} "$HZ reproduce --device cuda --out-dir $WORK/repro"
  cp "$WORK"/repro/*.json "$WORK"/repro/*.png "$LOGS"/ 2>/dev/null
  ;;
nov29a)
  # issue 15: event-aware steps on the frontier workload (16 384 x 1000 grains, gear6, dt = 1e-3, t = 20), the tile
  # kernel alone: the new event path (test before the corrector, one block vote a step, t_n's state through shared
  # memory only in the steps that take event steps) against the previous one (.trees/old, built by docs/gpu_logs/build_trees.sh: the tree of commit 0cb09e6)
  step cuda_event_tests 300 "python3 -m pytest -q -p no:cacheprovider -k 'cuda and event' tests 2>&1"
  step frontier_probe_new 240 "python3 docs/gpu_logs/frontier_events_probe.py --variants off4,call4,off8,call8"
  mkdir -p $WORK/hzold/hertzian
  for d in ensemble kernels sweeps; do ln -sfn "$REPO/.trees/old/$d" "$WORK/hzold/hertzian/$d"; done
  step frontier_probe_old 240 "cd .trees/old && PYTHONPATH=$WORK/hzold:$SITE python3 docs/gpu_logs/frontier_events_probe.py --variants call4,call8"
  ;;
nov29b)
  # issue 15, end to end (calibration included in the first run of each feature set; the second is warm)
  F="$HZ bench --device cuda --sweep sweeps/frontier_16384.toml --json"
  step frontier_gear6_auto_1e-3 240 "$F --set integrator.method=gear6 --set integrator.dt=1e-3 --set integrator.events=auto"
  step frontier_gear6_auto_1e-3_warm 120 "$F --set integrator.method=gear6 --set integrator.dt=1e-3 --set integrator.events=auto"
  step frontier_gear4_off_2e-4 150 "$F --set integrator.method=gear4 --set integrator.dt=2e-4 --set integrator.events=off"
  step frontier_gear4_off_2e-4_warm 120 "$F --set integrator.method=gear4 --set integrator.dt=2e-4 --set integrator.events=off"
  ;;
nov29c)
  # issue 15: the chain's event steps shared among its lanes (rounds), t_n's state and the results in shared memory,
  # the event step inlined or out of line (kernels/tile.py), against plain steps; the CUDA event tests first
  step cuda_event_tests 300 "python3 -m pytest -q -p no:cacheprovider -k 'cuda and event' tests 2>&1"
  step frontier_probe_rounds 300 "python3 docs/gpu_logs/frontier_events_probe.py --variants off4,inline4,call4,off8,inline8"
  ;;
nov29d)
  # issue 15: what the event-aware tile kernel's steps cost without event steps (.trees/abl, build_trees.sh: commit f30c0b3 with ablate_tile.patch;
  # HZ_ABLATE = 0 as committed; 1 vote taken but its branch never; 2 no vote (the test's code then unused);
  # 3 a vote on a constant 0 flag (the barrier alone)), G = 4, the event step inlined; plain steps beside
  step frontier_probe_off4 120 "python3 docs/gpu_logs/frontier_events_probe.py --variants off4"
  mkdir -p $WORK/hzabl/hertzian
  for d in ensemble kernels sweeps; do ln -sfn "$REPO/.trees/abl/$d" "$WORK/hzabl/hertzian/$d"; done
  for a in ${ABLATIONS:-0 1 2 3}; do
    step "frontier_probe_ablate$a" 120 "cd .trees/abl && HZ_ABLATE=$a WARP_CACHE_PATH=$WORK/wc_$a PYTHONPATH=$WORK/hzabl:$SITE python3 docs/gpu_logs/frontier_events_probe.py --variants inline4"
  done
  ;;
nov29e)
  # issue 15 after the branch-free event test (each contact once) and the unrolled lane loops: the tile kernel
  # alone (probe), then end to end: gear6 with event steps at 1e-3, gear4 with event steps at 4e-4 and plain at
  # 1e-4 and 2e-4 (docs/accuracy/frontier_spread_cpu.json: which steps meet 1e-8 on the sweep's speeds)
  step cuda_event_tests 300 "python3 -m pytest -q -p no:cacheprovider -k 'cuda and event' tests 2>&1"
  step frontier_probe_e 300 "python3 docs/gpu_logs/frontier_events_probe.py --variants off4,inline4,call4,off8,inline8"
  F="$HZ bench --device cuda --sweep sweeps/frontier_16384.toml --json"
  step frontier_gear6_auto_1e-3 240 "$F --set integrator.method=gear6 --set integrator.dt=1e-3 --set integrator.events=auto"
  step frontier_gear6_auto_1e-3_warm 120 "$F --set integrator.method=gear6 --set integrator.dt=1e-3 --set integrator.events=auto"
  step frontier_gear4_auto_4e-4 240 "$F --set integrator.method=gear4 --set integrator.dt=4e-4 --set integrator.events=auto"
  step frontier_gear4_auto_4e-4_warm 120 "$F --set integrator.method=gear4 --set integrator.dt=4e-4 --set integrator.events=auto"
  step frontier_gear4_off_2e-4 150 "$F --set integrator.method=gear4 --set integrator.dt=2e-4 --set integrator.events=off"
  step frontier_gear4_off_1e-4 150 "$F --set integrator.method=gear4 --set integrator.dt=1e-4 --set integrator.events=off"
  ;;
nov29f)
  # issue 15 end to end on one machine, each configuration twice (the first compiles and calibrates): gear4 at its
  # largest steps meeting 1e-8 on all of the sweep's sampled speeds (events 5e-4, plain 1e-4;
  # docs/accuracy/frontier_spread_cpu.json), plain 2e-4 (meets it at v_imp = 1e-2 only), gear6 with events at 1e-3
  F="$HZ bench --device cuda --sweep sweeps/frontier_16384.toml --json"
  for run in 1 2; do
    step "frontier_gear6_auto_1e-3_$run" 240 "$F --set integrator.method=gear6 --set integrator.dt=1e-3 --set integrator.events=auto"
    step "frontier_gear4_auto_5e-4_$run" 240 "$F --set integrator.method=gear4 --set integrator.dt=5e-4 --set integrator.events=auto"
    step "frontier_gear4_off_1e-4_$run" 150 "$F --set integrator.method=gear4 --set integrator.dt=1e-4 --set integrator.events=off"
    step "frontier_gear4_off_2e-4_$run" 150 "$F --set integrator.method=gear4 --set integrator.dt=2e-4 --set integrator.events=off"
  done
  ;;
nov29g)
  # the fused kernels' bench numbers after the event work (all tile loops unrolled), and gpu_10k with the default
  # event-aware steps against plain steps
  step bench_kernels 300 "$HZ bench --device cuda --chains 16384,16384,1,1 --grains 1000,4096,1000,10240 --repeats 3 --json"
  step e2e_gpu10k_events_auto 240 "$HZ bench --device cuda --sweep sweeps/gpu_10k.toml --set integrator.events=auto --json"
  step e2e_gpu10k_events_auto_warm 200 "$HZ bench --device cuda --sweep sweeps/gpu_10k.toml --set integrator.events=auto --json"
  step e2e_gpu10k_off_warm 120 "$HZ bench --device cuda --sweep sweeps/gpu_10k.toml --json"
  ;;
nov29h)
  # the submitted state of the seventh session: every CUDA test (the tile loops' unrolling touched every fused
  # kernel), then the 1000-grain bench scenes with the default event-aware steps and with plain steps
  step pytest_cuda_h 480 "python3 -m pytest -q -p no:cacheprovider -k cuda tests 2>&1"
  for s in impact_1000 impact_1000_traces driven_1000; do
    step "e2e_${s}_auto_h" 90 "$HZ bench --device cuda --scene docs/bench/$s.toml --json"
    step "e2e_${s}_off_h" 90 "$HZ bench --device cuda --scene docs/bench/$s.toml --set integrator.events=off --json"
  done
  ;;
nov29i)
  # the whole reproduction with each sweep file's own events setting (event-aware steps where a file keeps the
  # default), fresh then warm
  step reproduce_default_cold_i 300 "$HZ reproduce --device cuda --out-dir $WORK/repro_default_cold"
  cp "$WORK"/repro_default_cold/log.json "$LOGS"/reproduce_default_cold_i_log.json 2>/dev/null
  step reproduce_default_warm_i 150 "$HZ reproduce --device cuda --out-dir $WORK/repro_default_warm"
  cp "$WORK"/repro_default_warm/log.json "$LOGS"/reproduce_default_warm_i_log.json 2>/dev/null
  ;;
nov29j)
  # the submitted event kernel (.trees/abl2, build_trees.sh: commit 1652f05 with h100_2026-11-26f/ablate2.patch:
  # register caps in the probe's variant names, HZ_ABLATE 7 = the test without the vote, 8 = the vote without the
  # test): where the remaining cost of a step without event steps lies, and whether a register cap (2 blocks per SM
  # at G = 4) pays, for plain and event-aware steps
  mkdir -p $WORK/hzabl2/hertzian
  for d in ensemble kernels sweeps; do ln -sfn "$REPO/.trees/abl2/$d" "$WORK/hzabl2/hertzian/$d"; done
  P="cd .trees/abl2 && PYTHONPATH=$WORK/hzabl2:$SITE python3 docs/gpu_logs/frontier_events_probe.py"
  step frontier_probe_caps 300 "$P --variants off4,off4r128,off8,inline4,inline4r168,inline4r128"
  for a in 7 8; do
    step "frontier_probe_ablate$a" 120 "cd .trees/abl2 && HZ_ABLATE=$a WARP_CACHE_PATH=$WORK/wc2_$a PYTHONPATH=$WORK/hzabl2:$SITE python3 docs/gpu_logs/frontier_events_probe.py --variants inline4"
  done
  ;;
nov29k)
  # the contact forces after the event section: the tile kernel alone on the frontier workload, and the CUDA event tests
  step frontier_probe_k 300 "python3 docs/gpu_logs/frontier_events_probe.py --variants off4,inline4,off8,inline8"
  step cuda_event_tests_k 300 "python3 -m pytest -q -p no:cacheprovider -k 'cuda and (event or fused)' tests 2>&1"
  ;;
nov29l)
  # the event step's forces branchless (the sqrt's fast path, F(delta0) once): the tile kernel alone, the CUDA event
  # and fused tests, then end to end: the frontier's gear6 and gear4 with event steps, gpu_10k with event steps
  step frontier_probe_l 300 "python3 docs/gpu_logs/frontier_events_probe.py --variants off4,inline4,off8,inline8"
  step cuda_event_tests_l 300 "python3 -m pytest -q -p no:cacheprovider -k 'cuda and (event or fused)' tests 2>&1"
  F="$HZ bench --device cuda --sweep sweeps/frontier_16384.toml --json"
  for run in 1 2; do
    step "frontier_gear6_auto_1e-3_l$run" 240 "$F --set integrator.method=gear6 --set integrator.dt=1e-3 --set integrator.events=auto"
    step "frontier_gear4_auto_5e-4_l$run" 240 "$F --set integrator.method=gear4 --set integrator.dt=5e-4 --set integrator.events=auto"
    step "frontier_gear4_off_1e-4_l$run" 150 "$F --set integrator.method=gear4 --set integrator.dt=1e-4 --set integrator.events=off"
  done
  step e2e_gpu10k_events_auto_l 240 "$HZ bench --device cuda --sweep sweeps/gpu_10k.toml --set integrator.events=auto --json"
  step e2e_gpu10k_events_auto_warm_l 200 "$HZ bench --device cuda --sweep sweeps/gpu_10k.toml --set integrator.events=auto --json"
  ;;
nov29m)
  # the rounds of event steps out of line (a noinline function): the tile kernel alone, the CUDA event tests
  step frontier_probe_m 300 "python3 docs/gpu_logs/frontier_events_probe.py --variants off4,inline4,inline8"
  step cuda_event_tests_m 300 "python3 -m pytest -q -p no:cacheprovider -k 'cuda and event' tests 2>&1"
  ;;
nov29n)
  # issue 11's traced scene: what the trace-writing code costs the window kernel by its presence (.trees/abl3, build_trees.sh:
  # commit d49645a with h100_2026-11-26f/ablate3.patch; HZ_ABLATE=9 returns before writing any trace: wrong results,
  # only the time counts), the kernel alone on the 1000-grain scenes in the shapes the calibration picks
  mkdir -p $WORK/hzabl3/hertzian
  for d in ensemble kernels sweeps; do ln -sfn "$REPO/.trees/abl3/$d" "$WORK/hzabl3/hertzian/$d"; done
  for a in 0 9; do
    step "scenes_ablate$a" 200 "cd .trees/abl3 && HZ_ABLATE=$a WARP_CACHE_PATH=$WORK/wc3_$a PYTHONPATH=$WORK/hzabl3:$SITE python3 docs/gpu_logs/scene_probe.py --scenes impact_1000,impact_1000_traces --configs 'lanes=32' --out $LOGS/scenes_ablate$a.json"
  done
  ;;
nov29o)
  # the trace sample out of line: the kernel alone on the 1000-grain scenes (32-lane shapes), the CUDA trace tests,
  # then issue 11's traced and driven scenes against the impact, end to end as in nov28k (duration 300, events off)
  step scenes_o 200 "python3 docs/gpu_logs/scene_probe.py --scenes impact_1000,impact_1000_traces,driven_1000 --configs 'lanes=32' --out $LOGS/scenes_o.json"
  step pytest_cuda_o 300 "python3 -m pytest -q -p no:cacheprovider -k 'cuda and (trace or fused or drive)' tests 2>&1"
  for s in impact_1000 impact_1000_traces driven_1000; do
    step "e2e_${s}_off_o" 150 "$HZ bench --device cuda --scene docs/bench/$s.toml --set integrator.duration=300 --set integrator.events=off --json"
    step "e2e_${s}_off_o2" 100 "$HZ bench --device cuda --scene docs/bench/$s.toml --set integrator.duration=300 --set integrator.events=off --json"
  done
  ;;
nov29p)
  # the submitted state: issue 11's 1000-grain scenes end to end again on another lease (as nov29o), three warm runs each
  scene_runs p impact_1000 impact_1000_traces driven_1000
  ;;
nov29q)
  # trial: a driven launch's phases in shared memory: the kernel alone on the 1000-grain scenes and the driven
  # columns' shape, the CUDA drive tests, issue 11's scenes end to end (three warm runs each after one cold)
  step scenes_q 200 "python3 docs/gpu_logs/scene_probe.py --scenes impact_1000,driven_1000 --configs 'lanes=32' --out $LOGS/scenes_q.json"
  step pytest_cuda_q 300 "python3 -m pytest -q -p no:cacheprovider -k 'cuda and (drive or refilled)' tests 2>&1"
  scene_runs q impact_1000 driven_1000
  ;;
nov30a)
  # eighth session: the driven grain at a fixed register slot and no free-end mask for a driven surface: the kernel
  # alone on the 1000-grain scenes (32-lane shapes), the CUDA drive and fused tests, issue 11's scenes end to end
  # (one cold, then three warm runs each)
  step scenes_a 200 "python3 docs/gpu_logs/scene_probe.py --scenes impact_1000,impact_1000_traces,driven_1000 --configs 'lanes=32' --out $LOGS/scenes_a.json"
  step pytest_cuda_a 300 "python3 -m pytest -q -p no:cacheprovider -k 'cuda and (drive or refilled or fused or window or trace)' tests 2>&1"
  scene_runs a impact_1000 impact_1000_traces driven_1000
  ;;
nov30b)
  # the paper reproduction as shipped (plain Gear steps in every group, fused kernels on the GPU): on a fresh
  # machine, then warm; the fused kernels' bench (no regression)
  step reproduce_default_cold_b 330 "$HZ reproduce --device cuda --out-dir $WORK/repro_b_cold"
  cp "$WORK"/repro_b_cold/log.json "$LOGS"/reproduce_default_cold_b_log.json 2>/dev/null
  step reproduce_default_warm_b 150 "$HZ reproduce --device cuda --out-dir $WORK/repro_b_warm"
  cp "$WORK"/repro_b_warm/log.json "$LOGS"/reproduce_default_warm_b_log.json 2>/dev/null
  step bench_kernels_b 200 "$HZ bench --device cuda --chains 16384,16384,1,1 --grains 1000,4096,1000,10240 --repeats 3 --json"
  ;;
nov30c)
  # the driver's work after the step loop in parallel terms (and the fixed slot of nov30a): the kernel alone on the
  # 1000-grain scenes, the CUDA drive tests, issue 11's impact and driven scenes end to end (one cold, three warm),
  # the driven columns of Figs. 9-10 end to end (cold, warm)
  step scenes_c 200 "python3 docs/gpu_logs/scene_probe.py --scenes impact_1000,driven_1000 --configs 'lanes=32' --out $LOGS/scenes_c.json"
  step pytest_cuda_c 300 "python3 -m pytest -q -p no:cacheprovider -k 'cuda and (drive or refilled or fused or window)' tests 2>&1"
  scene_runs c impact_1000 driven_1000
  step e2e_fig9_10_c 200 "$HZ bench --device cuda --sweep sweeps/paper_fig9_10.toml --json"
  step e2e_fig9_10_c2 120 "$HZ bench --device cuda --sweep sweeps/paper_fig9_10.toml --json"
  ;;
nov30d)
  # the driver's phases in two registers in turn (no copy of a loaded value): as nov30c, and the traced scene once
  step scenes_d 200 "python3 docs/gpu_logs/scene_probe.py --scenes impact_1000,driven_1000 --configs 'lanes=32' --out $LOGS/scenes_d.json"
  step pytest_cuda_d 300 "python3 -m pytest -q -p no:cacheprovider -k 'cuda and (drive or refilled or fused or window)' tests 2>&1"
  scene_runs d impact_1000 driven_1000
  step e2e_fig9_10_d 200 "$HZ bench --device cuda --sweep sweeps/paper_fig9_10.toml --json"
  step e2e_fig9_10_d2 120 "$HZ bench --device cuda --sweep sweeps/paper_fig9_10.toml --json"
  ;;
nov30e)
  # up to 8 figure workers (4 before): the reproduction as shipped on a fresh machine, then warm twice
  step reproduce_default_cold_e 330 "$HZ reproduce --device cuda --out-dir $WORK/repro_e_cold"
  cp "$WORK"/repro_e_cold/log.json "$LOGS"/reproduce_default_cold_e_log.json 2>/dev/null
  for r in 1 2; do
    step "reproduce_default_warm_e$r" 150 "$HZ reproduce --device cuda --out-dir $WORK/repro_e_warm$r"
    cp "$WORK"/repro_e_warm$r/log.json "$LOGS"/reproduce_default_warm_e${r}_log.json 2>/dev/null
  done
  ;;
nov30f)
  # the driven loop without the cos of its phases and the driver's work (162 -> 150 registers): kernel alone, CUDA
  # drive tests, issue 11's impact and driven scenes end to end, the Figs. 9-10 columns
  step scenes_f 200 "python3 docs/gpu_logs/scene_probe.py --scenes impact_1000,driven_1000 --configs 'lanes=32' --out $LOGS/scenes_f.json"
  step pytest_cuda_f 300 "python3 -m pytest -q -p no:cacheprovider -k 'cuda and (drive or refilled or fused or window)' tests 2>&1"
  scene_runs f impact_1000 driven_1000
  step e2e_fig9_10_f 200 "$HZ bench --device cuda --sweep sweeps/paper_fig9_10.toml --json"
  step e2e_fig9_10_f2 120 "$HZ bench --device cuda --sweep sweeps/paper_fig9_10.toml --json"
  ;;
nov30g)
  # the submitted driven loop on another lease: kernel alone, issue 11's three 1000-grain scenes end to end
  step scenes_g 200 "python3 docs/gpu_logs/scene_probe.py --scenes impact_1000,impact_1000_traces,driven_1000 --configs 'lanes=32' --out $LOGS/scenes_g.json"
  scene_runs g impact_1000 impact_1000_traces driven_1000
  ;;
nov30h)
  # the final code on a fresh machine: gpu_10k as shipped (cold, then warm twice), every CUDA test, issue 11's impact
  # and driven scenes end to end
  step e2e_gpu10k_cold_h 200 "$HZ bench --device cuda --cold --sweep sweeps/gpu_10k.toml --json"
  step e2e_gpu10k_h 120 "$HZ bench --device cuda --sweep sweeps/gpu_10k.toml --json"
  step e2e_gpu10k_h2 120 "$HZ bench --device cuda --sweep sweeps/gpu_10k.toml --json"
  scene_runs h impact_1000 driven_1000
  step pytest_cuda_h 330 "python3 -m pytest -q -p no:cacheprovider -k cuda tests 2>&1"
  ;;
nov30i)
  # the inverse-mass function (sm_90: the impact window kernel 140 -> 122 registers, 26 moves fewer a step pair):
  # kernel alone, issue 11's impact and driven scenes, the fused kernels' bench, the event kernel alone
  step scenes_i 200 "python3 docs/gpu_logs/scene_probe.py --scenes impact_1000,driven_1000 --configs 'lanes=32' --out $LOGS/scenes_i.json"
  scene_runs i impact_1000 driven_1000
  step bench_kernels_i 200 "$HZ bench --device cuda --chains 16384,16384,1,1 --grains 1000,4096,1000,10240 --repeats 3 --json"
  step frontier_probe_i 200 "python3 docs/gpu_logs/frontier_events_probe.py --variants inline4,off4"
  ;;
detect)
  step detect_study_1000 500 "$HZ detect-study sweeps/detect_study_1000.toml --out $LOGS/study_1000_gpu.json --overwrite --device cuda"
  ;;
*) echo "unknown group $group"; exit 2 ;;
esac
done
cat "$LOGS/summary.tsv"
[ -n "$WATCHDOG_PID" ] && kill "$WATCHDOG_PID" 2>/dev/null
[ -n "${OUT:-}" ] && tar czf "$OUT/logs.tgz" -C "$LOGS" . && rm -f "$OUT/partial.tgz"
exit 0
