"""hertzian: many Hertzian granular chains at once, on a GPU or a CPU (Warp kernels, float64).

    import hertzian as hz

    scene = hz.load_scene("impact", {"chain.grains": 100, "integrator.duration": 5.0})
    faster = scene.with_overrides({"excitation.impact": 0.02})
    result = hz.run([scene, faster])                  # one ensemble
    dataset = result.to_xarray()                      # what `hertzian run --out` stores
    summary = hz.sweep("example.toml", "example.zarr") # what `hertzian sweep --json` prints
    dataset = hz.open_store("example.zarr")

Everything but the scene loads on first use (Warp, Zarr and xarray are slow to import and ``hertzian --help``
needs none of them).
"""

from __future__ import annotations

from importlib import import_module

from hertzian._version import __version__

# ---- scenes (light: numpy only) ----------------------------------------------------------------
from hertzian.core.errors import OptionError, RefusedError
from hertzian.core.scene import Scene, SceneError

# ---- loaded on first use: name → module ---------------------------------------------------------
_LAZY = {
    # scenes and runs
    "load_scene": "hertzian.api",
    "run": "hertzian.api",
    "design": "hertzian.api",
    "RunResult": "hertzian.api",
    # sweeps and stores
    "Sweep": "hertzian.sweeping.spec",
    "load_sweep": "hertzian.sweeping.spec",
    "sweep": "hertzian.sweeping.pipeline",
    "open_store": "hertzian.api",
    # errors of stores
    "SweepStoreError": "hertzian.sweeping.sweep_store",
}

__all__ = ["__version__", "Scene", "SceneError", "OptionError", "RefusedError", *_LAZY]


def __getattr__(name: str):
    if name not in _LAZY:
        raise AttributeError(f"module 'hertzian' has no attribute {name!r}")
    value = getattr(import_module(_LAZY[name]), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
