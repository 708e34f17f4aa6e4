"""The picture of a protector design store (``hertzian plot DESIGN.zarr``): how the best objective fell over the
generations, the best protector drawn bead by bead (size to scale, colour by material), and the force on the wall
behind it against uniform and tapered protectors of the same length in each of its materials
(hertzian.studies.design.compare); with several objectives, every candidate and the Pareto front of the first two."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from hertzian.core.outputs import PNG_METADATA

DPI = 110
LABELS = {
    "peak_wall_force": "peak wall force (program units, 2.3e-4 N)",
    "impulse": "impulse on the wall (program units, 2.3e-7 N s)",
    "mass": "protector mass (program units, 2.36e-5 kg)",
}
"""Each objective's axis label, with its unit."""
COLOURS = ("#4c72b0", "#dd8452", "#55a868", "#c44e52", "#8172b3", "#937860", "#da8bc3", "#8c8c8c")


def plot_design(summary: dict, out: Path) -> None:
    """Draw ``summary`` (hertzian.studies.design.compare) into the PNG ``out``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.ticker

    front = "pareto" in summary
    ratios = [1, 0.6, 1.2] + ([1.2] if front else [])
    fig, axes = plt.subplots(len(ratios), 1, figsize=(9, 10 + 3.5 * front), gridspec_kw={"height_ratios": ratios})
    conv, beads, force = axes[:3]
    objective = summary["objectives"][0].replace("_", " ")
    generations = np.arange(1, summary["generations"] + 1)
    conv.plot(generations, summary["best_objective"], label="best so far")
    median = [np.nan if m is None else m for m in summary["median_objective"]]
    conv.plot(generations, median, label="median of the generation", alpha=0.6)
    conv.set(xlabel="generation", ylabel=LABELS[summary["objectives"][0]], title=f"{objective}: convergence")
    conv.xaxis.set_major_locator(matplotlib.ticker.MaxNLocator(integer=True))  # generations are whole
    conv.legend()
    _draw_beads(beads, summary["best_materials"], summary["best_radii"])
    for name, (t, f) in summary["traces"].items():
        row = summary["chains"][name]
        label = f"{name}: peak {row['peak_wall_force']:.3g}, protector mass {row['mass']:.3g}"
        force.plot(t, f, label=label, lw=2.0 if name == "best" else 0.9, zorder=3 if name == "best" else 2)
    force.set(xlabel="t (time units of 1.0102 ms)", ylabel="force on the wall (program units, 2.3e-4 N)")
    force.set_yscale("symlog", linthresh=1e-3)
    force.set_title("the wall's force: best design against plain protectors of the same length")
    force.legend(fontsize=8)
    if front:
        _draw_front(axes[3], summary)
    fig.tight_layout()
    fig.savefig(out, dpi=DPI, metadata=PNG_METADATA)
    plt.close(fig)


def _draw_beads(ax, materials: list[str], radii: list[float]) -> None:
    """The chain from the striker (left) to the wall (right): circles to scale, one colour per material."""
    from matplotlib.patches import Circle

    names = list(dict.fromkeys(materials))
    x = 0.0
    for name, r in zip(materials, radii):
        x += r
        ax.add_patch(Circle((x, 0.0), r, color=COLOURS[names.index(name) % len(COLOURS)], ec="k", lw=0.5))
        x += r
    ax.axvline(x, color="k", lw=3)
    ax.set_xlim(-5, x + 20)
    ax.set_ylim(-max(radii) * 1.3, max(radii) * 1.3)
    ax.set_aspect("equal")
    ax.set_yticks([])
    ax.set_xlabel("position along the chain (1e-5 m); striker at the left, wall at the right")
    handles = [ax.plot([], [], "o", color=COLOURS[i % len(COLOURS)], label=n)[0] for i, n in enumerate(names)]
    ax.legend(handles=handles, loc="upper left", fontsize=8, ncol=len(names))
    ax.set_title("best protector")


def _draw_front(ax, summary: dict) -> None:
    """Every finite candidate in the plane of the first two objectives, and the Pareto front."""
    x, y = (LABELS[name] for name in summary["objectives"][:2])
    every = np.asarray(summary["candidates"])
    ax.scatter(every[:, 0], every[:, 1], s=6, alpha=0.3, label="every candidate")
    front = np.asarray([p["objectives"] for p in summary["pareto"]])
    ax.plot(front[:, 0], front[:, 1], "o-", color="k", ms=4, label=f"Pareto front ({len(front)} designs)")
    ax.set(xlabel=x, ylabel=y, xscale="log", title="Pareto front")
    ax.legend(fontsize=8)
