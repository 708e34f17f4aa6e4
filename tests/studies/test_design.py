"""Protector design (hertzian.studies.design): the stored best is a plain run of that design, bit for bit; each
optimizer finds the optimum of a problem small enough to enumerate, and the genetic algorithm its Pareto front; a
resumed design equals one run straight through; bad designs are refused in one line before anything runs."""

from __future__ import annotations

import functools
import itertools

import hertzian as hz
import numpy as np
import pytest
from hertzian.core.errors import SceneError
from hertzian.core.static import static_state
from hertzian.studies.design import candidate, check_design, evaluate, load_design, objectives, optimise, probe_scene
from hertzian.studies.design_optimizers import pareto_front
from hertzian.studies.design_store import read_design

from tests.helpers import hertzian, make_scene, toml_text

BASE = dict(
    chain={"grains": 8, "material": "stainless_steel"},
    boundary={"surface": "free"},
    excitation={"impact": 1e-2},
    integrator={"dt": 2.5e-5, "duration": 2.0, "events": "off"},
)
DESIGN = {"materials": ["stainless_steel", "ptfe"], "radius": [0.7, 1.3], "population": 8, "generations": 3}


def design_file(tmp_path, design: dict) -> str:
    """A design file of BASE and ``design``."""
    path = tmp_path / "design.toml"
    path.write_text(toml_text({"scene": BASE, "design": design}))
    return str(path)


def test_the_stored_best_is_a_plain_run_of_that_design_bit_for_bit(tmp_path):
    scene = make_scene(**BASE)
    spec = check_design(scene, DESIGN)
    result = optimise(scene, spec, tmp_path / "d.zarr", device="cpu")
    stored = read_design(tmp_path / "d.zarr")
    assert stored["objective"].shape == (3, 8, 1)
    assert result.best_objective == stored["best_objective"][-1, 0] == np.min(stored["objective"])
    best = probe_scene(candidate(scene, spec, np.asarray(result.best_genome)))
    alone = hz.run(best, "cpu")  # the design alone, as `hertzian run` runs it
    assert objectives(spec, [best], alone).tolist() == [[result.best_objective]]
    assert np.all(np.diff(stored["best_objective"]) <= 0)


NINE = {**BASE, "chain": {"grains": 10, "material": "stainless_steel"}}
"""A steel striker and nine beads of steel or PTFE: 512 designs, few enough to run every one."""
EVERY = np.array(list(itertools.product([0.0, 1.0], repeat=9)))


@functools.cache
def every_design() -> np.ndarray:
    """The peak wall force and the protector mass of each of the 512 designs of NINE (one launch)."""
    scene = make_scene(**NINE)
    spec = check_design(scene, {"materials": ["stainless_steel", "ptfe"], "objective": ["peak_wall_force", "mass"]})
    values = evaluate(scene, spec, EVERY, "cpu")
    assert np.all(np.isfinite(values))
    return values


@pytest.mark.parametrize("optimizer", ["cma", "ga"])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_each_optimizer_finds_the_optimum_of_an_enumerable_two_material_chain(optimizer, seed, tmp_path):
    """Of NINE's 512 designs, CMA-ES and the genetic algorithm, 32 candidates a generation, find the one of the
    smallest peak within 8 generations (256 runs), whatever the seed."""
    scene = make_scene(**NINE)
    table = {"materials": ["stainless_steel", "ptfe"], "population": 32, "generations": 8, "seed": seed}
    spec = check_design(scene, {**table, "optimizer": optimizer})
    values = every_design()[:, 0]
    best = float(values.min())
    assert np.sum(values == best) == 1  # one optimum
    found = optimise(scene, spec, tmp_path / "d.zarr", device="cpu")
    assert found.best_objective == best
    np.testing.assert_array_equal(np.rint(found.best_genome), EVERY[np.argmin(values)])


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_genetic_algorithm_finds_the_pareto_front_of_an_enumerable_chain(seed, tmp_path):
    """Peak wall force against protector mass over NINE's 512 designs: the true front, by running every design, has
    5 designs; the genetic algorithm (32 a generation, 16 generations) finds at least 4 of them, whatever the seed,
    and every design it calls non-dominated is one it ran."""
    scene = make_scene(**NINE)
    table = {"materials": ["stainless_steel", "ptfe"], "objective": ["peak_wall_force", "mass"]}
    spec = check_design(scene, {**table, "population": 32, "generations": 16, "seed": seed})
    assert spec.optimizer == "ga"
    values = every_design()
    truth = {tuple(v) for v in values[pareto_front(values)]}
    assert len(truth) == 5
    found = optimise(scene, spec, tmp_path / "d.zarr", device="cpu")
    assert len({tuple(v) for v in found.pareto_objectives} & truth) >= 4
    ran = {tuple(v) for v in read_design(tmp_path / "d.zarr")["objective"].reshape(-1, 2)}
    assert {tuple(v) for v in found.pareto_objectives} <= ran


def test_the_pareto_front_is_every_non_dominated_row():
    values = np.array([[1.0, 5.0], [2.0, 2.0], [3.0, 1.0], [2.0, 3.0], [1.0, 5.0], [np.inf, 0.0], [4.0, 4.0]])
    assert pareto_front(values).tolist() == [0, 1, 2, 4]


@pytest.mark.parametrize("objective", [["peak_wall_force"], ["peak_wall_force", "mass"]])
def test_a_resumed_design_equals_one_run_straight_through(objective, tmp_path):
    path = design_file(tmp_path, {**DESIGN, "objective": objective})
    first = hertzian("design", path, "--out", tmp_path / "a.zarr", "--device", "cpu", "--generations", "2")
    assert first.returncode == 0, first.stderr
    more = hertzian("design", path, "--out", tmp_path / "a.zarr", "--device", "cpu", "--generations", "4", "--resume")
    assert more.returncode == 0, more.stderr
    straight = hertzian("design", path, "--out", tmp_path / "b.zarr", "--device", "cpu", "--generations", "4")
    assert straight.returncode == 0, straight.stderr
    a, b = read_design(tmp_path / "a.zarr"), read_design(tmp_path / "b.zarr")
    for name in ("genome", "objective", "best_genome", "best_objective"):
        np.testing.assert_array_equal(a[name], b[name], err_msg=name)
    assert a["genome"].shape[0] == 4


@pytest.mark.parametrize(
    "change, key",
    [
        ({"radius": [0.0, 1.0]}, "design.radius"),
        ({"materials": ["stainless_steel", "unobtainium"]}, "design.materials"),
        ({"total_length": 5000.0}, "design.total_length"),
        ({"total_mass": 5.0}, "design.total_mass"),
        ({"total_mass": 0.6, "total_length": 700.0}, "design.total_mass"),
        ({"total_mass": -1.0}, "design.total_mass"),
        ({"vary": [0, 8]}, "design.vary"),
        ({"population": 1}, "design.population"),
        ({"objective": "fastest"}, "design.objective"),
        ({"objective": ["mass", "mass"]}, "design.objective"),
        ({"objective": ["peak_wall_force", "mass"], "optimizer": "cma"}, "design.optimizer"),
        ({"optimizer": "simplex"}, "design.optimizer"),
        ({"optimizer": "ga", "sigma": 0.2}, "design.sigma"),
        ({"popsize": 10}, "design.popsize"),
    ],
)
def test_bad_designs_are_one_line_and_write_nothing(tmp_path, change, key):
    path = design_file(tmp_path, {**DESIGN, **change})
    result = hertzian("design", path, "--out", tmp_path / "d.zarr", "--device", "cpu")
    assert result.returncode == 2, result.stderr
    assert result.stderr.startswith(f"error: {key} = ") and result.stderr.count("\n") == 1, result.stderr
    assert not (tmp_path / "d.zarr").exists()
    with pytest.raises(SceneError):
        load_design(path)


@pytest.mark.parametrize(
    "change, key",
    [
        ({"boundary": {"surface": "free", "bottom": "free"}}, "scene.boundary.bottom"),
        ({"boundary": {"surface": "wall"}}, "scene.boundary.surface"),
        ({"chain": {"grains": 8, "material": "stainless_steel", "gravity": 1.0}}, "scene.chain.gravity"),
    ],
)
def test_a_design_needs_a_wall_behind_a_chain_that_can_leave_it(change, key):
    scene = make_scene(**{**BASE, **change})
    with pytest.raises(SceneError, match=rf"^{key} = "):
        check_design(scene, DESIGN)


def test_the_total_length_is_kept_within_the_bounds():
    scene = make_scene(**BASE)
    spec = check_design(scene, {**DESIGN, "total_length": 7 * 100.0 * 1.2})
    rng = np.random.default_rng(3)
    for genes in rng.uniform(0, 1, (20, len(spec.gene_names))):
        ratios = candidate(scene, spec, genes).chain.radius_ratios[1:]
        assert ratios.sum() == pytest.approx(7 * 1.2, rel=1e-12)
        assert ratios.min() >= 0.7 - 1e-12 and ratios.max() <= 1.3 + 1e-12


def test_the_total_mass_is_kept_within_the_bounds_or_the_candidate_is_out():
    """Seven beads of steel (0.178 at R0) or PTFE (0.049) with R/R0 in [0.7, 1.3]: a mass every mix can reach is met
    to 1e-12 by rescaling the radii; a mass that all-PTFE cannot reach makes that design infinite, not the others."""
    scene = make_scene(**BASE)
    reachable = check_design(scene, {**DESIGN, "total_mass": 0.6})
    rng = np.random.default_rng(4)
    for genes in rng.uniform(0, 1, (20, len(reachable.gene_names))):
        genes[:7] = np.rint(genes[:7])
        design = candidate(scene, reachable, genes)
        ratios = design.chain.radius_ratios[1:]
        assert static_state(design).mass[1:].sum() == pytest.approx(0.6, rel=1e-12)
        assert ratios.min() >= 0.7 - 1e-12 and ratios.max() <= 1.3 + 1e-12
    heavy = check_design(scene, {**DESIGN, "total_mass": 1.0, "objective": ["peak_wall_force", "mass"]})
    steel, ptfe = np.r_[np.zeros(7), np.full(7, 0.5)], np.r_[np.ones(7), np.full(7, 0.5)]
    values = evaluate(scene, heavy, np.array([steel, ptfe]), "cpu")
    assert np.all(np.isfinite(values[0])) and values[0, 1] == pytest.approx(1.0, rel=1e-9)
    assert np.all(np.isinf(values[1]))


def test_a_candidate_is_judged_only_once_its_peak_cannot_be_exceeded():
    """A run cut while the chain still presses on the wall says nothing (infinite objective); once the energy left
    could not press harder than the peak seen, that peak is the one a longer run finds."""
    genes = None
    values = {}
    for duration in (0.08, 0.1, 0.3):
        scene = make_scene(**{**BASE, "integrator": {"dt": 2.5e-5, "duration": duration, "events": "off"}})
        spec = check_design(scene, DESIGN)
        genes = np.full((1, len(spec.gene_names)), 0.5) if genes is None else genes
        values[duration] = evaluate(scene, spec, genes, "cpu")[0, 0]
    assert np.isinf(values[0.08]) and np.isfinite(values[0.1])
    assert values[0.1] == values[0.3]


def test_plot_draws_a_design_store_and_writes_its_numbers(tmp_path):
    import json

    path = design_file(tmp_path, {**DESIGN, "generations": 2})
    made = hertzian("design", path, "--out", tmp_path / "d.zarr", "--device", "cpu")
    assert made.returncode == 0, made.stderr
    drawn = hertzian("plot", tmp_path / "d.zarr", "--out", tmp_path / "d.png")
    assert drawn.returncode == 0, drawn.stderr
    assert (tmp_path / "d.png").stat().st_size > 10_000
    numbers = json.loads((tmp_path / "d.json").read_text())
    stored = read_design(tmp_path / "d.zarr")
    assert numbers["chains"]["best"]["objective"] == stored["best_objective"][-1, 0]
    assert "pareto" not in numbers
    assert sum(m["beads"] for m in numbers["arrangement"]["materials"].values()) == 7
    assert 0 < numbers["chains"]["best"]["time_above_half_peak"] < BASE["integrator"]["duration"]
    assert set(numbers["chains"]) == {
        "best",
        "uniform stainless_steel",
        "tapered stainless_steel",
        "uniform ptfe",
        "tapered ptfe",
    }
    refused = hertzian("plot", tmp_path / "d.zarr", "--figure", "fig1", "--out", tmp_path / "e.png")
    assert refused.returncode == 2 and refused.stderr.count("\n") == 1 and not (tmp_path / "e.png").exists()
    _half_step_peaks_are_runs_at_half_the_step(tmp_path / "d.zarr", numbers)


def _half_step_peaks_are_runs_at_half_the_step(store, numbers: dict) -> None:
    """The plot's numbers at smaller steps against runs made here: the best design at dt/2 and dt/4 with both event
    settings, and a plain protector at dt/2."""
    from hertzian.core.runner import run_scene
    from hertzian.studies.design import candidate, probe_scene, references, stored_design, wall_forces

    data, scene, spec = stored_design(store)
    best = candidate(scene, spec, data["best_genome"][-1])
    chains = {"best": best, "uniform ptfe": references(scene, spec, best)["uniform ptfe"]}

    def peak(chain, divisor: int, events: str) -> float:
        probe = probe_scene(
            chain.with_overrides({"integrator.dt": chain.integrator.dt / divisor, "integrator.events": events})
        )
        return float(wall_forces(probe, run_scene(probe, "cpu").traces["u"][0, :, 0]).max())

    rows = numbers["best_peak_by_step"]
    assert [(r["events"], r["dt"] / best.integrator.dt) for r in rows] == [
        (e, 1 / d) for e in ("off", "auto") for d in (1, 2, 4)
    ]
    for row in rows[1:3] + rows[4:]:
        assert row["peak_wall_force"] == peak(best, round(best.integrator.dt / row["dt"]), row["events"])
    for name, chain in chains.items():
        assert numbers["chains"][name]["peak_wall_force_at_half_dt"] == peak(chain, 2, chain.integrator.events), name


def test_arrangement_is_read_against_the_same_beads_shuffled():
    """Closed forms: k beads of one kind among n in random order have 2k(n − k)/n unlike neighbours on average and a
    mean position of 1/2; beads sorted to one end are further than any but a few of the shuffles."""
    from hertzian.studies.design import arrangement

    sorted_beads = ["S"] * 7 + ["P"] * 12
    found = arrangement(sorted_beads, ["S", "P"])
    assert found["switches"]["count"] == 1
    assert found["switches"]["null_mean"] == pytest.approx(2 * 7 * 12 / 19, rel=0.01)
    assert found["switches"]["p_at_most"] < 1e-3 and found["switches"]["p_at_least"] == 1.0
    assert found["materials"]["S"]["mean_position"] == pytest.approx(3 / 18)
    assert found["materials"]["P"]["p_toward_wall"] < 1e-3 and found["materials"]["S"]["p_toward_striker"] < 1e-3
    alternating = arrangement(["S", "P"] * 9 + ["S"], ["S", "P"])
    assert alternating["switches"]["count"] == 18 and alternating["switches"]["p_at_least"] < 1e-3
    assert 0.05 < alternating["materials"]["P"]["p_toward_wall"] < 0.95


def test_time_above_a_fraction_of_the_peak_of_a_triangle():
    from hertzian.studies.design import time_above

    t = np.linspace(0.0, 2.0, 2001)
    force = 1.0 - np.abs(t - 1.0)
    assert time_above(force, t, 0.5) == pytest.approx(1.0, abs=2e-3)


def test_plot_of_two_objectives_draws_their_front(tmp_path):
    import json

    path = design_file(tmp_path, {**DESIGN, "generations": 2, "objective": ["peak_wall_force", "mass"]})
    made = hertzian("design", path, "--out", tmp_path / "d.zarr", "--device", "cpu")
    assert made.returncode == 0 and "Pareto front of" in made.stdout, made.stderr
    drawn = hertzian("plot", tmp_path / "d.zarr", "--out", tmp_path / "d.png")
    assert drawn.returncode == 0, drawn.stderr
    numbers = json.loads((tmp_path / "d.json").read_text())
    stored = read_design(tmp_path / "d.zarr")
    values = stored["objective"].reshape(-1, 2)
    front = [p["objectives"] for p in numbers["pareto"]]
    assert sorted(map(tuple, front)) == sorted(map(tuple, values[pareto_front(values)].tolist()))
    assert len(numbers["candidates"]) == int(np.all(np.isfinite(values), axis=1).sum())


def test_a_bad_override_on_the_command_line_is_refused(tmp_path):
    path = design_file(tmp_path, DESIGN)
    result = hertzian("design", path, "--out", tmp_path / "d.zarr", "--device", "cpu", "--generations", "0")
    assert result.returncode == 2 and result.stderr.startswith("error: design.generations = 0"), result.stderr
    assert not (tmp_path / "d.zarr").exists()


def test_a_missing_design_file_is_named_as_one(tmp_path):
    result = hertzian("design", tmp_path / "nothing.toml", "--out", tmp_path / "d.zarr", "--device", "cpu")
    assert (
        result.returncode == 2
        and result.stderr == f"error: design file = '{tmp_path / 'nothing.toml'}': no such file\n"
    )
    assert not (tmp_path / "d.zarr").exists()


def test_the_study_record_merges_each_part_under_its_name(tmp_path):
    import json
    import subprocess
    import sys

    path = design_file(tmp_path, {**DESIGN, "generations": 2})
    out = tmp_path / "record.json"
    other = {"command": "python -m hertzian.studies.design_record --part other", "kept": True}
    out.write_text(json.dumps({"other": other}))  # a record of the project's (a user's file is refused)
    command = [sys.executable, "-m", "hertzian.studies.design_record", "--out", str(out), "--part", "small"]
    command += ["--design", path, "--set", "design.population=4", "--store", str(tmp_path / "s.zarr")]
    done = subprocess.run(command, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    record = json.loads(out.read_text())
    assert record["other"] == other
    part = record["small"]
    assert part["design"]["population"] == 4 and len(part["best_objective"]) == 2
    assert "--set design.population=4" in part["command"] and "traces" not in part
    assert part["chains"]["best"]["objective"] == read_design(tmp_path / "s.zarr")["best_objective"][-1, 0]


def test_a_generation_too_big_for_memory_runs_in_parts_with_the_same_objectives(monkeypatch):
    """Each candidate keeps its wall grain's trace at every step: a generation that would not fit in memory at once
    runs as several ensembles, and every candidate's objectives are those of one run of all."""
    from hertzian.studies import design

    scene = make_scene(**BASE)
    spec = check_design(scene, DESIGN)
    genomes = np.random.default_rng(5).uniform(0, 1, (7, len(spec.gene_names)))
    genomes[:, :7] = np.rint(genomes[:, :7])
    whole = evaluate(scene, spec, genomes, "cpu")
    assert design.candidates_per_run(probe_scene(scene), "cpu") >= 7
    monkeypatch.setattr(design, "candidates_per_run", lambda probe, device: 3)
    np.testing.assert_array_equal(evaluate(scene, spec, genomes, "cpu"), whole)


def test_candidates_per_run_follows_the_free_memory(monkeypatch):
    from hertzian.core import check
    from hertzian.studies import design

    probe = probe_scene(make_scene(**BASE))
    per = sum(check.memory_needed(probe, 1).values())
    monkeypatch.setattr(check, "available_host_bytes", lambda: int(40 * per / design.MEMORY_SHARE))
    assert design.candidates_per_run(probe, "cpu") == 40
    monkeypatch.setattr(check, "available_host_bytes", lambda: 0)
    assert design.candidates_per_run(probe, "cpu") == 1


def test_plain_protectors_share_the_designs_length_or_its_mass():
    from hertzian.studies.design import references

    scene = make_scene(**BASE)
    genes = np.r_[np.array([0, 1, 0, 1, 1, 0, 1.0]), np.linspace(0.1, 0.9, 7)]
    for table, measure, target in (
        ({"total_length": 7 * 100.0 * 1.1}, lambda s: 2 * np.sum(s.chain.radius_ratios[1:]) * 50.0, 770.0),
        ({"total_mass": 0.6}, lambda s: static_state(s).mass[1:].sum(), 0.6),
    ):
        spec = check_design(scene, {**DESIGN, **table})
        chains = references(scene, spec, candidate(scene, spec, genes))
        assert len(chains) == 5
        for name, chain in chains.items():
            assert measure(chain) == pytest.approx(target, rel=1e-12), name


def test_set_overrides_design_and_scene_keys_and_refuses_others(tmp_path):
    path = design_file(tmp_path, DESIGN)
    out = tmp_path / "d.zarr"
    args = ["design", path, "--out", out, "--device", "cpu", "--set", "design.generations=1"]
    made = hertzian(*args, "--set", "scene.chain.grains=6", "--set", "design.population=3")
    assert made.returncode == 0, made.stderr
    stored = read_design(out)
    assert stored["attrs"]["scene"]["chain"]["grains"] == 6 and stored["objective"].shape == (1, 3, 1)
    for key, message in (
        ("chain.grains=6", "error: chain.grains = 6: a design run takes design.KEY"),
        ("scene.chain.color=3", "error: chain.color"),
    ):
        refused = hertzian("design", path, "--out", tmp_path / "e.zarr", "--set", key)
        assert refused.returncode == 2 and refused.stderr.startswith(message), refused.stderr
        assert refused.stderr.count("\n") == 1 and not (tmp_path / "e.zarr").exists()
    result = hz.design(path, tmp_path / "f.zarr", "cpu", scene_overrides={"chain.grains": 6}, generations=1)
    assert len(result.best_scene["chain"]["material"]) == 6


@pytest.fixture(scope="module")
def fixed_length_store(tmp_path_factory):
    """A design store of 3 generations whose beads' diameters must sum to 700 (7 beads of R/R0 1 on average)."""
    folder = tmp_path_factory.mktemp("design")
    path = design_file(folder, {**DESIGN, "total_length": 700.0})
    made = hertzian("design", path, "--out", folder / "d.zarr", "--device", "cpu")
    assert made.returncode == 0, made.stderr
    return folder / "d.zarr"


def test_summarize_reads_a_design_store(fixed_length_store):
    """The JSON against the store's raw arrays and the design's own constraint (the diameters sum to 700)."""
    import json

    shown = hertzian("summarize", fixed_length_store, "--json")
    assert shown.returncode == 0, shown.stderr
    numbers = json.loads(shown.stdout)
    stored = read_design(fixed_length_store)
    first = stored["best_objective"][:, 0]
    assert numbers["generations_done"] == numbers["generations"] == 3 and numbers["population"] == 8
    assert numbers["best"] == {"peak_wall_force": first[-1]} and first[-1] == np.min(stored["objective"])
    assert numbers["best_since_generation"] == 1 + min(g for g in range(3) if first[g] == first[-1])  # counted from 1
    assert numbers["seconds"] == pytest.approx(np.sum(stored["seconds"]), rel=1e-12)
    assert set(numbers["best_materials"]) <= {"stainless_steel", "ptfe"} and len(numbers["best_materials"]) == 7
    ratio = np.array(numbers["best_radius_ratio"])
    assert np.all((ratio >= 0.7 - 1e-12) & (ratio <= 1.3 + 1e-12))
    assert 2 * 50.0 * ratio.sum() == pytest.approx(700.0, rel=1e-12)
    text = hertzian("summarize", fixed_length_store)
    assert text.returncode == 0 and "3 of 3 generations of 8 candidates (cma, seed 0)" in text.stdout
    assert f"peak_wall_force {first[-1]:.6g}" in text.stdout and text.stdout.count("striker → ") == 1
    refused = hertzian("summarize", fixed_length_store, "--over", "seed")
    assert refused.returncode == 2 and refused.stderr.count("\n") == 1


def test_summary_names_the_generation_since_which_the_best_holds(fixed_length_store, tmp_path):
    """A best reached at the second generation and kept at the third (written into a copy of the store): since
    generation 2, counted from 1 as the progress lines, the plot's axis and the store's coordinate count."""
    import shutil

    import zarr
    from hertzian.studies.design import summary

    store = tmp_path / "d.zarr"
    shutil.copytree(fixed_length_store, store)
    zarr.open_group(store, mode="r+")["best_objective"][:, 0] = [0.3, 0.2, 0.2]
    numbers = summary(store)
    assert numbers["best"] == {"peak_wall_force": 0.2} and numbers["best_since_generation"] == 2
    shown = hertzian("summarize", store)
    assert shown.returncode == 0 and "peak_wall_force unchanged since generation 2\n" in shown.stdout, shown.stdout


def test_a_design_store_is_checksummed_and_verify_names_a_damaged_generation(fixed_length_store, tmp_path):
    import shutil

    import zarr
    from hertzian.sweeping.store_format import has_checksums

    store = tmp_path / "d.zarr"
    shutil.copytree(fixed_length_store, store)
    root = zarr.open_group(store, mode="r")
    assert all(has_checksums(root[name]) for name in ("genome", "objective", "best_genome", "best_objective"))
    clean = hertzian("verify", store)
    assert clean.returncode == 0 and f"{store}: 15 chunks read, 0 damaged" in clean.stdout, clean.stderr
    chunk = next((store / "genome" / "c" / "1").rglob("*"))  # index 1: the second generation
    while chunk.is_dir():
        chunk = next(chunk.iterdir())
    data = bytearray(chunk.read_bytes())
    data[len(data) // 2] ^= 0xFF
    chunk.write_bytes(bytes(data))
    damaged = hertzian("verify", store)
    assert damaged.returncode == 1 and "damaged: genome: generation 2:" in damaged.stdout, damaged.stdout
    for command, code in ((["summarize", store], 1), (["plot", store, "--out", tmp_path / "d.png"], 2)):
        result = hertzian(*command)
        assert result.returncode == code and result.stderr.count("\n") == 1, (command, result.stderr)
        assert "genome: a damaged chunk" in result.stderr
    path = design_file(tmp_path, {**DESIGN, "total_length": 700.0, "generations": 4})
    resumed = hertzian("design", path, "--out", store, "--resume", "--device", "cpu")
    assert (
        resumed.returncode == 2
        and resumed.stderr == f"error: --out = '{store}': generation 2 is damaged (ValueError)\n"
    )


def test_open_store_labels_a_design_store(fixed_length_store):
    """hz.open_store reads a design store as it reads a sweep store: a labelled Dataset, here against the raw
    arrays; the genes and objectives are named."""
    ds = hz.open_store(fixed_length_store)
    stored = read_design(fixed_length_store)
    assert ds.sizes == {"generation": 3, "candidate": 8, "gene": 7 + 7, "objective": 1}
    assert list(ds["generation"].values) == [1, 2, 3]  # as the progress lines and the plot's axis count them
    assert list(ds["objective"].values) == ["peak_wall_force"] and ds["gene"].values[0] == "material[1]"
    np.testing.assert_array_equal(ds["objectives"].values, stored["objective"])
    np.testing.assert_array_equal(ds["best_genome"].values, stored["best_genome"])
    assert float(ds["best_objectives"].sel(objective="peak_wall_force").min()) == np.min(stored["objective"])
