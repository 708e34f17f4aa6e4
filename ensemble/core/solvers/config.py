"""SolverConfig: which solver advances a model, in which compile-time launch shape. Frozen, hashable."""

from __future__ import annotations

from dataclasses import asdict, dataclass

from hertzian.kernels.tile import TileShape

SOLVER_KINDS = ("step", "tile", "window", "chain")
"""``step``: one Gear/Verlet step per launch over (chain, grain), every feature (kernels/step.py).
``tile``: whole chains per block, K steps per launch (kernels/tile.py).
``window``: long chains cut into blocks with ghost zones, K ≤ ghost steps per launch (kernels/tile.py +
kernels/ghost.py).
``chain``: one CPU thread per chain, every step of an ``advance`` in one launch (kernels/cpu.py).
The fused kinds (tile, window, chain) take a drive in the kernel and write trace samples inside their
launch, as the per-step kernel does."""

GRAPH_STEPS = 512
"""Steps per captured CUDA graph of the per-step solver (a graph of many launches, replayed)."""
FUSED_GRAPH_LAUNCHES = 64
"""Launches per captured CUDA graph of the tile and window solvers when ``graph_steps`` is None. A long
``advance`` replays that graph (and one for the remainder) instead of capturing all of its launches in
one graph: capturing and instantiating a graph of 10⁵ launches costs seconds, and every distinct
``advance`` length would pay it again."""
WHOLE = 1 << 30
"""``steps_per_launch`` of the chain solver: the whole ``advance`` in one launch."""


@dataclass(frozen=True)
class SolverConfig:
    """Everything that chooses a solver and its compiled code; the chain count only sets block counts.

    Runtime geometry (blocks per chain, window interior) follows from ``shape``, ``steps_per_launch`` and
    the model's grain and chain counts (``hertzian.core.solvers.tile.tile_plan``).
    """

    kind: str = "step"
    """One of SOLVER_KINDS."""
    shape: TileShape | None = None
    """Compile-time launch shape of the tile and window kernels; None for step and chain."""
    steps_per_launch: int = 1
    """Steps one kernel launch takes (1 for step, K for tile/window, WHOLE for chain)."""
    use_graph: bool | None = None
    """Capture launches in CUDA graphs and replay them; None: on CUDA devices (never on the CPU)."""
    graph_steps: int | None = None
    """Steps per captured graph (the per-step solver: GRAPH_STEPS); None: FUSED_GRAPH_LAUNCHES launches."""

    def __post_init__(self):
        if self.kind not in SOLVER_KINDS:
            raise ValueError(f"solver kind = {self.kind!r}: one of {', '.join(SOLVER_KINDS)}")
        if (self.shape is not None) != (self.kind in ("tile", "window")):
            raise ValueError(f"solver kind = {self.kind!r}: a launch shape is needed by tile and window only")
        if self.kind == "window" and not self.shape.windowed or self.kind == "tile" and self.shape.windowed:
            raise ValueError(f"solver kind = {self.kind!r} does not match shape.windowed = {self.shape.windowed}")
        if self.steps_per_launch < 1:
            raise ValueError(f"steps_per_launch = {self.steps_per_launch}: must be at least 1")

    def describe(self) -> str:
        """Short text: 'step', 'chain', or 'tile (G=8 lanes=4 K=64)' and the like."""
        if self.shape is None:
            return self.kind
        return f"{self.kind} ({self.shape.describe()} K={self.steps_per_launch})"

    def to_dict(self) -> dict:
        """JSON-ready fields (store attributes, calibration cache)."""
        return asdict(self)

    @classmethod
    def from_dict(cls, data: dict) -> "SolverConfig":
        shape = data.get("shape")
        return cls(**{**data, "shape": TileShape(**shape) if shape else None})


STEP = SolverConfig("step", graph_steps=GRAPH_STEPS)
"""The per-step solver's config."""
CHAIN = SolverConfig("chain", steps_per_launch=WHOLE)
"""The CPU chain kernel solver's config."""
