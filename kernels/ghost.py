"""Window geometry for long chains: several blocks per chain, each with ghost zones.

A chain longer than a block can hold is cut into pieces of ``interior`` grains. The block of
piece ``p`` loads the window ``[p·interior − ghost, (p + 1)·interior + ghost)`` (grains outside the
chain read as virtual grains at rest and never move), integrates all of it for ``steps ≤ ghost``
steps, and writes back only ``[p·interior, (p + 1)·interior)``.

Why that is exact: a step moves information one grain (grain i's new state depends on the
predicted positions of i − 1 and i + 1 only). The outermost window grains see a wrong neighbour
(there is none in the window), so after s steps the s outermost grains on each side may be wrong,
and after ``ghost`` steps the error has just not reached the interior. The window's outer grains
are therefore pure recomputation: the cost of this scheme is ``window / interior`` times the work,
plus one load and one store of the window per launch.
"""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class Windows:
    """How one chain is cut into blocks."""

    interior: int
    """Grains each block writes back."""
    ghost: int
    """Grains of each neighbour a block integrates as well; also the most steps per launch."""
    blocks_per_chain: int

    @property
    def window(self) -> int:
        return self.interior + 2 * self.ghost

    def overhead(self, grain_count: int) -> float:
        """Grain-steps computed per grain-step kept (≥ 1)."""
        return self.blocks_per_chain * self.window / grain_count


def plan_windows(grain_count: int, window: int, steps_per_launch: int) -> Windows:
    """Cut a chain of ``grain_count`` grains into windows of ``window`` grains for ``steps_per_launch`` steps.

    The interior is ``window − 2·steps_per_launch`` grains; raises ValueError when that is not positive.
    """
    if grain_count < 1:
        raise ValueError(f"grain_count = {grain_count}: must be at least 1")
    if steps_per_launch < 1:
        raise ValueError(f"steps_per_launch = {steps_per_launch}: must be at least 1")
    interior = window - 2 * steps_per_launch
    if interior < 1:
        raise ValueError(
            f"window = {window} grains leaves no interior for {steps_per_launch} ghost steps "
            f"(needs window > 2·steps_per_launch)"
        )
    return Windows(interior=interior, ghost=steps_per_launch, blocks_per_chain=math.ceil(grain_count / interior))
