"""The fused kernels against the per-step kernel: small ensembles, each kernel's state after some steps, the
cases that exercise each kernel layout, and the checks that two kernels agree and that motion reached every
window."""

from __future__ import annotations

import numpy as np
from hertzian.core.runner import Runner
from hertzian.core.scene import scene_from_dict
from hertzian.core.solvers import ChainSolver, SolverConfig, TileSolver, config_of
from hertzian.kernels.features import KERNEL_OPTIONS

MOVED = 1e-3
"""A grain has moved once its |u| or dt·|v| exceeds this fraction of the chain's largest."""


CUDA_ROUNDING = 1e-12
"""On CUDA with FMA contraction (the default), largest |difference| between two kernels over the largest
|value|: each kernel's a·b + c contractions are the compiler's choice, so results differ in the last bits
(a few ulps of the largest value after hundreds of steps, docs/benchmarks.md)."""


def bitwise(device) -> bool:
    """Kernels agree bit for bit on the CPU, and on CUDA when FMA contraction is off (HERTZIAN_FUSE_FP=0)."""
    return str(device).startswith("cpu") or not KERNEL_OPTIONS["fuse_fp"]


CUDA_ROUNDING_FLOAT32 = float(np.finfo(np.float32).eps)
"""The same for float32 results (compensated float32's fields are the float32 high parts of hi + lo): one float32
ulp of the largest value. A contraction changes hi + lo by ~1e-16 relative, which moves the rounded hi by an ulp
wherever hi + lo lies near a rounding boundary (with contraction off the kernels agree bit for bit)."""


def assert_kernels_agree(got, want, device) -> None:
    """Two kernels' results: bit for bit where ``bitwise(device)``, else equal to rounding (CUDA_ROUNDING, or
    CUDA_ROUNDING_FLOAT32 for float32 arrays)."""
    got, want = np.asarray(got), np.asarray(want)
    if bitwise(device):
        np.testing.assert_array_equal(got, want)
    else:
        rounding = CUDA_ROUNDING_FLOAT32 if want.dtype == np.float32 else CUDA_ROUNDING
        np.testing.assert_allclose(got, want, rtol=0, atol=rounding * np.max(np.abs(want)))


def chains(n_chains: int, **sections) -> list:
    """``n_chains`` scenes that differ in their impact speed."""
    data = {k: dict(v) if isinstance(v, dict) else v for k, v in sections.items()}
    data.setdefault("integrator", {}).setdefault("duration", 10.0)
    data.setdefault("excitation", {}).setdefault("impact", 1e-2)
    base = scene_from_dict(data)
    return [base.with_overrides({"excitation.impact": base.excitation.impact * (1 + 0.3 * c)}) for c in range(n_chains)]


def per_step(model, steps: int, status=None) -> np.ndarray:
    """State (values, chains, grains) after ``steps`` steps of the per-step kernel."""
    runner = Runner(model, kernel="step", use_graph=False)
    if status is not None:
        runner.current.status.assign(status)
    runner.advance(steps)
    return runner.current.x.numpy()


def advance(solver, model, steps: int, status=None) -> np.ndarray:
    """State (values, chains, grains) after one ``solver.advance`` of ``steps`` steps from the model's start."""
    start, scratch = model.state_pair()
    if status is not None:
        start.status.assign(status)
    end = solver.advance(start, scratch, steps)
    assert end.clock.numpy()[0] == steps
    return end.x.numpy()


def sweep(model, steps: int, status=None, steps_per_launch: int = 1 << 30) -> np.ndarray:
    """State after ``steps`` steps of the CPU chain kernel (``steps_per_launch`` steps per launch)."""
    return advance(ChainSolver(model, SolverConfig("chain", steps_per_launch=steps_per_launch)), model, steps, status)


def fused(model, plan, steps: int, status=None) -> np.ndarray:
    """State after ``steps`` steps of the tile or window kernel of ``plan``."""
    return advance(TileSolver(model, config_of(plan)), model, steps, status)


def window_ranges(plan, grains: int) -> list[tuple[int, int]]:
    """[first, last) grains each block of a chain writes back (one range for whole-chain plans)."""
    if not plan.shape.windowed:
        return [(0, grains)]
    return [(b * plan.interior, min((b + 1) * plan.interior, grains)) for b in range(plan.blocks_per_chain)]


def assert_every_window_moved(x: np.ndarray, ranges: list[tuple[int, int]], *, held_bottom: bool) -> None:
    """In every chain of state ``x`` the last free grain of every window has really moved (the pulse,
    not a round-off precursor, reached it), so each window, its ghost exchange and the bottom are compared."""
    u, dv = np.abs(x[0]), np.abs(x[1])
    for c in range(x.shape[1]):
        for first, last in ranges:
            g = last - 2 if held_bottom and last == x.shape[2] else last - 1
            moved = max(u[c, g] / u[c].max(), dv[c, g] / dv[c].max())
            assert moved > MOVED, f"chain {c}: grain {g} (window {first}…{last - 1}) has not moved ({moved:.2g})"


CASES = {
    # name: (scene sections, chain count, plan keywords, steps); steps: until the pulse has reached the
    # bottom of every chain (asserted by the tests), odd so the last fused launch is a partial one
    "walls, padded lanes": (
        dict(chain={"grains": 37, "l0": 1e-4}, integrator={"dt": 5e-4}),
        2,
        dict(grains_per_lane=4),
        4501,
    ),
    "free ends, 2 chains per block": (
        dict(chain={"grains": 12}, boundary={"surface": "free", "bottom": "free"}, integrator={"dt": 5e-4}),
        5,
        dict(grains_per_lane=4, chains_per_block=2),
        2501,
    ),
    "windows, fixed bottom, impurities, gravity": (
        dict(
            chain={"grains": 50, "gravity": 1.0, "l0": 1e-4},
            boundary={"bottom": "fixed"},
            impurities=[{"grains": [10, 11, 30], "mass": 0.5, "a": 3000.0}],
            integrator={"dt": 5e-4},
        ),
        2,
        dict(grains_per_lane=4, lanes_per_chain=8, steps_per_launch=6, windowed=True),
        2501,
    ),
    "verlet, exponent 2, surface load": (
        dict(
            chain={"grains": 20, "exponent": 2.0, "l0": 1e-4},
            boundary={"surface": "load"},
            integrator={"method": "verlet", "dt": 2e-4},
        ),
        2,
        dict(grains_per_lane=8),
        1501,
    ),
    "gear6, full lanes": (
        dict(chain={"grains": 16, "l0": 1e-4}, integrator={"method": "gear6", "dt": 5e-4}),
        3,
        dict(grains_per_lane=8),
        2501,
    ),
    # compensated float32 (kernels/gear.py): the low parts of u and dt·v are state rows, compared too;
    # gear4 takes event steps here (the struck grain leaves the wall)
    "float32, walls, padded lanes, events": (
        dict(chain={"grains": 37, "l0": 1e-4}, integrator={"dt": 5e-4, "precision": "float32"}),
        2,
        dict(grains_per_lane=4),
        4501,
    ),
    # lattice laws (docs/lattices.md): a law's shape per chain, tension; sound speed √(a/m) = 1 grain per time unit
    "fput α–β, walls, padded lanes": (
        dict(chain={"grains": 21, "potential": "fput", "a": 1.0, "alpha": 0.25, "beta": 0.5}, integrator={"dt": 0.05}),
        2,
        dict(grains_per_lane=4),
        601,
    ),
    "toda, windows, precompressed, impurities": (
        dict(
            chain={"grains": 40, "potential": "toda", "a": 1.0, "b": 2.0, "l0": 0.05},
            impurities=[{"grains": [10, 11, 25], "mass": 0.5, "a": 2.0}],
            integrator={"method": "gear5", "dt": 0.04},
        ),
        2,
        dict(grains_per_lane=4, lanes_per_chain=10, steps_per_launch=6, windowed=True),
        801,
    ),
    # rings (boundary periodic): whole chains in full lanes, the first and last lanes neighbours
    "fput ring, 2 chains per block": (
        dict(
            chain={"grains": 24, "potential": "fput", "a": 1.0, "alpha": 0.25, "beta": 0.5},
            boundary={"surface": "periodic", "bottom": "periodic"},
            integrator={"dt": 0.05},
        ),
        3,
        dict(grains_per_lane=4, chains_per_block=2),
        301,
    ),
    "hertz ring, precompressed, gear5": (
        dict(
            chain={"grains": 16, "l0": 1e-4},
            boundary={"surface": "periodic", "bottom": "periodic"},
            integrator={"method": "gear5", "dt": 5e-4, "events": "off"},
        ),
        2,
        dict(grains_per_lane=8),
        1501,
    ),
    # composed methods (yoshida4, yoshida6): a step of velocity-Verlet substeps, each exchanging the lanes' edges
    "yoshida6, fput, padded lanes": (
        dict(
            chain={"grains": 21, "potential": "fput", "a": 1.0, "alpha": 0.25, "beta": 0.5},
            integrator={"method": "yoshida6", "dt": 0.05},
        ),
        2,
        dict(grains_per_lane=4),
        301,
    ),
    "yoshida4, float32, precompressed, 2 chains per block": (
        dict(chain={"grains": 12, "l0": 1e-4}, integrator={"method": "yoshida4", "dt": 5e-4, "precision": "float32"}),
        3,
        dict(grains_per_lane=4, chains_per_block=2),
        1501,
    ),
    # lane buckets (calibrate.whole_chain_configs): lanes rounded up to whole warps, so whole lanes are padding
    "impact, event steps, whole padding lanes": (
        dict(chain={"grains": 20}, integrator={"dt": 5e-4}),
        2,
        dict(grains_per_lane=4, lanes_per_chain=16, masked=True),
        6001,
    ),
    "yoshida6, fput, whole padding lanes, 2 chains per block": (
        dict(
            chain={"grains": 21, "potential": "fput", "a": 1.0, "alpha": 0.25, "beta": 0.5},
            integrator={"method": "yoshida6", "dt": 0.05},
        ),
        3,
        dict(grains_per_lane=4, lanes_per_chain=8, chains_per_block=2, masked=True),
        301,
    ),
    "float32, verlet, windows, fixed bottom, impurities, gravity": (
        dict(
            chain={"grains": 50, "gravity": 1.0, "l0": 1e-4},
            boundary={"bottom": "fixed"},
            impurities=[{"grains": [10, 11, 30], "mass": 0.5, "a": 3000.0}],
            integrator={"method": "verlet", "dt": 5e-4, "precision": "float32"},
        ),
        2,
        dict(grains_per_lane=4, lanes_per_chain=8, steps_per_launch=6, windowed=True),
        2501,
    ),
}

COMPOSED_CASES = {
    # yoshida4 (three velocity-Verlet substeps per step) on the per-step kernel and the CPU sweep (the tile
    # kernel's composed steps are in CASES). Steps: until the pulse has reached the bottom of every chain (asserted
    # by the tests), odd.
    "yoshida4, walls": (dict(chain={"grains": 25, "l0": 1e-4}, integrator={"method": "yoshida4", "dt": 5e-4}), 2, 3001),
    "yoshida4, fixed bottom, impurities, gravity": (
        dict(
            chain={"grains": 30, "gravity": 1.0, "l0": 1e-4},
            boundary={"bottom": "fixed"},
            impurities=[{"grains": [10, 11, 20], "mass": 0.5, "a": 3000.0}],
            integrator={"method": "yoshida4", "dt": 5e-4},
        ),
        2,
        2501,
    ),
    "yoshida4, free ends, exponent 2": (
        dict(
            chain={"grains": 12, "exponent": 2.0},
            boundary={"surface": "free", "bottom": "free"},
            integrator={"method": "yoshida4", "dt": 5e-4},
        ),
        3,
        2501,
    ),
    "yoshida4, float32, walls, impurities": (
        dict(
            chain={"grains": 25, "l0": 1e-4},
            impurities=[{"grains": [7], "mass": 2.0}],
            integrator={"method": "yoshida4", "dt": 5e-4, "precision": "float32"},
        ),
        2,
        3001,
    ),
}
