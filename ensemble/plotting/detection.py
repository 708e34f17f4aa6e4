"""Figure of a detection: the signal with the best fit and residual, and the posterior over depth."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from hertzian.core.outputs import PNG_METADATA
from hertzian.studies.detection import Detection
from hertzian.studies.detection.library import Library
from hertzian.studies.detection.signal import Signal


def plot_detection(signal: Signal, detection: Detection, library: Library, path: str | Path) -> None:
    """Signal, best fit and residual (top); posterior over depth of both classes (bottom)."""
    # matplotlib is heavy and only needed for the figure
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (top, bottom) = plt.subplots(2, 1, figsize=(9, 7), constrained_layout=True)
    count = detection.best_fit.size  # the analysed window
    signal = Signal(t=signal.t[:count], v=signal.v[:count], source=signal.source)
    top.plot(signal.t, signal.v, lw=0.8, color="0.5", label="signal")
    top.plot(signal.t, detection.best_fit, lw=0.9, color="C0", label="best fit")
    residual = signal.v - detection.best_fit
    top.plot(signal.t, residual, lw=0.6, color="C3", label="residual")
    scale = max(float(np.max(np.abs(signal.v - library.clean))), 5 * detection.noise)
    top.set_ylim(-3 * scale, 3 * scale)
    top.set_xlabel("t [program time, 1.0102e-3 s]")
    top.set_ylabel("v of grain 0 [program velocity]")
    what = (
        detection.kind
        if detection.kind == "none"
        else (
            f"{detection.kind}, depth {detection.depth} {list(detection.depth_interval)}, "
            f"μ = {detection.mass_ratio:.3g} [{detection.mass_ratio_interval[0]:.3g}, "
            f"{detection.mass_ratio_interval[1]:.3g}]"
        )
    )
    top.set_title(f"{signal.source}: {what}; σ = {detection.noise:.3g}", fontsize=9)
    top.legend(fontsize=8, loc="upper right")
    for kind, color in (("light", "C2"), ("heavy", "C1")):
        p = detection.depth_posterior[kind] * detection.class_probability[kind]
        bottom.bar(library.grid.depths, p, color=color, alpha=0.7, width=1.0, label=f"{kind}")
    bottom.set_xlabel("depth (first impurity grain)")
    bottom.set_ylabel("p(depth, class | signal)")
    bottom.set_title(f"p(none) = {detection.class_probability['none']:.3g}", fontsize=9)
    bottom.legend(fontsize=8)
    fig.savefig(path, dpi=110, metadata=PNG_METADATA)
    plt.close(fig)
