"""Statistics over realisations of random chains: per-point observables of an impact store, reduced over one
of its dimensions (the seed of ``chain.radii``, typically) to mean, standard deviation and quantiles.

Observables, per point, from the snapshots ``v`` (record, grain) and, where stored, the grain masses:

* ``arrival_time`` [time]: the first record at which the bottom grain's speed exceeds ARRIVAL_FRACTION of the
  largest speed of the chain (the snapshot interval is its resolution);
* ``bottom_energy`` [energy]: the largest kinetic energy ½ m v² of the bottom grain: over its trace samples where the
  store traces it (``record.traces``), else over the snapshots. The bottom grain's pulse can be shorter than
  ``record.every`` (0.009 wide at q = 0.02 in a 100-grain taper, against snapshots every 0.02): snapshots then
  catch it at a phase that changes with dt, and their maximum is not a measurement (docs/heterogeneous.md);
* ``bottom_fraction``: that over the injected energy ½ m_0 v_0(0)²;
* ``leading_amplitude`` [length/time], per grain: the largest speed each grain reaches (the leading pulse's
  amplitude against depth);
* ``decay_length`` [grains]: λ of the least-squares fit ln(leading_amplitude) = c − z/λ over the grains between
  the surface and the bottom (excluded: the struck grain and the bottom grain, which a wall reflects on);
* ``bottom_peak_force`` [force], where the store records the bottom grain's displacement (traces or ``u``
  snapshots): the largest Hertz force on the bottom grain from below (:func:`bottom_peak_force`).
"""

from __future__ import annotations

import json
import warnings

import numpy as np
from hertzian.core.outputs import PNG_METADATA
from hertzian.core.scene import scene_from_dict
from hertzian.core.static import static_arrays, static_state
from hertzian.sweeping.spec import expand, sweep_from_dict

ARRIVAL_FRACTION = 1e-2
QUANTILES = (0.05, 0.5, 0.95)
SCALAR_OBSERVABLES = ("arrival_time", "bottom_energy", "bottom_fraction", "decay_length", "bottom_peak_force")
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
    bottom = (0.5 * mass[..., -1:] * bottom_speed(ds, v) ** 2).max(axis=-1)
    injected = 0.5 * mass[..., 0] * v[..., 0, 0] ** 2
    with np.errstate(divide="ignore", invalid="ignore"):
        fraction = bottom / injected
        z = np.arange(1, grains - 1, dtype=np.float64)
        logs = np.log(amplitude[..., 1:-1])
        zc = z - z.mean()
        slope = (logs * zc).sum(axis=-1) / (zc * zc).sum()
        decay = -1.0 / slope
    found = {
        "arrival_time": arrival,
        "bottom_energy": bottom,
        "bottom_fraction": fraction,
        "decay_length": decay,
        "leading_amplitude": amplitude,
    }
    try:
        found["bottom_peak_force"] = bottom_peak_force(ds)
    except NotRecorded:
        pass
    return found


def bottom_speed(ds, v: np.ndarray) -> np.ndarray:
    """|v| of the bottom grain over time, (…, time) float64: its trace (every ``record.trace_every``) where the store
    traces it, else its snapshots ``v`` (every ``record.every``; ``v``: their absolute values)."""
    grains = int(ds.sizes["grain"])
    if "trace_v" in ds:
        traced = np.asarray(ds.traced_grain.values).tolist()
        if grains - 1 in traced:
            return np.abs(np.asarray(ds.trace_v.isel(traced=traced.index(grains - 1)).values, dtype=np.float64))
    return v[..., :, -1]


class NotRecorded(ValueError):
    """A store that records nothing an observable is measured from (the message is one line)."""


def bottom_peak_force(ds) -> np.ndarray:
    """Largest contact force [force] on the bottom grain N − 1 from below, per point of a store (shape: the
    store's sweep dimensions), float64.

    With ``boundary.bottom = "wall"`` it is the wall contact's F = n·a_w·max(δ, 0)^(n−1), δ = δ0_w + u_(N−1),
    a_w the bottom grain's wall constant (a·√(R_(N−1)/R0), or an impurity's a) and δ0_w the wall contact's static
    overlap; for another bottom it is the last inner contact's, δ = δ0 + u_(N−2) − u_(N−1). Constants and static
    overlaps come from each point's scene, rebuilt from the store's ``sweep`` (or ``scene`` and
    ``scene_overrides``) attributes. The displacements are the traces (``record.traces``, every
    ``record.trace_every``) when they hold the grains needed, else the ``u`` snapshots, which sample the peak only
    every ``record.every`` and so under-estimate it. Raises :class:`NotRecorded` (one line) if neither is stored.
    """
    grains = int(ds.sizes["grain"])
    _displacements(ds, [grains - 1])  # refuse before rebuilding any scene
    constant, overlap, exponent, wall = _bottom_contact(ds)
    below, *above = _displacements(ds, [grains - 1] if wall.all() else [grains - 1, grains - 2])
    delta = overlap[..., None] + below
    if above:
        delta += np.where(wall[..., None], 0.0, above[0])
    n = exponent[..., None]
    force = n * constant[..., None] * np.maximum(delta, 0.0) ** (n - 1.0)
    return force.max(axis=-1)


def _displacements(ds, grains: list[int]) -> list[np.ndarray]:
    """u of each of ``grains`` over time, (…, time) float64: from the traces if they hold every one, else the u
    snapshots (:class:`NotRecorded` if neither)."""
    if "trace_u" in ds:
        traced = np.asarray(ds.traced_grain.values).tolist()
        if all(g in traced for g in grains):
            return [np.asarray(ds.trace_u.isel(traced=traced.index(g)).values, dtype=np.float64) for g in grains]
    if "u" in ds:
        return [np.asarray(ds.u.isel(grain=g).values, dtype=np.float64) for g in grains]
    listed = ", ".join(map(str, grains))
    raise NotRecorded(
        f"bottom_peak_force: the store records neither traces of grain(s) {listed} (record.traces) nor u snapshots "
        "(record.fields must include u)"
    )


def _bottom_contact(ds) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(contact constant, static overlap [length], exponent, bottom is a wall) of the contact below the bottom grain
    (the wall's, else the last inner contact's) at every point, each of the store's sweep shape."""
    shape = tuple(ds.status.shape)
    out = [np.empty(int(np.prod(shape))) for _ in range(3)] + [np.empty(int(np.prod(shape)), dtype=bool)]
    for indices, constant, overlap, exponent, wall in _point_statics(ds):
        last = constant.shape[-1] - (1 if wall else 2)  # padded contacts: N is the bottom wall, N − 1 the last inner
        for column, value in zip(out, (constant[:, last], overlap[:, last], exponent, wall)):
            column[indices] = value
    return tuple(column.reshape(shape) for column in out)


def _point_statics(ds):
    """Per group of points sharing a template: (flat point indices, padded contact constants and static overlaps
    (points, N + 1), exponents (points,), bottom is a wall)."""
    overrides = json.loads(ds.attrs.get("scene_overrides", "{}"))
    if overrides:  # a run of several scenes (hertzian.sweeping.sweep_store.write_result)
        base = scene_from_dict(json.loads(ds.attrs["scene"]))
        for p in range(len(next(iter(overrides.values())))):
            scene = base.with_overrides({k: v[p] for k, v in overrides.items()})
            st = static_state(scene)
            wall = scene.boundary.bottom == "wall"
            yield [p], st.contact_constant[None], st.static_overlap[None], st.exponent, wall
        return
    data = json.loads(ds.attrs["sweep"])
    sweep = sweep_from_dict({k: data[k] for k in ("scene", "axis", "zip") if k in data}, max_points=None)
    expanded = expand(sweep, validate=False)
    points = np.arange(expanded.point_count)
    templates = expanded.template_index(points)
    for t in np.unique(templates):
        members = points[templates == t]
        chains = expanded.chains(members)
        st = static_arrays(chains)
        wall = chains.template.boundary.bottom == "wall"
        yield members, st.contact_constant, st.static_overlap, st.exponent, wall


def statistics(ds, over: str) -> dict[str, dict[str, np.ndarray]]:
    """Observables reduced over dimension ``over``: name → {mean, std, q05, q50, q95, count}, each of shape (the
    store's other sweep dimensions…[, grain]). NaN points (a pulse that never arrived) are left out."""
    if "status" in ds:
        dims = list(ds["status"].dims)  # a point's status has the sweep's dimensions
    else:
        dims = [d for d in ds.dims if d not in ("record", "grain", "sample", "traced", "mode")]
    if over not in dims:
        held = f"its sweep dimensions: {', '.join(dims)}" if dims else "a single run: no sweep dimensions"
        raise ValueError(f"--over = {over!r}: not a sweep dimension of the store ({held})")
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


UNITS = {
    "arrival_time": "program time, 1.0102 ms",
    "bottom_energy": "program energy, 2.3e-9 J",
    "bottom_fraction": "of the injected energy",
    "decay_length": "grains",
    "bottom_peak_force": "program force, 0.23 mN",
}
"""Units of each scalar observable, for axis labels."""
REALISATION_DIM = "seed"
"""The sweep dimension whose points are realisations of one disorder: pooled in a histogram; every other sweep
dimension gets a histogram of its own."""


def plot_distribution(ds, of: str, out, *, bins: int = 30) -> None:
    """Histograms of one scalar observable over the realisations of the store, one panel per point of its other
    sweep dimensions (e.g. one per spread, each over its seeds), each with its own bins, its 5, 50 and 95 %
    quantiles dashed, and units; written as a PNG to ``out``."""
    if of not in SCALAR_OBSERVABLES:
        raise ValueError(f"--of = {of!r}: allowed: {', '.join(SCALAR_OBSERVABLES)}")
    import matplotlib  # optional, heavy: only plotting needs it

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    found = observables(ds)
    values = np.asarray(found[of] if of in found else bottom_peak_force(ds), dtype=np.float64)
    dims = [str(d) for d in ds.status.dims] if "status" in ds.variables else []
    groups = [d for d in dims if d != REALISATION_DIM]
    panels = list(np.ndindex(*[ds.sizes[d] for d in groups]))
    fig, axes = plt.subplots(len(panels), 1, figsize=(5.5, 1.6 + 1.9 * len(panels)), squeeze=False)
    for ax, index in zip(axes[:, 0], panels):
        where = dict(zip(groups, index))
        part = values[tuple(where.get(d, slice(None)) for d in dims)].reshape(-1)
        part = part[np.isfinite(part)]
        ax.hist(part, bins=bins)
        for x in np.quantile(part, QUANTILES) if part.size else []:
            ax.axvline(x, color="k", lw=0.8, ls="--")
        label = ", ".join(f"{d} = {np.asarray(ds[d].values)[k]:g}" for d, k in where.items()) or "every point"
        ax.set_title(f"{label}: {part.size} realisations; 5, 50, 95 % quantiles dashed", fontsize=8)
        ax.set_ylabel("realisations")
    axes[-1, 0].set_xlabel(f"{of} [{UNITS[of]}]")
    fig.tight_layout()
    fig.savefig(out, dpi=120, metadata=PNG_METADATA)
    plt.close(fig)
