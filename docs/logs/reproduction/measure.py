"""Measure the full-size stores behind docs/reproduction.md and redraw docs/figures from them.

Usage, from the repository root, after one ``hertzian reproduce`` per group:

    for g in fig1 fig1d fig2 fig3 fig3_load fig4 fig5 fig5_single fig5_modes fig6 depth \\
             fig7_8 fig7_8_single fig7_8_slow; do
        hertzian reproduce --figure $g --out-dir out/paper/$g --device cpu
        cp out/paper/$g/log.json docs/logs/reproduction/$g.json
    done
    python docs/logs/reproduction/measure.py out/paper

Writes docs/logs/reproduction/measurements.json (each group's run log and measurements, and the
comparisons across groups; see ``hertzian.ensemble.reproduce.measure_stores``) and the PNGs in docs/figures/.
"""

import json
import os
import sys
from pathlib import Path

from hertzian.ensemble.reproduce import measure_stores

root = Path(sys.argv[1] if len(sys.argv) > 1 else "out/paper")
here = Path(__file__).resolve().parent
figures = Path(os.path.relpath(here.parent.parent / "figures"))   # relative: no machine paths in the log
log = measure_stores(root, figures_dir=figures,
                     command=f"python docs/logs/reproduction/measure.py {root}")
(here / "measurements.json").write_text(json.dumps(log, indent=1))
print(f"wrote {here / 'measurements.json'}: {len(log['groups'])} groups")
