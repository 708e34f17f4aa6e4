#!/bin/sh
# End-to-end CPU benchmark of docs/benchmarks.md ("End to end"): run from the repository root;
# writes docs/logs/endtoend_cpu.txt (each command, then its --json records):
#   PYTHONPATH=$PWD ./docs/logs/endtoend_cpu.sh > docs/logs/endtoend_cpu.txt
# Device: the CPU of the session's machine (2 cores, shared with other jobs).
set -e
run() {
    echo "## $(date -u +%Y-%m-%dT%H:%M:%SZ) hertzian $*"
    python -m ensemble.cli "$@" --json
}
{
    echo "# hertzian end-to-end bench, CPU ($(nproc) cores, $(uname -m)), $(git rev-parse --short HEAD)"
    run bench --device cpu --cold --scene docs/bench/impact_1000_traces.toml
    run bench --device cpu --scene docs/bench/impact_1000_traces.toml
    for round in 1 2 3; do
        run bench --device cpu --scene docs/bench/impact_1000.toml
        run bench --device cpu --scene docs/bench/impact_1000_traces.toml
        run bench --device cpu --scene docs/bench/driven_1000.toml
    done
    run bench --device cpu --scene docs/bench/impact_1000_traces.toml --kernel step
    run bench --device cpu --scene docs/bench/driven_1000.toml --kernel step
    run bench --device cpu --cold --sweep sweeps/example.toml
    run bench --device cpu --sweep sweeps/example.toml
    run bench --device cpu --sweep sweeps/example.toml --kernel sweep
    run bench --device cpu --sweep sweeps/cpu_100k.toml
    # kernels and peers (JAX CPU build, if installed), in a loop without records or stores
    run bench --device cpu --chains 64,1 --grains 1000,1000 --repeats 3
} 2>&1
