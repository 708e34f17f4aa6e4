"""Protector design: which beads, of which materials and sizes, transmit the smallest peak force to the wall behind
them (Fraternali, Porter & Daraio, Mech. Adv. Mater. Struct. 17, 1 (2010)), by CMA-ES or a genetic algorithm
(hertzian.studies.design_optimizers) over a whole population per launch; with several objectives, their Pareto front.

A design file holds a base scene (``[scene]``: the striker is grain 0, struck at ``excitation.impact``; the bottom is a
wall) and a ``[design]`` table: the grains that vary, the materials they may take, the bounds of their radii
(r = R/R0), optional mirror symmetry and a fixed total length, the objectives, the optimizer, the population, the
generations and the seed. Every generation is one ensemble run of all its candidates (``hertzian.core.runner.run_ensemble``), stored in a Zarr store
with its genomes and objectives; a run resumes where it stopped (the stored generations replayed into an optimizer of
the same seed) and a seed reproduces it. The genes: one per varying grain for its material (an integer, the index into ``materials``), and with
``radius`` one per varying grain for its radius ratio (scaled to [0, 1]); with ``mirror`` only the first half of the
varying grains carry genes and the rest mirror them.
"""

from __future__ import annotations

import math
import time
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, Callable

import numpy as np
from hertzian.core.errors import SceneError
from hertzian.core.materials import MATERIALS
from hertzian.core.scene import Scene, read_toml, refuse_other_kind, scene_from_dict
from hertzian.studies.design_optimizers import OPTIMIZERS, new_optimizer, pareto_front

OBJECTIVES = ("peak_wall_force", "impulse", "mass")
"""What a design minimises: the largest force on the bottom wall, the impulse it receives (∫ F dt over the run),
or the protector's mass (the varying grains')."""
DESIGN_KEYS = (
    "vary",
    "materials",
    "radius",
    "mirror",
    "total_length",
    "total_mass",
    "objective",
    "optimizer",
    "population",
    "generations",
    "seed",
    "sigma",
)


@dataclass(frozen=True)
class DesignSpec:
    """The ``[design]`` table, checked."""

    vary: tuple[int, ...]
    """Grains whose material (and radius) the optimizer chooses (default: every grain but the striker, 0)."""
    materials: tuple[str, ...]
    """The materials a varying grain may take."""
    radius: tuple[float, float] | None = None
    """Bounds (lo, hi) of a varying grain's radius ratio R/R0; None: radii as in the base scene."""
    mirror: bool = False
    """Grain vary[k] takes the genes of vary[n − 1 − k]: a protector symmetric about its middle."""
    total_length: float | None = None
    """Sum of the varying grains' diameters [length], kept by rescaling their radii within the bounds."""
    total_mass: float | None = None
    """Sum of the varying grains' masses [mass], kept by rescaling their radii within the bounds; a candidate whose
    materials cannot reach it there is infinite."""
    objective: tuple[str, ...] = ("peak_wall_force",)
    """What the design minimises (OBJECTIVES); several: their Pareto front."""
    optimizer: str = "cma"
    """cma (one objective) | ga (hertzian.studies.design_optimizers); default: cma for one objective, else ga."""
    population: int = 64
    generations: int = 50
    seed: int = 0
    sigma: float | None = None
    """CMA-ES step size, in units of a gene's range (a material gene's range is the number of choices − 1); None:
    0.3 (cma). The genetic algorithm takes none."""

    @property
    def step_size(self) -> float:
        """CMA-ES's step size: ``sigma``, or 0.3."""
        return 0.3 if self.sigma is None else self.sigma

    @property
    def gene_grains(self) -> tuple[int, ...]:
        """The varying grains that carry genes (the first half with ``mirror``)."""
        return self.vary[: math.ceil(len(self.vary) / 2)] if self.mirror else self.vary

    @property
    def gene_names(self) -> list[str]:
        """One name per gene: ``material[g]`` then ``radius[g]`` for each gene grain g."""
        names = [f"material[{g}]" for g in self.gene_grains]
        return names + ([f"radius[{g}]" for g in self.gene_grains] if self.radius else [])


def load_design(
    path: str | Path, overrides: dict[str, Any] | None = None, scene_overrides: dict[str, Any] | None = None
) -> tuple[Scene, DesignSpec]:
    """(base scene, design) of a design file (``overrides`` replace ``[design]`` keys, ``scene_overrides`` dotted
    keys of its ``[scene]``, e.g. ``chain.grains``); bad input raises one line (SceneError) before anything runs."""
    from hertzian.core.scene import apply_overrides

    data = read_toml(path, "design file")
    refuse_other_kind(data, path, "design")
    for key in data:
        if key not in ("scene", "design"):
            raise SceneError(key, "(table)", "a design file holds [scene] and [design]")
    if not isinstance(data.get("scene"), dict) or not isinstance(data.get("design"), dict):
        raise SceneError("design", str(path), "needs a [scene] table (the base scene) and a [design] table")
    scene = scene_from_dict(apply_overrides(data["scene"], scene_overrides or {}))
    return scene, check_design(scene, {**data["design"], **(overrides or {})})


def split_overrides(overrides: dict[str, Any]) -> tuple[dict[str, Any], dict[str, Any]]:
    """``--set`` keys of a design run as ([design] keys, [scene] keys): ``design.KEY`` and ``scene.SECTION.KEY``;
    any other key is refused in one line (SceneError)."""
    design, scene = {}, {}
    for key, value in overrides.items():
        head, _, rest = key.partition(".")
        if head == "design" and rest:
            design[rest] = value
        elif head == "scene" and rest:
            scene[rest] = value
        else:
            raise SceneError(key, value, "a design run takes design.KEY or scene.SECTION.KEY")
    return design, scene


def check_design(scene: Scene, table: dict[str, Any]) -> DesignSpec:
    """The ``[design]`` table as a DesignSpec for ``scene``, or one line (SceneError) naming the key."""
    for key in table:
        if key not in DESIGN_KEYS:
            raise SceneError(f"design.{key}", table[key], f"unknown key; allowed: {', '.join(DESIGN_KEYS)}")
    n = scene.chain.grains
    if scene.boundary.bottom != "wall":
        raise SceneError("scene.boundary.bottom", scene.boundary.bottom, 'must be "wall": the design reads its force')
    if scene.boundary.surface != "free":
        raise SceneError(
            "scene.boundary.surface", scene.boundary.surface, 'must be "free": the chain must be able to leave the wall'
        )
    if scene.chain.gravity != 0 or scene.chain.load is not None:
        raise SceneError(
            "scene.chain.gravity",
            scene.chain.gravity,
            "must be 0 without a load: nothing may hold the chain on the wall",
        )
    if scene.chain.material is None:
        raise SceneError("scene.chain.material", None, "is required: the base chain's materials (the striker's first)")
    vary = table.get("vary", list(range(1, n)))
    if not _int_list(vary) or not vary or len(set(vary)) != len(vary) or min(vary) < 0 or max(vary) >= n:
        raise SceneError("design.vary", vary, f"must be distinct grain indices in 0 … {n - 1}")
    known = [*MATERIALS, *(m.name for m in scene.materials)]
    materials = table.get("materials")
    if not isinstance(materials, list) or not materials or not all(isinstance(m, str) for m in materials):
        raise SceneError("design.materials", materials, f"must be a list of material names ({', '.join(known)})")
    for name in materials:
        if name not in known:
            raise SceneError("design.materials", name, f"not a material here; one of {', '.join(known)}")
    spec = DesignSpec(vary=tuple(int(g) for g in vary), materials=tuple(materials), **_numbers(table))
    _check_bounds(scene, spec)
    return spec


def _int_list(value) -> bool:
    return isinstance(value, list) and all(isinstance(g, int) and not isinstance(g, bool) for g in value)


def _numbers(table: dict[str, Any]) -> dict[str, Any]:
    """The design's scalar keys, each checked."""
    out: dict[str, Any] = {}
    for key, low in (("population", 2), ("generations", 1)):
        value = table.get(key, getattr(DesignSpec, key))
        if not isinstance(value, int) or isinstance(value, bool) or value < low:
            raise SceneError(f"design.{key}", value, f"must be a whole number ≥ {low}")
        out[key] = value
    seed = table.get("seed", 0)
    if not isinstance(seed, int) or isinstance(seed, bool) or seed < 0:
        raise SceneError("design.seed", seed, "must be a whole number ≥ 0")
    objective = table.get("objective", "peak_wall_force")
    names = [objective] if isinstance(objective, str) else objective
    if not isinstance(names, list) or not names or len(set(map(str, names))) != len(names):
        raise SceneError("design.objective", objective, f"one or a list of distinct ones of {', '.join(OBJECTIVES)}")
    for name in names:
        if name not in OBJECTIVES:
            raise SceneError("design.objective", name, f"one of {', '.join(OBJECTIVES)}")
    optimizer = table.get("optimizer", "cma" if len(names) == 1 else "ga")
    if optimizer not in OPTIMIZERS:
        raise SceneError("design.optimizer", optimizer, f"one of {', '.join(OPTIMIZERS)}")
    if optimizer == "cma" and len(names) > 1:
        raise SceneError("design.optimizer", optimizer, 'takes one objective; several need "ga" (a Pareto front)')
    sigma = table.get("sigma")
    if sigma is not None and optimizer != "cma":
        raise SceneError("design.sigma", sigma, "is CMA-ES's step size; ga takes none")
    if sigma is not None and (isinstance(sigma, bool) or not isinstance(sigma, (int, float)) or not 0 < sigma <= 1):
        raise SceneError("design.sigma", sigma, "must be a number in (0, 1]")
    mirror = table.get("mirror", False)
    if not isinstance(mirror, bool):
        raise SceneError("design.mirror", mirror, "must be true or false")
    radius = table.get("radius")
    if radius is not None:
        ok = isinstance(radius, list) and len(radius) == 2 and all(_number(r) for r in radius)
        if not ok or not 0 < radius[0] < radius[1] or not math.isfinite(radius[1]):
            raise SceneError("design.radius", radius, "must be [lo, hi] with 0 < lo < hi (radius ratios R/R0)")
        radius = (float(radius[0]), float(radius[1]))
    length = table.get("total_length")
    if length is not None and (not _number(length) or not length > 0):
        raise SceneError("design.total_length", length, "must be a length > 0 (the varying grains' diameters)")
    mass = table.get("total_mass")
    if mass is not None and (not _number(mass) or not mass > 0):
        raise SceneError("design.total_mass", mass, "must be a mass > 0 (the varying grains' masses)")
    if mass is not None and length is not None:
        raise SceneError("design.total_mass", mass, "give one of design.total_length and design.total_mass")
    return {
        **out,
        "seed": seed,
        "sigma": None if sigma is None else float(sigma),
        "objective": tuple(names),
        "optimizer": optimizer,
        "mirror": mirror,
        "radius": radius,
        "total_length": length,
        "total_mass": None if mass is None else float(mass),
    }


def _number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def _check_bounds(scene: Scene, spec: DesignSpec) -> None:
    """A total length, or a total mass, that the radius bounds cannot reach with any of the materials is refused."""
    key, target = ("total_length", spec.total_length) if spec.total_mass is None else ("total_mass", spec.total_mass)
    if target is None:
        return
    if spec.radius is None:
        raise SceneError(f"design.{key}", target, "needs design.radius (the radii it rescales)")
    count = len(spec.vary)
    if key == "total_length":
        lo, hi = (count * scene.chain.diameter * r for r in spec.radius)
        what = "span"
    else:
        masses = _reference_masses(scene, list(spec.materials))
        lo, hi = count * masses.min() * spec.radius[0] ** 3, count * masses.max() * spec.radius[1] ** 3
        what = "weigh"
    if not lo <= target <= hi:
        raise SceneError(
            f"design.{key}", target, f"out of reach of the radius bounds: {count} grains {what} {lo:g} … {hi:g}"
        )


def _reference_masses(scene: Scene, names: list[str]) -> np.ndarray:
    """The mass of a grain of the base diameter in each material of ``names`` [mass]."""
    from hertzian.core.materials import reference_masses, scene_material

    return reference_masses([scene_material(scene, name) for name in names], [scene.chain.diameter])[0]


# ---- genomes → scenes ---------------------------------------------------------------------------------------


def candidate(scene: Scene, spec: DesignSpec, genes: np.ndarray) -> Scene:
    """The scene of one genome: the base scene with the varying grains' materials (and radii) set."""
    n = scene.chain.grains
    from hertzian.core.materials import pattern_index

    names, index = pattern_index(scene.chain.material, n)
    materials = [names[i] for i in index]
    count = len(spec.gene_grains)
    choice = np.clip(np.rint(genes[:count]), 0, len(spec.materials) - 1).astype(int)
    for k, g in enumerate(spec.vary):
        materials[g] = spec.materials[choice[_gene_of(spec, k)]]
    data = scene.to_dict()
    data["chain"]["material"] = materials
    if spec.radius is not None:
        base = scene.chain.radius_ratios
        ratios = np.ones(n) if base is None else np.array(base)
        lo, hi = spec.radius
        scaled = lo + np.clip(genes[count:], 0.0, 1.0) * (hi - lo)
        ratios[list(spec.vary)] = [scaled[_gene_of(spec, k)] for k in range(len(spec.vary))]
        vary = list(spec.vary)
        if spec.total_length is not None:
            target = spec.total_length / scene.chain.diameter  # the ratios' sum
            ratios[vary] = _rescaled(ratios[vary], spec.radius, np.ones(len(vary)), 1.0, target)
        if spec.total_mass is not None:
            weights = _reference_masses(scene, [materials[g] for g in vary])
            ratios[vary] = _rescaled(ratios[vary], spec.radius, weights, 3.0, spec.total_mass)
        data["chain"]["radii"] = (0.5 * scene.chain.diameter * ratios).tolist()
    return scene_from_dict(data)


def _gene_of(spec: DesignSpec, k: int) -> int:
    """The gene index of the k-th varying grain (mirrored: the first half's)."""
    return min(k, len(spec.vary) - 1 - k) if spec.mirror else k


def _rescaled(ratios: np.ndarray, bounds: tuple[float, float], weights: np.ndarray, power: float, target: float):
    """Ratios r scaled so that Σ w r^power is ``target``, within the bounds (clipped grains keep their bound, the
    rest take the remainder; at most one pass per grain). A target these materials cannot reach within the bounds
    is missed: the caller checks."""
    lo, hi = bounds
    out = ratios.copy()
    for _ in range(len(out) + 1):
        free = (out > lo) & (out < hi) if np.any((out > lo) & (out < hi)) else np.ones(len(out), bool)
        terms = weights * out**power
        scale = ((target - terms[~free].sum()) / terms[free].sum()) ** (1.0 / power)
        out[free] = np.clip(out[free] * scale, lo, hi)
        if abs(np.sum(weights * out**power) - target) <= 1e-12 * target:
            break
    return out


# ---- evaluating a generation -------------------------------------------------------------------------------


def probe_scene(scene: Scene) -> Scene:
    """The scene as a design evaluates it: the bottom grain traced every step, u and v at the start and the end."""
    n = scene.chain.grains
    data = scene.to_dict()
    data["record"] = {**data["record"], "traces": [n - 1], "trace_every": None, "fields": ["u", "v"], "every": None}
    return scene_from_dict(data)


LEFTOVER = 1.0
"""A run has seen a candidate's peak once the energy still able to reach the wall at its end could not press on it
harder than that peak (:func:`leftover_force` ≤ LEFTOVER × the peak); else the candidate's objective is infinite, so
``integrator.duration`` must let the slowest design's pulse come back off the wall."""


def leftover_force(scene: Scene, u: np.ndarray, v: np.ndarray, st=None) -> float:
    """The largest force the energy left at displacements ``u`` and velocities ``v`` (N,) could put on the bottom
    wall [force]: the kinetic energy of grains moving toward the wall, of neighbours closing on each other (their
    relative motion, ½ μ Δv²) and the energy of compressed contacts, all put into the wall contact. ``st``: the
    scene's static state when the caller has it."""
    from hertzian.core.static import static_state

    st = static_state(scene) if st is None else st
    n = scene.chain.exponent
    toward = 0.5 * float(np.sum(st.mass * np.maximum(v, 0.0) ** 2))
    reduced = st.mass[:-1] * st.mass[1:] / (st.mass[:-1] + st.mass[1:])
    closing = 0.5 * float(np.sum(reduced * np.maximum(v[:-1] - v[1:], 0.0) ** 2))
    overlaps = np.concatenate([st.static_overlap[1:-1] + u[:-1] - u[1:], [st.static_overlap[-1] + u[-1]]])
    stored = float(np.sum(st.contact_constant[1:] * np.maximum(overlaps, 0.0) ** n))
    wall = st.contact_constant[-1]
    return n * wall * ((toward + closing + stored) / wall) ** ((n - 1.0) / n)


def wall_forces(scene: Scene, trace_u: np.ndarray, st=None) -> np.ndarray:
    """Force on the bottom wall at each trace sample of the bottom grain's displacement ``trace_u`` (S,) [force];
    ``st``: the scene's static state when the caller has it."""
    from hertzian.core.static import static_state

    st = static_state(scene) if st is None else st
    n = scene.chain.exponent
    overlap = np.maximum(st.static_overlap[-1] + trace_u, 0.0)
    return n * st.contact_constant[-1] * overlap ** (n - 1.0)


def objectives(spec: DesignSpec, scenes: list[Scene], result) -> np.ndarray:
    """The objectives (candidates, spec.objective) of each candidate of a run (``result`` of ``scenes``)."""
    from hertzian.core.static import static_state

    out = np.empty((len(scenes), len(spec.objective)))
    for c, scene in enumerate(scenes):
        st = static_state(scene)
        force = wall_forces(scene, result.traces["u"][c, :, 0], st)
        values = {
            "peak_wall_force": float(force.max()),
            "impulse": float(np.trapezoid(force - force[0], result.trace_t)),
            "mass": float(st.mass[list(spec.vary)].sum()),
        }
        out[c] = [values[name] for name in spec.objective]
        if spec.total_mass is not None and abs(values["mass"] - spec.total_mass) > 1e-9 * spec.total_mass:
            out[c] = np.inf  # its materials cannot reach the total mass within the radius bounds
        if leftover_force(scene, result.fields["u"][c, -1], result.fields["v"][c, -1], st) > LEFTOVER * force.max():
            out[c] = np.inf  # the chain may still press on the wall harder after the run: its peak is not known
    out[result.status != 0] = np.inf  # a candidate that failed is never the best
    return out


MEMORY_SHARE = 0.25
"""The share of the memory free on the host (and on a GPU) one ensemble run of a generation may take."""


def evaluate(scene: Scene, spec: DesignSpec, genomes: np.ndarray, device: str) -> np.ndarray:
    """Objectives (P, objectives) of ``genomes`` (P, genes): one ensemble run of every candidate, or of as many as
    fit in memory at once (:func:`candidates_per_run`) and then the next."""
    from hertzian.core.runner import run_ensemble

    scenes = [probe_scene(candidate(scene, spec, g)) for g in genomes]
    size = candidates_per_run(scenes[0], device)
    return np.concatenate([objectives(spec, part, run_ensemble(part, device)) for part in _parts(scenes, size)], axis=0)


def candidates_per_run(probe: Scene, device: str) -> int:
    """How many candidates like ``probe`` one ensemble run takes: MEMORY_SHARE of the free memory (each candidate
    keeps its wall grain's trace at every step), and fewer than 2³¹ elements in its trace arrays."""
    from hertzian.core.check import available_host_bytes, memory_needed

    need = memory_needed(probe, 1)
    free = available_host_bytes()
    per = sum(need.values())
    if str(device).startswith("cuda"):
        import warp as wp

        free, per = min(free, int(wp.get_device(device).free_memory)), max(per, need["state"])
    elements = 2 * max(probe.trace_sample_count, 1)
    return max(1, min(int(MEMORY_SHARE * free) // max(per, 1), (2**31 - 1) // elements))


def _parts(items: list, size: int) -> list[list]:
    return [items[k : k + size] for k in range(0, len(items), size)]


# ---- the optimisation ---------------------------------------------------------------------------------------


@dataclass(frozen=True)
class DesignResult:
    """What ``hertzian design`` and ``hz.design`` return: the best of the first objective, and with several
    objectives the Pareto front of every candidate run (their objectives and genomes)."""

    store: str
    generations: int
    best_objective: float
    best_genome: list[float]
    best_scene: dict
    seconds: float
    pareto_objectives: list[list[float]]
    pareto_genomes: list[list[float]]

    def to_dict(self) -> dict:
        return asdict(self)


def optimise(
    scene: Scene,
    spec: DesignSpec,
    out: str | Path,
    *,
    device: str,
    resume: bool = False,
    progress: Callable[[int, int, np.ndarray], None] | None = None,
) -> DesignResult:
    """Run (or resume) the design into the store ``out``; ``progress(generation, generations, best)`` after each
    (``best``: each objective's best so far)."""
    from hertzian.studies.design_store import best_of, create_store, open_for_resume, read_design, write_generation
    from hertzian.sweeping.storage import resolved_link, store_lock

    start = time.perf_counter()
    with store_lock(resolved_link(out)):
        if resume:
            store, optimizer, done = open_for_resume(out, scene, spec, new_optimizer)
        else:
            store, optimizer, done = create_store(out, scene, spec), new_optimizer(spec), 0
        for generation in range(done, spec.generations):
            clock = time.perf_counter()
            genomes = optimizer.ask()
            values = evaluate(scene, spec, genomes, device)
            optimizer.tell(genomes, values)
            best = write_generation(store, generation, genomes, values, time.perf_counter() - clock)
            if progress is not None:
                progress(generation + 1, spec.generations, best)
        best_value, best_genome = best_of(store)
    front_objectives, front_genomes = [], []
    if len(spec.objective) > 1:
        front_objectives, front_genomes = front_of(read_design(out))
    best_scene = candidate(scene, spec, np.asarray(best_genome)).to_dict()
    return DesignResult(
        str(out),
        spec.generations,
        best_value,
        list(best_genome),
        best_scene,
        time.perf_counter() - start,
        front_objectives,
        front_genomes,
    )


def front_of(data: dict) -> tuple[list[list[float]], list[list[float]]]:
    """(objectives, genomes) of the Pareto front of every candidate a design store holds (``read_design``), sorted
    by the first objective."""
    values = data["objective"].reshape(-1, data["objective"].shape[-1])
    genomes = data["genome"].reshape(-1, data["genome"].shape[-1])
    front = pareto_front(values)
    front = front[np.lexsort(values[front].T[::-1])]
    return values[front].tolist(), genomes[front].tolist()


# ---- what a design found, against plain chains ------------------------------------------------------------


def references(scene: Scene, spec: DesignSpec, best: Scene) -> dict[str, Scene]:
    """The best design and plain protectors in each of the design's materials: ``uniform <m>`` (equal beads) and
    ``tapered <m>`` (radii falling linearly from the struck end to the wall, as far as the radius bounds allow), of
    the best design's length; with ``design.total_mass``, of its mass instead (scaled as a whole, past the radius
    bounds if that material needs it)."""
    from hertzian.core.materials import pattern_index

    n = scene.chain.grains
    ratios = np.ones(n) if best.chain.radius_ratios is None else np.array(best.chain.radius_ratios)
    vary = list(spec.vary)
    mean = float(ratios[vary].mean())
    names, index = pattern_index(scene.chain.material, n)
    out = {"best": best}
    for material in spec.materials:
        for name, shape in (("uniform", np.zeros(len(vary))), ("tapered", np.linspace(0.5, -0.5, len(vary)))):
            plain = ratios.copy()
            plain[vary] = mean * (1.0 + shape * (0.8 if spec.radius is None else _span(spec, mean)))
            if spec.total_mass is not None:
                weight = _reference_masses(scene, [material])[0]
                plain[vary] *= (spec.total_mass / (weight * np.sum(plain[vary] ** 3))) ** (1.0 / 3.0)
            materials = [names[i] for i in index]
            for g in vary:
                materials[g] = material
            data = scene.to_dict()
            data["chain"]["radii"] = (0.5 * scene.chain.diameter * plain).tolist()
            data["chain"]["material"] = materials
            out[f"{name} {material}"] = scene_from_dict(data)
    return out


def _span(spec: DesignSpec, mean: float) -> float:
    """The relative spread of the tapered protector's radii: as wide as the radius bounds allow about ``mean``."""
    lo, hi = spec.radius
    return 2.0 * min(hi / mean - 1.0, 1.0 - lo / mean)


def compare(store: str | Path, device: str) -> dict:
    """The design store's best against uniform and tapered protectors of the same length in each of its materials:
    each one's objective (the first), peak wall force (also at half the step: whether it survives halving dt),
    transmitted impulse and protector mass, its wall-force trace, and the best design itself (its peak also at
    smaller steps and with event-aware steps, :func:`best_peak_by_step`); with several objectives also every
    candidate's objectives and the Pareto front, each front design's materials and radii."""
    from hertzian.core.runner import run_scene as run
    from hertzian.core.static import static_state

    data, scene, spec = stored_design(store)
    attrs = data["attrs"]
    best = candidate(scene, spec, data["best_genome"][-1])
    chains = references(scene, spec, best)
    rows, traces = {}, {}
    longer = probe_scene(best.with_overrides({"integrator.duration": 2 * scene.integrator.duration}))
    again = run(longer, device)
    by_step = best_peak_by_step(best, device)
    for name, chain in chains.items():
        probe = probe_scene(chain)
        result = run(probe, device)
        force = wall_forces(probe, result.traces["u"][0, :, 0])
        rows[name] = {
            "peak_wall_force": float(force.max()),
            "peak_wall_force_at_half_dt": _peak_at_half_dt(chain, device, by_step if name == "best" else []),
            "impulse": float(np.trapezoid(force - force[0], result.trace_t)),
            "mass": float(static_state(chain).mass[list(spec.vary)].sum()),
            "length": float(sum(2 * r for r in _radii(chain)[list(spec.vary)])),
            "objective": float(objectives(spec, [probe], result)[0, 0]),
            "time_above_half_peak": time_above(force, result.trace_t, 0.5),
        }
        traces[name] = (result.trace_t, force)
    from datetime import datetime, timezone

    return {
        "store": Path(store).name,
        "device": device,
        "date": datetime.now(timezone.utc).date().isoformat(),
        "package_version": attrs.get("package_version"),
        "design": attrs["design"],
        "design_seconds": float(np.sum(data["seconds"])),
        "generations": len(data["best_objective"]),
        "best_peak_at_twice_the_duration": float(wall_forces(longer, again.traces["u"][0, :, 0]).max()),
        "best_peak_by_step": by_step,
        "objectives": list(spec.objective),
        "best_objective": data["best_objective"][:, 0].tolist(),
        "median_objective": [
            float(np.median(o[np.isfinite(o)])) if np.any(np.isfinite(o)) else None for o in data["objective"][..., 0]
        ],
        **(_front_summary(scene, spec, data) if len(spec.objective) > 1 else {}),
        "best_materials": list(best.chain.material),
        "arrangement": arrangement([best.chain.material[g] for g in spec.vary], list(spec.materials)),
        "best_radii": _radii(best).tolist(),
        "chains": rows,
        "traces": traces,
    }


STEP_DIVISORS = (1, 2, 4)
"""The steps (the design's dt over these) at which :func:`best_peak_by_step` runs the best design."""


def best_peak_by_step(best: Scene, device: str) -> list[dict]:
    """The best design's peak wall force (and when it comes) at the design's step and at its halves and quarters,
    with plain and with event-aware steps: whether the objective the search ranked designs by is resolved."""
    from hertzian.core.runner import run_scene as run

    rows = []
    for events in ("off", "auto"):
        for divisor in STEP_DIVISORS:
            dt = best.integrator.dt / divisor
            probe = probe_scene(best.with_overrides({"integrator.dt": dt, "integrator.events": events}))
            result = run(probe, device)
            force = wall_forces(probe, result.traces["u"][0, :, 0])
            peak = int(np.argmax(force))
            rows.append(
                {"events": events, "dt": dt, "peak_wall_force": float(force[peak]), "at": float(result.trace_t[peak])}
            )
    return rows


def _peak_at_half_dt(chain: Scene, device: str, known: list[dict]) -> float:
    """The chain's peak wall force at half its step with its own event setting: from ``known`` (rows of
    :func:`best_peak_by_step` of this chain) when one is that run, else run here."""
    from hertzian.core.runner import run_scene as run

    dt, events = chain.integrator.dt / 2, chain.integrator.events
    for row in known:
        if row["dt"] == dt and row["events"] == events:
            return row["peak_wall_force"]
    halved = probe_scene(chain.with_overrides({"integrator.dt": dt}))
    return float(wall_forces(halved, run(halved, device).traces["u"][0, :, 0]).max())


def stored_design(store: str | Path) -> tuple[dict, Scene, DesignSpec]:
    """(the store's data as :func:`~hertzian.studies.design_store.read_design` gives it, its base scene, its
    design)."""
    from hertzian.studies.design_store import read_design

    data = read_design(store)
    scene = scene_from_dict(data["attrs"]["scene"])
    return data, scene, check_design(scene, {k: v for k, v in data["attrs"]["design"].items() if v is not None})


def summary(store: str | Path) -> dict:
    """A design store in numbers, nothing run: the design (optimizer, seed, population, generations planned and
    done, seconds), each objective's best so far, the generation since which the first objective's best holds, and
    the best design's materials and R/R0 over the varying grains, from the striker to the wall."""
    data, scene, spec = stored_design(store)
    out: dict[str, Any] = {
        "store": str(store),
        "optimizer": spec.optimizer,
        "seed": spec.seed,
        "population": spec.population,
        "generations": spec.generations,
        "generations_done": len(data["best_objective"]),
        "seconds": float(np.nansum(data["seconds"])),
        "objectives": list(spec.objective),
    }
    if not out["generations_done"]:
        return out
    first = data["best_objective"][:, 0]
    best = candidate(scene, spec, data["best_genome"][-1])
    r0 = scene.chain.diameter / 2
    return out | {
        "best": dict(zip(spec.objective, data["best_objective"][-1].tolist())),
        # generations count from 1, as the progress lines, the plot and the store's coordinate do
        "best_since_generation": int(np.argmax(first == first[-1])) + 1,
        "best_materials": [best.chain.material[g] for g in spec.vary],
        "best_radius_ratio": [float(r) for r in _radii(best)[list(spec.vary)] / r0],
    }


SHUFFLES = 20_000
"""Random orders of the best design's beads that make the null of :func:`arrangement`."""


def arrangement(materials: list[str], names: list[str], seed: int = 0) -> dict:
    """Where each material sits in a protector (``materials``: the varying beads' from the striker to the wall),
    against the same beads in random order (SHUFFLES of them, seeded): each material's mean position (0 next to the
    striker, 1 next to the wall) with the fraction of shuffles at least as close to the wall (``p_toward_wall``) and
    at least as close to the striker (``p_toward_striker``); and the number of neighbours of unlike materials
    (``switches``) with the fractions of shuffles having at least as many and at most as many."""
    index = np.array([names.index(m) for m in materials])
    position = np.linspace(0.0, 1.0, len(index)) if len(index) > 1 else np.zeros(1)
    shuffled = np.random.default_rng(seed).permuted(np.tile(index, (SHUFFLES, 1)), axis=1)
    out: dict[str, Any] = {"materials": {}}
    for k, name in enumerate(names):
        if not np.any(index == k):
            continue
        mean = float(position[index == k].mean())
        null = (shuffled == k) @ position / np.count_nonzero(index == k)
        out["materials"][name] = {
            "beads": int(np.count_nonzero(index == k)),
            "mean_position": mean,
            "p_toward_wall": float(np.mean(null >= mean - 1e-12)),
            "p_toward_striker": float(np.mean(null <= mean + 1e-12)),
        }
    switches = int(np.count_nonzero(np.diff(index)))
    null_switches = np.count_nonzero(np.diff(shuffled, axis=1), axis=1)
    out["switches"] = {
        "count": switches,
        "null_mean": float(null_switches.mean()),
        "p_at_least": float(np.mean(null_switches >= switches)),
        "p_at_most": float(np.mean(null_switches <= switches)),
    }
    return out


def time_above(force: np.ndarray, t: np.ndarray, fraction: float) -> float:
    """How long the wall's force stays above ``fraction`` of its peak [time]: a long, low pulse against a spike."""
    above = force > fraction * force.max()
    return float(np.sum(np.diff(t)[above[1:] & above[:-1]]))


def _front_summary(scene: Scene, spec: DesignSpec, data: dict) -> dict:
    """Every finite candidate's objectives, and the Pareto front's designs (objectives, materials, radii)."""
    values = data["objective"].reshape(-1, len(spec.objective))
    front_values, front_genomes = front_of(data)
    designs = [candidate(scene, spec, np.asarray(g)) for g in front_genomes]
    return {
        "candidates": values[np.all(np.isfinite(values), axis=1)].tolist(),
        "pareto": [
            {"objectives": v, "materials": list(d.chain.material), "radii": _radii(d).tolist()}
            for v, d in zip(front_values, designs)
        ],
    }


def _radii(scene: Scene) -> np.ndarray:
    """Each grain's radius [length], as a store keeps it (hertzian.sweeping.grain_store)."""
    from hertzian.sweeping.grain_store import grain_arrays

    return grain_arrays([scene])["radius"][0]
