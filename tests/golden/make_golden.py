"""Golden outputs: small CPU runs of every solver kind and every feature, saved before a refactor.

``python tests/golden/make_golden.py`` (from the repository root, with the repository on
``PYTHONPATH``) runs every case in ``CASES`` on the CPU and writes ``tests/golden/golden.npz``:
for each case its snapshots u and v, energy, work (driven), traces u and v, per-chain status,
largest overlap and energy error. ``tests/core/test_golden.py`` reruns the cases and asserts that
every array is bitwise equal. A case is a plain dict, so a later kernel option can be pinned here:

* ``scenes``: scene dictionaries (the TOML layout), one per chain of the ensemble;
* ``solver``: ``step`` (one step per launch), ``chain`` (CPU chain-per-thread kernel), ``tile``
  (whole chains per block) or ``window`` (windows with ghost zones);
* ``plan``: for ``tile``/``window``, the keywords of ``kernels.tile.plan_tile``.

The file was made from commit f3b003b (before the solver refactor, with that commit's own
``run_case``, see git history) and regenerated once since, when gear4 came to start in its
corrector's steady-state form (ensemble/core/startup.py; u and v moved by at most 5e-11 of their
largest values). Do not regenerate it unless a change is meant to alter results, and say so in
the commit. On a CPU whose NumPy powers are not the C library's (tests/core/test_golden.py),
run it with ``NPY_DISABLE_CPU_FEATURES`` set as that test sets it.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

GOLDEN = Path(__file__).with_name("golden.npz")


def _impact(grains=24, **sections):
    """Scene dict: an impact on a short chain, records every 0.3 (600 steps: a monitor check between)."""
    base = {
        "chain": {"grains": grains, "l0": 1e-4},
        "excitation": {"impact": 1e-2},
        "integrator": {"duration": 0.9, "dt": 5e-4},
        "record": {"every": 0.3},
    }
    for key, value in sections.items():
        if isinstance(value, dict):
            base.setdefault(key, {}).update(value)
        else:
            base[key] = value
    return base


def _three(**sections):
    """Three chains that differ in impact speed (and so in everything downstream)."""
    out = []
    for c, v in enumerate((1e-2, 2e-2, 5e-3)):
        s = _impact(**sections)
        s = {k: (dict(v2) if isinstance(v2, dict) else v2) for k, v2 in s.items()}
        s["excitation"] = dict(s.get("excitation", {}), impact=v)
        out.append(s)
    return out


CASES: dict[str, dict] = {
    # per-step kernel: every feature it has
    "step_walls_gear4": {"solver": "step", "scenes": _three()},
    "step_traces_gear5": {
        "solver": "step",
        "scenes": _three(
            integrator={"method": "gear5"}, record={"every": 0.3, "traces": [0, 5, 23], "trace_every": 0.01}
        ),
    },
    "step_gear6_gravity": {
        "solver": "step",
        "scenes": _three(chain={"grains": 24, "l0": 0.0, "gravity": 1.0}, integrator={"method": "gear6"}),
    },
    "step_free_bottom": {
        "solver": "step",
        "scenes": _three(chain={"grains": 24, "l0": 0.0}, boundary={"bottom": "free"}),
    },
    "step_verlet_load_fixed": {
        "solver": "step",
        "scenes": _three(
            chain={"grains": 24, "l0": 0.0, "load": 0.02},
            boundary={"surface": "load", "bottom": "fixed"},
            integrator={"method": "verlet"},
        ),
    },
    "step_impurities_harmonic_own": {
        "solver": "step",
        "scenes": [
            _impact(impurities=[{"grains": [5, 6], "mass": 0.5, "a": 3000.0, "contact": "harmonic"}]),
            _impact(impurities=[{"grains": [12], "mass": 2.0, "a": 8000.0, "contact": "own"}]),
            _impact(chain={"grains": 24, "l0": 1e-4, "gravity": 0.5}),
        ],
    },
    "step_exponent_free_surface": {
        "solver": "step",
        "scenes": [
            _impact(
                chain={"grains": 20, "l0": 0.0, "exponent": e},
                boundary={"surface": "free"},
                record={"every": 0.3, "traces": [0, 10]},
            )
            for e in (2.0, 3.0)
        ],
    },
    "step_driven": {
        "solver": "step",
        "scenes": [
            {
                "chain": {"grains": 20, "gravity": g},
                "boundary": {"surface": "driven", "bottom": "fixed"},
                "excitation": {"drive_amplitude": a, "drive_period": p},
                "integrator": {"duration": 0.6, "dt": 5e-4},
                "record": {"every": 0.3, "traces": [0, 1, 19]},
            }
            for a, p, g in ((1e-3, 0.05, 1.0), (3e-3, 0.02, 0.0))
        ],
    },
    "step_float32": {
        "solver": "step",
        "scenes": _three(integrator={"precision": "float32"}, record={"every": 0.3, "traces": [0, 3]}),
    },
    "step_overlap_beyond_validity": {
        "solver": "step",
        "scenes": [_impact(chain={"grains": 16, "l0": 1e-4, "diameter": 1e-3}), _impact(grains=16)],
    },
    "step_blow_up_frozen": {
        "solver": "step",
        "scenes": [
            _impact(
                grains=16, excitation={"impact": 1e3}, integrator={"duration": 0.6, "dt": 5e-2}, record={"every": 0.2}
            ),
            _impact(grains=16, integrator={"duration": 0.6, "dt": 5e-2}, record={"every": 0.2}),
        ],
    },
    # CPU chain kernel
    "chain_walls_gear4": {"solver": "chain", "scenes": _three()},
    "chain_impurities_gravity_fixed_gear5": {
        "solver": "chain",
        "scenes": [
            _impact(
                chain={"grains": 24, "l0": 1e-4, "gravity": 1.0},
                boundary={"bottom": "fixed"},
                impurities=[{"grains": [5, 6], "mass": 0.5, "a": 3000.0}],
                integrator={"method": "gear5"},
            ),
            _impact(
                impurities=[{"grains": [9], "mass": 2.0, "a": 8000.0, "contact": "own"}],
                boundary={"bottom": "fixed"},
                integrator={"method": "gear5"},
            ),
        ],
    },
    "chain_verlet_exponent_free": {
        "solver": "chain",
        "scenes": [
            _impact(
                chain={"grains": 20, "l0": 0.0, "exponent": e},
                boundary={"surface": "free", "bottom": "free"},
                integrator={"method": "verlet"},
            )
            for e in (2.0, 3.0)
        ],
    },
    "chain_float32_gear6_load": {
        "solver": "chain",
        "scenes": _three(
            chain={"grains": 24, "l0": 0.0, "load": 0.02},
            boundary={"surface": "load"},
            integrator={"method": "gear6", "precision": "float32"},
        ),
    },
    # fused tile kernel (whole chains per block; CPU blocks run as fibers)
    "tile_walls_padded": {
        "solver": "tile",
        "plan": {"grains_per_lane": 4, "steps_per_launch": 64},
        "scenes": _three(chain={"grains": 23, "l0": 1e-4}),
    },
    "tile_free_two_per_block_gear6": {
        "solver": "tile",
        "plan": {"grains_per_lane": 4, "chains_per_block": 2, "steps_per_launch": 50},
        "scenes": _three(
            chain={"grains": 12, "l0": 0.0},
            boundary={"surface": "free", "bottom": "free"},
            integrator={"method": "gear6"},
        ),
    },
    "tile_verlet_exponent_load": {
        "solver": "tile",
        "plan": {"grains_per_lane": 8, "steps_per_launch": 64},
        "scenes": _three(
            chain={"grains": 16, "l0": 1e-4, "exponent": 2.0},
            boundary={"surface": "load"},
            integrator={"method": "verlet"},
        ),
    },
    "tile_float32_impurities": {
        "solver": "tile",
        "plan": {"grains_per_lane": 4, "steps_per_launch": 32},
        "scenes": [
            _impact(grains=16, impurities=[{"grains": [3], "mass": 0.5}], integrator={"precision": "float32"}),
            _impact(grains=16, integrator={"precision": "float32"}),
        ],
    },
    # fused window kernel (several blocks per chain with ghost zones)
    "window_fixed_impurities_gravity_gear5": {
        "solver": "window",
        "plan": {"grains_per_lane": 4, "lanes_per_chain": 8, "steps_per_launch": 6, "windowed": True},
        "scenes": [
            _impact(
                grains=50,
                chain={"grains": 50, "l0": 1e-4, "gravity": 1.0},
                boundary={"bottom": "fixed"},
                impurities=[{"grains": [10, 11, 30], "mass": 0.5, "a": 3000.0}],
                integrator={"method": "gear5"},
            ),
            _impact(grains=50, boundary={"bottom": "fixed"}, integrator={"method": "gear5"}),
        ],
    },
    "window_walls_gear4": {
        "solver": "window",
        "plan": {"grains_per_lane": 4, "lanes_per_chain": 8, "steps_per_launch": 8, "windowed": True},
        "scenes": _three(chain={"grains": 40, "l0": 1e-4}),
    },
}

FIELDS = ("u", "v", "energy", "work", "trace_u", "trace_v", "status", "max_overlap", "energy_error", "t", "trace_t")


def run_case(case: dict):
    """Run one golden case on the CPU and return its RunResult."""
    import warp as wp
    from hertzian.core.model import build_model
    from hertzian.core.runner import Runner
    from hertzian.core.scene import scene_from_dict
    from hertzian.core.solvers import config_of
    from hertzian.kernels.tile import plan_tile

    wp.init()
    # the stored outputs predate event-aware Gear steps: pin them off (integrator.events = "off"
    # reproduces the earlier steps bit for bit; tests/kernels/test_event_steps.py covers "auto")
    scenes = [
        scene_from_dict({**s, "integrator": {**s.get("integrator", {}), "events": "off"}}) for s in case["scenes"]
    ]
    # the stored float32 outputs predate compensated float32 (kernels/gear.py): pin the plain float32
    # update, which the kernels keep bit for bit (features.compensated = False)
    from dataclasses import replace

    from hertzian.core.model import features_of

    features = features_of(scenes)
    model = build_model(scenes, "cpu", features=replace(features, compensated=False))
    solver = case["solver"]
    if solver in ("tile", "window"):
        config = config_of(plan_tile(model.features, model.grain_count, model.chain_count, **case["plan"]))
        assert config.kind == solver
        return Runner(model, kernel=config).run()
    return Runner(model, kernel=solver).run()


def arrays_of(result) -> dict[str, np.ndarray]:
    """The compared arrays of one run (absent ones are left out)."""
    out = {
        "u": result.fields.get("u"),
        "v": result.fields.get("v"),
        "energy": result.energy,
        "work": result.work,
        "status": result.status,
        "max_overlap": result.max_overlap,
        "energy_error": result.energy_error,
        "t": result.t,
        "trace_t": result.trace_t,
    }
    if result.traces:
        out["trace_u"], out["trace_v"] = result.traces["u"], result.traces["v"]
    return {k: np.asarray(v) for k, v in out.items() if v is not None}


def main() -> None:
    saved = {}
    for name, case in CASES.items():
        result = run_case(case)
        print(
            f"{name}: kernel {result.kernel}, status {result.status.tolist()}, "
            f"energy error {np.array2string(result.energy_error, precision=2)}"
        )
        for key, value in arrays_of(result).items():
            saved[f"{name}/{key}"] = value
    np.savez_compressed(GOLDEN, **saved)
    print(f"wrote {GOLDEN} ({GOLDEN.stat().st_size / 1e3:.0f} kB, {len(saved)} arrays)")


if __name__ == "__main__":
    sys.exit(main())
