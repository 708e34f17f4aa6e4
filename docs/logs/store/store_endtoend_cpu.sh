# End-to-end store seconds of a gpu_10k-shaped sweep on this CPU (10 000 points × 500 grains, 11 records, two
# traces of 501 samples; 500 steps so that the store, not the kernel, is what is timed), with the batch writes'
# write_empty_chunks as Zarr's default (False, commit given as BEFORE) and as the store now sets it (True).
# Run from the repository root: bash docs/logs/store/store_endtoend_cpu.sh BEFORE_COMMIT > docs/logs/store/store_endtoend_cpu.txt
set -u
before="$1"
run() {
  hertzian bench --device cpu --sweep sweeps/gpu_10k.toml --set integrator.duration=0.005 --set integrator.dt=1e-5 \
    --set record.every=0.0005 --set record.trace_every=1e-5 --json 2>/dev/null |
    python3 -c "import json,sys; r=json.load(sys.stdin)[0]; print('$1', json.dumps(r['seconds']))"
}
for round in 1 2; do
  git checkout -q "$before" -- ensemble/sweep_store.py && run before
  git checkout -q HEAD -- ensemble/sweep_store.py && run after
done
