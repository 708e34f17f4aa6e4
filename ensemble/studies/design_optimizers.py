"""The optimizers of a protector design (hertzian.studies.design), each from a well-kept library:

- ``cma``: CMA-ES (the cma package) for one objective, with its integer handling for the material genes;
- ``ga``: a genetic algorithm (pymoo's mixed-variable one) with NSGA-II's survival, for one objective or several:
  its survivors are the non-dominated designs, spread along their front.

Each asks for a generation of genomes (P, genes) and is told their objectives (P, M). A seed and the values told
reproduce what it asks, which is how a stored design resumes (hertzian.studies.design_store).
"""

from __future__ import annotations

import numpy as np

OPTIMIZERS = ("cma", "ga")

FAILED = 1e300
"""What an optimizer is told of a candidate whose objective is infinite (its run failed, or its peak is not known)."""


def told(values: np.ndarray) -> np.ndarray:
    """Objectives as an optimizer is told them: infinities as FAILED."""
    return np.where(np.isfinite(values), values, FAILED)


def gene_bounds(spec) -> tuple[np.ndarray, np.ndarray, int]:
    """(lower, upper, count of whole-number genes first) of the design's genes: a material gene takes 0 … choices − 1,
    a radius gene 0 … 1."""
    materials = len(spec.gene_grains)
    radii = materials if spec.radius else 0
    upper = [float(len(spec.materials) - 1)] * materials + [1.0] * radii
    return np.zeros(materials + radii), np.array(upper), materials


class CmaOptimizer:
    """CMA-ES of one objective, seeded, started at the middle of every gene's range."""

    def __init__(self, spec):
        import cma

        lower, upper, whole = gene_bounds(spec)
        options = {
            "seed": spec.seed + 1,  # cma reads seed 0 as "random"
            "popsize": spec.population,
            "bounds": [lower.tolist(), upper.tolist()],
            "CMA_stds": [max(u, 1.0) for u in upper],
            "integer_variables": list(range(whole)),
            "verbose": -9,
        }
        self.es = cma.CMAEvolutionStrategy((0.5 * upper).tolist(), spec.step_size, options)

    def ask(self) -> np.ndarray:
        return np.asarray(self.es.ask(), dtype=np.float64)

    def tell(self, genomes: np.ndarray, values: np.ndarray) -> None:
        self.es.tell(list(genomes), told(values[:, 0]).tolist())


class GeneticOptimizer:
    """pymoo's mixed-variable genetic algorithm with NSGA-II's survival (non-dominated rank, then crowding): a material
    gene is a choice among the materials (uniform crossover, random reset), a radius gene a real number in [0, 1]
    (simulated binary crossover, polynomial mutation); P offspring a generation, duplicates allowed (a generation is
    always P runs)."""

    def __init__(self, spec, objectives: int):
        from pymoo.algorithms.moo.nsga2 import RankAndCrowding
        from pymoo.core.mixed import MixedVariableGA
        from pymoo.core.problem import Problem
        from pymoo.core.variable import Choice, Real

        lower, upper, whole = gene_bounds(spec)
        self.names = [f"g{k}" for k in range(len(lower))]
        genes = {
            name: Choice(options=list(range(len(spec.materials)))) if k < whole else Real(bounds=(0.0, 1.0))
            for k, name in enumerate(self.names)
        }
        self.problem = Problem(vars=genes, n_obj=objectives)
        self.algorithm = MixedVariableGA(
            pop_size=spec.population, survival=RankAndCrowding(), eliminate_duplicates=False
        )
        self.algorithm.setup(self.problem, termination=("n_gen", spec.generations + 1), seed=spec.seed)
        self._asked = None

    def ask(self) -> np.ndarray:
        self._asked = self.algorithm.ask()
        return np.array([[x[name] for name in self.names] for x in self._asked.get("X")], dtype=np.float64)

    def tell(self, genomes: np.ndarray, values: np.ndarray) -> None:
        from pymoo.core.evaluator import Evaluator
        from pymoo.problems.static import StaticProblem

        Evaluator().eval(StaticProblem(self.problem, F=told(values)), self._asked)
        self.algorithm.tell(infills=self._asked)


def new_optimizer(spec):
    """The design's optimizer, new and seeded."""
    if spec.optimizer == "cma":
        return CmaOptimizer(spec)
    return GeneticOptimizer(spec, len(spec.objective))


def pareto_front(values: np.ndarray) -> np.ndarray:
    """Indices of the rows of ``values`` (K, M) that no other finite row dominates (no worse in every objective,
    better in one), among the finite rows; duplicates of a front row are all kept."""
    from pymoo.util.nds.non_dominated_sorting import NonDominatedSorting

    finite = np.flatnonzero(np.all(np.isfinite(values), axis=1))
    if finite.size == 0:
        return finite
    front = NonDominatedSorting().do(values[finite], only_non_dominated_front=True)
    return np.sort(finite[np.asarray(front, dtype=int)])
