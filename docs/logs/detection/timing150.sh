#!/bin/sh
# 150-grain timing of `hertzian detect` from an empty library cache, then with the library cached.
set -e
export HERTZIAN_DETECT_CACHE=$(mktemp -d)
D=docs/logs/detection
date -u; echo "cores: $(nproc); load average: $(cut -d' ' -f1-3 /proc/loadavg)"; git rev-parse --short HEAD
python -m ensemble.cli run $D/planted150.toml --out /tmp/planted150.zarr --overwrite --device cpu
echo "## first call (library simulated)"
/usr/bin/time -f "wall %e s, user %U s, CPU share %P" python -m ensemble.cli detect /tmp/planted150.zarr --scene $D/base150.toml --noise 1e-5 --device cpu
echo "## second call (library cached)"
/usr/bin/time -f "wall %e s, user %U s, CPU share %P" python -m ensemble.cli detect /tmp/planted150.zarr --scene $D/base150.toml --noise 1e-5 --device cpu
echo "load average after: $(cut -d' ' -f1-3 /proc/loadavg)"
