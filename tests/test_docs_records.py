"""Numbers in the docs against the raw records they cite: each table row checked here is read from the Markdown and
compared, at the precision the table prints, with the record's values."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import pytest

DOCS = Path(__file__).resolve().parents[1] / "docs"


def table_after(doc: str, heading: str) -> dict[str, list[str]]:
    """The first Markdown table after the line that starts with ``heading``: first cell → the other cells."""
    lines = (DOCS / doc).read_text().splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith(heading))
    rows: dict[str, list[str]] = {}
    for line in lines[start + 1 :]:
        if line.startswith("|"):
            cells = [c.strip() for c in line.strip().strip("|").split("|")]
            if not set(cells[0]) <= {"-", " "}:
                rows[cells[0]] = cells[1:]
        elif rows:
            break
    return rows


def table_rows(doc: str, heading: str) -> list[list[str]]:
    """Every row (header first, the separator left out) of the first Markdown table after the line that starts
    with ``heading``."""
    lines = (DOCS / doc).read_text().splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith(heading))
    table = []
    for line in lines[start:]:
        if line.startswith("|"):
            cells = [c.strip() for c in line.strip().strip("|").split("|")]
            if not all(set(c) <= {"-", " "} for c in cells):
                table.append(cells)
        elif table:
            break
    return table


def record(name: str) -> dict:
    return json.loads((DOCS / "records" / name).read_text())


def shown(cell: str) -> tuple[float, int] | None:
    """A printed number and its count of significant digits (None for a dash)."""
    if cell in ("—", "-"):
        return None
    match = re.fullmatch(r"[−-]?\d+(\.\d+)?", cell)
    assert match, cell
    return float(cell.replace("−", "-")), len(cell.replace("−", "").replace("-", "").replace(".", "").lstrip("0"))


def agrees(cell: str, value: float) -> bool:
    """Whether ``cell`` is ``value`` printed to the cell's own number of decimals."""
    number = shown(cell)
    if number is None:
        return value != value or value == 0  # a dash stands for nothing measured
    decimals = len(cell.split(".")[1]) if "." in cell else 0
    return abs(value - number[0]) <= 0.5 * 10**-decimals * (1 + 1e-9)  # a tie may round either way


@pytest.mark.parametrize(
    "heading, name",
    [
        ("Taper, bottom grain's largest kinetic energy", "heterogeneous_cpu.json"),
        ("At the shipped size (100 grains", "heterogeneous_shipped_cpu.json"),
    ],
)
def test_taper_tables_are_their_records(heading, name):
    rows = table_after("heterogeneous.md", heading)
    taper = record(name)["taper"]
    q = [float(c.replace("−", "-")) for c in rows["q"]]
    assert q == taper["q"]
    columns = {
        "bottom_fraction": "bottom_fraction",
        "relative to q = 0": "relative_to_uniform",
        "binary-collision estimate": "binary_collision_relative",
        "bottom_peak_force": "bottom_peak_force",
        "arrival time": "arrival_time",
    }
    checked = 0
    for row, key in columns.items():
        if row not in rows:
            continue
        for cell, value in zip(rows[row], taper[key]):
            assert agrees(cell, value), (row, cell, value)
            checked += 1
    assert checked >= 3 * len(q)


def test_the_cpu_disorder_table_is_its_record():
    """heterogeneous.md's disorder table (40 grains, 20 realisations per spread): every row's mean ± std and 5–95 %
    band; the uniform chain (s = 0) has one value and no band."""
    rows = table_after("heterogeneous.md", "Disorder (20 realisations per spread)")
    disorder = record("heterogeneous_cpu.json")["disorder"]
    assert disorder["realisations"] == 20 and [float(c) for c in rows["s"]] == disorder["spread"]
    for name in ("bottom_fraction", "decay_length", "bottom_peak_force"):
        label = next(k for k in rows if k.startswith(f"{name} mean"))
        for k, cell in enumerate(rows[label]):
            parts = cell.split(" ± ")
            assert agrees(parts[0], disorder[f"{name}_mean"][k]), (name, cell)
            assert len(parts) == 1 or agrees(parts[1], disorder[f"{name}_std"][k]), (name, cell)
        if f"{name} 5–95 %" in rows:
            for k, cell in enumerate(rows[f"{name} 5–95 %"]):
                if k == 0:
                    assert cell == "—" and disorder[f"{name}_std"][0] < 1e-12
                    continue
                low, high = cell.split("–")
                assert agrees(low, disorder[f"{name}_q05"][k]) and agrees(high, disorder[f"{name}_q95"][k]), cell


@pytest.mark.parametrize(
    "heading, dt_name, half_name",
    [
        (
            "the share of the kinetic energy at ω says how much",
            "reproduction/sec6_standing_full_cpu.json",
            "reproduction/sec6_standing_full_half_cpu.json",
        ),
    ],
)
def test_sec6_standing_tables_are_their_records(heading, dt_name, half_name):
    table = table_rows("reproduction.md", heading)
    header, body = table[0], [row for row in table[1:] if row[1] != "any"]
    at_dt = {(p["tau"], p["A"]): p for p in record(dt_name)["points"]}
    at_half = {(p["tau"], p["A"]): p for p in record(half_name)["points"]}
    assert body
    for row in body:
        key = (float(row[0]), float(row[1]))
        for column, point in (("s at dt (quartiles)", at_dt[key]), ("s at dt/2 (quartiles)", at_half[key])):
            cell = row[header.index(column)]
            median, quartiles = cell.split(" (")
            low, high = quartiles.rstrip(")").split("–")
            assert agrees(median, point["fraction"]), (key, column, cell)
            assert agrees(low, point["fraction_quartiles"][0]) and agrees(high, point["fraction_quartiles"][1]), cell
        if "verdict at dt" in header:
            assert row[header.index("verdict at dt")] == at_dt[key]["verdict"]
            assert row[header.index("verdict at dt/2")] == at_half[key]["verdict"]
            null = row[header.index("null at dt: median (95 % band)")]
            median, band = null.split(" (")
            low, high = band.rstrip(")").split("–")
            assert agrees(median, at_dt[key]["null_median"]), null
            assert agrees(low, at_dt[key]["null_band"][0]) and agrees(high, at_dt[key]["null_band"][1]), null
            shares = row[header.index("kinetic energy at ω (dt / dt/2)")].replace(" %", "").split(" / ")
            assert agrees(shares[0], 100 * at_dt[key]["ke_share_drive"]), shares
            assert agrees(shares[1], 100 * at_half[key]["ke_share_drive"]), shares
            assert agrees(row[header.index("two-wave residual (dt)")], at_dt[key]["residual"])
            null = row[header.index("its null at dt (shuffled)")].replace(" %", "")
            assert agrees(null, 100 * at_dt[key]["ke_share_null"]), null
            assert at_dt[key]["ke_share_verdict"] == at_half[key]["ke_share_verdict"] == "above the null"


def test_sec6_lag_table_is_its_record():
    rows = table_rows("reproduction.md", "| τ | t0 | instantaneous v | averaged v |")[1:]
    runs = {run["name"]: run for run in record("reproduction/sec6_lag_h200.json")["runs"]}
    run = runs["sec6_lag"]
    lags = run["lag_steps_at_paper_dt"]
    columns = ("instantaneous_v", "averaged_v", "instantaneous_ke", "averaged_ke")
    checked = 0
    for tau_text, *cells in rows:
        tau, t0 = float(tau_text), float(cells[0])
        ti, ki = run["taus"].index(tau), run["t0"].index(t0)
        for name, cell in zip(columns, cells[1:]):
            for text, lag in zip(cell.split(", "), (800, 2000, 4000, 8000, 12000)):
                value = run["correlation"][name][ti][ki][lags.index(lag)]
                assert agrees(text.replace("−", "-"), value), (tau, t0, name, lag, text, value)
                checked += 1
    assert checked == 4 * 4 * 5


def test_the_cost_table_is_its_record():
    """reproduction.md's "What each group costs" CPU table against measurements.json's runs, row by row."""
    table = table_rows("reproduction.md", "| run | chains × grains | steps | device | date |")
    header, rows = table[0], table[1:]
    groups = record("reproduction/measurements.json")["groups"]
    assert len(rows) == len(groups) == 14
    for row in rows:
        cells = dict(zip(header, row))
        run = groups[cells["run"]]
        assert cells["date"] == run["run"]["date"][:10] and cells["record"].endswith(f"`groups.{cells['run']}`")
        chains, grains = (int(x) for x in cells["chains × grains"].split(" × "))
        assert (chains, grains) == (int(run["points"]), int(run["grains"])), cells["run"]
        assert int(cells["steps"].replace(" ", "")) == int(run["steps"]), cells["run"]
        assert agrees(cells["wall [s]"], float(run["wall_seconds"])), cells["run"]
        rate, error = float(cells["grain-steps/s"]), float(cells["energy error (max)"])
        assert abs(rate / float(run["grain_steps_per_second"]) - 1) < 0.06, cells["run"]  # printed to 2 digits
        assert abs(error / float(run["energy_error_max"]) - 1) < 0.05, cells["run"]
        count, code = cells["status (chains × code)"].split(" × ")
        assert run["status_counts"] == {code: int(count)}, cells["run"]


def test_the_cpu_lag_table_is_its_record():
    """Sec. VI's reduced-column lag table: each entry at dt, and the dt/2 value in parentheses where it is given."""
    table = table_rows(
        "reproduction.md", "| τ | t0 | instantaneous ½v² | averaged ½v² | instantaneous v | averaged v |"
    )
    runs = {run["name"]: run for run in record("reproduction/sec6_lag_cpu.json")["runs"]}
    at_dt, at_half = runs["sec6_lag"], runs["sec6_lag_dt_check"]
    names = ("instantaneous_ke", "averaged_ke", "instantaneous_v", "averaged_v")
    checked = 0
    for tau_text, t0_text, *cells in table[1:]:
        tau, t0 = float(tau_text), float(t0_text)
        for name, cell in zip(names, cells):
            for text, lag in zip(cell.split(", "), (80, 800, 4000, 8000, 12000)):
                value, half = (text.replace("−", "-").rstrip(")").split(" (") + [None])[:2]
                series = at_dt["correlation"][name][at_dt["taus"].index(tau)][at_dt["t0"].index(t0)]
                assert agrees(value, series[at_dt["lag_steps_at_paper_dt"].index(lag)]), (tau, t0, name, lag, text)
                if half is not None:
                    halves = at_half["correlation"][name][at_half["taus"].index(tau)][at_half["t0"].index(t0)]
                    assert agrees(half, halves[at_half["lag_steps_at_paper_dt"].index(lag)]), (tau, t0, name, lag)
                checked += 1
    assert checked == 4 * 4 * 5


def test_the_fig1d_speed_table_is_its_record():
    table = table_rows("reproduction.md", "| l0 \\ v_imp |")
    found = record("reproduction/measurements.json")["groups"]["fig1d"]["measurements"]
    assert all(agrees(cell, v) or f"{v:.3g}" == cell for cell, v in zip(table[0][1:], found["v_imp"]))
    for row, l0, speeds in zip(table[1:], found["l0"], found["speed"]):
        assert float(row[0]) == l0
        for cell, speed in zip(row[1:], speeds):
            assert agrees(cell, speed), (l0, cell, speed)
    assert "(1σ fit errors ≤ 0.0012)" in (DOCS / "reproduction.md").read_text()
    assert max(max(errors) for errors in found["speed_error"]) <= 0.0012


def test_the_expanding_rectangle_table_is_its_record():
    table = table_rows("reproduction.md", "| l0, v_imp | c | dW/dt | W ∝ t^β |")
    fig1 = record("reproduction/measurements.json")["groups"]["fig1"]["measurements"]
    assert len(table) == 4
    for label, speed, rate, beta in table[1:]:
        v_imp = label.split(", ")[1]
        point, width = fig1[f"v_imp={float(v_imp):g}"], fig1["width"][f"v_imp={float(v_imp):g}"]
        assert agrees(speed, point["speed"]), (label, speed)
        value, error = rate.split(" ± ")
        assert agrees(value, width["dW_dt"][0]) and agrees(error, width["dW_dt"][1]), (label, rate)
        value, error = beta.removeprefix("β = ").split(" ± ")
        assert agrees(value, width["beta"][0]) and agrees(error, width["beta"][1]), (label, beta)


def test_the_fig6_table_is_its_record():
    table = table_rows("reproduction.md", "| g | head depth | bumps ≥ 10 % (≥ 30 %) of the head's velocity |")
    fig6 = record("reproduction/measurements.json")["groups"]["fig6"]["measurements"]
    assert len(table) == 5
    for g, head, bumps, largest in table[1:]:
        point = fig6[f"g={g}"]
        assert agrees(head, point["head"]), (g, head)
        assert bumps == f"{point['bumps_10pc']} ({point['bumps_30pc']})", (g, bumps)
        assert agrees(largest, point["largest_u_below_grain_2"]), (g, largest)


def test_the_nesterenko_table_is_its_record():
    """The soliton table: at dt (rows) and, as the text says, the same to the digits shown at the smaller step."""
    table = table_rows("reproduction.md", "| v_imp | c | v_m / v_imp | c / Nesterenko(v_m) | FWHM [grains] |")
    values = record("reproduction/daggers_cpu.json")["items"]["nesterenko"]["values"]
    steps = [key for key in values if key.startswith("dt=")]
    assert len(steps) == 2 and len(table) == 4
    for v_imp, speed, ratio, nesterenko, fwhm in table[1:]:
        for step in steps:
            row = values[step]["rows"][f"v_imp={float(v_imp):g}"]
            expected = (row["speed"], row["v_m_over_v_imp"], row["speed_over_nesterenko"], row["fwhm_grains"])
            for cell, value in zip((speed, ratio, nesterenko, fwhm), expected):
                assert agrees(cell, value), (v_imp, step, cell, value)


def test_the_fig9_10_lag_table_is_its_record():
    """Sec. VI's full-column table of the H100 run: correlations at lags 1.5 … 10.5, their mean, node counts, spacing
    and shifts, for each τ and t0."""
    table = table_rows("reproduction.md", "| τ | t0 | correlation at lags 1.5 … 10.5 | mean |")
    runs = record("reproduction/fig9_10_h100.json")["runs"]
    (run,) = [r for r in runs if r["name"] == "fig9_10"]
    assert len(table) == 1 + 2 * 5
    for tau, t0, correlations, mean, nodes, spacing, shift in table[1:]:
        windows = run["standing_wave"][run["taus"].index(float(tau))]
        (window,) = [w for w in windows if w.get("t") == float(t0)]
        later = window["correlation"][1:]
        assert all(agrees(c.replace("−", "-"), v) for c, v in zip(correlations.split(", "), later)), (tau, t0)
        assert agrees(mean, sum(later) / len(later)), (tau, t0, mean)
        first, span = nodes.split("; ")
        low, high = span.split("–") if "–" in span else (span, span)
        counts = window["node_count"]
        assert (int(first), int(low), int(high)) == (counts[0], min(counts), max(counts)), (tau, t0, nodes)
        if spacing != "—" and not spacing.startswith("("):
            assert agrees(spacing, window["node_spacing"]), (tau, t0, spacing)
            low, high = shift.split("–")
            assert agrees(low, min(window["node_shift"][1:])) and agrees(high, max(window["node_shift"][1:]))


def close_to_shown(cell: str, value: float) -> bool:
    """Whether ``cell`` (decimal or e-notation, − as minus) is ``value`` to the significant digits it shows."""
    text = cell.replace("−", "-")
    mantissa = text.split("e")[0].lstrip("-")
    digits = len(mantissa.replace(".", "").lstrip("0")) or 1
    shown_value = float(text)
    if shown_value == 0 or value == 0:
        return shown_value == value == 0 or abs(shown_value - value) <= 0.5 * 10 ** -(
            len(mantissa.split(".")[1]) if "." in mantissa else 0
        )
    scale = 10 ** (math.floor(math.log10(abs(shown_value))) - digits + 1)
    return abs(shown_value - value) <= 0.5 * scale * (1 + 1e-9)


def test_the_drive_map_table_is_its_record():
    table = table_rows("drive.md", "| τ | A | swr (dt / dt/2) | driver open | bottom KE share | late power |")
    points = {
        (p["tau"], p["A"]): p for p in record("drive/drive_map_cpu.json")["items"]["drive_map"]["values"]["points"]
    }
    assert len(table) == 1 + len(points)
    for tau, a, swr, open_, bottom, late, part in table[1:]:
        point = points[(float(tau), float(a))]
        for cell, name in ((swr, "swr"), (open_, "driver_open"), (bottom, "bottom_ke_fraction"), (late, "late_power")):
            at_dt, at_half = cell.split(" / ")
            assert close_to_shown(at_dt, point[name]) and close_to_shown(at_half, point[f"{name}_half_dt"]), (
                tau,
                a,
                name,
            )
        parted = point["trajectories_part_at"]
        assert (part.startswith("never") and parted is None) or float(part) == parted, (tau, a, part)


def test_the_tail_table_is_its_record():
    """Fig. 3's exponential tails: λ, R² and λ/(c t) at each time, for both chains."""
    table = table_rows("reproduction.md", "| case | t | head | λ | R² | λ/(c t) |")
    values = record("reproduction/daggers_cpu.json")["items"]["fig3_raw_tails"]["values"]
    assert len(table) == 3
    for case, times, _head, lengths, fits, ratios in table[1:]:
        envelope = values[f"l0={float(case.split(',')[0].removeprefix('l0 = ')):g}"]["envelope"]
        assert [float(t) for t in times.split(" / ")] == [e["t"] for e in envelope], case
        for column, key in ((lengths, "decay_length"), (fits, "r_squared"), (ratios, "decay_over_ct")):
            for cell, entry in zip(column.split(" / "), envelope):
                assert agrees(cell, entry[key]), (case, key, cell, entry[key])


THRESHOLDS = ("0.05", "0.1", "0.2", "0.3", "0.4", "0.5")


def test_the_echo_sign_table_is_its_record():
    """Figs. 7–8's leading signs at the surface grain for thresholds 5 … 50 %, per run, class and contact rule."""
    table = table_rows("reproduction.md", "| run | light, harmonic | light, own | heavy, harmonic | heavy, own |")
    found = record("reproduction/measurements.json")
    groups, comparisons = found["groups"], found["comparisons"]
    single = comparisons["fig7_8_single_echo_by_threshold (sign, arrival, amplitude, peak sign)"]
    signs = {
        "five, v_imp = 0.1": groups["fig7_8"]["measurements"]["echo"]["grain 0"]["leading_sign_by_threshold"],
        "five, v_imp = 1e-2": groups["fig7_8_slow"]["measurements"]["echo"]["grain 0"]["leading_sign_by_threshold"],
        "five, g = 0 (Fig. 5)": groups["fig5"]["measurements"]["echo"]["grain 0"]["leading_sign_by_threshold"],
        "single, v_imp = 0.1": {case: {t: entry[0] for t, entry in by.items()} for case, by in single.items()},
    }
    header = table[0]
    assert len(table) == 1 + len(signs)
    for row in table[1:]:
        for column, cell in zip(header[1:], row[1:]):
            case = column.replace(", ", "/")
            expected = " ".join("+" if signs[row[0]][case][t] > 0 else "−" for t in THRESHOLDS)
            assert cell == expected, (row[0], column, cell, expected)


def test_the_contrast_table_is_its_record():
    table = table_rows("reproduction.md", "| | five impurities, harmonic / own | single impurity, harmonic / own |")
    contrast = record("reproduction/measurements.json")["comparisons"]["light_heavy_contrast_at_surface"]
    groups = {
        "g = 0, l0 = 1e-4, v_imp = 1e-2 (Fig. 5)": ("fig5", "fig5_single"),
        "g = 1, v_imp = 0.1 (Figs. 7–8)": ("fig7_8", "fig7_8_single"),
        "g = 1, v_imp = 1e-2": ("fig7_8_slow", None),
    }
    assert [row[0] for row in table[1:]] == list(groups)
    for label, five, single in table[1:]:
        for cell, name in zip((five, single), groups[label]):
            if name is None:
                assert cell == "—"
                continue
            harmonic, own = cell.split(" / ")
            assert agrees(harmonic, contrast[name]["harmonic"]) and agrees(own, contrast[name]["own"]), (label, name)


def test_the_fig5_echo_table_is_its_record():
    """Fig. 5's echoes at the surface: arrival, largest |echo| and leading sign at the 20 % threshold, and the
    light/heavy contrast, for five and single impurities under both contact rules."""
    table = table_rows("reproduction.md", "| impurities | contact | light (m 0.5, a 2000) | heavy (m 2, a 1e4) |")
    found = record("reproduction/measurements.json")
    five = found["groups"]["fig5"]["measurements"]["echo"]["grain 0"]
    single = found["comparisons"]["fig5_single_echo_by_threshold (sign, arrival, amplitude, peak sign)"]
    contrast = found["comparisons"]["light_heavy_contrast_at_surface"]
    assert len(table) == 5
    for impurities, contact, light, heavy, ratio in table[1:]:
        for cell, kind in ((light, "light"), (heavy, "heavy")):
            case = f"{kind}/{contact}"
            if impurities == "five":
                sign = five["leading_sign_by_threshold"][case]["0.2"]
                arrival, amplitude = five["arrival_by_threshold"][case]["0.2"], five["amplitude"][case]
            else:
                sign, arrival, amplitude, _ = single[case]["0.2"]
            shown_arrival, shown_amplitude, shown_sign = cell.split(" / ")
            assert agrees(shown_arrival, arrival) and close_to_shown(shown_amplitude, amplitude), (impurities, case)
            assert shown_sign == ("+" if sign > 0 else "−"), (impurities, case)
        name = "fig5" if impurities == "five" else "fig5_single"
        assert agrees(ratio, contrast[name][contact]), (impurities, contact)


def test_the_finite_g_table_is_its_record():
    """Five impurities at g = 0 and g = 1, nothing else different: light/heavy contrast per traced grain (harmonic /
    own) and the leading signs at the 20 % threshold."""
    table = table_rows("reproduction.md", "| traced grain | g = 0 | g = 1 | leading sign, 20 % threshold")
    (run,) = record("reproduction/finite_g.json")["runs"]
    measured = run["measurements"]
    assert len(table) == 4
    text = " ".join((DOCS / "reproduction.md").read_text().split())
    date = record("reproduction/finite_g.json")["date"][:10]
    assert (
        f"{run['wall_seconds']:.0f} s on the 2-core CPU ({date}), energy error ≤ {run['energy_error_max']:.1e}".replace(
            "e-0", "e-"
        )
        in text
    )
    for grain, at_zero, at_one, signs in table[1:]:
        key = f"grain {grain.split()[0]}"
        for cell, g in ((at_zero, "g=0"), (at_one, "g=1")):
            harmonic, own = cell.split(" / ")
            contrast = measured[g][key]["light_heavy_contrast"]
            assert agrees(harmonic, contrast["harmonic"]) and agrees(own, contrast["own"]), (grain, g, cell)
        for part, g in zip(signs.split(" / "), ("g=0", "g=1")):
            leading = measured[g][key]["leading_sign_by_threshold"]
            expected = ", ".join("+" if leading[f"{kind}/harmonic"]["0.2"] > 0 else "−" for kind in ("light", "heavy"))
            assert part == expected, (grain, g, part, expected)


def test_the_measured_items_table_is_its_record():
    """The items of daggers_cpu.json: each row's date to the minute and wall seconds."""
    table = table_rows("reproduction.md", "| item | what | date (UTC) | wall [s] | written by |")
    items = record("reproduction/daggers_cpu.json")["items"]
    rows = table[1:]
    assert {row[0].strip("`") for row in rows} == set(items)
    for name, _what, date, wall, _by in rows:
        item = items[name.strip("`")]
        assert item["date"].replace("T", " ").startswith(date), (name, date, item["date"])
        assert agrees(wall, item["wall_seconds"]), (name, wall, item["wall_seconds"])
    text = " ".join((DOCS / "reproduction.md").read_text().split())
    total = sum(item["wall_seconds"] for item in items.values())
    assert (
        f"(`--measure daggers`: all of them, {total:.0f} s on the 2-core CPU by the items' wall seconds below;" in text
    )
    (run,) = record("reproduction/finite_g.json")["runs"]
    assert f"(only g differs), {run['wall_seconds']:.0f} s on a 2-core CPU" in text


def test_the_h100_run_table_is_its_record():
    table = table_rows("reproduction.md", "| run | chains × grains | steps | device | wall [s] | grain-steps/s |")
    runs = {run["name"]: run for run in record("reproduction/fig9_10_h100.json")["runs"]}
    assert len(table) == 3
    for label, size, steps, _device, wall, rate, errors in table[1:]:
        run = runs[label.split(",")[0]]
        chains = len(run["energy_error"])
        assert size == f"{chains} × {int(run['grains']):,}".replace(",", " ")
        assert int(steps.replace(" ", "")) == int(run["steps"]) and agrees(wall, float(run["wall_seconds"]))
        grain_steps = chains * int(run["grains"]) * int(run["steps"])
        assert close_to_shown(rate, run.get("grain_steps_per_second", grain_steps / run["wall_seconds"])), label
        shown = [float(part.split(" (")[0]) for part in errors.split(" / ")]
        assert all(any(close_to_shown(f"{x:.2g}", e) for e in run["energy_error"]) for x in shown), (label, errors)


def test_the_fig2_overlap_table_is_its_record():
    """Fig. 2's overlaps behind the front (l0 = 1e-5), the speeds at l0 = 1e-5 and 1e-6, and the profile change."""
    table = table_rows("reproduction.md", "| v_imp | largest overlap behind the front / at the front |")
    found = record("reproduction/measurements.json")
    fig1, fig2 = found["groups"]["fig1"]["measurements"], found["groups"]["fig2"]["measurements"]
    change = found["comparisons"]["fig2_vs_fig1"]
    assert len(table) == 4
    for v_imp, overlap, speed_5, speed_6, profile in table[1:]:
        key = f"v_imp={float(v_imp):g}"
        ratio = fig2[key]["overlap_behind_head_over_head"]
        span, times = overlap.rstrip(")").split(" (t = ")
        low, high = span.split("–")
        assert agrees(low, ratio["min"]) and agrees(high, ratio["max"]), (v_imp, overlap)
        assert [float(t) for t in times.split("–")] == ratio["t_range"], (v_imp, times)
        assert agrees(speed_5, fig2[key]["speed"]) and agrees(speed_6, fig1[key]["speed"]), v_imp
        value, rest = profile.split(" at t = ")
        t, grain = rest.rstrip(")").split(" (largest at grain ")
        row = change[key]
        assert agrees(value, row["relative_profile_change"]) and float(t) == row["t"], (v_imp, profile)
        assert int(grain) == row["largest_change_at_grain"], (v_imp, profile)


def test_the_grain_500_table_is_its_record():
    """The impurity grain's ringing: RMS velocity over the clean pulse's peak in four windows, and the change."""
    table = table_rows("reproduction.md", "| grain 500 | 5–15 | 15–25 | 25–35 | 35–45 | change |")
    modes = record("reproduction/measurements.json")["groups"]["fig5_modes"]["measurements"]
    masses = {"light (m = 0.5)": "m=0.5", "clean chain": "m=1", "heavy (m = 2)": "m=2"}
    assert [row[0] for row in table[1:]] == list(masses)
    for label, *cells, change in table[1:]:
        rms = modes[masses[label]]["rms_over_clean_peak"]
        assert all(agrees(cell, value) for cell, value in zip(cells, rms)), (label, cells, rms)
        assert agrees(change.replace(" %", ""), 100 * (rms[-1] / rms[0] - 1)), (label, change)


def test_fixed_costs_readme_rows_are_their_record():
    """The README command's cold / warm medians with and without prebuilt kernels, and the prebuild's seconds."""
    rows = table_after("fixed-costs.md", "## Measured on the CPU")
    bench = record("bench/cpu_auto_rule.json")
    cells = {key: cells[0] for key, cells in rows.items()}
    plain = next(v for k, v in cells.items() if "(`readme`," in k)
    prebuilt = next(v for k, v in cells.items() if "(`readme_prebuilt`," in k)
    for cell, part in ((plain, "readme"), (prebuilt, "readme_prebuilt")):
        cold, warm = cell.split(" / ")
        assert agrees(cold, bench[part]["median_cold_s"]) and agrees(warm, bench[part]["median_warm_s"]), part
    prebuild = next(v for k, v in cells.items() if "`readme_prebuilt.prebuild_s`" in k)
    assert agrees(prebuild, bench["readme_prebuilt"]["prebuild_s"])
    costs = bench["kernel_costs"]
    from hertzian.core.solvers.calibrate import CPU_COSTS  # the auto rule's constants are this record's medians

    for kind in ("step", "chain"):
        assert CPU_COSTS[kind] == (round(costs[kind]["compile_s"], 3), float(f"{costs[kind]['rate']:.3g}")), kind
    row = next(v for k, v in cells.items() if "(`kernel_costs`, medians of 3)" in k)
    assert row == f"{costs['step']['compile_s']:.2f} / {costs['chain']['compile_s']:.2f}"
    for key, label in (
        ("import_cli", "`start.import_cli`"),
        ("run_help", "`start.run_help`"),
        ("tiny_run", "`start.tiny_run`"),
    ):
        assert agrees(next(v for k, v in cells.items() if label in k), bench["start"][key]), key
    installed = next(v for k, v in cells.items() if "(`readme_installed`," in k)
    cold, warm = installed.split(" / ")
    assert agrees(cold, bench["readme_installed"]["median_cold_s"]) and agrees(
        warm, bench["readme_installed"]["median_warm_s"]
    )
    million = bench["build_million"]["seconds"]
    row = next(v for k, v in cells.items() if k.startswith("million sweep, first 2 batches (80 000 points)"))
    assert row == " / ".join(f"{million[k]:.3f}" for k in ("expand", "plan", "jobs"))
    row = next(v for k, v in cells.items() if k.startswith("million sweep, first 2 batches: `prepare_model`"))
    assert row == f"{million['prepare_model']:.2f} / {million['upload']:.4f} / {million['state_pair']:.2f}"
    text = " ".join((DOCS / "fixed-costs.md").read_text().split())
    part = bench["readme_prebuilt"]
    assert (
        f"the default family takes {part['prebuild_s']:.1f} s to build and {part['prebuilt_bytes'] / 1e6:.1f} MB of disk"
        in text
    )


def claims_row(claim: str) -> tuple[str, str]:
    """(measured, verdict) cells of the row of reproduction.md's claims table whose claim starts with ``claim``."""
    (row,) = [cells for cells in table_rows("reproduction.md", "| claim (section)") if cells[0].startswith(claim)]
    return row[2], row[3]


def measured(group: str) -> dict:
    """``groups.<group>.measurements`` of reproduction/measurements.json (the claims table's record)."""
    return record("reproduction/measurements.json")["groups"][group]["measurements"]


def test_claims_speed_exponent_and_load_are_their_record():
    cell, verdict = claims_row("speed exponent")
    alpha = measured("fig1d")["alpha"]
    value, sigma = alpha["l0=1e-06"]
    assert f"α = {value:.4f} ± {sigma:.4f} (l0 = 1e-6)" in cell
    assert f"({100 * (0.2 - value) / 0.2:.1f} % low; {value:.4f} is {(0.2 - value) / sigma:.1f} σ below 0.2" in verdict
    for key, label in (("l0=1e-05", "1e-5"), ("l0=0.0001", "1e-4")):
        value, sigma = alpha[key]
        assert f"{value:.3f} ± {sigma:.3f} ({label})" in cell
    value, sigma = alpha["l0=1e-05"]
    assert f"({value:.3f}, {100 * (0.2 - value) / 0.2:.1f} % low, {(0.2 - value) / sigma:.1f} σ)" in verdict
    value, sigma = measured("fig1d")["alpha_lumped"]
    assert f"all lumped {value:.3f} ± {sigma:.3f}" in cell
    assert f"({100 * (0.2 - value) / 0.2:.0f} % low, {(0.2 - value) / sigma:.1f} σ)" in verdict
    cell, _ = claims_row("c and the load")
    speeds = measured("fig1d")["speed"]  # (l0, v_imp) with v_imp from 1e-3 to 0.1
    for column, v_imp in ((-1, "0.1"), (0, "1e-3")):
        assert f"v_imp = {v_imp}: " + " / ".join(f"{row[column]:.2f}" for row in speeds) in cell


def test_claims_expanding_rectangle_and_sloping_top_are_their_record():
    cell, verdict = claims_row("expanding rectangle")
    width = measured("fig1")["width"]
    for v_imp, printed in (("0.1", "{} (v_imp = 0.1)"), ("0.01", "{} (1e-2)"), ("0.001", "{} at 1e-3")):
        beta, sigma = width[f"v_imp={v_imp}"]["beta"]
        assert printed.format(f"{beta:.4f} ± {sigma:.4f}") in cell
    beta, sigma = width["v_imp=0.001"]["beta"]
    assert f"{(1 - beta) / sigma:.0f} σ below 1" in cell and f"({100 * (1 - beta):.0f} % below 1)" in verdict
    ratio = width["v_imp=0.1"]["dW_dt"][0] / measured("fig1")["v_imp=0.1"]["speed"]
    assert f"dW/dt = {ratio:.2f} c" in cell
    cell, _ = claims_row("sloping top")
    tilt = measured("fig4")
    in_going = [100 * abs(v) for v in tilt["in_going"].values()]
    reflected = [100 * abs(v) for t, v in tilt["reflected"].items() if t != "t=110.5"]  # t = 110.5: at the wall
    assert f"{min(in_going):.1f}–{max(in_going):.1f} % in-going, {min(reflected):.1f}–{max(reflected):.1f} %" in cell


def test_claims_depth_law_and_echo_amplitude_are_their_record():
    cell, _ = claims_row("depth law")
    fits = [measured("depth")[f"v_imp={v}"]["beta"] for v in ("0.001", "0.01", "0.1")]
    betas, sigmas = [b for b, _ in fits], [s for _, s in fits]
    assert f"β = {min(betas):.4f}–{max(betas):.4f} ± {max(sigmas):.4f}" in cell
    above = [100 * (b - 1 / 6) * 6 for b in betas]
    distance = [(b - 1 / 6) / s for b, s in fits]
    assert f"{min(above):.1f}–{max(above):.1f} % above 1/6, i.e. {min(distance):.0f}–{max(distance):.0f} σ" in cell
    closed = [measured("depth")[f"v_imp={v}"]["c_over_closed_form"] for v in ("0.001", "0.01", "0.1")]
    mean = sum(c[0] for c in closed) / 3
    assert f"{mean:.3f} on average ({min(c[1] for c in closed):.3f}–{max(c[2] for c in closed):.3f})" in cell
    cell, _ = claims_row("echo amplitude")
    fast, slow = (measured(g)["echo"]["grain 0"]["amplitude"] for g in ("fig7_8", "fig7_8_slow"))
    pairs = [f"{fast[f'light/{r}']:.4f} vs {fast[f'heavy/{r}']:.4f} ({r})" for r in ("harmonic", "own")]
    assert "surface grain: " + ", ".join(pairs) in cell
    assert f"v_imp = 1e-2: {slow['light/harmonic']:.5f} vs {slow['heavy/harmonic']:.5f}" in cell


@pytest.mark.parametrize(
    "header, part",
    [
        ("| protector (19 mm long)", "beads_20"),
        ("| protector (99 mm long)", "beads_100"),
        ("| protector (19 mm long, four materials)", "four_materials"),
    ],
)
def test_the_design_tables_are_their_record(header, part):
    rows = table_after("design.md", header)
    chains = record("design/protector_cpu.json")[part]["chains"]
    labels = {"stainless_steel": "stainless steel", "ptfe": "PTFE", "aluminium": "aluminium", "glass": "glass"}
    materials = record("design/protector_cpu.json")[part]["design"]["materials"]
    names = {"best design": "best"}
    for kind in ("uniform", "tapered"):
        names.update({f"{kind}, {labels[m]}": f"{kind} {m}" for m in materials})
    assert set(rows) == set(names)
    for label, key in names.items():
        peak, mass, impulse = rows[label]
        row = chains[key]
        assert agrees(peak, row["peak_wall_force"]) and agrees(mass, row["mass"]) and agrees(impulse, row["impulse"])


def design_text() -> str:
    """docs/design.md with its line breaks read as spaces (its sentences wrap)."""
    return " ".join((DOCS / "design.md").read_text().split())


def falls(best: list[float]) -> list[tuple[int, float]]:
    """(generation counted from 1, value) at each generation where a best-so-far curve reaches a new value."""
    return [(g + 1, value) for g, value in enumerate(best) if g == 0 or value != best[g - 1]]


def beads_line(part: dict) -> str:
    """The best protector as ``hertzian summarize`` prints it: each varying bead's material letter and R/R0."""
    r0 = part["best_radii"][0]  # the striker, grain 0, keeps the base radius
    beads = zip(part["best_materials"][1:], part["best_radii"][1:])
    return "striker → " + " ".join(f"{m[0].upper()}{r / r0:.2f}" for m, r in beads) + " → wall"


def test_the_design_studys_prose_is_its_record():
    """Every number in docs/design.md's sentences about the four runs: their seconds, the best design's beads, its
    ratios to the plain protectors, where each material sits against the shuffles, the pulse's width above half its
    peak, and when the best last fell."""
    text = design_text()
    parts = record("design/protector_cpu.json")
    short, long_, wide, four = (parts[k] for k in ("beads_20", "beads_100", "population_6400", "four_materials"))
    chains = short["chains"]
    best = chains["best"]["peak_wall_force"]
    steel, switches = short["arrangement"]["materials"]["stainless_steel"], short["arrangement"]["switches"]
    assert f"The 50 generations took {short['design_seconds']:.0f} s" in text
    assert beads_line(short) in text
    ratios = (
        chains["tapered ptfe"]["peak_wall_force"] / best,
        chains["uniform stainless_steel"]["peak_wall_force"] / best,
    )
    assert f"{ratios[0]:.1f} times below the best plain protector's (tapered PTFE) and {ratios[1]:.0f} times" in text
    assert f"six steel beads sit at mean position {steel['mean_position']:.2f}" in text and steel["beads"] == 6
    assert f"all but {100 * steel['p_toward_striker']:.1f} % of the shuffles" in text
    assert f"neighbours differ {switches['count']} times against {switches['null_mean']:.1f}" in text
    assert f"only {100 * switches['p_at_most']:.0f} % of them have as few" in text
    widths = [chains[k]["time_above_half_peak"] for k in ("best", "uniform stainless_steel", "uniform ptfe")]
    assert "for {:.2f} time units, against {:.3f} for uniform steel and {:.3f} for uniform PTFE".format(*widths) in text
    assert (
        f"Run twice as long, the best design's peak is the same ({short['best_peak_at_twice_the_duration']:.4f})"
        in text
    )
    assert f"{best:.4f}" == f"{short['best_peak_at_twice_the_duration']:.4f}"

    history = falls(long_["best_objective"])
    fell_at = {f"{value:.5f}": generation for generation, value in history}
    assert (
        f"The best fell in {len(history) - 1} of the {len(long_['best_objective'])} generations, the last time at "
        f"generation {history[-1][0]} (0.00285 from generation {fell_at['0.00285']}, 0.00223 from generation "
        f"{history[-1][0]})" in text
    )
    assert f"{history[-1][1]:.5f}" == "0.00223"
    assert f"The 40 generations took {long_['design_seconds']:.0f} s" in text
    assert f"above half its peak for {long_['chains']['best']['time_above_half_peak']:.1f} time units" in text
    steel, switches = long_["arrangement"]["materials"]["stainless_steel"], long_["arrangement"]["switches"]
    assert (
        f"(mean position {steel['mean_position']:.2f}; {100 * steel['p_toward_striker']:.2f} % of the shuffles" in text
    )
    assert f"({switches['count']} against {switches['null_mean']:.1f}; {100 * switches['p_at_most']:.0f} %" in text

    assert f"32 000 runs in {wide['design_seconds']:.0f} s" in text
    per_generation = (wide["design_seconds"] / wide["generations"], short["design_seconds"] / short["generations"])
    assert "(%.0f s on average against %.1f s)" % per_generation in text
    assert f"the best peak is {wide['best_objective'][-1]:.4f} after 5 generations" in text
    assert f"against {short['best_objective'][4]:.4f} after 5 (and {short['best_objective'][-1]:.4f} after 50)" in text
    assert f"a design {100 * (wide['best_objective'][-1] / best - 1):.0f} % worse" in text

    assert f"best last fell at generation {falls(four['best_objective'])[-1][0]} of 50" in text
    assert f"The 50 generations took {four['design_seconds']:.0f} s on the 2-core CPU" in text
    glass = four["arrangement"]["materials"]["glass"]
    third = 2 / (len(four["best_materials"]) - 2)  # positions run from 0 (next to the striker) to 1 (the wall)
    assert glass["beads"] == 1 and glass["mean_position"] == pytest.approx(third, rel=1e-12)
    assert "the one glass bead third from the striker" in text


def test_claims_fig6_and_light_impurity_rows_are_their_record():
    cell, _ = claims_row("Fig. 6 (V)")
    fig6 = measured("fig6")
    gs = ("0.001", "0.1", "1", "10")
    bumps = ", ".join(str(fig6[f"g={g}"]["bumps_10pc"]) for g in gs)
    largest = ", ".join(f"{1e3 * fig6[f'g={g}']['largest_u_below_grain_2']:.1f}" for g in gs)
    assert f"bumps ≥ 10 % of the head {bumps}, largest u {largest} (×1e-3)" in cell
    cell, _ = claims_row("light-impurity oscillations")
    modes = measured("fig5_modes")
    rms = {m: modes[f"m={m}"]["rms_over_clean_peak"] for m in ("0.5", "1", "2")}
    ratios = [light / clean for light, clean in zip(rms["0.5"], rms["1"])]
    assert f"{ratios[0]:.1f} → {ratios[-1]:.1f} × the clean chain's" in cell
    falls = {m: 100 * (1 - r[-1] / r[0]) for m, r in rms.items()}
    assert f"(light falls {falls['0.5']:.0f} %, clean {falls['1']:.0f} %, heavy {falls['2']:.0f} %)" in cell
    assert f"above the band edge ({100 * modes['m=0.5']['power_fraction_above_band_edge']:.1f} %)" in cell


def test_claims_fig5_tails_row_is_its_record():
    cell, _ = claims_row("Fig. 5 tails")
    echo = measured("fig5")["echo"]["grain 0"]
    rules = ("harmonic", "own")
    earlier = [
        echo["arrival_by_threshold"][f"light/{rule}"][f] - echo["arrival_by_threshold"][f"heavy/{rule}"][f]
        for rule in rules
        for f in echo["arrival_by_threshold"][f"light/{rule}"]
    ]
    larger = [100 * (echo["amplitude"][f"light/{r}"] / echo["amplitude"][f"heavy/{r}"] - 1) for r in rules]
    assert f"heavy {min(earlier):.2f}–{max(earlier):.2f} t.u. earlier (arrival at 5–50 % of the peak" in cell
    assert f"light {min(larger):.0f}–{max(larger):.0f} % larger" in cell


def _range(cell: str, before: str, after: str) -> tuple[str, str]:
    """The 'low–high' printed between ``before`` and ``after`` in ``cell``."""
    inner = cell.split(before, 1)[1].split(after, 1)[0]
    low, high = inner.split("–")
    return low, high


def test_claims_exponential_tails_row_is_its_record():
    cell, _ = claims_row("exponential tails")
    wall, load = measured("fig3"), measured("fig3_load")
    tails = [t for v in wall.values() for t in v["tail"]]
    low, high = _range(cell, "(R² ", ")")
    assert agrees(low, min(t["r_squared"] for t in tails)) and agrees(high, max(t["r_squared"] for t in tails))
    for group, before in ((wall, "λ = ("), (load, "; (")):
        ratios = [t["decay_over_ct"] for v in group.values() for t in v["tail"]]
        low, high = _range(cell, before, ")·c t")
        assert agrees(low, min(ratios)) and agrees(high, max(ratios)), (before, ratios)
    exponents = [v["decay_length_exponent"][0] for v in wall.values()]
    low, high = _range(cell, "λ ∝ t^", " (")
    assert agrees(low, min(exponents)) and agrees(high, max(exponents))


def test_claims_fig2_row_is_its_record():
    cell, _ = claims_row("Fig. 2(a)")
    fig2 = measured("fig2")
    ranges = [fig2[f"v_imp={v}"]["overlap_behind_head_over_head"] for v in ("0.1", "0.01", "0.001")]
    printed = [f"{r['min']:.2f}–{r['max']:.2f}" for r in ranges]
    assert f"{printed[0]} (v_imp = 0.1), {printed[1]} (1e-2), {printed[2]} (1e-3)" in cell
    changes = record("reproduction/measurements.json")["comparisons"]["fig2_vs_fig1"]
    text = ", ".join(
        f"{changes[f'v_imp={v}']['relative_profile_change']:.2f} (v_imp = {v})" for v in ("0.1", "0.01", "0.001")
    )
    assert text in cell


def test_claims_single_impurities_row_is_its_record():
    cell, _ = claims_row("single impurities")
    comparisons = record("reproduction/measurements.json")["comparisons"]
    by_threshold = {
        group: next(v for k, v in comparisons.items() if k.startswith(f"{group}_echo_by_threshold"))
        for group in ("fig7_8_single", "fig5_single")
    }
    column = by_threshold["fig7_8_single"]  # [sign, arrival, amplitude, peak sign] per threshold
    echoes = [
        f"{column[f'light/{r}']['0.1'][2]:.4f} vs {column[f'heavy/{r}']['0.1'][2]:.4f} ({r})"
        for r in ("harmonic", "own")
    ]
    assert "echo " + ", ".join(echoes) in cell
    chain = by_threshold["fig5_single"]
    earlier, larger = [], []
    for rule in ("harmonic", "own"):
        light, heavy = chain[f"light/{rule}"], chain[f"heavy/{rule}"]
        earlier += [light[f][1] - heavy[f][1] for f in light]
        larger += [100 * (light[f][2] / heavy[f][2] - 1) for f in light]
    low, high = _range(cell, "toward the surface, heavy ", " t.u. earlier")
    assert agrees(low, min(earlier)) and agrees(high, max(earlier))
    assert f"light {min(larger):.0f}–{max(larger):.0f} % larger" in cell


def test_claims_fig5_caption_rows_are_their_record():
    profiles = measured("fig5")["profiles"]
    rules = ("harmonic", "own")
    cell, _ = claims_row("Fig. 5 caption (a)")
    light = [profiles[r]["reflected_tail"]["light"]["r_squared"] for r in rules]
    heavy = [profiles[r]["reflected_tail"]["heavy"]["r_squared"] for r in rules]
    assert f"R² = {light[0]:.2f} (harmonic) / {light[1]:.2f} (own) for light, {min(heavy):.2f}–{max(heavy):.2f}" in cell
    rows = [cells for cells in table_rows("reproduction.md", "| claim (section)") if cells[0] == "Fig. 5 caption (b)"]
    structure, compression = rows[0][2], rows[1][2]
    shifts = [profiles[r]["shift_grains"] for r in rules]
    aligned = [100 * profiles[r]["profile_difference_after_shift"] for r in rules]
    assert f"different arrival ({min(shifts)}–{max(shifts)} grains)" in structure
    assert f"tail ({min(aligned):.0f}–{max(aligned):.0f} % after aligning the fronts)" in structure
    block = {k: [1e4 * profiles[r]["block_dynamic_overlap_max"][k] for r in rules] for k in ("heavy", "clean", "light")}
    printed = {
        k: f"{min(v):.1f}–{max(v):.1f}e-4" if f"{min(v):.1f}" != f"{max(v):.1f}" else f"{v[0]:.1f}e-4"
        for k, v in block.items()
    }
    assert f"heavy {printed['heavy']}, clean {printed['clean']}, light {printed['light']}" in compression


def test_claims_finite_g_and_nesterenko_rows_are_their_records():
    cell, _ = claims_row("finite g")
    runs = record("reproduction/finite_g.json")["runs"][0]["measurements"]
    contrast = {
        (g, grain): [runs[f"g={g}"][f"grain {grain}"]["light_heavy_contrast"][r] for r in ("harmonic", "own")]
        for g in (0, 1)
        for grain in (0, 100, 250)
    }
    deep0 = contrast[(0, 100)] + contrast[(0, 250)]
    deep1 = contrast[(1, 100)] + contrast[(1, 250)]
    assert f"contrast {min(deep0):.2f} (g = 0) against {min(deep1):.2f}–{max(deep1):.2f} (g = 1)" in cell
    assert f"{max(deep0):.2f}" == f"{min(deep0):.2f}"  # one value printed for g = 0
    surface0, surface1 = contrast[(0, 0)], contrast[(1, 0)]
    assert (
        f"{min(surface0):.2f}–{max(surface0):.2f} against {min(surface1):.2f}–{max(surface1):.2f} at the surface"
        in cell
    )
    cell, verdict = claims_row("Nesterenko's soliton")
    values = record("reproduction/daggers_cpu.json")["items"]["nesterenko"]["values"]
    rows = values["dt=0.000125"]["rows"].values()
    ratio = [r["speed_over_nesterenko"] for r in rows]
    width = [r["fwhm_grains"] for r in rows]
    assert f"speed = {min(ratio):.4f} × (2a/m)^(2/5) v_m^(1/5)" in cell and f"{max(ratio):.4f}" == f"{min(ratio):.4f}"
    assert f"FWHM {min(width):.2f} grains vs {values['nesterenko_fwhm']:.2f}" in cell
    assert f"to {100 * (1 - min(ratio)):.1f} % on the prefactor" in verdict


def test_claims_echo_sign_row_is_its_record():
    """The first lobe's share of the largest, and the thresholds up to which the leading sign is the predicted one
    (light +, heavy −) in every case, with five impurities and with one."""
    cell, _ = claims_row("echo sign")
    five = [measured(g)["echo"] for g in ("fig7_8", "fig7_8_slow")]
    lobes = {
        grain: [h for echo in five for _, h in echo[f"grain {grain}"]["first_lobe (sign, height / largest)"].values()]
        for grain in (0, 100, 250)
    }
    every = [h for hs in lobes.values() for h in hs]
    deep = lobes[100] + lobes[250]
    assert f"the first lobe is {100 * min(every):.0f}–{100 * max(every):.0f} % (five; " in cell
    assert (
        f"{100 * min(lobes[0]):.0f}–{100 * max(lobes[0]):.0f} % at the surface, {100 * min(deep):.0f}–{100 * max(deep):.0f} % at grains 100 and 250)"
        in cell
    )
    comparisons = record("reproduction/measurements.json")["comparisons"]
    single = [h for _, h in comparisons["fig7_8_single_first_lobe (sign, height / largest)"].values()]
    assert f"and {100 * min(single):.0f}–{100 * max(single):.0f} % (single)" in cell

    def agreeing(signs: dict) -> float:
        """The largest threshold up to which every case reads the predicted sign."""
        thresholds = sorted({float(f) for case in signs.values() for f in case})
        good = [
            t
            for t in thresholds
            if all(
                (1 if k.startswith("light") else -1) == case[str(t) if str(t) in case else f"{t:g}"]
                for k, case in signs.items()
            )
        ]
        last = 0.0
        for t in thresholds:
            if t not in good:
                break
            last = t
        return last

    five_signs = {
        f"{k}@{g}{grain}": v
        for g, echo in enumerate(five)
        for grain in (0, 100, 250)
        for k, v in echo[f"grain {grain}"]["leading_sign_by_threshold"].items()
    }
    table = comparisons["fig7_8_single_echo_by_threshold (sign, arrival, amplitude, peak sign)"]
    single_signs = {k: {f: row[0] for f, row in v.items()} for k, v in table.items()}
    assert f"agrees for thresholds 5–{100 * agreeing(single_signs):.0f} % everywhere" in cell
    assert f"and up to {100 * agreeing(five_signs):.0f} % with five impurities" in cell


def test_claims_standing_waves_row_is_its_records():
    """The H100 run's shape correlations over 12 000–84 000 steps, and the H200 lag run's correlations after 4 000
    steps (averaged against instantaneous), after 800 steps (τ = 1), and how far dt/2 moves them."""
    import numpy as np

    cell, _ = claims_row("standing waves")
    run = record("reproduction/fig9_10_h100.json")["runs"][0]
    windows = {tau: [w for w in sw if "correlation" in w] for tau, sw in zip(run["taus"], run["standing_wave"])}
    later = [c for w in windows[10.0] for c in w["correlation"][1:]]
    assert f"≤ {max(later):.2f} (τ = 10)" in cell
    first, last = max((w["correlation"][1], w["correlation"][-1]) for w in windows[1.0])
    assert f"{first:.2f} → {last:.2f} (τ = 1)" in cell
    runs = {r["name"]: r for r in record("reproduction/sec6_lag_h200.json")["runs"]}
    lag, half = runs["sec6_lag"], runs["sec6_lag_dt_check"]
    steps = np.array(lag["lag_steps_at_paper_dt"])
    at = {k: np.array(v)[..., list(steps).index(4000)] for k, v in lag["correlation"].items()}
    averaged = np.concatenate([at["averaged_v"].ravel(), at["averaged_ke"].ravel()])
    instantaneous = np.concatenate([at["instantaneous_v"][0], at["instantaneous_ke"][0]])
    assert f"correlate at {averaged.min():.2f}–{averaged.max():.2f} after 4 000 steps" in cell
    assert f"at {instantaneous.min():.2f}–{instantaneous.max():.2f} (τ = 10)" in cell
    late = steps >= 800
    tau1 = [
        max(np.array(r["correlation"][k])[1][:, late].max() for k in ("instantaneous_v", "instantaneous_ke"))
        for r in (lag, half)
    ]
    assert f"at most {tau1[0]:.2f} from 800 steps on ({tau1[1]:.2f} at dt/2; τ = 1)" in cell
    moved = max(
        np.abs(np.array(lag["correlation"][k]) - np.array(half["correlation"][k])).max() for k in lag["correlation"]
    )
    assert f"dt/2 agrees to ≤ {moved:.2f}" in cell


def test_claims_three_decades_row_is_its_records():
    import numpy as np

    cell, verdict = claims_row("three decades in time")
    runs = {(r["drive_period"], r["A"]): r for r in record("drive/fig9_10_settle.json")["runs"]}
    parts = [runs[(tau, 2.0)]["half_dt"]["trajectories_part_at"] for tau in (10.0, 1.0)]
    assert f"dt and dt/2 part at t = {parts[0]:g} / {parts[1]:g}" in cell
    windows = runs[(10.0, 2.0)]["windows"]
    assert f"correlate at {np.nanmedian(windows['ke_correlation_next']):.2f} (τ = 10)" in cell
    assert f"nodes drift {np.nanmedian(windows['node_drift']):.0f} grains a period" in cell
    at_dt = {(p["tau"], p["A"]): p for p in record("reproduction/sec6_standing_full_cpu.json")["points"]}
    at_half = {(p["tau"], p["A"]): p for p in record("reproduction/sec6_standing_full_half_cpu.json")["points"]}
    for tau, a in ((10.0, 2.0), (10.0, 0.2), (10.0, 0.02), (1.0, 2.0), (1.0, 0.2), (1.0, 0.02)):
        text = f"A = {a:g}: {at_dt[(tau, a)]['fraction']:.2f} / {at_half[(tau, a)]['fraction']:.2f}"
        assert text in verdict, text
    bands = [at_dt[(10.0, a)]["null_band"] for a in (2.0, 0.2)]
    assert f"band ({min(b[0] for b in bands):.2f}–{max(b[1] for b in bands):.2f})" in verdict
    shares = {key: 100 * p["ke_share_drive"] for key, p in at_dt.items()}
    assert f"with {shares[(10.0, 2.0)]:.0f} % and {shares[(10.0, 0.2)]:.0f} % of the kinetic energy at ω" in verdict
    assert f"{shares[(10.0, 0.02)]:.0f} % at ω" in verdict and f"{shares[(1.0, 0.02)]:.0f} % at ω" in verdict
    low, high = sorted((shares[(1.0, 2.0)], shares[(1.0, 0.2)]))
    assert f"with {low:.0f}–{high:.0f} % of the kinetic energy at ω" in verdict
    assert all(at_dt[k]["verdict"] == at_half[k]["verdict"] for k in at_dt)  # "Every verdict survives dt/2"


def test_claims_time_step_row_is_its_record():
    cell, verdict = claims_row("time step")
    items = record("reproduction/daggers_cpu.json")["items"]
    velocities = [items["fig4"]["values"]["dt_check"]["max_abs_dv_over_max_abs_v"]]
    velocities += items["fig7_8_dt"]["values"]["max_abs_dv_over_max_abs_v (snapshots, per chain)"]
    assert max(velocities) <= float(cell.split("agree to ≤ ")[1].split(" ")[0])
    energy = items["drive_tau1_energy"]["values"]
    for dt in ("1.25e-4", "1.25e-5"):
        key = "dt=0.000125 step" if dt == "1.25e-4" else "dt=1.25e-05 auto"
        balance = energy[key]["energy_balance_between_records"]
        numbers = [*balance["change_percentiles (50, 90, 99 %)"], balance["largest_jump"]["relative"]]
        where = "(median / 90 % / 99 % / largest) at dt = 1.25e-4" if dt == "1.25e-4" else "at 1.25e-5"
        assert " / ".join(f"{v:.1e}".replace("e-0", "e-") for v in numbers) + f" {where}" in cell
    coarse, fine = (energy[k]["energy_error_max"] for k in ("dt=0.000125 step", "dt=1.25e-05 auto"))
    assert f"reaches {coarse:.1e} against {fine:.1e}".replace("e-0", "e-") in cell
    jumps = [
        energy[k]["energy_balance_between_records"]["largest_jump"]["relative"] for k in energy if k.startswith("dt=")
    ]
    assert max(jumps) < 1e-6 and "No change between records reaches 1e-6 at either step" in verdict
    assert f"total error is about {10 * round(coarse / fine / 10)} times the smaller step's" in verdict
    ratios = [
        a / b
        for a, b in zip(
            *(
                [
                    *energy[k]["energy_balance_between_records"]["change_percentiles (50, 90, 99 %)"],
                    energy[k]["energy_balance_between_records"]["largest_jump"]["relative"],
                ]
                for k in ("dt=0.000125 step", "dt=1.25e-05 auto")
            )
        )
    ]
    assert f"{10 * round(min(ratios) / 10)}–{10 * round(max(ratios) / 10)} times less accurate per record" in verdict


def test_every_docs_table_row_has_its_headers_cells():
    """A '|' inside a cell splits it: every row of every table in docs/ has as many cells as its header."""
    bad = []
    for doc in sorted(DOCS.glob("*.md")):
        width = None
        for number, line in enumerate(doc.read_text().splitlines(), 1):
            if not line.startswith("|"):
                width = None
                continue
            cells = len(line.replace("\\|", "").strip().strip("|").split("|"))
            if width is None:
                width = cells
            elif cells != width:
                bad.append(f"{doc.name}:{number}")
    assert not bad, bad


def test_lattice_study_table_is_its_record():
    """docs/lattices.md §5: every cell of the equilibration-time table is the record's number as printed."""
    rows = table_after("lattices.md", "## 5. Study")
    study = record("lattices/fput_equilibration_cpu.json")
    points = study["points"]
    assert [float(c) for c in rows["ε"]] == [p["density"] for p in points]
    columns = {"mean T_eq": "mean", "standard error": "standard_error", "5 %": "q05", "median": "q50", "95 %": "q95"}
    for row, key in columns.items():
        for cell, point in zip(rows[row], points, strict=True):
            assert agrees(cell, point[key]), (row, cell, point[key])
    halved = {p["density"]: p for p in study["halved"]}
    for cell, point in zip(rows["mean at dt/2"], points, strict=True):
        assert agrees(cell, halved[point["density"]]["mean"]) if point["density"] in halved else cell == "—", cell
    assert all(p["realisations"] == 1000 and p["not_equilibrated"] == 0 for p in points + study["halved"])
    text = " ".join((DOCS / "lattices.md").read_text().split())  # sentences wrap
    for h in study["halved"]:
        assert f"{100 * h['same_chain_within_one_record']:.1f} %" in text
    by_density = {p["density"]: p for p in points}
    for density, digits in ((0.05, 0), (0.5, 1)):
        full, half = by_density[density], halved[density]
        pair = f"{full['mean']:.{digits}f} ± {full['standard_error']:.{digits}f} against "
        assert pair + f"{half['mean']:.{digits}f} ± {half['standard_error']:.{digits}f}" in text, pair
    assert f"median difference {halved[0.05]['same_chain_median_difference']:.0f}, two records" in text
    assert max(p["energy_error_max"] for p in points + study["halved"]) < 6e-4  # "stays below 6e-4"
    local = ", ".join(f"{x['exponent']:.2f}" for x in study["fit"]["local"]).replace("-", "−")
    assert f"the exponent runs {local} from ε = 0.02 up" in text
    weak, strong = study["fit"]["weak"], study["fit"]["strong"]
    assert f"T_eq ∝ ε^{weak['exponent']:.2f}±{weak['exponent_error']:.2f}".replace("-", "−") in text
    assert f"ε^{strong['exponent']:.2f}±{strong['exponent_error']:.2f}".replace("-", "−") in text
    assert f"took {by_density[0.02]['seconds']:.0f} s on the 2-core CPU" in text
    total = sum(p["seconds"] for p in points + study["halved"]) / 60
    assert f"the whole study, the dt/2 runs included, {total:.0f} minutes" in text

    rows = table_after("lattices.md", "| check | against | result |")
    toda, recurrence = study["validation"]["toda_soliton"], study["validation"]["fput_recurrence"]
    errors = [f"{r['max_error']:.2e} at dt = {r['dt']:g}".replace("e-0", "e-") for r in toda]
    toda_cell = rows[next(k for k in rows if k.startswith("Toda soliton"))][1]
    assert toda_cell == f"largest error {', '.join(errors)} (order 6)"
    cell = rows[next(k for k in rows if k.startswith("FPUT recurrence"))]
    first = recurrence[0]
    assert f"{first['zabusky_estimate_periods']:.1f} T_1" in cell[0]
    assert cell[1].startswith(f"{first['recurrence_periods']:.2f} T_1 at dt 0.2 and 0.1")
    assert all(f"{r['recurrence_periods']:.2f}" == f"{first['recurrence_periods']:.2f}" for r in recurrence)
    down, back = 100 * first["lowest_share"], 100 * first["returned_share"]
    below = 100 * (1 - first["recurrence_periods"] / first["zabusky_estimate_periods"])
    assert f"(mode 1 down to {down:.1f} %, back to {back:.1f} %): {below:.1f} % below" in cell[1]


def test_the_gpu_family_table_is_its_record():
    rows = table_after("fixed-costs.md", "| `--gpu-family 90 --ptx 90`")
    parts = record("bench/cpu_auto_rule.json")
    for label, part in (
        ("the README scene's features (`prebuild impact`)", "gpu_family"),
        ("the whole default family", "gpu_family_whole"),
    ):
        modules, binaries, disk, wheel, build = rows[label]
        report = parts[part]["report"]
        assert modules.split()[0] == str(report["modules"]) and binaries == str(report["binaries"])
        assert agrees(disk.removesuffix(" MB"), report["bytes"] / 1e6) and agrees(
            build.removesuffix(" s"), report["seconds"]
        )
        assert (
            wheel == "–"
            if part == "gpu_family"
            else agrees(wheel.removesuffix(" MB"), parts[part]["wheel_bytes"] / 1e6)
        )


def test_the_modules_per_job_table_is_its_record():
    rows = table_after("fixed-costs.md", "How many modules each shipped job loads on the CPU")
    counts = record("bench/cpu_auto_rule.json")["family_counts"]
    listed = {job.strip("`"): int(n) for n, (jobs,) in rows.items() for job in jobs.split(", ") if job.startswith("`")}
    assert listed == counts["jobs"]
    assert rows[str(counts["default_family"])] == ["all of them together: the default family"]


def test_the_modules_per_job_record_covers_every_shipped_job():
    from hertzian.core.scene import read_toml
    from hertzian.core.shipped import shipped_file, shipped_names

    shipped = [n for n in shipped_names() if not {"design", "study"} & set(read_toml(shipped_file(n)))]
    jobs = record("bench/cpu_auto_rule.json")["family_counts"]["jobs"]
    assert sorted(jobs) == sorted([*shipped, "reproduce", "reproduce --quick"])


def test_the_cpu_readme_rows_of_the_benchmarks_are_their_record():
    """docs/benchmarks.md's README rows on the CPU: cold and warm ranges over the record's pairs."""
    rows = table_after("benchmarks.md", "| workload | device, date |")
    parts = record("bench/cpu_auto_rule.json")
    labels = {
        "readme": "README first command, `hertzian run --out impact.zarr --device cpu`, process wall, empty kernel "
        "cache / warm (3 pairs)",
        "readme_installed": "the same after `pip install .`, which compiled the default family into the package "
        "(3 pairs)",
    }
    for part, label in labels.items():
        _, cold, warm, _, _ = rows[label]
        for cell, key in ((cold, "cold_s"), (warm, "warm_s")):
            low, high = cell.removesuffix(" s").split("–")
            values = [pair[key] for pair in parts[part]["pairs"]]
            assert agrees(low, min(values)) and agrees(high, max(values)), (part, key, cell)
    rate = rows[labels["readme"]][
        3
    ]  # the warm runs' integration phase: 1000 grains × 2·10⁵ steps of the built-in example
    phases = [pair["warm_timeline"]["phases"] for pair in parts["readme"]["pairs"]]
    rates = [1000 * 200_000 / (p["integrated"] - p["kernels_loaded"]) / 1e8 for p in phases]
    assert rate == f"{min(rates):.1f}–{max(rates):.1f}e8 GS/s integrating", (rate, rates)
    spans = [p["integrated"] - p["kernels_loaded"] for p in phases]
    text = " ".join((DOCS / "benchmarks.md").read_text().split())
    assert (
        f"integrates in {min(spans):.2f}–{max(spans):.2f} s on the 2-core CPU ({min(rates):.1f}–{max(rates):.1f}e8 "
        "grain-steps/s; the warm runs of `readme`" in text
    )


def test_the_float32_table_is_its_record():
    """docs/stability.md §2b: every cell against accuracy/float32.json → paper (2 significant digits, seconds to
    0.01), and the reference step the text names."""
    part = record("accuracy/float32.json")["parts"]["paper"]
    runs = {(r["method"], r["dt"], r["precision"]): r for r in part["records"]}
    table = table_rows("stability.md", "**The paper's scene** to t = 20")
    assert len(table) == 1 + 8
    for method, dt, e64, e32, position, seconds in table[1:]:
        dt = float(dt.split()[0])
        f64, f32 = runs[(method, dt, "float64")], runs[(method, dt, "float32")]
        for cell, value in (
            (e64, f64["energy_error"]),
            (e32.strip("*"), f32["energy_error"]),
            (position, f32["error"]),
        ):
            assert float(cell) == float(f"{value:.1e}"), (method, dt, cell, value)
        assert seconds == f"{f64['seconds']:.2f} / {f32['seconds']:.2f}", (method, dt, seconds)
    assert part["reference"]["dt"] == 3.125e-6 and "dt = 3.125e-6" in (DOCS / "stability.md").read_text()


def test_the_time_to_target_table_is_its_record():
    """docs/stability.md §7: each row against accuracy/frontier.json → target_paper's targets, every target row
    of the record shown."""
    part = record("accuracy/frontier.json")["parts"]["target_paper"]
    targets = {(t["target"], t["method"], t["precision"]): t for t in part["targets"]}
    table = table_rows("stability.md", "The paper's 1000-grain impact to t = 20")
    assert len(table) - 1 == len(targets) == 8
    for target, method, precision, dt, energy_error, seconds in table[1:]:
        found = targets[(float(target), method, precision)]
        if dt.startswith("none"):
            assert found["dt"] is None and energy_error == seconds == "", (target, method, precision)
            continue
        assert float(dt) == found["dt"], (target, method, precision)
        assert float(energy_error) == float(f"{found['energy_error']:.1e}"), (target, method, precision)
        assert seconds == f"{found['seconds']:.2f}", (target, method, precision)


def test_the_step_size_table_on_the_sweeps_speeds_is_its_record():
    """docs/stability.md §7c: each configuration's energy error at v_imp = 1e-2 and its largest over the 9 sweep
    speeds, against the spread_* parts of accuracy/frontier.json (one ensemble per configuration)."""
    parts = record("accuracy/frontier.json")["parts"]
    rows = {}
    for name in ("spread_gear4_off", "spread_gear4_events", "spread_gear6_events"):
        values = parts[name]["values"]
        assert len(values) == 10 and values[0] == 0.01 and min(values[1:]) == 0.0099 and max(values) == 0.0101
        for row in parts[name]["rows"]:
            assert set(row["status"]) == {0}
            rows[(row["method"], row["events"], row["dt"])] = (row["energy_errors"][0], max(row["energy_errors"][1:]))
    table = table_rows("stability.md", "**Step sizes** (2-core CPU")
    assert len(table) == 1 + 6
    for configuration, at_example, largest, meets in table[1:]:
        method, events, dt = configuration.split(", ")
        at, most = rows[(method, events, float(dt))]
        assert float(at_example) == float(f"{at:.1e}") and float(largest) == float(f"{most:.1e}"), configuration
        assert meets.strip("*").startswith("yes" if most <= 1e-8 else "no"), configuration


def test_the_composed_methods_table_is_its_record():
    """docs/stability.md §2c: each method's largest step meeting each target and that run's seconds, against
    accuracy/composed.json → example and smooth; and the smooth chain's yoshida4 slope the text quotes."""
    import numpy as np

    parts = record("accuracy/composed.json")["parts"]
    table = table_rows("stability.md", "| scene | target | gear4 (events auto) | verlet | yoshida4 |")
    assert len(table) == 1 + 4
    for scene, target, *cells in table[1:]:
        part = parts["example" if scene.startswith("built-in example") else "smooth"]
        found = {t["method"]: t for t in part["targets"] if t["target"] == float(target) and t["events"] == "auto"}
        for method, cell in zip(("gear4", "verlet", "yoshida4"), cells, strict=True):
            best = found[method]
            if cell.startswith("none"):
                smallest = min(r["dt"] for r in part["records"])
                assert best["dt"] is None and float(cell.removeprefix("none (≥ ").rstrip(")")) == smallest, cell
                continue
            dt, seconds = cell.strip("*").removesuffix(" s").split(": ")
            assert (float(dt), seconds) == (best["dt"], f"{best['seconds']:.2f}"), (scene, target, method, cell)
    runs = [r for r in parts["smooth"]["records"] if r["method"] == "yoshida4"]
    slope = np.polyfit(np.log([r["dt"] for r in runs]), np.log([r["error"] for r in runs]), 1)[0]
    assert f"position error has slope {slope:.2f} in dt" in (DOCS / "stability.md").read_text()


def test_the_event_steps_table_is_its_record():
    """docs/stability.md §6b: every error (and its reference-limited mark) against accuracy/events.json, and the
    20-grain slopes the text quotes (least squares over the three steps)."""
    import numpy as np

    parts = record("accuracy/events.json")["parts"]
    table = table_rows("stability.md", "| scene | events | dt = 4e-4 | 2e-4 | 1e-4 | 5e-5 |")
    assert len(table) == 1 + 7
    names = {"wall": "wall", "wall, `--set boundary.surface=load` (no wall)": "wall_load"}
    names |= {"l0_zero, duration 8": "l0_zero", "l0_zero, duration 2": "l0_zero_duration2"}
    for scene, events, *cells in table[1:]:
        part = parts[names.get(scene, names.get(scene.split(" (")[0]))]
        runs = {r["dt"]: r for r in part["records"] if r["events"] == events}
        for dt, cell in zip((4e-4, 2e-4, 1e-4, 5e-5), cells, strict=True):
            run = runs[dt]
            assert float(cell.rstrip("*\\")) == float(f"{run['error']:.1e}"), (scene, events, dt, cell)
            assert cell.endswith("\\*") == run["reference_limited"], (scene, events, dt, cell)
    text = " ".join((DOCS / "stability.md").read_text().split())
    slopes = {}
    for events in ("auto", "off"):
        for method in ("gear4", "gear5", "gear6"):
            runs = [r for r in parts["l0_zero_20grains"]["records"] if (r["method"], r["events"]) == (method, events)]
            slopes[(method, events)] = np.polyfit(
                np.log([r["dt"] for r in runs]), np.log([r["error"] for r in runs]), 1
            )[0]
    on, off = ([f"{slopes[(m, e)]:.2f}" for m in ("gear4", "gear5", "gear6")] for e in ("auto", "off"))
    assert (
        f"slopes are {on[0]} (gear4), {on[1]} (gear5) and {on[2]} (gear6) against {off[0]}, {off[1]} and {off[2]}"
        in text
    )


def test_the_cpu_benchmark_rows_are_their_record():
    """docs/benchmarks.md's CPU rows against bench/cpu.json: the kernel table's rates and ratio to JAX, and each
    end-to-end scene's range of seconds over the rounds, its range of rate against the impact's, its median rate."""
    import statistics

    parts = record("bench/cpu.json")["parts"]
    kernels = {(r["implementation"], r["chains"]): r for r in parts["kernels"]["runs"][0]["records"]}
    lines = (DOCS / "benchmarks.md").read_text().splitlines()
    for chains in (64, 1):
        (line,) = [line for line in lines if line.startswith(f"| {chains} × 1000 | CPU")]
        cells = [c.strip() for c in line.strip("|").split("|")]
        chain, jax = kernels[("warp-chain", chains)], kernels[("jax", chains)]
        assert float(cells[3]) == float(f"{chain['grain_steps_per_second']:.2e}"), cells
        assert float(cells[4]) == float(f"{chain['steps_per_second']:.2e}"), cells
        assert float(cells[6]) == float(f"{jax['grain_steps_per_second']:.2e}"), cells
        assert cells[7] == f"{chain['grain_steps_per_second'] / jax['grain_steps_per_second']:.2f}×", cells
    rounds: dict[str, list[dict]] = {}
    for run in parts["endtoend"]["runs"]:
        (found,) = run["records"]
        rounds.setdefault(found["workload"], []).append(found)
    impact = [r["seconds"]["total"] for r in rounds["docs/scenes/impact_1000.toml"]]
    for workload, runs in rounds.items():
        (line,) = [line for line in lines if line.startswith(f"| `{workload}`, 2·10⁵ steps | CPU")]
        cells = [c.strip() for c in line.strip("|").split("|")]
        seconds = [r["seconds"]["total"] for r in runs]
        assert len(runs) == 3 and cells[3].startswith(f"{min(seconds):.2f}–{max(seconds):.2f} s"), cells
        if workload != "docs/scenes/impact_1000.toml":
            ratios = [a / b for a, b in zip(impact, seconds, strict=True)]
            assert f"({min(ratios):.2f}–{max(ratios):.2f}" in cells[3], cells
        rate = statistics.median(r["grain_steps_per_second"] for r in runs)
        assert float(cells[4].removesuffix(" GS/s")) == float(f"{rate:.1e}"), cells


def test_the_readme_quotes_the_quick_reproductions_record():
    found = record("reproduction/reproduce_quick_cpu.json")
    assert found["command"] == "hertzian reproduce --quick --device cpu" and found["figure_failures"] == 0
    readme = " ".join((DOCS.parent / "README.md").read_text().split())
    assert f"small on a CPU ({found['total_seconds']:.0f} s on 2 cores, {found['date'][:10]}, record" in readme
    text = (DOCS / "reproduction.md").read_text()
    assert (
        f"--out-dir quick              # all groups small, on a CPU, {found['total_seconds']:.0f} s on 2 cores" in text
    )


def accuracy_text() -> str:
    """docs/accuracy.md with its line breaks read as spaces (its sentences wrap)."""
    return " ".join((DOCS / "accuracy.md").read_text().split())


def estimate_counts(row: dict) -> dict:
    """An event setting's per-point estimate against true error, counted as accuracy.md counts it."""
    import numpy as np

    ratio = np.array(row["estimate"]) / np.array(row["true_error"])
    within = (ratio >= 1 / 3) & (ratio <= 3)
    marked = np.array(row["uncertain"], dtype=bool)
    logs = np.sort(np.log(ratio[marked]))
    best = max((int(np.sum((logs >= x) & (logs <= x + np.log(9)))) for x in logs), default=0)
    return {
        "points": len(ratio),
        "within": int(within.sum()),
        "marked": int(marked.sum()),
        "marked_within": int(within[marked].sum()),
        "unmarked": int((~marked).sum()),
        "unmarked_within": int(within[~marked].sum()),
        "span": float(np.exp(logs[-1] - logs[0])) if len(logs) else None,
        "best_divisor": best,  # the most marked points any one divisor puts within 3× (a window of 9× in ratio)
    }


def test_the_estimate_tables_and_sentences_are_their_records():
    """accuracy.md's check of the estimate: the events table (CPU), the second sweep, the best single divisor and
    the GPU sentence, each counted from the records' per-point estimate and true error."""
    text = accuracy_text()
    check, wide = record("accuracy/estimate_check_cpu.json"), record("accuracy/estimate_wide_cpu.json")
    rows = table_after("accuracy.md", "| events | within 3× |")
    for setting in ("auto", "off"):
        row, counts = check["events"][setting], estimate_counts(check["events"][setting])
        cells = rows[setting]
        assert cells[0] == f"{counts['within']}/{counts['points']} ({100 * counts['within'] / counts['points']:.0f} %)"
        assert cells[1] == f"{100 * row['fraction_within_where_contacts_open']:.0f} %"
        assert cells[2] == f"{100 * row['fraction_within_where_none_open']:.0f} %"
        assert cells[3] == str(counts["marked"]) == str(row["uncertain_points"])
        low, high = row["ratio_range"]
        assert cells[5] == f"{low:.2f} … {high:.2f}" if high < 2 else cells[5] == f"{low:.2f} … {high:.1f}"
    off = estimate_counts(check["events"]["off"])
    assert rows["off"][4] == (
        f"{off['unmarked_within']}/{off['unmarked']} ({100 * off['unmarked_within'] / off['unmarked']:.0f} %) / "
        f"{off['marked_within']}/{off['marked']} ({100 * off['marked_within'] / off['marked']:.0f} %)"
    )
    assert f"{sum(check['can_open'])} points where a contact can open" in text
    assert f"{sum(wide['can_open'])} points where a contact can open" in text

    auto, wide_off = wide["events"]["auto"], estimate_counts(wide["events"]["off"])
    assert estimate_counts(auto)["within"] == 64
    low, high = auto["ratio_range"]
    assert (
        f"takes {wide['reference_seconds']:.1f} s of it): events auto 64/64 (100 %) within 3×, ratio {low:.2f} … {high:.2f}"
        in text
    )
    sentence = (
        f"events off {wide_off['within']}/64 ({100 * wide_off['within'] / 64:.0f} %) within 3×, {wide_off['marked']} "
        f"marked, {wide_off['marked_within']}/{wide_off['marked']} "
        f"({100 * wide_off['marked_within'] / wide_off['marked']:.0f} %) of them within 3×, "
        f"{wide_off['unmarked_within']}/{wide_off['unmarked']} unmarked within 3×, ratio "
        f"{wide['events']['off']['ratio_range'][0]:.2f} … {wide['events']['off']['ratio_range'][1]:.1f}"
    )
    assert sentence in text, sentence

    sentence = (
        f"spans a factor {off['span']:.0f} on the check and {wide_off['span']:.0f} on the second sweep, so even the "
        f"best single divisor chosen with the true errors in hand puts {off['best_divisor']}/{off['marked']} (check) "
        f"and {wide_off['best_divisor']}/{wide_off['marked']} (second sweep) of those points within 3× "
        f"({100 * (off['best_divisor'] + off['unmarked_within']) / 64:.0f} % and "
        f"{100 * (wide_off['best_divisor'] + wide_off['unmarked_within']) / 64:.0f} % overall"
    )
    assert sentence in text, sentence
    assert f"(over a factor {off['span']:.0f} on the check below)" in text

    gpu = record("accuracy/estimate_check_h200.json")["events"]
    g_auto, g_off = estimate_counts(gpu["auto"]), estimate_counts(gpu["off"])
    sentence = (
        f"events auto {g_auto['within']}/64 ({100 * g_auto['within'] / 64:.0f} %) within 3×, ratio "
        f"{gpu['auto']['ratio_range'][0]:.2f} … {gpu['auto']['ratio_range'][1]:.2f}; events off {g_off['within']}/64 "
        f"({100 * g_off['within'] / 64:.0f} %), {g_off['marked']} marked, {g_off['unmarked_within']}/"
        f"{g_off['unmarked']} unmarked within 3×, ratio {gpu['off']['ratio_range'][0]:.2f} … "
        f"{gpu['off']['ratio_range'][1]:.1f}"
    )
    assert sentence in text, sentence


def test_the_estimate_cost_tables_are_their_records():
    """accuracy.md's cost of the estimate: the CPU and GPU case, and every feature on both kernels (medians)."""
    import statistics

    rows = table_after("accuracy.md", "| device | case | without | with | ratio |")
    for label, name in (("CPU, 2 cores, quiet", "estimate_check_cpu.json"), ("H200", "estimate_check_h200.json")):
        cost = record(f"accuracy/{name}")["cost"]
        case, without, with_, ratio = rows[label]
        steps = f"{cost['steps']:,}".replace(",", " ")
        assert case.startswith(f"{cost['chains']} chains × {cost['grains']} grains, {steps} steps")
        assert agrees(without.removesuffix(" s"), statistics.median(cost["seconds_without"]))
        assert agrees(with_.removesuffix(" s"), statistics.median(cost["seconds_with"]))
        assert agrees(ratio.strip("*").removesuffix("×"), cost["ratio"])
    features = {(f["case"], f["kernel_asked"]): f for f in record("accuracy/estimate_check_cpu.json")["cost_features"]}
    rows = table_after("accuracy.md", "| case | chain kernel | ratio | per-step kernel | ratio |")
    cases = {
        "walls at both ends (the cost case)": "walls",
        "gravity, three light impurities": "gravity, impurities",
        "driven surface": "drive",
        "viscous damping": "viscous damping",
        "contact (dashpot) damping": "contact damping",
    }
    assert set(rows) == set(cases)
    for label, case in cases.items():
        cells = rows[label]
        for k, kernel in enumerate(("chain", "step")):
            row = features[(case, kernel)]
            without, with_ = cells[2 * k].removesuffix(" s").split(" / ")
            assert agrees(without, statistics.median(row["seconds_without"])), (label, kernel)
            assert agrees(with_, statistics.median(row["seconds_with"])), (label, kernel)
            assert agrees(cells[2 * k + 1].removesuffix("×"), row["ratio"]), (label, kernel)


def test_the_defaults_table_is_its_records():
    """accuracy.md's cheapest run per target and event setting, on both devices, is each record's choice."""
    rows = table_rows("accuracy.md", "| device | scene | target | events auto | events off |")[1:]
    records = {"CPU": record("accuracy/defaults_cpu.json"), "GPU": record("accuracy/defaults_h200.json")}
    assert len(rows) == 2 * 3 * 3
    for device, scene, target, *cells in rows:
        cheapest = records[device]["scenes"][scene]["cheapest_per_events"][str(float(target))]
        for cell, events in zip(cells, ("auto", "off"), strict=True):
            best = cheapest[events]
            if best is None:
                assert cell == "none", (device, scene, target, events)
                continue
            method, dt, seconds = cell.removesuffix(" s").replace(",", "").split()
            assert (method, float(dt)) == (best["method"], best["dt"]), (device, scene, target, events)
            assert agrees(seconds, best["seconds"]), (device, scene, target, events, cell)


def test_the_readme_h100_table_is_its_records():
    """README's H100 rows: the kernels' rates against the JAX peer, and the end-to-end seconds (the last, warm run
    of each workload; the paper's runs on a fresh machine and twice after)."""
    lines = (DOCS.parent / "README.md").read_text().splitlines()
    start = lines.index("| what | result | record |")
    rows = {
        cells[0]: cells[1]
        for cells in (
            [c.strip() for c in line.strip("|").split("|")] for line in lines[start + 2 :] if line.startswith("|")
        )
        if cells
    }
    kernels = record("bench/h100_kernels.json")["records"]

    def rate(implementation: str, chains: int, grains: int) -> dict:
        return next(
            r for r in kernels if (r["implementation"], r["chains"], r["grains"]) == (implementation, chains, grains)
        )

    tile, jax = rate("warp-tile", 16384, 1000), rate("jax", 16384, 1000)
    speedup = tile["grain_steps_per_second"] / jax["grain_steps_per_second"]
    assert rows["16384 chains × 1000 grains, tile kernel"] == (
        f"{tile['grain_steps_per_second']:.1e} grain-steps/s, {speedup:.1f}× the JAX peer".replace("e+11", "e11")
    )
    windows = [rate("warp-window", 1, n)["steps_per_second"] for n in (1000, 10240)]
    assert {f"{w:.1e}".replace("e+06", "e6") for w in windows} == {"3.2e6"}
    assert rows["one chain of 1000 or 10 240 grains, window kernel"] == "3.2e6 steps/s"
    workloads = record("bench/h100_endtoend.json")["workloads"]
    warm = {k: workloads[k]["records"][-1] for k in ("gpu_10k", "paper_fig9_10")}
    assert not any(r["cold"] for r in warm.values())
    assert rows["`sweeps/gpu_10k.toml` end to end, warm caches"] == f"{warm['gpu_10k']['seconds']['total']:.2f} s"
    label = "the driven 10 000-grain columns of Figs. 9–10, end to end, warm"
    assert rows[label] == f"{warm['paper_fig9_10']['seconds']['total']:.2f} s"
    runs = workloads["reproduce"]["runs"]
    cold = [r["total_seconds"] for r in runs if r["first_on_fresh_machine"]]
    again = sorted(r["total_seconds"] for r in runs if not r["first_on_fresh_machine"])
    assert rows["the whole paper, `hertzian reproduce --device cuda`"] == (
        f"{again[0]:.1f} and {again[1]:.1f} s warm, {cold[0]:.0f} s on a fresh machine (mostly compiling)"
    )


def median(values) -> float:
    """The median of a record's list over its finite values (a window without a node has an infinite ratio)."""
    import numpy as np

    values = np.array([np.nan if v is None else v for v in values], dtype=float)
    return float(np.median(values[np.isfinite(values)]))


def test_the_drive_settle_table_is_its_record():
    """docs/drive.md's settling table (Figs. 9–10 to t = 5 000): each run's energy errors, strobe labels, parting
    time, driver power, and the medians over its windows (all, t ≤ 1000 at dt, and the windows both dt and dt/2
    have)."""

    def printed(windows: dict, count: int | None) -> list[str]:  # the first count windows' medians, as printed
        swr, drift, corr, driver_open = (
            median(windows[k][:count]) for k in ("swr", "node_drift", "ke_correlation_next", "driver_open")
        )
        return [f"{swr:.3g}", f"{drift:.3g}", f"{corr:.3f}", f"{driver_open:.3f}"]

    table = table_rows("drive.md", "| τ | A | energy error (dt; dt/2) |")[1:]
    runs = {(r["drive_period"], r["A"]): r for r in record("drive/fig9_10_settle.json")["runs"]}
    assert len(table) == len(runs) == 6
    for tau, a, errors, labels, part, power, swr, drift, corr, driver_open, early, early_half in table:
        run = runs[(float(tau), float(a))]
        half = run["half_dt"]
        assert errors == f"{run['energy_error']:.1e}; {half['energy_error']:.1e}", (tau, a, errors)
        assert labels == f"{run['strobe_all'].split(' (')[0]} / {run['strobe_late'].split(' (')[0]}"
        parted = half["trajectories_part_at"]
        assert part == ("never (t ≤ 1000)" if parted is None else f"{parted:g}"), (tau, a, part)
        assert power == " / ".join(f"{v:.3g}" for v in run["mean_power"].values())
        common = len(half["windows"]["window_start"])  # windows both runs have
        assert [swr, drift, corr, driver_open] == printed(run["windows"], None), (tau, a)
        assert early == ", ".join(printed(run["windows"], common)), (tau, a)
        assert early_half == ", ".join(printed(half["windows"], None)), (tau, a)


def test_the_damped_drive_table_is_its_records():
    """docs/drive.md's damped table: the damped rows from their record (window medians over the 100 windows at dt),
    the undamped rows from the settling record's A = 2 runs."""

    table = table_rows("drive.md", "| τ | A, γ | energy error (E + D − W; dt, dt/2) |")[1:]
    damped = {r["drive_period"]: r for r in record("drive/fig9_10_damped.json")["runs"]}
    undamped = {r["drive_period"]: r for r in record("drive/fig9_10_settle.json")["runs"] if r["A"] == 2.0}
    assert len(table) == 4
    for tau, a_gamma, errors, part, swr, drift, corr, driver_open, power in table:
        run = (damped if a_gamma == "2, 1e-3" else undamped)[float(tau)]
        assert a_gamma in ("2, 1e-3", "2, 0 (table above)")
        half = run["half_dt"]
        assert errors == f"{run['energy_error']:.1e}; {half['energy_error']:.1e}", (tau, a_gamma)
        assert part == f"{half['trajectories_part_at']:g}", (tau, a_gamma)
        medians = [median(run["windows"][k]) for k in ("swr", "node_drift", "ke_correlation_next", "driver_open")]
        assert [swr, drift, corr, driver_open] == [
            f"{medians[0]:.3g}",
            f"{medians[1]:.3g}",
            f"{medians[2]:.3f}",
            f"{medians[3]:.3f}",
        ]
        assert power == f"{run['mean_power']['0-1000']:.3g}", (tau, a_gamma)
    text = " ".join((DOCS / "drive.md").read_text().split())
    assert "correlation and the driver's open fraction are within 6 % of the undamped run's" in text
    for tau in (10.0, 1.0):
        for key in ("ke_correlation_next", "driver_open"):
            ratio = median(damped[tau]["windows"][key]) / median(undamped[tau]["windows"][key])
            assert abs(ratio - 1) < 0.06, (tau, key, ratio)
    drifts = [
        (median(damped[t]["windows"]["node_drift"]), median(undamped[t]["windows"]["node_drift"])) for t in (10.0, 1.0)
    ]
    assert "(7 against 10 grains a window at τ = 10, 27 against 27.5 at τ = 1)" in text
    assert drifts == [(7, 10), (27, 27.5)]


def test_the_shipped_gpu_disorder_table_is_its_record():
    """heterogeneous.md's shipped-size disorder table (200 grains, 1000 realisations per spread, H200): every mean
    ± std and 5–95 % band; a decay length beyond five chain lengths is shown in parentheses, without a band."""
    rows = table_after("heterogeneous.md", "At the shipped size on the GPU (200 grains")
    disorder = record("heterogeneous_shipped_h200.json")["disorder"]
    assert disorder["realisations"] == 1000 and [float(c) for c in rows["s"]] == disorder["spread"]
    names = {
        "bottom_fraction (snapshots)": "bottom_fraction",
        "decay_length [grains]": "decay_length",
        "bottom_peak_force": "bottom_peak_force",
        "arrival time": "arrival_time",
    }
    assert set(rows) == {"s", "decay_length 5–95 %", *names}
    for label, name in names.items():
        for k, cell in enumerate(rows[label]):
            if cell == "(≫ 200)":
                assert disorder[f"{name}_mean"][k] > 10 * 200 and k == 0
                continue
            parts = cell.strip("()").split(" ± ")
            assert agrees(parts[0], disorder[f"{name}_mean"][k]), (label, cell)
            assert len(parts) == 1 or agrees(parts[1], disorder[f"{name}_std"][k]), (label, cell)
            unresolved = name == "decay_length" and disorder["decay_length_mean"][k] > 5 * 200  # five chain lengths
            assert cell.startswith("(") == unresolved, (label, cell)
    for k, cell in enumerate(rows["decay_length 5–95 %"]):
        if cell == "—":
            assert disorder["decay_length_mean"][k] > 5 * 200, k  # not resolved
            continue
        low, high = cell.split("–")
        assert agrees(low, disorder["decay_length_q05"][k]) and agrees(high, disorder["decay_length_q95"][k]), cell


def test_the_disorder_throughput_table_is_its_record():
    """heterogeneous.md's throughput table (H200): each run's end-to-end seconds, rate, device and compile seconds,
    and the sentence that compares the random chains with their uniform twin."""
    rows = table_rows("heterogeneous.md", "| chain | cache | end to end [s] |")[1:]
    runs = record("bench/disorder_throughput_h200.json")
    keys = {("random radii", "warm"): "heterogeneous_warm", ("random radii", "empty"): "heterogeneous_cold"}
    keys[("uniform twin", "its variant not yet cached")] = "uniform_cold"
    assert len(rows) == 3
    for chain, cache, total, rate, device, compile_ in rows:
        run = runs[keys[(chain, cache)]]
        assert agrees(total, run["seconds"]["total"]) and agrees(device, run["device_seconds"]), (chain, cache)
        assert agrees(compile_, run["seconds"]["compile"]), (chain, cache)
        assert rate.strip("*") == f"{run['grain_steps_per_second']:.3g}".replace("e+11", "e11"), (chain, cache, rate)
    text = " ".join((DOCS / "heterogeneous.md").read_text().split())
    warm, twin = runs["heterogeneous_warm"], runs["uniform_cold"]
    twin_less = twin["seconds"]["total"] - twin["seconds"]["compile"]
    assert (
        f"{warm['device_seconds']:.2f} device seconds against {twin['device_seconds']:.2f} for the uniform twin "
        f"({warm['device_seconds'] / twin['device_seconds']:.2f}×), and {warm['seconds']['total']:.1f} s end to end "
        f"against {twin['seconds']['total']:.1f} − {twin['seconds']['compile']:.1f} = {twin_less:.1f} s" in text
    )
    assert f"({warm['seconds']['store']:.1f} s of writes, overlapped)" in text


def test_the_stability_limits_table_is_the_amplification_matrices():
    """stability.md's limits table, derived again from check.amplification_matrix: each method's growth per
    period at ω·dt = 0.1, 0.5, 1.0 as printed, and the limits (gear5 and gear6: where the growth reaches 10 % per
    period, found by bisection)."""
    import numpy as np
    from hertzian.core.check import amplification_matrix

    def growth(method: str, omega_dt: float) -> float:
        rho = max(abs(np.linalg.eigvals(amplification_matrix(method, omega_dt))))
        return rho ** (2 * math.pi / omega_dt) - 1

    rows = table_after("stability.md", "| method | stable for ω·dt ≤ |")
    assert set(rows) == {"verlet", "gear4", "gear5", "gear6", "yoshida4", "yoshida6"}
    for method, (limit, _, changes) in rows.items():
        for cell, omega_dt in zip(changes.split(" / "), (0.1, 0.5, 1.0), strict=True):
            value = growth(method, omega_dt)
            if cell == "0":
                assert abs(value) < 1e-12, (method, omega_dt, value)
            else:
                number = cell.split()[0].replace("−", "-")
                assert f"{value:+.2g}" == f"{float(number):+.2g}" and number[0] in "+-", (method, cell, value)
        if method in ("gear5", "gear6"):
            low, high = 0.5, 1.5
            for _ in range(60):
                middle = (low + high) / 2
                low, high = (middle, high) if growth(method, middle) < 0.1 else (low, middle)
            assert limit == f"{low:.2f}", (method, limit, low)
    assert rows["gear4"][0] == f"√2 = {math.sqrt(2):.3f}"


def test_the_h100_time_to_target_table_is_its_record():
    """stability.md §7c's H100 table: the warm (second) run of each configuration, its total and device seconds,
    and the ratios to gear6 with events that the table and its verdict quote."""
    rows = table_after("stability.md", "| configuration | total s | device s |")
    workloads = record("bench/h100_events.json")["workloads"]
    names = {
        "gear6, events auto, dt = 1e-3": "frontier_gear6_auto_1e-3_l2",
        "gear4, events auto, dt = 5e-4": "frontier_gear4_auto_5e-4_l2",
        "gear4, events off, dt = 1e-4": "frontier_gear4_off_1e-4_l2",
    }
    assert set(rows) == set(names)
    warm = {label: workloads[name][0] for label, name in names.items()}
    best = warm["gear6, events auto, dt = 1e-3"]["seconds"]["total"]
    for label, (total, device, ratio) in rows.items():
        run = warm[label]
        assert agrees(total.strip("*"), run["seconds"]["total"]) and agrees(device, run["device_seconds"]), label
        assert (
            ratio == "1"
            if run["seconds"]["total"] == best
            else ratio == f"{run['seconds']['total'] / best:.2f}× slower"
        )
    text = " ".join((DOCS / "stability.md").read_text().split())
    ratios = [warm[k]["seconds"]["total"] / best for k in list(names)[1:]]
    assert f"{ratios[0]:.2f}× faster end to end than gear4 at its own largest step" in text
    assert f"and {ratios[1]:.1f}× faster than gear4 with plain steps" in text


def test_the_gpu_cold_and_warm_table_is_its_record():
    """fixed-costs.md's cold and warm table (H200) and the README command's warm timeline under it."""
    rows = table_after("fixed-costs.md", "| workload | command | cold [s] | warm [s] | target |")
    runs = record("bench/fixed_costs_h200.json")

    def row(start: str) -> list[str]:
        return next(cells for label, cells in rows.items() if label.startswith(start))

    gpu_10k = runs["gpu_10k"]
    _, cold, warm, _ = row("gpu_10k")
    seconds = gpu_10k["cold"]["seconds"]
    assert cold == f"{seconds['total']:.2f} (compile {seconds['compile']:.2f})"
    assert warm == ", ".join(f"{r['seconds']['total']:.2f}" for r in gpu_10k["warm"])
    million = runs["million_point_sweep"]
    _, cold, warm, _ = row("million-point sweep")
    seconds = million["cold"]["seconds"]
    assert cold == f"{seconds['total']:.1f} (compile {seconds['compile']:.1f})"
    seconds = million["warm"]["seconds"]
    assert (
        warm == f"{seconds['total']:.2f} (build {seconds['build']:.2f}, device {million['warm']['device_seconds']:.2f})"
    )
    detection = runs["first_detection"]
    _, cold, warm, _ = row("first detection")
    first, again = detection["fresh_cache_kernels_prepared_up_front"], detection["warm_kernel_cache_no_library"]
    assert cold == (
        f"{first['process_seconds']:.1f} (library {first['seconds']['library']:.1f}, refinement "
        f"{first['seconds']['refinement']:.1f})"
    )
    assert warm == f"{again['process_seconds']:.1f} (library not cached; {again['seconds']['total']:.2f} s inside)"
    _, cold, warm, _ = row("paper reproduction")
    assert (
        cold == f"{runs['reproduce']['cold_total_seconds']:.1f}"
        and warm == f"{runs['reproduce']['warm_total_seconds']:.1f}"
    )
    pairs = runs["readme_first_command"]["pairs"]
    _, cold, warm, _ = row("README first command")
    assert cold == ", ".join(f"{p['cold_s']:.2f}" for p in sorted(pairs, key=lambda p: p["cold_s"]))
    assert warm == ", ".join(f"{p['warm_s']:.2f}" for p in sorted(pairs, key=lambda p: p["warm_s"]))
    threads = runs["compile_threads"]
    _, cold, _, _ = row("`hertzian warmup --paper --quick`")
    assert cold == f"{threads['1']['seconds']:.2f} (1 thread) / {threads['8']['seconds']:.2f} (8 threads)"

    text = " ".join((DOCS / "fixed-costs.md").read_text().split())
    phases = min(pairs, key=lambda p: p["warm_s"])["warm_timeline"]["phases"]
    assert (
        f"`hertzian.cli` ready {phases['cli_ready']:.2f}, scene loaded with Warp imported {phases['scene_loaded']:.2f}, "
        f"`wp.init` {phases['warp_initialised']:.2f}, CUDA context {phases['device_ready']:.2f}, model built "
        f"{phases['model_built']:.2f}, kernels loaded from the cache {phases['kernels_loaded']:.2f}, integrated "
        f"{phases['integrated']:.2f}" in text
    )
    cpu = record("bench/cpu_auto_rule.json")["readme"]
    spans = [p["warm_timeline"]["phases"] for p in cpu["pairs"]]
    spans = [p["integrated"] - p["kernels_loaded"] for p in spans]
    assert (
        f"takes {cpu['median_warm_s']:.2f} s warm on the 2-core CPU (the median of the `readme` pairs above), where "
        f"Zarr's import is hidden behind a {min(spans):.2f}–{max(spans):.2f} s integration" in text
    )


def test_the_h100_kernel_rows_are_their_record():
    """docs/benchmarks.md's H100 kernel rows: the best project kernel and its shape, its rates, the per-step kernel
    and the JAX peer, and the memory-wall sentence under the table."""
    kernels = record("bench/h100_kernels.json")["records"]
    lines = (DOCS / "benchmarks.md").read_text().splitlines()
    for chains, grains in ((16384, 1000), (16384, 4096), (1, 1000), (1, 10240)):
        (line,) = [line for line in lines if line.startswith(f"| {chains} × {grains} | H100")]
        cells = [c.strip().strip("*") for c in line.strip("|").split("|")]
        mine = [r for r in kernels if (r["chains"], r["grains"]) == (chains, grains)]
        best = max(
            (r for r in mine if r["implementation"].startswith("warp-")), key=lambda r: r["grain_steps_per_second"]
        )
        step = next(r for r in mine if r["implementation"] == "warp-step")
        jax = next(r for r in mine if r["implementation"] == "jax")
        kind, shape = best["kernel"].split(" (")
        G = shape.split()[0]
        assert cells[2].startswith(f"{kind} ({G}, ") and cells[2].endswith(f"K={shape.split('K=')[1]}"), (
            cells[2],
            best["kernel"],
        )
        assert cells[3] == f"{best['grain_steps_per_second']:.2e}".replace("e+", "e").replace("e0", "e"), cells
        assert cells[4] == f"{best['steps_per_second']:.2e}".replace("e+", "e").replace("e0", "e"), cells
        per = "steps_per_second" if chains == 1 else "grain_steps_per_second"
        unit = " steps/s" if chains == 1 else ""
        for cell, peer in ((cells[5], step), (cells[6], jax)):
            assert cell == f"{peer[per]:.2e}".replace("e+", "e").replace("e0", "e") + unit, (cell, peer[per])
        assert cells[7] == f"{best['grain_steps_per_second'] / jax['grain_steps_per_second']:.1f}×", cells
    text = " ".join((DOCS / "benchmarks.md").read_text().split())
    tile = next(r for r in kernels if (r["implementation"], r["chains"], r["grains"]) == ("warp-tile", 16384, 1000))
    steps = [r["ratio_to_memory_wall"] for r in kernels if r["implementation"] == "warp-step" and r["chains"] == 16384]
    assert f"({tile['memory_wall_grain_steps_per_second']:.2e} GS/s on the H100)".replace("e+", "e") in text
    assert f"the tile kernel runs at {tile['ratio_to_memory_wall']:.1f}× the memory wall at 16384 × 1000" in text
    assert f"the per-step kernel at {min(steps):.2f}–{max(steps):.2f} of it" in text


def test_the_four_gpu_scaling_tables_are_their_record():
    """docs/scale-out.md's strong and weak tables on 4 × H200, every cell from the record."""
    scale = record("bench/scale_out_4gpu_h200.json")
    rows = table_after("scale-out.md", "| workers | process wall [s] | speed-up |")
    strong = {("serial" if s["serial"] else str(s["workers"])): s for s in scale["strong"]}
    assert set(rows) == set(strong)
    for workers, (wall, speedup, efficiency, batches, batch_speedup, busy, bitwise) in rows.items():
        run = strong[workers]
        assert agrees(wall, run["process_seconds"]) and agrees(speedup, run["speedup"]), workers
        assert efficiency == f"{100 * run['efficiency']:.0f} %" and agrees(batches, run["seconds"]["batches"])
        assert agrees(batch_speedup, run["batch_phase_speedup"]), workers
        shown_busy = ", ".join(f"{100 * b:.0f} %" for b in run["busy"].values())
        assert busy == (f"{shown_busy} (main)" if workers == "serial" else shown_busy), (workers, busy)
        assert bitwise == ("reference" if workers == "serial" else "equal" if run["differing_arrays"] == [] else "?")
    rows = table_after("scale-out.md", "| workers | work | process wall [s] | batch phase [s] |")
    weak = scale["weak_runs"]
    names = {"serial": ("1", "W/4"), "2": ("2", "W/2"), "4": ("4", "W")}
    assert set(rows) == set(names)
    for label, (work, wall, batches, wait, efficiency) in rows.items():
        key, shown_work = names[label]
        run = weak[key]
        seconds = run["summary"]["seconds"]
        assert work == shown_work and agrees(wall, run["process_seconds"]) and agrees(batches, seconds["batches"])
        assert wait == ("—" if label == "serial" else f"{seconds['cluster_wait']:.2f}"), (label, wait)
        assert efficiency == f"{100 * run['efficiency']:.0f} %", (label, efficiency)


def test_the_two_gpu_scaling_sentence_is_its_record():
    scale = record("bench/scale_out_2gpu_h200.json")
    serial, one, two = scale["strong"]
    weak_serial, weak_two = scale["weak"]
    text = " ".join((DOCS / "scale-out.md").read_text().split())
    assert scale["bitwise_equal"] and one["differing_arrays"] == two["differing_arrays"] == []
    assert (
        f"serial {serial['process_seconds']:.2f} s (batch phase {serial['seconds']['batches']:.2f} s), `--workers 1` "
        f"{one['process_seconds']:.2f} s ({one['speedup']:.2f}×), `--workers 2` {two['process_seconds']:.2f} s "
        f"({two['speedup']:.2f}×, {100 * two['efficiency']:.0f} %; batch phase {two['seconds']['batches']:.2f} s, "
        f"{two['batch_phase_speedup']:.2f}×); weak: serial at W/2 {weak_serial['process_seconds']:.2f} s, 2 workers at "
        f"W {weak_two['process_seconds']:.2f} s ({100 * weak_two['efficiency']:.0f} %)" in text
    )


def test_the_detection_target_table_is_its_record():
    """docs/detection.md's H100 target table, counted again from the record's 416 detections."""
    import numpy as np

    study = record("detection/h100_target_1000.json")
    detections = [dict(zip(study["columns"], row)) for row in study["records"]]
    planted = [d for d in detections if d["true_class"] != "none"]
    summary = study["summary"]["g0-single"]["26.0"]
    correct = sum(d["class"] == d["true_class"] for d in detections)
    near = sum(d["depth"] is not None and abs(d["depth"] - d["true_depth"]) <= 1 for d in planted)
    exact = sum(d["depth"] == d["true_depth"] for d in planted)
    covered = sum(d["mass_ratio_lo"] <= d["true_mass_ratio"] <= d["mass_ratio_hi"] for d in planted)
    seconds = np.array([d["seconds_total"] for d in detections])
    rows = table_after("detection.md", "| 26 dB, 1000 grains, depths 50–800 |")
    assert rows[f"class correct ({len(detections)}, clean chains included)"][:2] == [
        f"**{correct} / {len(detections)}**",
        f"{100 * summary['class_accuracy_lower95']:.1f} %",
    ]
    assert rows[f"depth within ±1 grain ({len(planted)})"][:2] == [
        f"**{near} / {len(planted)}** (exact: {exact})",
        f"{100 * summary['depth_within_1_lower95']:.1f} %",
    ]
    assert rows["μ interval holds the truth"][0] == (
        f"{covered} / {len(planted)} ({100 * covered / len(planted):.0f} %; nominal 95 %: too narrow)"
    )
    text = " ".join((DOCS / "detection.md").read_text().split())
    assert f"understates the uncertainty ({100 * covered / len(planted):.0f} % coverage at 26 dB above)" in text
    assert rows["seconds per detection, cached library"][0].startswith(
        f"median {np.median(seconds):.2f} s, 95th percentile {np.percentile(seconds, 95):.2f} s, at most "
        f"{seconds.max():.1f} s"
    )


def test_the_driven_preview_energy_paragraph_is_its_record():
    """reproduction.md's energy balance of the τ = 1 driven preview (1000 grains to t = 78) at two steps: the
    percentiles of the changes between records, the largest, the errors and their ratio, the two kernels' equal
    balance, and where the largest record |v| of the two steps part."""
    import numpy as np

    items = record("reproduction/daggers_cpu.json")["items"]
    runs = items["drive_tau1_energy"]["values"]
    coarse, step, fine = runs["dt=0.000125 auto"], runs["dt=0.000125 step"], runs["dt=1.25e-05 auto"]
    text = " ".join((DOCS / "reproduction.md").read_text().split())
    changes = []
    for run in (coarse, fine):
        balance = run["energy_balance_between_records"]
        changes.append([*balance["change_percentiles (50, 90, 99 %)"], balance["largest_jump"]["relative"]])
    shown = [[f"{c:.1e}".replace("e-0", "e-") for c in row] for row in changes]
    assert (
        f"by {shown[0][0]} (median), {shown[0][1]} (90 %), {shown[0][2]} (99 %) and at most {shown[0][3]} at dt = "
        f"1.25e-4, against {shown[1][0]}, {shown[1][1]}, {shown[1][2]} and {shown[1][3]} at dt = 1.25e-5" in text
    )
    ratios = [a / b for a, b in zip(changes[0], changes[1])]
    assert f"({10 * round(min(ratios) / 10)}–{10 * round(max(ratios) / 10)} times smaller)" in text
    errors = [f"{r['energy_error_max']:.1e}".replace("e-0", "e-") for r in (coarse, fine)]
    assert f"the error reaches {errors[0]} and {errors[1]}" in text
    assert coarse["energy_error_by_record (max |W|)"] == step["energy_error_by_record (max |W|)"]
    largest = coarse["energy_balance_between_records"]["largest_jump"]
    assert all(c < 1e-6 for row in changes for c in row)
    assert (
        f"the largest is {shown[0][3]} (between t = {largest['between_t'][0]:g} and {largest['between_t'][1]:g}" in text
    )
    history = items["drive_1000_energy_history"]["values"]["tau=1"]
    assert (
        f"{history['largest_jump']['relative']:.1e} of max |W| = {history['max_abs_W']:.1e}".replace(
            "e+04", "e4"
        ).replace("e-07", "e-7")
        in text
    )
    ratio = coarse["energy_error_max"] / fine["energy_error_max"]
    assert f"error is about {10 * round(ratio / 10)} times the smaller step's ({errors[0]} against {errors[1]})" in text
    t = np.array(coarse["t"])
    v_coarse, v_fine = np.array(coarse["largest_abs_v_by_record"]), np.array(fine["largest_abs_v_by_record"])
    apart = np.abs(v_coarse - v_fine) / v_fine
    late = t >= 27.5
    worst = np.argmax(apart * late)
    assert t[np.argmax(apart > 1e-6) - 1] == 18.0
    assert (
        f"differs by up to {100 * apart[late].max():.0f} % from t = 27.5 on ({v_coarse[worst]:.1f} vs "
        f"{v_fine[worst]:.1f} at t = {t[worst]:g})" in text
    )


def test_the_both_periods_run_is_its_record():
    both = record("drive/fig9_10_both.json")
    text = " ".join((DOCS / "drive.md").read_text().split())
    h200, h100 = (both[k]["seconds"] for k in ("h200", "h100"))
    assert (
        f"its batch takes **{h200['batches']:.1f} s on an H200 and {h100['batches']:.1f} s on an H100**, of which "
        f"{h200['build']:.1f} and {h100['build']:.1f} s build it" in text
    )
    assert f"and {h200['kernel']:.1f} and {h100['kernel']:.1f} s integrate" in text


def test_the_suites_module_count_is_its_record():
    """fixed-costs.md's count of the kernel modules the test suite loads, per kernel factory, from its record."""
    part = record("bench/cpu_auto_rule.json")["suite_modules"]
    factories = part["by_factory"]
    assert sum(factories.values()) == part["modules"] and part["summary"].split()[1] == "passed"
    readme = (DOCS.parent / "README.md").read_text()
    assert f'pip install ".[test]" && {part["command"]}' in readme  # the README's own test command
    kinds = {
        "per-step": factories["step_kernel__locals__step"],
        "chain-kernel": factories["chain_kernel__locals__chain_steps"],
        "fused-kernel": factories["fused_kernel__locals__fused"],
    }
    records = sum(n for name, n in factories.items() if name.startswith("record_kernels__"))
    others = part["modules"] - sum(kinds.values()) - records
    text = " ".join((DOCS / "fixed-costs.md").read_text().split())
    assert f"The test suite loads far more: {part['modules']} modules on the CPU" in text
    assert f"the README's test command in {part['seconds']:.0f} s" in text
    assert (
        f"{kinds['per-step']} per-step, {kinds['chain-kernel']} chain-kernel and {kinds['fused-kernel']} fused-kernel "
        f"variants, {records} record reductions, and {others} other modules" in text
    )


def test_the_paper_chains_step_limits_are_the_check():
    """stability.md's step limits on the paper's chain: the contact time, where each method stops being stable
    (its ω·dt limit over the chain's highest frequency) and where it stops being accurate, from hertzian check."""
    from hertzian.api import load_scene
    from hertzian.core.check import ACCURATE_STEPS_PER_CONTACT_TIME, STABLE_OMEGA_DT, check_scene

    report = check_scene(load_scene("impact"))
    omega, contact = report.highest_frequency, report.contact_time
    stable = {m: STABLE_OMEGA_DT[m] / omega for m in ("gear4", "verlet", "gear6")}
    accurate = {m: contact / ACCURATE_STEPS_PER_CONTACT_TIME[m] for m in ("gear4", "verlet")}
    text = " ".join((DOCS / "stability.md").read_text().split())
    assert (
        f"On the paper's chain (T = {contact:.3f}): stable up to dt ≈ {stable['gear4']:.2f} (gear4), "
        f"{stable['verlet']:.3f} (verlet), {stable['gear6']:.3f} (gear6); accurate up to {accurate['gear4']:.1e} "
        f"(gear4), {accurate['verlet']:.0e} (verlet)".replace("e-04", "e-4").replace("e-05", "e-5")
        in text
    )
    steps = ACCURATE_STEPS_PER_CONTACT_TIME
    assert (
        f"T/dt ≥ {steps['gear4']:g} (gear4, gear6, yoshida4), {steps['gear5']:g} (gear5), {steps['verlet']:g} (verlet), "
        f"{steps['yoshida6']:g} (yoshida6)" in text
    )
    assert steps["gear4"] == steps["gear6"] == steps["yoshida4"]


def test_the_composed_methods_thresholds_are_their_record():
    """stability.md's accuracy thresholds of yoshida4 and yoshida6: the code's constants are the record's scan,
    and the text's worst energy errors are the record's."""
    from hertzian.core.check import ACCURATE_STEPS_PER_CONTACT_TIME

    scan = record("accuracy/composed.json")["thresholds"]["methods"]
    for method in ("yoshida4", "yoshida6"):
        assert ACCURATE_STEPS_PER_CONTACT_TIME[method] == scan[method]["threshold"], method
        passing = [float(r) for r, row in scan[method]["ratios"].items() if not row["failing"]]
        assert scan[method]["threshold"] == min(passing), method
    six = scan["yoshida6"]["ratios"]
    text = " ".join((DOCS / "stability.md").read_text().split())
    assert (
        f"(worst {six['150']['worst_energy_error']:.1e}; at 100, l0 = 0 reaches {six['100']['worst_energy_error']:.1e})".replace(
            "e-07", "e-7"
        ).replace("e-06", "e-6")
        in text
    )
    assert six["100"]["failing"][0] == "l0=0"


def test_the_accuracy_thresholds_are_their_record():
    """ACCURATE_STEPS_PER_CONTACT_TIME of the Gear methods and Verlet is the extreme-case scan's record (the larger
    of the two event settings), and stability.md quotes each setting's threshold."""
    from hertzian.core.check import ACCURATE_STEPS_PER_CONTACT_TIME

    scan = record("accuracy/composed.json")["thresholds_gear_verlet"]["methods"]
    for method in ("gear4", "gear5", "gear6", "verlet"):
        each = {setting: row["threshold"] for setting, row in scan[method]["events"].items()}
        assert ACCURATE_STEPS_PER_CONTACT_TIME[method] == scan[method]["threshold"] == max(each.values()), method
    text = " ".join((DOCS / "stability.md").read_text().split())
    auto, off = (
        [f"{scan[m]['events'][e]['threshold']:g}" for m in ("gear4", "gear5", "gear6")] for e in ("auto", "off")
    )
    assert (
        f"event-aware steps need {auto[0]}, {auto[1]} and {auto[2]} for gear4, gear5 and gear6, plain steps {off[0]}, "
        f"{off[1]} and {off[2]}, and verlet {scan['verlet']['threshold']:g} with both" in text
    )


def test_the_design_objective_against_halving_dt_is_its_record():
    """design.md's dt check: at 19 beads every peak survives halving dt; at 99 beads the best design's peak at the
    search's step is not resolved. Each number from the record's `best_peak_by_step` and per-chain half-step peaks."""
    import numpy as np

    parts = record("design/protector_cpu.json")
    text = " ".join((DOCS / "design.md").read_text().split())
    short = ("beads_20", "population_6400", "four_materials")

    def spread(part: str) -> float:
        peaks = [row["peak_wall_force"] for row in parts[part]["best_peak_by_step"]]
        return max(peaks) / min(peaks) - 1

    def moved(part: str, plain: bool) -> float:
        rows = parts[part]["chains"]
        return max(
            abs(r["peak_wall_force_at_half_dt"] / r["peak_wall_force"] - 1)
            for k, r in rows.items()
            if (k != "best") == plain
        )

    improvements = []
    for part in short:
        curve = np.array(parts[part]["best_objective"])
        falls = np.diff(curve) < 0
        improvements += list(-np.diff(curve)[falls] / curve[:-1][falls])
    numbers = (max(spread(p) for p in short), max(moved(p, True) for p in short), min(improvements))
    assert (
        "The best designs' peaks agree to %.1e over the six steps and settings, every plain protector's moves by at most "
        "%.1e at dt/2, and the smallest step by which any of these searches improved its best was %.1e of it" % numbers
    ).replace("e-0", "e-") in text
    steps = parts["beads_100"]["best_peak_by_step"]
    assert [(r["events"], r["dt"]) for r in steps] == [(e, 2.5e-5 / d) for e in ("off", "auto") for d in (1, 2, 4)]
    plain, aware = ([f"{r['peak_wall_force']:.6f}" for r in steps if r["events"] == e] for e in ("off", "auto"))
    assert (
        f"The best design's peak is {plain[0]} at dt with plain steps, {plain[1]} at dt/2 and {plain[2]} at dt/4"
        in text
    )
    assert f"with event-aware steps {aware[0]}, {aware[1]} and {aware[2]}" in text
    resolved = steps[4]["peak_wall_force"]
    below = 1 - steps[0]["peak_wall_force"] / resolved
    agree = abs(steps[5]["peak_wall_force"] / resolved - 1)
    assert (
        f"is {100 * below:.1f} % below the resolved one (event-aware, dt/2 and dt/4 agree to {agree:.1e})".replace(
            "e-0", "e-"
        )
        in text
    )
    curve = np.array(parts["beads_100"]["best_objective"])
    falls = np.diff(curve) < 0
    assert (
        f"The search's smallest improvements there ({100 * min(-np.diff(curve)[falls] / curve[:-1][falls]):.1f} %)"
        in text
    )
    plain_best = min(r["peak_wall_force"] for k, r in parts["beads_100"]["chains"].items() if k != "best")
    ratios = [plain_best / r["peak_wall_force"] for r in steps]
    assert {f"{x:.0f}" for x in ratios} == {"16"} and "16 times below the best plain protector's at every step" in text
    assert f"move by at most {moved('beads_100', True):.1e} at dt/2".replace("e-0", "e-") in text


def test_sweeps_store_costs_are_their_record():
    """sweeps.md's checksum cost, byte-flip outcomes and per-point expansion cost against bench/cpu.json's
    ``store`` part (``python -m hertzian.studies.store_costs``)."""
    store = record("bench/cpu.json")["parts"]["store"]
    text = " ".join((DOCS / "sweeps.md").read_text().split())
    seconds = store["checksum"]["seconds"]
    median = {(k, op): sorted(v[op])[len(v[op]) // 2] for k, v in seconds.items() for op in v}
    reads = seconds["with_checksum"]["read"] + seconds["without_checksum"]["read"]
    assert (
        f"a {store['checksum']['megabytes']:.0f} MB float64 array in 1 MiB chunks took a median "
        f"{median['with_checksum', 'write']:.2f} s to write with the checksum and "
        f"{median['without_checksum', 'write']:.2f} s without, and {median['with_checksum', 'read']:.2f} s and "
        f"{median['without_checksum', 'read']:.2f} s to read ({store['checksum']['repeats']} interleaved pairs; "
        f"single reads ranged {min(reads):.2f}–{max(reads):.2f} s either way)"
    ) in text
    flips = store["flips"]
    assert flips["with_checksum"] == {"raised": flips["flips"], "silent": 0, "harmless": 0}
    assert (
        f"({flips['flips']} flips, ten chunks): with the checksum all {flips['flips']} reads raised; without it, "
        f"{flips['without_checksum']['silent']} read back wrong values with no error"
    ) in text
    assert f"--repeats {store['checksum']['repeats']}`" in text and flips["chunks"] == 10
    expansion = store["expansion"]
    assert (
        f"one took {expansion['scene_seconds_per_point'] * 1e3:.2f} ms of CPU a point, against "
        f"{expansion['expand_seconds_per_point'] * 1e6:.2f} µs a point for the expansion below "
        f"(`{expansion['sweep']}`, 2-core CPU, {store['date'][:10]};"
    ) in text


def _moved_in_standard_errors(reference: dict, other: dict, observable: str) -> tuple[float, dict[float, float]]:
    """Largest |change| of the mean, std and 5/50/95 % quantiles of ``observable`` over the spreads > 0, and the
    mean's change by spread, in standard errors at 1000 realisations (the reference's std/√1000)."""
    worst, means = 0.0, {}
    for i, spread in enumerate(reference["spread"]):
        if spread == 0:
            continue
        error = reference[f"{observable}_std"][i] / math.sqrt(1000)
        for stat in ("mean", "std", "q05", "q50", "q95"):
            worst = max(worst, abs(other[f"{observable}_{stat}"][i] - reference[f"{observable}_{stat}"][i]) / error)
        means[spread] = abs(other[f"{observable}_mean"][i] - reference[f"{observable}_mean"][i]) / error
    return worst, means


def test_the_shipped_physics_check_is_its_record():
    """heterogeneous.md's events and half-step check of the disorder statistics, and what event-aware steps cost the
    CPU, against heterogeneous_shipped_cpu.json's parts."""
    parts = record("heterogeneous_shipped_cpu.json")["parts"]
    text = " ".join((DOCS / "heterogeneous.md").read_text().split())
    plain, events, half = (parts[p]["disorder"] for p in ("disorder_8", "disorder_8_events", "disorder_8_dt2"))
    assert plain["realisations"] == events["realisations"] == half["realisations"] == 8
    assert (plain["events"], events["events"], half["events"]) == ("off", "auto", "off")
    assert half["dt"] == plain["dt"] / 2 == events["dt"] / 2
    bottom = max(
        _moved_in_standard_errors(plain, other, name)[0]
        for other in (events, half)
        for name in ("bottom_fraction", "bottom_peak_force")
    )
    assert f"moved by at most {bottom:.1e} of their standard error".replace("e-0", "e-") in text
    by_events, mean_events = _moved_in_standard_errors(plain, events, "decay_length")
    by_step, mean_step = _moved_in_standard_errors(plain, half, "decay_length")
    assert (
        f"moved by up to {by_events:.1f} standard errors (auto against off) and {by_step:.1f} (dt/2 against dt), the "
        f"mean at s = 0.3 by {mean_events[0.3]:.2f} and {mean_step[0.3]:.1f}"
    ) in text
    taper_auto, taper_off = parts["dt25x_events"]["taper"]["seconds"], parts["dt25x"]["taper"]["seconds"]
    chains = len(plain["spread"]) * plain["realisations"]
    assert (
        f"cost the CPU {taper_auto / taper_off:.0f}× on the shipped taper sweep at dt 5e-5 ({taper_auto:.1f} s "
        f"against {taper_off:.1f} s, parts `dt25x_events` and `dt25x`) and {events['seconds'] / plain['seconds']:.1f}× "
        f"on the {chains} disorder chains ({events['seconds']:.0f} s against {plain['seconds']:.0f} s)"
    ) in text


def test_the_shipped_taper_step_paragraph_is_its_record():
    """heterogeneous.md's shipped taper at dt/2 and at 25× the step, against heterogeneous_shipped_cpu.json."""
    whole = record("heterogeneous_shipped_cpu.json")
    taper, half, coarse = whole["taper"], whole["parts"]["dt2"]["taper"], whole["parts"]["dt25x"]["taper"]
    text = " ".join((DOCS / "heterogeneous.md").read_text().split())
    for key in ("bottom_fraction", "bottom_peak_force", "arrival_time"):
        for a, b in zip(taper[key], half[key]):
            assert f"{a:.4g}" == f"{b:.4g}" or abs(a - b) <= 5e-5 * abs(a), (key, a, b)
    assert (
        f"the energy error is at most {max(taper['energy_error']):.1e} (q = 0.04) at dt and "
        f"{max(half['energy_error']):.1e} at dt/2"
    ).replace("e-0", "e-") in text
    assert taper["energy_error"].index(max(taper["energy_error"])) == taper["q"].index(0.04)
    last = coarse["q"].index(0.04)
    assert coarse["status"][last] == 3 and f"(energy error {coarse['energy_error'][last]:.2f})" in text
    moved = max(
        abs(coarse[key][last] / taper[key][last] - 1)
        for key in ("bottom_fraction", "bottom_peak_force", "arrival_time")
    )
    assert moved < 0.01 and "differ from these by under 1 %" in text
    seconds = record("heterogeneous_cpu.json")
    chains = len(seconds["disorder"]["spread"]) * seconds["disorder"]["realisations"]
    assert (
        f"{seconds['date']}: {seconds['taper']['seconds']:.1f} s for the taper sweep, "
        f"{seconds['disorder']['seconds']:.0f} s for {chains} disorder chains.)"
    ) in text
    assert (
        f"2026-11-29, record [heterogeneous_shipped_cpu.json](records/heterogeneous_shipped_cpu.json), {taper['seconds']:.0f} s;"
        in text
    )


def test_heterogeneous_published_trends_are_their_records():
    """heterogeneous.md's "Against the published trends": the taper's cuts at 40 and 100 grains, the binary-collision
    estimate, and the disorder's attenuation, against heterogeneous_cpu.json and heterogeneous_shipped_cpu.json."""
    text = " ".join((DOCS / "heterogeneous.md").read_text().split())

    def cuts(taper: dict, q: float) -> tuple[str, str]:
        i, uniform = taper["q"].index(q), taper["q"].index(0.0)
        force = taper["bottom_peak_force"][i] / taper["bottom_peak_force"][uniform]
        return f"{100 * taper['relative_to_uniform'][i]:.0f} %", f"{100 * force:.0f} %"

    cpu, shipped = record("heterogeneous_cpu.json"), record("heterogeneous_shipped_cpu.json")
    share, force = cuts(cpu["taper"], 0.04)
    assert f"keeps {share} of the uniform chain's share, and the wall feels {force} of its peak force" in text
    (share3, force3), (share4, force4) = cuts(shipped["taper"], 0.03), cuts(shipped["taper"], 0.04)
    assert f"q = 0.03 leaves {share3} of the uniform chain's share and {force3} of its peak force" in text
    assert f"(the bottom grain 0.018 R0) {share4} and {force4}." in text
    taper = cpu["taper"]
    i = taper["q"].index(0.04)
    assert f"leaves {taper['binary_collision_relative'][i]:.2f} at q = 0.04 (40 grains)" in text
    assert f"is larger ({taper['relative_to_uniform'][i]:.2f})" in text
    d = cpu["disorder"]
    assert d["spread"][0] == 0.0 and d["spread"][-1] == 0.4
    assert (
        f"falls from {d['bottom_fraction_mean'][0]:.2f} to {d['bottom_fraction_mean'][-1]:.2f} as s grows to 0.4, "
        f"the decay length of the speed amplitude from ~{round(d['decay_length_mean'][0], -1):.0f} to "
        f"~{d['decay_length_mean'][-1]:.2g} grains, and the mean peak force on the bottom wall from "
        f"{d['bottom_peak_force_mean'][0]:.1f} to {d['bottom_peak_force_mean'][-1]:.1f}, with a spread over "
        f"realisations (5–95 %: {d['bottom_peak_force_q05'][-1]:.2f}–{d['bottom_peak_force_q95'][-1]:.2f} at s = 0.4)"
    ) in text


def test_stability_prose_numbers_are_their_records():
    """stability.md: compensated float32's slowdown on the CPU (§2b, accuracy/float32.json → paper) and gpu_10k's
    warm time with event-aware steps against plain ones (§6c, bench/h100_events.json and bench/h100_endtoend.json)."""
    text = " ".join((DOCS / "stability.md").read_text().split())
    seconds: dict = {}
    for run in record("accuracy/float32.json")["parts"]["paper"]["records"]:
        seconds.setdefault((run["method"], run["dt"]), {})[run["precision"]] = run["seconds"]
    ratios = [s["float32"] / s["float64"] for s in seconds.values()]
    assert f"slower than float64, {min(ratios):.1f}–{max(ratios):.1f}× in these single runs" in text
    (events,) = record("bench/h100_events.json")["workloads"]["e2e_gpu10k_events_auto_warm_l"]
    plain = record("bench/h100_endtoend.json")["workloads"]["gpu_10k"]["records"][-1]
    assert events["workload"] == plain["workload"] == "sweeps/gpu_10k.toml" and not events["cold"] | plain["cold"]
    assert (
        f"takes **{events['seconds']['total']:.2f} s warm ({events['device_seconds']:.2f} device seconds)** with "
        f"`--set integrator.events=auto` against **{plain['seconds']['total']:.2f} s** with the file's plain steps"
    ) in text


def test_the_disorder_trace_sampling_is_its_record():
    """heterogeneous.md: the bottom's peak force sampled every 0.005 against every step, in the full-size chains of
    seed 0 (heterogeneous_shipped_cpu.json, parts disorder_1 and disorder_1_every_step)."""
    parts = record("heterogeneous_shipped_cpu.json")["parts"]
    sampled, every_step = parts["disorder_1"]["disorder"], parts["disorder_1_every_step"]["disorder"]
    assert (sampled["trace_every"], every_step["trace_every"]) == (0.005, every_step["dt"])
    assert sampled["realisations"] == every_step["realisations"] == 1 and len(sampled["spread"]) == 6
    low = [1 - a / b for a, b in zip(sampled["bottom_peak_force_mean"], every_step["bottom_peak_force_mean"])]
    assert min(low) >= 0  # a sampled peak is never above the peak of every step
    text = " ".join((DOCS / "heterogeneous.md").read_text().split())
    assert (
        f"a peak force sampled this often is low by at most {100 * max(low):.2f} % against one sampled every step, "
        f"at each of the six spreads"
    ) in text


def test_the_heterogeneous_store_sizes_follow_from_the_shipped_sweeps():
    """heterogeneous.md's sample counts and sizes of the shipped taper and disorder sweeps' traces and snapshots."""
    import tomllib

    sweeps = DOCS.parent / "sweeps"
    taper, disorder = (tomllib.loads((sweeps / f"{n}.toml").read_text()) for n in ("taper", "disorder"))
    text = " ".join((DOCS / "heterogeneous.md").read_text().split())

    def samples(data: dict, every: str) -> int:
        return round(data["scene"]["integrator"]["duration"] / data["scene"]["record"][every]) + 1

    tapers = len(taper["axis"][0]["values"])
    steps = taper["scene"]["record"]["trace_every"] / taper["scene"]["integrator"]["dt"]
    assert round(steps, 9) == 10 and "the taper sweep every 2e-5, every tenth step" in text
    assert f"33 samples; {tapers} points × {samples(taper, 'trace_every')} samples of u and v, " in text
    assert f"{tapers * samples(taper, 'trace_every') * 2 * 8 / 1e6:.0f} MB)" in text and round(6.6e-4 / 2e-5) == 33
    points = len(disorder["axis"][0]["values"]) * int(disorder["axis"][1]["linspace"][2])
    traces = points * samples(disorder, "trace_every") * 2 * 8
    snapshots = points * samples(disorder, "every") * disorder["scene"]["chain"]["grains"] * 8
    assert (
        f"({points} points × {samples(disorder, 'trace_every')} samples of u and v, {traces / 1e9:.2f} GB against "
        f"the {snapshots / 1e9:.1f} GB of `v` snapshots"
    ) in text


def test_the_driven_columns_accuracy_and_cost_are_their_records():
    """reproduction.md VI's accuracy and cost paragraphs (fig9_10_h100.json) and the later fused-window run of the
    same columns (repro_drive_h100.json)."""
    text = " ".join((DOCS / "reproduction.md").read_text().split())
    h100 = record("reproduction/fig9_10_h100.json")
    main, check = (next(r for r in h100["runs"] if r["name"] == n) for n in ("fig9_10", "fig9_10_dt_check"))
    window = main["taus"].index(10.0), main["taus"].index(1.0)
    difference = check["relative_l2_difference_of_window_ke(dt=1.25e-4 vs 1.25e-5)"]
    energy = [f"{main['energy_error'][i]:.1e}".replace("e-0", "e-") for i in window]
    assert f"Energy balance |E − E0 − W| / max|W|: {energy[0]} (τ = 10) and {energy[1]} (τ = 1)" in text
    differences = [f"{difference[i][0]:.1e}".replace("e-0", "e-") for i in window]
    assert f"kinetic-energy profile {differences[0]} (τ = 10) and {differences[1]} (τ = 1)" in text
    steps_per_second = main["steps"] / main["wall_seconds"]
    check_rate = check["steps"] / check["wall_seconds"]
    alone = main["steps"] / check_rate
    assert (
        f"**Cost.** {main['wall_seconds']:.1f} s on the H100 for both columns to t = {main['duration']:.0f}: "
        f"{main['steps']:_} steps of 2 × {main['grains']:_} grains, {main['grain_steps_per_second']:.1e} grain-steps/s "
        f"({steps_per_second:.1e} steps/s)"
    ).replace("_", " ").replace("e+0", "e") in text
    assert (
        f"integrated at {check_rate:.1e} steps/s ({check_rate * 2 * check['grains']:.1e} grain-steps/s; "
        f"{check['steps']:_} steps in {check['wall_seconds']:.1f} s). At that rate the main run's steps alone take "
        f"~{alone:.0f} s, so about {round(main['wall_seconds'] - alone, -1):.0f} s (≈ "
        f"{1e3 * (main['wall_seconds'] - alone) / 6227:.0f} ms per stop"
    ).replace("_", " ").replace("e+0", "e") in text
    assert f"The whole script took {h100['total_seconds']:.0f} s including both stores." in text
    fused = {r["name"]: r for r in record("reproduction/repro_drive_h100.json")["runs"]}
    run, dt_check = fused["fig9_10"], fused["fig9_10_dt_check"]
    assert (
        f"fig9_10 **{run['wall_seconds']:.1f} s** ({run['grain_steps_per_second']:.1e} grain-steps/s), energy error "
        f"{run['energy_error'][0]:.2e} (τ = 10) and {run['energy_error'][1]:.2e} (τ = 1), both status 0"
    ).replace("e+0", "e").replace("e-0", "e-") in text and run["status"] == [0, 0]
    assert f"its dt check {dt_check['wall_seconds']:.1f} s" in text


def test_the_event_aware_reproduction_is_its_record():
    """reproduction.md: what event-aware steps change in the reproduction's numbers, energy errors and CPU time,
    against measurements.json → parts.events_auto (``python -m hertzian.studies.events_effect``)."""
    measurements = record("reproduction/measurements.json")
    effect = measurements["parts"]["events_auto"]
    assert effect["plain_date"] == measurements["date"]  # compared with the plain run the record holds
    text = " ".join((DOCS / "reproduction.md").read_text().split())
    groups = effect["groups"]
    where = effect["largest_at"].split("/")
    assert where[0] == "fig5" and where[-1] == "r_squared" and "tail" in effect["largest_at"]
    medians = max(g["median_change"] for g in groups.values())
    assert (
        f"move none of the reproduction's {effect['numbers']} measured numbers by more than "
        f"{effect['largest_change']:.1e} relative (an r² of a tail fit in fig5; the median change per group is ≤ "
        f"{medians:.1e})".replace("e-0", "e-")
    ) in text
    same = [n for n, g in groups.items() if g["largest_change"] == 0 and len(set(g["energy_error_max"].values())) == 1]
    assert f"Where no contact opens ({', '.join(same)}) they change nothing" in text
    lowered = [n for n in groups if n not in same]
    assert all(groups[n]["energy_error_max"]["auto"] < groups[n]["energy_error_max"]["off"] for n in lowered)
    least = max(lowered, key=lambda n: groups[n]["energy_error_max"]["auto"] / groups[n]["energy_error_max"]["off"])
    fig6 = groups["fig6"]["energy_error_max"]
    assert least == "fig6"
    assert (
        f"lower the other groups' largest energy error from ≤ "
        f"{max(groups[n]['energy_error_max']['off'] for n in lowered):.1e} to ≤ "
        f"{max(groups[n]['energy_error_max']['auto'] for n in lowered):.1e} (fig6's least, from "
        f"{fig6['off']:.1e} to {fig6['auto']:.1e})".replace("e-0", "e-")
    ) in text
    ratios = [g["wall_seconds"]["auto"] / g["wall_seconds"]["off"] for g in groups.values()]
    assert (
        f"cost {min(ratios):.1f}–{max(ratios):.1f}× a group's wall time on the 2-core CPU ({effect['date'][:10]};"
        in text
    )


def test_the_cpu_readme_timelines_are_their_record():
    """fixed-costs.md's prose on the CPU: the compile threads, the `auto` rule's kernel costs, and the README
    command's warm and cold timelines and prebuilt runs, against bench/cpu_auto_rule.json."""
    text = " ".join((DOCS / "fixed-costs.md").read_text().split())
    cpu = record("bench/cpu_auto_rule.json")

    def span(values: list[float]) -> str:
        return f"{min(values):.2f}–{max(values):.2f}"

    threads = cpu["compile_8_variants"]
    assert (
        f"prepares 8 variants in {threads['workers_1_s']:.2f} s with one thread and {threads['workers_2_s']:.2f} s"
        in text
    )
    costs = cpu["kernel_costs"]
    assert (
        f"per-step kernel {costs['step']['compile_s']:.2f} s compile, {costs['step']['rate']:.1e} grain-steps/s; chain "
        f"kernel {costs['chain']['compile_s']:.2f} s compile, {costs['chain']['rate']:.1e} grain-steps/s"
    ).replace("e+0", "e") in text
    readme = cpu["readme"]
    warm = [p["warm_timeline"]["phases"] for p in readme["pairs"]]
    cold = [p["cold_timeline"]["phases"] for p in readme["pairs"]]
    assert (
        f"`hertzian.cli` ready at {span([p['cli_ready'] for p in warm])} s, Warp initialised at "
        f"{span([p['warp_initialised'] for p in warm])} s, kernels loaded from the cache at "
        f"{span([p['kernels_loaded'] for p in warm])} s, integration "
        f"{span([p['integrated'] - p['kernels_loaded'] for p in warm])} s"
    ) in text
    assert f"store written {span([p['store_written'] - p['integrated'] for p in warm])} s." in text
    added = readme["median_cold_s"] - readme["median_warm_s"]
    assert f"cold adds {added:.2f} s, so cold is {readme['cold_over_warm']:.2f}× warm on this CPU" in text
    header = [p["precompiled_header_built"] - p["warp_initialised"] for p in cold]
    assert (
        f"Warp starts at {span([p['warp_initialised'] for p in cold])} s and the header thread with it; the header is "
        f"built at {span([p['precompiled_header_built'] for p in cold])} s"
    ) in text
    assert (
        f"loaded at {span([p['kernels_loaded'] for p in cold])} s (warm: {span([p['kernels_loaded'] for p in warm])} s)"
        in text
    )
    assert f"about {sum(header) / len(header):.1f} s of clang parsing" in text
    prebuilt, installed = cpu["readme_prebuilt"], cpu["readme_installed"]
    assert f"({prebuilt['median_cold_s']:.2f} s against {prebuilt['median_warm_s']:.2f} s, medians of 3 pairs)" in text
    assert f"{installed['median_cold_s']:.2f} s cold against {installed['median_warm_s']:.2f} s warm (part" in text


def test_the_readme_prose_numbers_are_their_records():
    """README.md: the error estimate's cost (accuracy/estimate_check_cpu.json), the fastest way to 1e-8 on an H100
    (bench/h100_events.json) and the detection paragraph (detection/h100_target_1000.json)."""
    import numpy as np

    readme = " ".join((DOCS.parent / "README.md").read_text().split())
    cost = record("accuracy/estimate_check_cpu.json")["cost"]
    assert f"for about {cost['ratio']:.1f}× the run's time" in readme
    workloads = record("bench/h100_events.json")["workloads"]
    best, events, plain = (
        workloads[name][0]["seconds"]["total"]
        for name in ("frontier_gear6_auto_1e-3_l2", "frontier_gear4_auto_5e-4_l2", "frontier_gear4_off_1e-4_l2")
    )
    assert (
        f"gear6 with event-aware steps at dt = 1e-3: {best:.1f} s end to end, against {events:.1f} s for gear4 with them "
        f"at its largest passing step (5e-4) and {plain:.1f} s for plain gear4 at 1e-4"
    ) in readme
    study = record("detection/h100_target_1000.json")
    detections = [dict(zip(study["columns"], row)) for row in study["records"]]
    planted = [d for d in detections if d["true_class"] != "none"]
    grains = 1000
    depths = [d["true_depth"] / grains for d in planted]
    ratios = [d["true_mass_ratio"] for d in planted]
    assert len(detections) == 416 and all(d["class"] == d["true_class"] for d in detections)
    assert all(abs(d["depth"] - d["true_depth"]) <= 1 for d in planted)
    assert (
        f"{len(detections)} planted signals at 26 dB (single impurities of mass ratio {min(ratios):.1f}–{max(ratios):.0f}"
        f" at depths of {100 * min(depths):.0f}–{100 * max(depths):.0f} % of the chain"
    ) in readme
    seconds = np.median([d["seconds_total"] for d in detections])
    assert f"a detection with the library cached took {seconds:.2f} s (median;" in readme


def test_the_h100_host_side_sentences_are_their_record():
    """benchmarks.md: the warm runs' compile seconds and the 1000-grain scenes' and gpu_10k's seconds outside the
    device, against bench/h100_endtoend.json (the warm runs of benchmarks.md's table)."""
    workloads = {k: v for k, v in record("bench/h100_endtoend.json")["workloads"].items() if k != "reproduce"}
    warm = {k: [r for r in v["records"][1:] if not r["cold"]] for k, v in workloads.items()}
    warm["gpu_10k"] = warm["gpu_10k"][
        -1:
    ]  # its second run still calibrated a launch shape: the table's warm run is the third
    compiles = [r["seconds"]["compile"] for runs in warm.values() for r in runs]
    text = " ".join((DOCS / "benchmarks.md").read_text().split())
    assert f"warm compile seconds are {min(compiles):.1f}–{max(compiles):.1f} s" in text
    scenes = [r for k, runs in warm.items() if k.endswith(("_1000", "_traces")) for r in runs]
    outside = [r["seconds"]["total"] - r["device_seconds"] for r in scenes]
    totals = [r["seconds"]["total"] for r in scenes]
    assert min(outside) >= 0.35 and max(outside) < 0.55 and 2.2 < min(totals) and max(totals) < 3.0
    gpu = warm["gpu_10k"][-1]
    assert (
        "the 1000-grain scenes spend ~0.4–0.5 s of their ~2.5 s outside the device (records, store, compile-cache "
        f"load), and gpu_10k about {gpu['seconds']['total'] - gpu['device_seconds']:.1f} s of "
        f"{gpu['seconds']['total']:.1f} s"
    ) in text


def test_the_gpu_event_cost_in_accuracy_md_is_its_record():
    (events,) = record("bench/h100_events.json")["workloads"]["e2e_gpu10k_events_auto_warm_l"]
    plain = record("bench/h100_endtoend.json")["workloads"]["gpu_10k"]["records"][-1]
    text = " ".join((DOCS / "accuracy.md").read_text().split())
    ratio = events["device_seconds"] / plain["device_seconds"]
    assert f"the fused kernels' event steps took {ratio:.1f}× the device time of plain steps at the same step" in text


def test_the_defaults_prose_is_its_records():
    """accuracy.md's reading of the defaults table: what plain steps save or cost against event-aware ones, per
    device, from the records' cheapest runs, and the two runs it names."""
    records = {"CPU": record("accuracy/defaults_cpu.json"), "GPU": record("accuracy/defaults_h200.json")}
    text = " ".join((DOCS / "accuracy.md").read_text().split())
    saving = {}  # (device, scene, target) → seconds with events auto over seconds with events off
    for device, found in records.items():
        for scene, data in found["scenes"].items():
            for target, best in data["cheapest_per_events"].items():
                auto, off = best["auto"], best["off"]
                assert auto is not None  # event-aware steps meet every target
                if off is not None:
                    saving[device, scene, float(target)] = auto["seconds"] / off["seconds"]
                    if float(target) == 1e-6 and device == "CPU":
                        assert auto["dt"] == 4 * off["dt"], (scene, auto, off)  # "a 4× smaller step"
                else:
                    assert float(target) == 1e-8
    cpu = [v for (d, _, t), v in saving.items() if d == "CPU" and t == 1e-4]
    assert max(cpu) <= 2 and "at 1e-4 they save at most 2×" in text
    assert max(v for (d, _, _), v in saving.items() if d == "CPU") <= 2 and "(≤ 2×)" in text
    loose = records["GPU"]["scenes"]["loose"]["cheapest_per_events"]["1e-06"]
    assert (
        f"on the GPU {saving['GPU', 'loose', 1e-6]:.1f}× on the loose chain at 1e-6 (gear4 at dt/4, "
        f"{loose['off']['seconds']:.3f} s, against event-aware gear6 at {loose['auto']['seconds']:.3f} s), "
        f"{saving['GPU', 'loose', 1e-4]:.1f}× on the loose chain at 1e-4, and at most "
        f"{max(v for (d, s, _), v in saving.items() if d == 'GPU' and s != 'loose'):.1f}× elsewhere."
    ) in text


def test_the_drive_map_reading_is_its_record():
    """drive.md's reading of the reduced drive map: run times, what survives halving dt at each amplitude, and the
    driver-open ranges, against drive/drive_map_cpu.json."""
    values = record("drive/drive_map_cpu.json")["items"]["drive_map"]["values"]
    points = values["points"]
    text = " ".join((DOCS / "drive.md").read_text().split())
    seconds = values["sweep_seconds"]
    half = f"{values['dt_half']:.3e}".replace("e-0", "e-")
    assert f"at dt and at dt/2 = {half} ({seconds['drive_map']:.0f} s and {seconds['drive_map_half']:.0f} s)" in text
    small = [p for p in points if p["A"] == 0.02]
    parted = {p["tau"]: p["trajectories_part_at"] for p in small}
    assert parted[2.0] is None and f"they part at t = {parted[0.5]:g} and {parted[1.0]:g} (τ = 0.5, 1)" in text
    late = ("late_power", "work_growth")
    others = [p[f"{k[:-7]}_change"] for p in small for k in p if k.endswith("_change") and k[:-7] not in late]
    bound = math.ceil(1000 * max(c for c in others if c is not None)) / 10  # an upper bound, rounded up
    assert f"the numbers agree to ≤ {bound:.1f} %" in text
    growth = {p["tau"]: max(p["late_power_change"], p["work_growth_change"]) for p in small}
    assert f"parting ({100 * growth[0.5]:.1f} % at τ = 0.5, {100 * growth[1.0]:.1f} % at τ = 1)" in text

    def percent(ps):
        both = [x for p in ps for x in (p["driver_open"], p["driver_open_half_dt"])]
        return f"{100 * min(both):.0f}–{100 * max(both):.0f} %"

    large = [p for p in points if p["A"] >= 0.2]
    part = [p["trajectories_part_at"] for p in large]
    assert f"the trajectories part at t = {min(part):g}–{max(part):g}, before the first window" in text
    assert f"open {percent(small)} of the time already at A = 0.02, and {percent(large)} at A ≥ 0.2" in text
    open_change = max(abs(p["driver_open"] - p["driver_open_half_dt"]) for p in large)
    assert (
        f"the driver-open fraction (within {open_change:.2f} absolute), the bottom's energy share (within "
        f"{100 * max(p['bottom_ke_fraction_change'] for p in large):.0f} %) and the driver's mean power (within "
        f"{100 * max(p['late_power_change'] for p in large):.0f} %)"
    ) in text
    drifts = [d for p in points for d in (p["node_drift"], p["node_drift_half_dt"]) if d is not None]
    assert f"(node drift {min(drifts):g}–{max(drifts):g} grains)" in text


def test_the_scale_out_prose_is_its_records():
    """scale-out.md's 2-GPU paragraph, its verdict on the targets and the killed worker, against the 2- and 4-GPU
    records and worker_kill_2gpu_h200.json."""
    text = " ".join((DOCS / "scale-out.md").read_text().split())
    four, two = record("bench/scale_out_4gpu_h200.json"), record("bench/scale_out_2gpu_h200.json")
    serial, one, pair = two["strong"]
    weak_serial, weak_pair = two["weak"]
    batches = lambda run: run["seconds"]["batches"]  # noqa: E731
    assert (
        f"serial {serial['process_seconds']:.2f} s (batch phase {batches(serial):.2f} s), `--workers 1` "
        f"{one['process_seconds']:.2f} s ({one['speedup']:.2f}×), `--workers 2` {pair['process_seconds']:.2f} s "
        f"({pair['speedup']:.2f}×, {100 * pair['efficiency']:.0f} %; batch phase {batches(pair):.2f} s, "
        f"{pair['batch_phase_speedup']:.2f}×); weak: serial at W/2 {weak_serial['process_seconds']:.2f} s, 2 workers "
        f"at W {weak_pair['process_seconds']:.2f} s ({100 * weak_pair['efficiency']:.0f} %)"
    ) in text
    assert two["bitwise_equal"] and four["bitwise_equal"]
    strong4 = four["strong"]
    speedups = [pair["speedup"], strong4[1]["speedup"]]
    weak = [four["weak_runs"][n]["efficiency"] for n in ("2", "4")] + [weak_pair["efficiency"]]
    busy = [b for run in strong4[1:] for b in run["busy"].values()]
    assert (
        f"**Not met**: {min(speedups):.2f}–{max(speedups):.2f}×, {strong4[2]['speedup']:.2f}× and "
        f"{100 * min(weak):.0f}–{100 * max(weak):.0f} %. The batches scale ({strong4[1]['batch_phase_speedup']:.2f}× and "
        f"{strong4[2]['batch_phase_speedup']:.2f}× in the batch phase, every worker busy ≥ {100 * min(busy):.0f} %)"
    ) in text
    kill = record("bench/worker_kill_2gpu_h200.json")
    assert kill["differing_arrays"] == [] and kill["returncode"] == 0
    assert (
        f"the kill came {kill['seconds_to_kill']:.1f} s in, with {kill['done_at_kill']} batch complete; the sweep "
        f"finished all {kill['batches_completed']} batches in {kill['killed_run_seconds']:.1f} s (serially "
        f"{kill['serial_seconds']:.1f} s)"
    ) in text


def test_the_heterogeneous_gpu_prose_is_its_records():
    """heterogeneous.md's shipped-size GPU run and the event-aware disorder throughput, against their records."""
    text = " ".join((DOCS / "heterogeneous.md").read_text().split())
    shipped = record("heterogeneous_shipped_h200.json")
    points = len(shipped["disorder"]["spread"]) * shipped["disorder"]["realisations"]
    assert (
        f"took **{shipped['process_seconds']:.1f} s** from process start to exit on an empty kernel cache: "
        f"{shipped['taper']['seconds']:.1f} s for the taper sweep, {shipped['disorder']['seconds']:.1f} s for the "
        f"{points} disorder chains"
    ) in text
    events = record("bench/disorder_h200.json")
    assert "--set chain.grains=1000" in events["command"] and 'events = "auto"' in events["what"]
    assert (
        f"(`sweeps/disorder.toml` with `--set chain.grains=1000`) ran at "
        f"{events['result']['grain_steps_per_second']:.1e} grain-steps/s".replace("e+0", "e")
    ) in text


def test_the_lost_work_bound_in_sweeps_md_is_the_planners():
    from hertzian.sweeping.planner import LOST_WORK_FRACTION, LOST_WORK_SECONDS, SAFE_RATE

    text = " ".join((DOCS / "sweeps.md").read_text().split())
    assert (
        f"at most **{LOST_WORK_SECONDS:.0f} s of work at a conservative rate** ({SAFE_RATE['cpu']:.0e} grain-steps/s on "
        f"a CPU, {SAFE_RATE['cuda']:.0e} on a GPU) **or {100 * LOST_WORK_FRACTION:.0f} % of the sweep**"
    ).replace("e+0", "e").replace("e+", "e") in text


def test_the_reproduction_run_times_are_their_records():
    """reproduction.md's run times of the measurements command and of the CPU Sec. VI lag run."""
    text = " ".join((DOCS / "reproduction.md").read_text().split())
    groups = record("reproduction/measurements.json")["groups"].values()
    total = sum(g["wall_seconds"] for g in groups)
    assert f"(the groups' wall seconds add up to {total:.0f} s):" in text
    lag = record("reproduction/sec6_lag_cpu.json")
    assert f"--device cpu`, {lag['total_seconds']:.0f} s on the 2-core CPU, {lag['date'][:10]};" in text


def test_the_weak_gravity_column_paragraph_is_its_record():
    """stability.md §6b's column under weak gravity, whose first steps are event steps: event-aware steps below plain
    ones at every step, in position and in energy, against accuracy/events.json → column_weak_gravity (\\* where the
    record says the reference limits the error)."""
    part = record("accuracy/events.json")["parts"]["column_weak_gravity"]
    runs = {(r["events"], r["dt"]): r for r in part["records"]}
    steps = sorted({dt for _, dt in runs}, reverse=True)
    assert steps == [2.5e-4, 1.25e-4, 6.25e-5, 3.125e-5] and "--set chain.gravity=0.001" in part["command"]
    assert all(runs["auto", dt][key] < runs["off", dt][key] for dt in steps for key in ("error", "energy_error"))
    assert math.log2(runs["auto", steps[0]]["error"] / runs["auto", steps[1]]["error"]) > 3.7
    text = " ".join((DOCS / "stability.md").read_text().split())

    def shown(events: str, key: str) -> str:
        values = [
            f"{runs[events, dt][key]:.1e}".replace("e-0", "e-")
            + ("\\*" if key == "error" and runs[events, dt]["reference_limited"] else "")
            for dt in steps
        ]
        return ", ".join(values[:-1]) + " and " + values[-1]

    assert (
        f"With event-aware steps the position error is {shown('auto', 'error')} at dt = 2.5e-4 … 3.125e-5, against "
        f"{shown('off', 'error')} with plain steps; the energy error {shown('auto', 'energy_error')} against "
        f"{shown('off', 'energy_error')}."
    ) in text


def test_the_fig4_tilt_paragraph_is_its_record():
    """reproduction.md's Fig. 4 paragraph: the tilts of the in-going and reflected tops, the pulse speed, the wall
    time and the head's speed amplitude, against daggers_cpu.json → fig4."""
    fig4 = record("reproduction/daggers_cpu.json")["items"]["fig4"]["values"]
    tilt, head = fig4["tilt"], fig4["head_speed_amplitude"]
    text = " ".join((DOCS / "reproduction.md").read_text().split())

    def listed(tilts: dict, skip=()) -> str:
        return ", ".join(f"{100 * abs(v):.1f} % ({k.replace('=', ' = ')})" for k, v in tilts.items() if k not in skip)

    assert (
        f"in-going {listed(tilt['in_going'])}; reflected {listed(tilt['reflected'], skip=('t=110.5',))} (pulse speed "
        f"{tilt['speed']:.2f}, reaches the wall at t = {tilt['t_wall']:.0f})"
    ) in text
    assert (
        f"(largest |v| of a snapshot {head['in_going'][0]:.3f}–{head['in_going'][1]:.3f} in-going, "
        f"{head['reflected'][0]:.3f}–{head['reflected'][1]:.3f} from 5 units after the wall to the end;"
    ) in text
    assert head["reflected_t"][0] == tilt["t_wall"] + 5


def test_the_design_arrangement_sentences_are_their_record():
    """design.md: where steel sits and how often beads alternate in the 6400-candidate and four-material designs,
    against the shuffle statistics of design/protector_cpu.json, and the materials' compliances."""
    from hertzian.core.materials import MATERIALS

    design = record("design/protector_cpu.json")
    text = " ".join((DOCS / "design.md").read_text().split())
    wide = design["population_6400"]["arrangement"]
    steel, switches = wide["materials"]["stainless_steel"], wide["switches"]
    assert (
        f"less markedly: {100 * steel['p_toward_striker']:.0f} % of the shuffles as close) with as few unlike neighbours "
        f"({switches['count']} against {switches['null_mean']:.1f}; p = {switches['p_at_most']:.3f})"
    ) in text
    four = design["four_materials"]["arrangement"]
    materials, switches = four["materials"], four["switches"]
    steel = materials["stainless_steel"]
    assert (
        f"mostly PTFE ({materials['ptfe']['beads']} beads) with steel toward the striker ({steel['beads']} beads at mean "
        f"position {steel['mean_position']:.2f}; {100 * steel['p_toward_striker']:.1f} % of the shuffles as close)"
    ) in text
    assert (
        f"({switches['count']} unlike neighbours against {switches['null_mean']:.1f}; "
        f"{100 * switches['p_at_most']:.0f} % of the shuffles as few). The {materials['aluminium']['beads']} aluminium "
        f"beads sit toward the wall (mean position {materials['aluminium']['mean_position']:.2f})"
    ) in text
    aluminium, glass, ptfe = (MATERIALS[n].compliance for n in ("aluminium", "glass", "ptfe"))
    assert abs(glass / aluminium - 1) < 0.03 and "within 3 % of each other" in text
    assert f"about {round(ptfe / glass, -1):.0f} times below PTFE's" in text
