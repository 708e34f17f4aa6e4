"""Studies built on the core and the sweeps: accuracy, detection, reproduction of the paper, benchmarks and peers."""
