"""Statistics over realisations of random chains: per-point observables of an impact store, reduced over one
of its dimensions (the seed of ``chain.radii``, typically) to mean, standard deviation and quantiles.

Observables, per point, from the snapshots ``v`` (record, grain) and, where stored, the grain masses:

* ``arrival_time`` [time]: the first record at which the bottom grain's speed exceeds ARRIVAL_FRACTION of the
  largest speed of the chain (the snapshot interval is its resolution);
* ``bottom_energy`` [energy]: the largest kinetic energy ½ m v² of the bottom grain over the records;
* ``bottom_fraction``: that over the injected energy ½ m_0 v_0(0)²;
* ``leading_amplitude`` [length/time], per grain: the largest speed each grain reaches (the leading pulse's
  amplitude against depth);
* ``decay_length`` [grains]: λ of the least-squares fit ln(leading_amplitude) = c − z/λ over the grains between
  the surface and the bottom (excluded: the struck grain and the bottom grain, which a wall reflects on).
"""

from __future__ import annotations

import warnings

import numpy as np

ARRIVAL_FRACTION = 1e-2
QUANTILES = (0.05, 0.5, 0.95)
SCALAR_OBSERVABLES = ("arrival_time", "bottom_energy", "bottom_fraction", "decay_length")
OBSERVABLES = SCALAR_OBSERVABLES + ("leading_amplitude",)


def observables(ds) -> dict[str, np.ndarray]:
    """Per-point observables of an xarray store ``ds`` holding ``v`` (…, record, grain): name → array of shape
    (…) (``leading_amplitude``: (…, grain)), float64."""
    if "v" not in ds:
        raise ValueError("the store holds no v snapshots (record.fields must include v)")
    v = np.abs(np.asarray(ds.v.values, dtype=np.float64))
    t = np.asarray(ds.t.values, dtype=np.float64)
    grains = v.shape[-1]
    mass = np.asarray(ds.mass.values) if "mass" in ds else np.ones(grains)
    mass = np.broadcast_to(mass, v.shape[:-2] + (grains,))
    amplitude = v.max(axis=-2)
    moved = v[..., -1] > ARRIVAL_FRACTION * v.max(axis=(-2, -1))[..., None]
    arrival = np.where(moved.any(axis=-1), t[np.argmax(moved, axis=-1)], np.nan)
    bottom = (0.5 * mass[..., -1:] * v[..., :, -1] ** 2).max(axis=-1)
    injected = 0.5 * mass[..., 0] * v[..., 0, 0] ** 2
    with np.errstate(divide="ignore", invalid="ignore"):
        fraction = bottom / injected
        z = np.arange(1, grains - 1, dtype=np.float64)
        logs = np.log(amplitude[..., 1:-1])
        zc = z - z.mean()
        slope = (logs * zc).sum(axis=-1) / (zc * zc).sum()
        decay = -1.0 / slope
    return {
        "arrival_time": arrival,
        "bottom_energy": bottom,
        "bottom_fraction": fraction,
        "decay_length": decay,
        "leading_amplitude": amplitude,
    }


def statistics(ds, over: str) -> dict[str, dict[str, np.ndarray]]:
    """Observables reduced over dimension ``over``: name → {mean, std, q05, q50, q95, count}, each of shape (the
    store's other sweep dimensions…[, grain]). NaN points (a pulse that never arrived) are left out."""
    if over not in ds.dims:
        dims = [d for d in ds.dims if d not in ("record", "grain", "sample", "traced")]
        raise ValueError(f"--over = {over!r}: not a dimension of the store (its sweep dimensions: {', '.join(dims)})")
    axis = list(ds.v.dims).index(over)
    out = {}
    with warnings.catch_warnings():  # an all-NaN slice (no arrival anywhere) gives NaN statistics, as it should
        warnings.simplefilter("ignore", RuntimeWarning)
        for name, values in observables(ds).items():
            out[name] = _reduce(values, axis)
    return out


def _reduce(values: np.ndarray, axis: int) -> dict[str, np.ndarray]:
    finite = np.isfinite(values)
    return {
        "mean": np.nanmean(values, axis=axis),
        "std": np.nanstd(values, axis=axis, ddof=1) if values.shape[axis] > 1 else np.zeros_like(values.take(0, axis)),
        **{f"q{round(100 * q):02d}": np.nanquantile(values, q, axis=axis) for q in QUANTILES},
        "count": finite.sum(axis=axis),
    }


def statistics_json(ds, over: str) -> dict:
    """:func:`statistics` as plain data: the kept dimensions and their coordinates, and each observable's
    statistics as nested lists."""
    numbers = statistics(ds, over)
    kept = [d for d in ds.v.dims if d not in (over, "record", "grain")]
    return {
        "over": over,
        "realisations": int(ds.sizes[over]),
        "dims": kept,
        "coords": {d: np.asarray(ds[d].values).tolist() for d in kept if d in ds.coords},
        "observables": {name: {k: np.asarray(v).tolist() for k, v in stats.items()} for name, stats in numbers.items()},
    }


def plot_distribution(ds, of: str, out, *, bins: int = 30) -> None:
    """Histogram of one scalar observable over every point of the store, written as a PNG to ``out``."""
    if of not in SCALAR_OBSERVABLES:
        raise ValueError(f"--of = {of!r}: allowed: {', '.join(SCALAR_OBSERVABLES)}")
    import matplotlib  # optional, heavy: only plotting needs it

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    values = observables(ds)[of].reshape(-1)
    values = values[np.isfinite(values)]
    fig, ax = plt.subplots(figsize=(5, 3.5))
    ax.hist(values, bins=bins)
    q = np.quantile(values, QUANTILES) if values.size else []
    for x in q:
        ax.axvline(x, color="k", lw=0.8, ls="--")
    ax.set_xlabel(of)
    ax.set_ylabel("points")
    ax.set_title(f"{values.size} points; 5, 50, 95 % quantiles dashed")
    fig.tight_layout()
    fig.savefig(out, dpi=120)
    plt.close(fig)
