"""Pictures of hertzian stores: any store (``plot_store``) and the paper's figures (``plot_figure``).

``plot_store(dataset, "run.png")`` draws one point of any store written by ``hertzian run`` or
``hertzian sweep``: the depth–time picture of u or v, the traced grains' signals and the energy
error against time. ``plot_figure(dataset, "fig1", "fig1.png")`` draws one figure group of Sen,
Manciu & Wright (1998) from a store written by ``hertzian sweep sweeps/paper_*.toml`` or
``hertzian reproduce``. Matplotlib's Agg backend; program units throughout (length 1e-5 m,
time 1.0102e-3 s). Every reduction of the data is in ``hertzian.studies.analysis``; this module draws.

Signs: profile plots show the paper's sign, −u and −v (the change of a grain's *position*, positive
toward the surface), because the paper plots grain positions; the compressive part of a pulse
moving into the chain is therefore negative, as on the paper's "negative side of the y axis".
Figs. 1, 2 and 4 use the paper's grain label N − i (surface grain = N, pulse moving right to
left); the other figures use the depth i (surface = 0).
"""

from __future__ import annotations

import json
import math
import textwrap
from pathlib import Path
from typing import Callable

import numpy as np
from hertzian.core.outputs import PNG_METADATA
from hertzian.studies import analysis as an

DPI = 110
PAPER_SIGN = "paper sign: + toward the surface"
SIGN_NOTE = (
    "−u, −v: the paper's sign (change of grain position, + toward the surface); hertzian's u, v are "
    "+ into the chain. Program units: length 1e-5 m, time 1.0102 ms."
)
TIME_UNIT = "time units of 1.0102 ms"
VELOCITY_UNIT = "1e-5 m per 1.0102 ms = 9.9 mm/s"
ENERGY_UNIT = "2.3e-9 J"
"""Program energy unit: 2.36e-5 kg × (9.9e-3 m/s)²."""


class PlotError(ValueError):
    """The store does not hold what the figure needs (names the missing piece)."""


def store_contents(ds) -> str:
    """What a store holds, in a few words: its sweep axes (with their lengths) and its data variables."""
    axes = ds["status"].dims if "status" in ds.variables else tuple(ds.dims)
    axes_text = ", ".join(f"{d} ({ds.sizes[d]})" for d in axes) or "none (a single run)"
    names = ", ".join(sorted(map(str, ds.data_vars)))
    return f"sweep axes {axes_text}; variables {names}"


def _require(ds, *names: str, figure: str) -> None:
    missing = [n for n in names if n not in ds.variables and n not in ds.dims]
    if missing:
        raise PlotError(f"figure {figure} needs {', '.join(missing)} in the store; it has {store_contents(ds)}")


def _pyplot():
    # matplotlib is heavy and only needed when a figure is drawn
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    plt.rcParams.update({"font.size": 9, "axes.titlesize": 9, "legend.fontsize": 7.5, "lines.linewidth": 0.9})
    return plt


def _grains(ds) -> int:
    return int(ds.sizes["grain"])


def _cmap_colors(plt, n: int):
    cmap = plt.get_cmap("viridis")
    return [cmap(x) for x in np.linspace(0.0, 0.85, max(n, 1))]


NOTE_FONTSIZE = 6.5
"""Font size [pt] of a figure's footnote."""


def _finish(fig, out: Path, *, note: str | None = None) -> Path:
    bottom = 0.0
    if note:
        width_pt, height_pt = fig.get_figwidth() * 72, fig.get_figheight() * 72
        # wrapped to the figure's width (an average character is ~0.55 em wide), so no line is cut off
        lines = textwrap.wrap(note, width=max(40, int(0.98 * width_pt / (0.55 * NOTE_FONTSIZE))))
        fig.text(0.005, 0.003, "\n".join(lines), fontsize=NOTE_FONTSIZE, color="0.35", ha="left", va="bottom")
        bottom = (len(lines) * 1.25 * NOTE_FONTSIZE + 4) / height_pt
    fig.tight_layout(rect=(0, bottom, 1, 1))
    fig.savefig(out, dpi=DPI, metadata=PNG_METADATA)
    import matplotlib.pyplot as plt  # heavy: loaded by _pyplot when the figure was made

    plt.close(fig)
    return out


# ---- Figs. 1-3: horizontal chains ----------------------------------------------------------


def _profiles_vs_label(ax, plt, ds_point, *, label_axis: bool, count: int = 5, records=None):
    """Paper displacement against grain label (or depth) at several times while the pulse is in flight."""
    t = ds_point.t.values
    u = ds_point.u.values
    n = u.shape[-1]
    if records is None:
        heads = an.head_positions(ds_point.v.values) if "v" in ds_point else an.head_positions(u)
        records = an.times_in_flight(t, heads, n, count)
    x = an.paper_label(np.arange(n), n) if label_axis else np.arange(n)
    for color, r in zip(_cmap_colors(plt, len(records)), records):
        ax.plot(x, an.paper_displacement(u[r]), color=color, label=f"t = {t[r]:g}")
    if label_axis:
        ax.set_xlim(0, n)
        ax.invert_xaxis()
        ax.set_xlabel(f"grain label N − i (surface = {n}; pulse moves right to left)")
    else:
        ax.set_xlim(0, n)
        ax.set_xlabel("depth z [grain diameters] (surface = 0)")
    ax.set_ylabel("−u [1e-5 m]")
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=7)


def _fig_profiles_by_vimp(ds, out: Path, figure: str, *, label_axis: bool, title: str) -> Path:
    _require(ds, "u", "v", "v_imp", figure=figure)
    plt = _pyplot()
    speeds = ds.v_imp.values
    fig, axes = plt.subplots(len(speeds), 1, figsize=(8.0, 2.5 * len(speeds)), squeeze=False)
    for k, (ax, v_imp) in enumerate(zip(axes[:, 0], speeds)):
        point = ds.isel(v_imp=k)
        _profiles_vs_label(ax, plt, point, label_axis=label_axis)
        l0 = float(point.l0) if "l0" in point.variables and point.l0.size == 1 else _scene_value(ds, "chain", "l0")
        heads = an.head_positions(point.v.values)
        beyond = np.flatnonzero(heads > 0.9 * _grains(ds))  # before the head first reaches 0.9 of the chain
        flight = np.flatnonzero(heads[: beyond[0] if beyond.size else len(heads)] > 0.1 * _grains(ds))
        ratio = (
            max(an.overlap_behind_head(point.u.values[r], heads[r], l0=l0) for r in flight) if flight.size else math.nan
        )
        ax.set_title(
            f"({'abcdef'[k]}) {title}, l0 = {l0:g}, v_imp = {v_imp:g}\nlargest overlap more than 10 grains "
            f"behind the front ≤ {ratio:.2f} × the front's",
            fontsize=8.5,
        )
    return _finish(fig, out, note=SIGN_NOTE)


def _scene_value(ds, section: str, key: str):
    scene = json.loads(ds.attrs.get("scene", "{}"))
    return scene.get(section, {}).get(key, math.nan)


def fig1(ds, out: Path) -> Path:
    """Fig. 1(a)-(c): displacement against grain label for l0 = 1e-6 and three impact speeds."""
    return _fig_profiles_by_vimp(ds, out, "fig1", label_axis=True, title="shock-like regime")


def fig2(ds, out: Path) -> Path:
    """Fig. 2(a)-(c): as Fig. 1 for l0 = 1e-5."""
    return _fig_profiles_by_vimp(ds, out, "fig2", label_axis=True, title="precompressed chain")


def fig1d(ds, out: Path) -> Path:
    """Fig. 1(d): ln c against ln v_imp for each l0, with the fitted α and the linear sound speeds."""
    _require(ds, "v", "l0", "v_imp", figure="fig1d")
    plt = _pyplot()
    c, _ = an.speeds_table(ds)
    v_imp, l0s = ds.v_imp.values, ds.l0.values
    a = _scene_value(ds, "chain", "a")
    fig, ax = plt.subplots(figsize=(6.0, 4.2))
    markers = "os^dv"
    for i, l0 in enumerate(l0s):
        fit = an.speed_exponent(v_imp, c[i])
        ax.plot(
            np.log(v_imp),
            np.log(c[i]),
            markers[i % 5],
            mfc="none",
            label=f"l0 = {l0:g}: α = {fit.exponent:.4f} ± {fit.exponent_error:.4f}",
        )
        c0 = math.sqrt(3.75 * a * math.sqrt(l0))
        ax.axhline(math.log(c0), color=f"C{i}", ls=":", lw=0.8)
        ax.text(np.log(v_imp[0]), math.log(c0), f" sound speed, l0 = {l0:g}", color=f"C{i}", va="bottom", fontsize=7)
    lumped = an.speed_exponent(np.tile(v_imp, len(l0s)), c.ravel())
    ref = an.speed_exponent(v_imp, c[0])
    x = np.log(v_imp[[0, -1]])
    ax.plot(x, math.log(ref.prefactor) + 0.2 * x, "k-", lw=0.8, label="slope 0.2 (paper)")
    ax.set_xlabel("ln v_imp   (v_imp in 1e-5 m per 1.0102 ms)")
    ax.set_ylabel("ln c   (c in grains per time unit)")
    ax.set_title(f"(d) pulse speed; all l0 lumped: α = {lumped.exponent:.3f} ± {lumped.exponent_error:.3f}")
    ax.legend(loc="upper left")
    return _finish(fig, out)


def fig3(ds, out: Path) -> Path:
    """Fig. 3(a),(b): long tails in the compressive regime at the times of the tail fits
    (``analysis.PAPER_TAIL_TIMES``), and (c) their exponential envelopes with λ/(c t)."""
    _require(ds, "u", "v", "l0", figure="fig3")
    plt = _pyplot()
    dim = "l0"
    points = ds.sizes[dim]
    fig, axes = plt.subplots(
        points + 1, 1, figsize=(8.0, 2.6 * (points + 1) + 1.2), gridspec_kw={"height_ratios": [1] * points + [1.5]}
    )
    t = ds.t.values
    for k in range(points):
        point = ds.isel({dim: k})
        l0 = float(point.l0)
        v_imp = float(point.v_imp) if "v_imp" in point.variables else _scene_value(ds, "excitation", "impact")
        heads = an.head_positions(point.v.values)
        speed = an.pulse_speed(t, heads, first_grain=100, last_grain=800).slope
        times = an.PAPER_TAIL_TIMES.get(l0) or [t[r] for r in an.times_in_flight(t, heads, _grains(ds), 4, reach=0.8)]
        records = [int(np.argmin(np.abs(t - x))) for x in times]
        _profiles_vs_label(axes[k], plt, point, label_axis=False, records=records)
        surface = _scene_value(ds, "boundary", "surface")
        axes[k].set_title(
            f"({'ab'[k]}) l0 = {l0:g}, v_imp = {v_imp:g}, surface {surface}: head at c = {speed:.2f} "
            "grains per time unit"
        )
        u = point.u.values
        load = _scene_value(ds, "boundary", "surface") == "load"
        for color, r in zip(_cmap_colors(plt, len(records)), records):
            z = heads[r] - np.arange(u.shape[-1])
            level = an.rear_level(u[r]) if load else 0.0  # a constant-force surface shifts the whole rear
            env = an.running_max(u[r] - level, 11)
            keep = (z >= 0) & (env > 0)
            fit = an.tail_decay(u[r], heads[r], baseline=level)
            style = "-" if k == 0 else "--"
            axes[points].semilogy(
                z[keep],
                env[keep],
                style,
                color=color,
                label=f"({'ab'[k]}) t = {t[r]:g}: λ = {fit.decay_length:.0f}, "
                f"λ/(c t) = {fit.decay_length / (speed * t[r]):.2f}, "
                f"R² = {fit.r_squared:.2f}",
            )
    axes[points].set_xlabel("z = grains behind the head")
    axes[points].set_ylabel(
        "compressive u"
        + (" − rear level" if _scene_value(ds, "boundary", "surface") == "load" else "")
        + ", envelope [1e-5 m]",
        fontsize=8,
    )
    axes[points].set_title(
        "(c) tail envelopes (running max over 11 grains), (a) solid, (b) dashed; λ from exp(−z/λ) fits for z ≥ 10"
    )
    axes[points].legend(loc="upper center", bbox_to_anchor=(0.5, -0.2), ncol=2, fontsize=6.5)
    return _finish(fig, out, note=SIGN_NOTE)


def fig4(ds, out: Path) -> Path:
    """Fig. 4: a 3000-grain chain, l0 = 1e-3, v_imp = 0.1: the in-going pulse and its reflection."""
    _require(ds, "u", "v", figure="fig4")
    plt = _pyplot()
    t = ds.t.values
    u, v = ds.u.values, ds.v.values
    n = u.shape[-1]
    heads = an.head_positions(v)
    arrive = np.flatnonzero(heads > 0.98 * n)
    t_wall = t[arrive[0]] if arrive.size else t[-1]
    fig, axes = plt.subplots(2, 1, figsize=(7.0, 5.2))
    x = an.paper_label(np.arange(n), n)
    before = [int(np.argmin(np.abs(t - f * t_wall))) for f in (0.25, 0.5, 0.75, 0.95)]
    after = [int(np.argmin(np.abs(t - tt))) for tt in np.linspace(t_wall, t[-1], 5)[1:]]
    for ax, records, title in (
        (axes[0], before, "(a) in-going pulse"),
        (axes[1], after, "(b) after reflection from the rigid wall at label 0"),
    ):
        for color, r in zip(_cmap_colors(plt, len(records)), records):
            ax.plot(x, an.paper_displacement(u[r]), color=color, label=f"t = {t[r]:g}")
        ax.set_xlim(n, 0)
        ax.set_ylabel("−u [1e-5 m]")
        ax.set_title(
            f"{title}; l0 = {_scene_value(ds, 'chain', 'l0'):g}, v_imp = {_scene_value(ds, 'excitation', 'impact'):g}"
        )
        ax.legend(loc="best", ncol=2)
    axes[1].set_xlabel(f"grain label N − i (surface = {n})")
    return _finish(fig, out, note=SIGN_NOTE)


# ---- Figs. 5, 7, 8: impurities -------------------------------------------------------------


def fig5(ds, out: Path) -> Path:
    """Fig. 5: displacement profiles with light (a) and heavy (b) impurities; (c) the reflected pulses
    of both, (d) their difference light − heavy, (e) the echo at the surface grain, both contact rules."""
    _require(ds, "u", "v", "impurity_mass", "contact", "trace_v", figure="fig5")
    plt = _pyplot()
    light, heavy, clean = an.impurity_points(ds)
    t = ds.t.values
    n = _grains(ds)
    block = an.impurity_grains(ds)
    depth = float(np.mean(block))
    z = np.arange(n)
    fig, axes = plt.subplots(5, 1, figsize=(7.5, 14.0))
    reference = ds.v.isel(impurity_mass=clean if clean is not None else light, contact=0).values
    speed = an.pulse_speed(t, an.head_positions(reference), first_grain=20, last_grain=depth - 20).slope
    t_hit = depth / speed
    times = [0.5 * t_hit, 0.95 * t_hit, 1.4 * t_hit, 1.8 * t_hit]
    records = [int(np.argmin(np.abs(t - x))) for x in times]
    for ax, index, name in ((axes[0], light, "light (m = 0.5, a = 2000)"), (axes[1], heavy, "heavy (m = 2, a = 1e4)")):
        u = ds.u.isel(impurity_mass=index).sel(contact="harmonic").values
        for color, r in zip(_cmap_colors(plt, len(records)), records):
            ax.plot(z, an.paper_displacement(u[r]), color=color, label=f"t = {t[r]:g}")
        ax.axvspan(min(block) - 0.5, max(block) + 0.5, color="0.85")
        ax.set_title(
            f"({'ab'[index == heavy]}) {len(block)} {name} impurit{'ies' if len(block) > 1 else 'y'} "
            f"around grain {depth:g} (grey), contact rule harmonic",
            fontsize=8.5,
        )
        ax.set_ylabel("−u [1e-5 m]")
        ax.set_xlim(0, n)
        ax.legend(loc="upper right", ncol=4)
    r = records[-1]
    front = z < depth - 10
    profiles = {}
    for rule, light_style, heavy_style in (("harmonic", "--", "-"), ("own", ":", "-.")):
        pl = an.paper_displacement(ds.u.isel(impurity_mass=light).sel(contact=rule).values[r])
        ph = an.paper_displacement(ds.u.isel(impurity_mass=heavy).sel(contact=rule).values[r])
        profiles[rule] = (pl, ph)
        axes[2].plot(z[front], pl[front], light_style, color="C3", label=f"light, {rule}")
        axes[2].plot(z[front], ph[front], heavy_style, color="C0", label=f"heavy, {rule}")
    axes[2].set_title(f"(c) reflected pulses at t = {t[r]:g}, moving toward the surface: light (red) and heavy (blue)")
    axes[2].set_ylabel("−u [1e-5 m]")
    axes[2].legend(loc="upper right", ncol=2)
    for rule, style in (("harmonic", "-"), ("own", ":")):
        pl, ph = profiles[rule]
        relative = np.linalg.norm(pl[front] - ph[front]) / np.linalg.norm(ph[front])
        axes[3].plot(
            z[front],
            pl[front] - ph[front],
            style,
            color="k",
            label=f"{rule}: ‖light − heavy‖ / ‖heavy‖ = {relative:.2f}",
        )
    axes[3].axhline(0, color="0.6", lw=0.5)
    axes[3].set_title(f"(d) difference of the reflected profiles, light − heavy, at t = {t[r]:g}")
    axes[3].set_ylabel("Δ(−u) [1e-5 m]")
    axes[3].legend(loc="upper right")
    for ax in axes[2:4]:
        ax.set_xlim(0, depth)
    for ax in axes[:4]:
        ax.set_xlabel("depth z [grain diameters] (surface = 0)")
    _echo_panel(axes[4], ds, "(e)", span=(-1.0, 8.0), legend="below")
    return _finish(fig, out, note=SIGN_NOTE)


def _echo_panel(ax, ds, tag: str, *, span: tuple[float, float] = (-0.3, 2.0), legend: str = "lower right") -> None:
    """Velocity echo (signal − clean chain) at the shallowest traced grain, both contact rules, from
    ``span[0]`` before the echo's first arrival to ``span[1]`` after it; the first sample reaching 20 % of
    each echo's largest value (where its leading sign is read) is marked."""
    light, heavy, clean = an.impurity_points(ds)
    tt = ds.trace_t.values
    grain = int(ds.traced_grain.values[0])
    if clean is None:
        ax.axis("off")
        ax.text(
            0.5,
            0.5,
            f"{tag} no echo panel: this store has no clean chain (impurity_mass = 1) to subtract",
            ha="center",
            va="center",
            fontsize=8,
            transform=ax.transAxes,
        )
        return
    reference = ds.trace_v.isel(impurity_mass=clean, contact=0).values[:, 0]
    table = an.echo_table(ds)
    early = an.echo_table(ds, fraction=0.05)
    start = min(b.arrival_time for b in early.values() if np.isfinite(b.arrival_time))
    window = (tt > start + span[0]) & (tt < start + span[1])
    for name, index, color in (("light", light, "C3"), ("heavy", heavy, "C0")):
        for rule, style, marker in (("harmonic", "-", "v"), ("own", ":", "^")):
            echo = ds.trace_v.isel(impurity_mass=index).sel(contact=rule).values[:, 0] - reference
            b = table[f"{name}/{rule}"]
            ax.plot(
                tt[window],
                -echo[window],
                style,
                color=color,
                label=f"{name}, {rule}: first lobe {'into chain' if b.leading_sign > 0 else 'toward surface'}"
                f", |echo| ≤ {b.amplitude:.2g}",
            )
            k = int(np.argmin(np.abs(tt - b.arrival_time)))
            ax.plot(tt[k], -echo[k], marker, color=color, ms=5)
    ax.axhline(0, color="0.6", lw=0.5)
    ax.set_xlim(start + span[0], start + span[1])
    ax.set_xlabel(f"t [{TIME_UNIT}]")
    ax.set_ylabel("−(v − v_clean) [9.9 mm/s]", fontsize=7.5)
    ax.set_title(
        f"{tag} echo at grain {grain}, −(v − v_clean) ({PAPER_SIGN});\n"
        "triangles: first sample with |echo| ≥ 20 % of its largest (where the leading sign is read)",
        fontsize=8,
    )
    if legend == "below":
        ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.3), ncol=2, fontsize=6.5)
    else:
        ax.legend(loc=legend, fontsize=6.5)


def fig7_8(ds, out: Path) -> Path:
    """Figs. 7 and 8: grain velocity against depth in a g = 1 column with five light (left) and heavy
    (right) impurities, at six times; bottom row: the echo at the surface grain."""
    _require(ds, "v", "impurity_mass", "contact", figure="fig7_8")
    plt = _pyplot()
    light, heavy, clean = an.impurity_points(ds)
    t = ds.t.values
    n = _grains(ds)
    depth = float(np.mean(an.impurity_grains(ds)))
    reference = ds.v.isel(impurity_mass=clean if clean is not None else light, contact=0).values
    heads = an.head_positions(reference)
    t_hit = t[np.flatnonzero(heads >= depth)[0]]
    times = t_hit * np.array([0.4, 0.7, 0.95, 1.1, 1.5, 1.9])
    records = [int(np.argmin(np.abs(t - x))) for x in times]
    has_traces = "trace_v" in ds.variables and clean is not None
    rows = len(records) + (1 if has_traces else 0)
    # each profile panel about 2 in tall: a pulse a few grains wide and its echo stay readable
    fig, axes = plt.subplots(
        rows,
        2,
        figsize=(11.0, 2.0 * len(records) + (4.4 if has_traces else 0.0) + 1.0),
        sharex=False,
        gridspec_kw={"height_ratios": [1] * len(records) + ([2.0] if has_traces else [])},
    )
    z = np.arange(n)
    for col, (index, name) in enumerate(((light, "Fig. 7: light"), (heavy, "Fig. 8: heavy"))):
        v = ds.v.isel(impurity_mass=index).sel(contact="harmonic").values
        for row, r in enumerate(records):
            ax = axes[row, col]
            ax.plot(z, -v[r], color="k", lw=0.9)
            ax.axvspan(min(an.impurity_grains(ds)) - 0.5, max(an.impurity_grains(ds)) + 0.5, color="0.85")
            ax.set_title(f"{name} ({'abcdef'[row]}) t = {t[r]:g}", loc="left", fontsize=9)
            ax.set_xlim(0, n)
            ax.grid(alpha=0.25)
            ax.tick_params(labelsize=8, labelbottom=row == len(records) - 1)
            ax.set_ylabel("−v [9.9 mm/s]", fontsize=8)
        axes[len(records) - 1, col].set_xlabel("depth z [grain diameters] (surface = 0)")
    if has_traces:
        ax = axes[-1, 0]
        gs = ax.get_gridspec()
        for a in axes[-1]:
            a.remove()
        ax = fig.add_subplot(gs[-1, :])
        _echo_panel(ax, ds, "(g)", legend="below")
    # the scene goes into the note: tight_layout leaves no room for a suptitle above the first titles
    scene = (
        f"{n}-grain column, g = {_scene_value(ds, 'chain', 'gravity'):g}, v_imp = "
        f"{_scene_value(ds, 'excitation', 'impact'):g}, impurities shaded, contact rule harmonic (panels a–f). "
    )
    return _finish(fig, out, note=scene + SIGN_NOTE)


def modes(ds, out: Path) -> Path:
    """Sec. IV: velocity of the impurity grain after the pulse has passed, light / heavy / none (the clean
    chain's same grain), and its power spectrum against the linear chain's band edge."""
    _require(ds, "trace_v", "impurity_mass", figure="modes")
    plt = _pyplot()
    site = an.impurity_grains(ds)[0]
    column = int(np.flatnonzero(ds.traced_grain.values == site)[0])
    tt = ds.trace_t.values
    masses = ds.impurity_mass.values
    stiff = ds.impurity_a.values if "impurity_a" in ds.variables else [math.nan] * len(masses)
    clean = int(np.flatnonzero(masses == 1.0)[0])
    v_clean = ds.trace_v.isel(impurity_mass=clean).values[:, column]
    arrival = float(tt[np.flatnonzero(np.abs(v_clean) >= 0.5 * np.max(np.abs(v_clean)))[0]])
    a = _scene_value(ds, "chain", "a")
    a = 5657.0 if not np.isfinite(a) else a
    l0 = _scene_value(ds, "chain", "l0")
    band_edge = 2.0 * math.sqrt(float(an.hertz_stiffness(a, 2.5 * a * l0**1.5))) / (2 * math.pi)
    fig, axes = plt.subplots(4, 1, figsize=(7.5, 11.0))
    colors = {clean: "k"}
    starts = np.arange(arrival + 5.0, tt[-1] - 5.0 + 1e-9, 5.0)
    late = tt >= arrival + 5.0
    for k, (mass, stiffness) in enumerate(zip(masses, stiff)):
        v = ds.trace_v.isel(impurity_mass=k).values[:, column]
        color = colors.get(k, "C3" if mass < 1 else "C0")
        name = (
            "no impurity (clean chain)"
            if k == clean
            else f"{'light' if mass < 1 else 'heavy'} (m = {mass:g}, a = {stiffness:g})"
        )
        axes[0].plot(tt - arrival, v, color=color, lw=0.6, label=name)
        axes[1].plot(tt[late] - arrival, v[late], color=color, lw=0.6, label=name)
        freq, power = an.power_spectrum(tt[late], v[late])
        axes[2].semilogy(freq[1:], power[1:], color=color, lw=0.7, label=name)
        rms = [np.sqrt(np.mean(v[(tt >= lo) & (tt < lo + 5.0)] ** 2)) for lo in starts]
        axes[3].plot(starts + 2.5 - arrival, rms, "o-", color=color, ms=3, label=name)
    for ax in axes[:2]:
        ax.axhline(0, color="0.6", lw=0.5)
        ax.set_xlabel(f"t − {arrival:.2f} (clean pulse's arrival) [{TIME_UNIT}]")
        ax.set_ylabel(f"v at grain {site} [9.9 mm/s]")
        ax.legend(loc="upper right", fontsize=7)
    axes[0].set_xlim(-2.0, 10.0)
    axes[0].set_title(
        f"(a) velocity of grain {site} (+ into the chain): the impurity itself, or the clean chain's grain",
        fontsize=8.5,
    )
    axes[1].set_title("(b) the same from 5 time units after the pulse's arrival (the ringing, if any)", fontsize=8.5)
    axes[2].axvline(band_edge, color="0.4", ls="--", lw=0.8)
    axes[2].text(
        band_edge,
        0.5,
        f" linear band edge {band_edge:.2f}",
        va="center",
        fontsize=7,
        transform=axes[2].get_xaxis_transform(),
    )
    axes[2].set_xlim(0, 3 * band_edge)
    top = max(line.get_ydata().max() for line in axes[2].get_lines()[:-1])
    axes[2].set_ylim(top * 1e-8, top * 3)
    axes[2].set_xlabel("frequency [cycles per time unit]")
    axes[2].set_ylabel("power of (b) [arb. units]")
    axes[2].set_title(
        f"(c) power spectrum of (b); l0 = {l0:g}, v_imp = {_scene_value(ds, 'excitation', 'impact'):g}, g = 0",
        fontsize=8.5,
    )
    axes[2].legend(loc="upper right", fontsize=7)
    axes[3].set_xlabel(f"t − {arrival:.2f}, middle of each 5-unit window [{TIME_UNIT}]")
    axes[3].set_ylabel("rms v [9.9 mm/s]")
    axes[3].set_ylim(0, None)
    axes[3].set_title(f"(d) rms velocity of grain {site} over 5-unit windows: how long the ringing lasts", fontsize=8.5)
    axes[3].legend(loc="lower left", fontsize=7)
    return _finish(fig, out)


# ---- Fig. 6 and the depth law --------------------------------------------------------------


SURFACE_SKIP = 3
"""Grains next to a free surface left out of Fig. 6's scales (the surface grain is thrown off)."""


def fig6(ds, out: Path) -> Path:
    """Fig. 6: displacement against depth for several g after the same elapsed time."""
    _require(ds, "u", "v", "g", figure="fig6")
    plt = _pyplot()
    t = ds.t.values
    n = _grains(ds)
    g_values = ds.g.values
    heads = an.head_positions(ds.v.sel(g=g_values.max()).values)
    inside = np.flatnonzero(heads <= 0.8 * n)
    r = int(inside[-1]) if inside.size else len(t) - 1
    fig, axes = plt.subplots(2, 1, figsize=(7.0, 5.6))
    styles = [":", "--", "-", "-."]
    low = 0.0
    for k, g in enumerate(g_values):
        u = ds.u.sel(g=g).values[r]
        # the free surface grain bounces off the column: leave the first grains out of the scales
        scale = np.max(np.abs(u[SURFACE_SKIP:]))
        low = min(low, float(np.min(an.paper_displacement(u[SURFACE_SKIP:]))))
        axes[0].plot(np.arange(n), an.paper_displacement(u), styles[k % 4], color=f"C{k}", label=f"g = {g:g}")
        axes[1].plot(np.arange(n), an.paper_displacement(u) / scale, styles[k % 4], color=f"C{k}", label=f"g = {g:g}")
    axes[0].set_ylim(1.1 * low, -0.25 * low)
    axes[1].set_ylim(-1.1, 0.3)
    axes[0].set_title(
        f"(a) t = {t[r]:g} after an impact v_imp = {_scene_value(ds, 'excitation', 'impact'):g} "
        f"({n}-grain column; g = 1 ≙ 9.8 m/s²)"
    )
    axes[0].set_ylabel("−u [1e-5 m]")
    axes[1].set_title(f"(b) the same, each scaled by its largest |u| below grain {SURFACE_SKIP - 1} (tail bumps)")
    axes[1].set_ylabel("−u / max|u|")
    for ax in axes:
        ax.set_xlabel("depth z [grain diameters] (surface = 0)")
        ax.set_xlim(0, n)
        ax.legend(loc="best")
    return _finish(fig, out, note=SIGN_NOTE)


def depth(ds, out: Path) -> Path:
    """Pulse speed against depth in a compacted column (log-log), with the z^(1/6) closed form."""
    _require(ds, "v", figure="depth")
    plt = _pyplot()
    t = ds.t.values
    n = _grains(ds)
    g = _scene_value(ds, "chain", "gravity")
    a = _scene_value(ds, "chain", "a")
    dim = [d for d in ds.v.dims if d not in ("record", "grain")]
    fig, ax = plt.subplots(figsize=(6.0, 4.2))
    values = ds[dim[0]].values if dim else [None]
    for k, value in enumerate(values):
        v = ds.v.isel({dim[0]: k}).values if dim else ds.v.values
        heads = an.head_positions(v)
        fit = an.depth_law(t, heads, first_grain=50, last_grain=0.9 * n)
        mid, speed = an.speed_against_depth(t, heads, last_grain=0.9 * n)
        label = f"{dim[0]} = {value:g}: " if dim else ""
        ax.loglog(
            mid, speed, ".", ms=3, color=f"C{k}", label=f"{label}c ∝ z^{fit.exponent:.4f}±{fit.exponent_error:.4f}"
        )
    z = np.geomspace(5, n, 100)
    ax.loglog(z, an.column_sound_speed(z, gravity=g, a=a), "k-", lw=0.8, label="closed form √(K(z)/m), ∝ z^(1/6)")
    ax.set_xlabel("depth z of the head [grain diameters]")
    ax.set_ylabel("pulse speed c [grains per time unit]")
    ax.set_title(f"pulse speed against depth, g = {g:g}, {n} grains")
    ax.legend(loc="lower right")
    return _finish(fig, out)


# ---- Figs. 9-10: driven columns ------------------------------------------------------------


def _fig_driven(ds, out: Path, which: str) -> Path:
    _require(ds, "tau", figure=which)
    plt = _pyplot()
    windows = an.driven_windows(ds)
    taus, centres = windows["taus"], windows["centres"]
    n = _grains(ds)
    data = windows["ke"] if which == "fig9" else -windows["v"]
    fig, axes = plt.subplots(
        len(centres), len(taus), figsize=(4.4 * len(taus), 1.4 * len(centres) + 1.2), squeeze=False
    )
    ylabel = f"⟨m v²/2⟩ [{ENERGY_UNIT}]" if which == "fig9" else "⟨−v⟩ [9.9 mm/s]"
    for col, tau in enumerate(taus):
        for row, centre in enumerate(centres):
            ax = axes[row, col]
            ax.plot(np.arange(n), data[col, row], color="k", lw=0.5)
            ax.set_xlim(0, n)
            ax.set_ylabel(ylabel, fontsize=7)
            corr = windows["persistence"][col][row].correlation[1:]
            text = f"({'abcdef'[row]}) t = {centre:.4g}, τ = {tau:g}"
            if corr.size:
                text += f"; shape corr. over next {an.PAPER_WINDOW * corr.size:g} t.u.: {np.nanmean(corr):.2f}"
            ax.set_title(text, loc="left", fontsize=7.5)
        axes[-1, col].set_xlabel("depth z [grain diameters] (surface = 0)")
    label = "kinetic energy per grain" if which == "fig9" else f"velocity −v ({PAPER_SIGN})"
    fig.suptitle(
        f"{'Fig. 9' if which == 'fig9' else 'Fig. 10'}: {label}, averaged over {an.PAPER_WINDOW:g} "
        f"time units\n{n}-grain column, g = 1, surface driven 2 sin(2πt/τ), bottom grain fixed; "
        f"left τ = {taus[0]:g}" + (f", right τ = {taus[1]:g}" if len(taus) > 1 else ""),
        fontsize=8,
    )
    note = (
        SIGN_NOTE + " The paper's panel (f) (a later time) is not part of this run."
        if which == "fig10"
        else "Program units: energy 2.36e-5 kg × (9.9 mm/s)² = 2.3e-9 J, time 1.0102 ms. "
        "The paper's panel (f) (a later time) is not part of this run."
    )
    return _finish(fig, out, note=note)


def fig9(ds, out: Path) -> Path:
    """Fig. 9: time-averaged kinetic energy against depth in the driven column, for each τ."""
    return _fig_driven(ds, out, "fig9")


def fig10(ds, out: Path) -> Path:
    """Fig. 10: time-averaged velocity against depth in the driven column, for each τ."""
    return _fig_driven(ds, out, "fig10")


def sec6_lag(ds, out: Path) -> Path:
    """Sec. VI at the paper's timescale: shape correlation of the driven column's kinetic-energy and velocity
    profiles with the one at t0, against the lag (80 to 12 000 steps at the paper's dt), instantaneous and
    averaged over the paper's 1.5-unit window; solid at dt, dashed at dt/2. One column of panels per τ."""
    _require(ds, "instantaneous_ke", "averaged_ke", figure="sec6_lag")
    plt = _pyplot()
    taus, t0s = ds.tau.values, ds.t0.values
    steps = ds.lag.values / float(ds.dt.values[0])
    fig, axes = plt.subplots(2, len(taus), figsize=(5.2 * len(taus), 6.4), squeeze=False, sharex=True)
    colors = {"instantaneous": "tab:red", "averaged": "tab:blue"}
    for row, quantity in enumerate(("ke", "v")):
        for col, tau in enumerate(taus):
            ax = axes[row, col]
            for kind, color in colors.items():
                for k, t0 in enumerate(t0s):
                    for d, style in zip(range(ds.sizes["dt"]), ("-", "--")):
                        curve = ds[f"{kind}_{quantity}"].values[d, col, k]
                        label = f"{kind}, t0 = {t0:g}" if d == 0 else None
                        ax.plot(steps[1:], curve[1:], style, color=color, alpha=1.0 - 0.45 * k, lw=1.1, label=label)
            ax.set_xscale("log")
            ax.set_ylim(-1.05, 1.05)
            ax.axhline(0.0, color="0.6", lw=0.5)
            ax.grid(alpha=0.3, which="both")
            what = "kinetic energy ½v²" if quantity == "ke" else "velocity v"
            ax.set_title(f"τ = {tau:g}: {what}", loc="left", fontsize=9)
            ax.set_ylabel("correlation with t0", fontsize=8)
    axes[-1, 0].legend(fontsize=7, loc="lower left")
    for ax in axes[-1]:
        ax.set_xlabel(f"lag [steps of dt = {float(ds.dt.values[0]):g}] (80 steps = 0.01 t.u.)")
    fig.suptitle(
        f"Shape correlation against lag, {int(ds.attrs['grains'])}-grain column, A = {float(ds.attrs['amplitude']):g}: "
        f"instantaneous profiles vs averaged over {float(ds.attrs['window']):g} t.u.",
        fontsize=9,
    )
    return _finish(fig, out, note="Solid: dt; dashed: dt/2 (same lag in time units). 5-grain smoothing.")


# ---- any store ---------------------------------------------------------------------------------


def point_dims(ds) -> list[str]:
    """The sweep axes of a store (the dims of ``status``; none for a single run)."""
    return [str(d) for d in ds.status.dims] if "status" in ds.variables else []


def select_point(ds, at: dict[str, float] | None = None, notify=None):
    """One point of a store: the coordinate nearest each value in ``at`` {axis: value}, the first along
    every other axis. Raises PlotError naming an unknown axis; ``notify(line)`` hears of each value that is not
    on the axis (a warning when it lies outside the axis' range, else a note), with the point taken instead."""
    at = dict(at or {})
    axes = point_dims(ds)
    for dim in axes:
        if dim in at:
            asked, axis = at.pop(dim), ds[dim].values
            if axis.dtype.kind in "fiu":
                if isinstance(asked, str):
                    raise PlotError(f"--at {dim}={asked}: {dim} is a number axis ({_axis_text(axis)})")
                ds = ds.sel({dim: asked}, method="nearest")
                _tell_nearest(notify, dim, asked, axis, ds[dim].values)
            elif str(asked) in [str(v) for v in axis]:  # an axis of names: the one asked
                ds = ds.isel({dim: [str(v) for v in axis].index(str(asked))})
            else:
                raise PlotError(f"--at {dim}={asked}: not on the axis ({_axis_text(axis)})")
        else:
            ds = ds.isel({dim: 0})
    if at:
        raise PlotError(f"no sweep axis {', '.join(at)}; the store's axes: {', '.join(axes) or 'none'}")
    return ds


def _axis_text(axis) -> str:
    """An axis' values for a message."""
    return ", ".join(f"{v:g}" if isinstance(v, (int, float, np.number)) else str(v) for v in axis)


def point_label(ds, point) -> str:
    """``axis = value`` of each sweep axis of ``point`` (a point of ``ds``), comma-separated ('' for a run)."""
    return ", ".join(f"{d} = {_axis_text([point[d].values.item()])}" for d in point_dims(ds) if d in point.coords)


def _tell_nearest(notify, dim: str, asked: float, axis, taken) -> None:
    """``notify`` that ``asked`` is not on ``axis`` (its values): a warning outside its range, else a note."""
    taken = float(taken)
    if notify is None or taken == asked:
        return
    low, high = float(np.min(axis)), float(np.max(axis))
    line = f"--at {dim}={asked:g} is not on the axis: drew the nearest point, {dim}={taken:g}"
    if asked < low or asked > high:
        notify(f"warning: {line} (the axis runs from {low:g} to {high:g})")
    else:
        notify(f"note: {line}")


MOVED_FRACTION = 1e-3
"""A grain counts as moved in a picture once its |value| reaches this fraction of the picture's largest."""


def moved_extent(data: np.ndarray, limit: float) -> int:
    """Grains to show of a (record, grain) picture: up to the deepest that moved, with a margin of a tenth of that
    depth (at least 10 grains), at most all of them."""
    moved = np.flatnonzero(np.nanmax(np.abs(data), axis=0) >= MOVED_FRACTION * limit)
    n = data.shape[-1]
    if moved.size == 0:
        return n
    deepest = int(moved[-1]) + 1
    return min(n, deepest + max(10, deepest // 10))


def plot_store(ds, out: str | Path, *, field: str = "v", at: dict[str, float] | None = None, notify=None) -> Path:
    """One point of any store: depth–time picture of ``field`` (u or v, the store's sign: + into the chain),
    the traced grains' velocities, and the relative energy error against time (a store with mode energies: those,
    the spectral entropy and the participation number against time)."""
    if field not in ("u", "v"):
        raise PlotError(f"field {field!r}: u or v")
    if "response" in ds.variables:
        return plot_response_point(select_point(ds, at, notify), Path(out))
    if "mode_energy" in ds.variables:
        from hertzian.plotting.spectrum import plot_spectrum_point

        point = select_point(ds, at, notify)
        return plot_spectrum_point(
            point, Path(out), _pyplot(), time_unit=TIME_UNIT, energy_unit=ENERGY_UNIT, where=point_label(ds, point)
        )
    _require(ds, field, "energy", figure=f"a {field} picture")
    point = select_point(ds, at, notify)
    plt = _pyplot()
    traced = "trace_v" in point.variables and point.sizes.get("traced", 0) > 0
    rows = 2 + traced
    fig, axes = plt.subplots(rows, 1, figsize=(7.0, 3.0 * rows), squeeze=False)
    axes = axes[:, 0]
    t = point.t.values
    data = point[field].values
    n = data.shape[-1]
    limit = float(np.nanmax(np.abs(data))) or 1.0
    half = 0.5 * (t[-1] - t[0]) / max(len(t) - 1, 1) or 0.5  # each record's row centred on its time
    image = axes[0].imshow(
        data,
        origin="lower",
        aspect="auto",
        cmap="RdBu_r",
        vmin=-limit,
        vmax=limit,
        extent=(-0.5, n - 0.5, t[0] - half, t[-1] + half),
        interpolation="nearest",
    )
    fig.colorbar(image, ax=axes[0], label=f"{field} [{'1e-5 m' if field == 'u' else '1e-5 m per time unit'}]")
    reached = moved_extent(data, limit)
    if reached < n:  # the rest of the chain has not moved yet: show where the motion is
        axes[0].set_xlim(-0.5, reached - 0.5)
    axes[0].set_xlabel(
        "grain (depth; surface = 0)"
        + (f"; grains {reached}–{n - 1}, below 0.1 % of the largest |{field}|, not shown" if reached < n else "")
    )
    axes[0].set_ylabel(f"t [{TIME_UNIT}]")
    where = point_label(ds, point)
    axes[0].set_title(
        f"{field}(grain, t), + into the chain; {n} grains, {len(t)} records" + (f"; {where}" if where else "")
    )
    ax = axes[1]
    if traced:
        tt = point.trace_t.values
        for k, grain in enumerate(point.traced_grain.values):
            ax.plot(tt, point.trace_v.values[:, k], lw=0.7, label=f"grain {int(grain)}")
        ax.set_xlabel(f"t [{TIME_UNIT}]")
        ax.set_ylabel("v [1e-5 m per time unit]")
        ax.set_title("traced grains' velocity (+ into the chain)")
        ax.legend(loc="best", ncol=4)
        ax = axes[2]
    drift, scale = an.energy_drift(point.energy.values, point.work.values if "work" in point.variables else None)
    ax.plot(t, drift, ".-", ms=3)
    ax.axhline(0, color="0.6", lw=0.5)
    ax.set_xlabel(f"t [{TIME_UNIT}]")
    ax.set_ylabel(f"(E − E(0){' − W' if 'work' in point.variables else ''}) / {scale}")
    title = "energy error at the records"
    if "energy_error" in point.variables:
        title += f"; max over the run (records and checks between): {float(point.energy_error):.3g}"
    ax.set_title(title)
    return _finish(fig, Path(out))


MAP_TITLES = {
    "swr": "log10 max|V1| / min|V1| (node contrast,\nnot a standing-wave test: docs/drive.md)",
    "label": "stroboscopic label: P periodic, QP quasi-periodic,\nC chaotic, ? unknown (too few samples)",
}
"""Panel titles of the response map where the number's name alone would mislead."""
SHORT_LABELS = ("P", "QP", "C", "?")
"""Cell text of each of analysis.LABELS (the long names overlap in a cell)."""


def drive_map(ds, out: Path) -> Path:
    """Response map of a drive sweep (two sweep axes, e.g. τ × A): one heatmap per number of
    ``analysis.response_map`` (standing-wave ratio on a log scale, labels as codes of analysis.LABELS)."""
    _require(ds, "response", "window_ke", "driver_open", figure="drive_map")
    numbers = an.response_map(ds)
    dims = numbers["dims"]
    if len(dims) != 2:
        raise PlotError(f"a response map needs a store with two sweep axes; this one has {len(dims)}")
    plt = _pyplot()
    metrics = an.MAP_METRICS
    cols = 4
    rows = -(-len(metrics) // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(4.0 * cols, 3.2 * rows), squeeze=False)
    y, x = numbers["coords"][dims[0]], numbers["coords"][dims[1]]
    for ax, metric in zip(axes.flat, metrics):
        data = np.asarray(numbers[metric], dtype=float)
        shown = np.log10(data) if metric == "swr" else data
        image = ax.imshow(
            shown,
            origin="lower",
            aspect="auto",
            cmap="viridis" if metric != "label" else "Set2",
            vmin=0 if metric == "label" else None,
            vmax=len(an.LABELS) - 1 if metric == "label" else None,
        )
        ax.set_xticks(range(len(x)), [f"{v:g}" for v in x])
        ax.set_yticks(range(len(y)), [f"{v:g}" for v in y])
        ax.set_xlabel(dims[1])
        ax.set_ylabel(dims[0])
        ax.set_title(MAP_TITLES.get(metric, metric), fontsize=8)
        for (i, j), value in np.ndenumerate(data):
            text = SHORT_LABELS[int(value)] if metric == "label" and np.isfinite(value) else f"{value:.3g}"
            ax.text(j, i, text, ha="center", va="center", fontsize=7, color="w" if metric != "label" else "k")
        if metric != "label":  # the label's codes are named in its cells and title, not on a scale
            fig.colorbar(image, ax=ax)
    for ax in list(axes.flat)[len(metrics) :]:
        ax.axis("off")
    return _finish(fig, out)


def standing(ds, out: Path) -> Path:
    """Sec. VI: standing fraction s = 2 min(|F|, |B|)/(|F| + |B|) of the two-wave fit at the drive frequency
    (``analysis.standing_fractions``) per response window (top) and against depth over the second half of the
    windows (bottom), one column per τ, one line per drive amplitude A."""
    _require(ds, "response", figure="standing")
    rows = an.standing_fractions(ds)
    plt = _pyplot()
    taus = sorted({row["tau"] for row in rows}, reverse=True)
    fig, axes = plt.subplots(2, len(taus), figsize=(5.2 * len(taus), 6.4), squeeze=False)
    for col, tau in enumerate(taus):
        for row in (r for r in rows if r["tau"] == tau and "residual" in r):
            label = f"A = {row.get('A', float('nan')):g}: s = {row['fraction']:.2f}, residual {row['residual']:.2f}"
            axes[0, col].plot(row["window_start"], row["window_fraction"], ".-", lw=0.8, label=label)
            axes[1, col].plot(row["depth"], row["depth_fraction"], ".-", lw=0.8, label=f"A = {row.get('A', 0):g}")
        axes[0, col].set_title(f"τ = {tau:g}: median standing fraction per window", loc="left", fontsize=9)
        axes[0, col].set_xlabel("window start [time units]")
        axes[1, col].set_title(f"τ = {tau:g}: against depth, second half of the windows", loc="left", fontsize=9)
        axes[1, col].set_xlabel("depth z [grain diameters] (surface = 0)")
        for ax in axes[:, col]:
            ax.set_ylim(-0.02, 1.02)
            ax.set_ylabel("s (1 standing, 0 travelling)", fontsize=8)
            ax.grid(alpha=0.3)
            if ax.lines:
                ax.legend(fontsize=7)
            else:
                ax.text(0.5, 0.5, "column shorter than half a wavelength", ha="center", transform=ax.transAxes)
    fig.suptitle(f"Forward and backward waves at the drive frequency, {_grains(ds)}-grain column", fontsize=9)
    return _finish(fig, out, note="Fit per stretch of one local wavelength; residual = unexplained fraction of |V1|.")


def plot_response_point(point, out: Path) -> Path:
    """One point with response windows: |V_1(z)| and its phase per window, window_ke (window × grain) and
    the depth–time picture of v from the snapshots."""
    plt = _pyplot()
    fig, axes = plt.subplots(2, 2, figsize=(12.0, 7.0), squeeze=False)
    v1 = point.response.sel(harmonic=1).values
    starts = point.window_start.values
    grains = np.arange(v1.shape[-1])
    for w in range(v1.shape[0]):
        axes[0, 0].plot(grains, np.abs(v1[w]), lw=0.8, label=f"window from t = {starts[w]:g}")
        axes[0, 1].plot(grains, np.angle(v1[w]), ".", ms=2)
    axes[0, 0].set_yscale("log")
    axes[0, 0].set_xlabel("grain (depth; surface = 0)")
    axes[0, 0].set_ylabel("|V_1| [1e-5 m per time unit]")
    axes[0, 0].set_title("|V_1(z)|, fundamental of the drive")
    axes[0, 0].legend(fontsize=7)
    axes[0, 1].set_xlabel("grain")
    axes[0, 1].set_ylabel("arg V_1 [rad]")
    axes[0, 1].set_title("phase of V_1 (t absolute)")
    ke = point.window_ke.values
    image = axes[1, 0].imshow(ke, origin="lower", aspect="auto", cmap="magma", interpolation="nearest")
    fig.colorbar(image, ax=axes[1, 0], label="window-averaged ½ m v²")
    axes[1, 0].set_xlabel("grain")
    axes[1, 0].set_ylabel("window")
    axes[1, 0].set_title("window_ke; driver open " + ", ".join(f"{f:.2f}" for f in point.driver_open.values))
    if "v" in point.variables:
        t, v = point.t.values, point.v.values
        limit = float(np.nanmax(np.abs(v))) or 1.0
        image = axes[1, 1].imshow(
            v,
            origin="lower",
            aspect="auto",
            cmap="RdBu_r",
            vmin=-limit,
            vmax=limit,
            extent=(-0.5, v.shape[-1] - 0.5, t[0], t[-1]),
            interpolation="nearest",
        )
        fig.colorbar(image, ax=axes[1, 1], label="v [1e-5 m per time unit]")
        axes[1, 1].set_xlabel("grain")
        axes[1, 1].set_ylabel(f"t [{TIME_UNIT}]")
        axes[1, 1].set_title("v(grain, t) at the snapshots, + into the chain")
    else:
        axes[1, 1].axis("off")
    return _finish(fig, out)


FIGURES: dict[str, Callable] = {
    "fig1": fig1,
    "fig1d": fig1d,
    "fig2": fig2,
    "fig3": fig3,
    "fig4": fig4,
    "fig5": fig5,
    "fig6": fig6,
    "depth": depth,
    "fig7_8": fig7_8,
    "fig9": fig9,
    "fig10": fig10,
    "sec6_lag": sec6_lag,
    "modes": modes,
    "drive_map": drive_map,
    "standing": standing,
}
"""Figure name → drawing function (dataset, output path)."""


def plot_figure(dataset, figure: str, out: str | Path) -> Path:
    """Draw ``figure`` (a key of :data:`FIGURES`) from an xarray dataset into the PNG ``out``."""
    if figure not in FIGURES:
        raise PlotError(f"unknown figure {figure!r}; allowed: {', '.join(FIGURES)}")
    try:
        return FIGURES[figure](dataset, Path(out))
    except PlotError:
        raise
    except (KeyError, IndexError, ValueError, TypeError, AttributeError):  # the right names, another sweep's shape
        raise PlotError(not_this_figure(dataset, figure)) from None


def not_this_figure(dataset, figure: str) -> str:
    """One line: the store is not ``figure``'s, and what it holds."""
    return f"the store does not hold figure {figure}'s sweep; it has {store_contents(dataset)}"
