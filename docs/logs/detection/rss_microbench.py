"""Per-depth cost of the library's RSS over the interpolated points (ensemble/detect.py), old and new form.

    python docs/logs/detection/rss_microbench.py

Old: form W @ models (points × samples) and sum the squared residuals. New: ``interpolated_rss`` (Gram form).
Sizes: 8 library nodes (7 ratios + the clean chain), 57 interpolated points, S samples (1700: the 150-grain
example; 11 000: about a 1000-grain chain's record at spacing 0.01). Median of 30 repeats per size.
"""
import statistics
import time

import numpy as np

from hertzian.ensemble.detect import interpolated_rss, lagrange_weights

rng = np.random.default_rng(0)
nodes = np.linspace(-1.4, 0.0, 8)
W, _ = lagrange_weights(nodes, np.linspace(nodes[0], nodes[-1], 57))
print(f"numpy {np.__version__}")
for samples in (1700, 11000):
    clean = rng.normal(size=samples)
    models = clean[None] + 1e-3 * rng.normal(size=(8, samples))
    signal = clean + 1e-3 * rng.normal(size=samples)

    def old():
        residual = signal[None] - W @ models
        return np.einsum("ms,ms->m", residual, residual)

    def new():
        return interpolated_rss(signal, models, clean, W)

    for name, f in (("old", old), ("new", new)):
        f()
        times = []
        for _ in range(30):
            t0 = time.perf_counter()
            f()
            times.append(time.perf_counter() - t0)
        print(f"S = {samples}: {name} {statistics.median(times) * 1e3:.3f} ms per depth and class")
