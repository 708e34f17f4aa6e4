"""Batch sizes for several workers: a short tail, the same bits.

A sweep's batches are blocks of equal shape (``hertzian.sweeping.planner``); with W workers pulling them the
batch phase lasts about ``ceil(B / W)`` batches, so 9 batches on 4 workers keep one worker busy a whole round
while three wait (69 % efficiency). :func:`balance_plan` cuts the grid into smaller blocks until the batches,
handed out biggest first to whichever worker is free, finish within :data:`TAIL_TOLERANCE` of a perfect split.

A point's result does not depend on its batch: every batch of a launch group is compiled with the group's kernel
variant (``LaunchGroup.features``, computed over all the group's points) and the fused kernels reproduce the
per-step kernel bit for bit, so a balanced plan writes the same store values as any other plan of the sweep.
The store is chunked (sharded) by the balanced block, so each batch still writes whole shards of its own.
"""

from __future__ import annotations

import heapq
import math
from dataclasses import replace

from hertzian.sweeping.planner import Plan, _splitting_dims, batches_for, block_for

TAIL_TOLERANCE = 0.03
"""Accepted excess of the batch phase's predicted length over a perfect split (total work / workers)."""
SMALLEST_FRACTION = 4
"""Blocks are not cut below 1/SMALLEST_FRACTION of the planned batch size (small launches fill a GPU poorly)."""


def makespan(costs: list[float], workers: int) -> float:
    """Length of the batch phase when ``workers`` equal workers take the batches of ``costs`` (any unit)
    biggest first, each from whichever worker is free first (the order :func:`batch_priorities` gives)."""
    finish = [0.0] * workers
    for cost in sorted(costs, reverse=True):
        heapq.heappush(finish, heapq.heappop(finish) + cost)
    return max(finish) if finish else 0.0


def tail_excess(plan: Plan, workers: int) -> float:
    """Predicted batch-phase length of ``plan`` on ``workers`` workers over a perfect split, minus 1."""
    costs = [float(plan.batch_grain_steps(b)) for b in plan.batches]
    ideal = sum(costs) / workers
    return makespan(costs, workers) / ideal - 1.0 if ideal > 0 else 0.0


def balance_plan(plan: Plan, workers: int) -> Plan:
    """``plan`` with a block small enough that ``workers`` workers finish together (within TAIL_TOLERANCE),
    or the most balanced block down to 1/SMALLEST_FRACTION of the planned batch size; the plan itself when
    it already is balanced, or for one worker."""
    if workers <= 1 or not plan.shape or tail_excess(plan, workers) <= TAIL_TOLERANCE:
        return plan
    splitting = _splitting_dims(plan.point_group)
    points = plan.point_count
    best, best_excess = plan, tail_excess(plan, workers)
    smallest = max(1, plan.batch_size // SMALLEST_FRACTION)
    for count in range(len(plan.batches) + 1, points + 1):
        target = math.ceil(points / count)
        if target < smallest:
            break
        block = block_for(plan.shape, splitting, target)
        if block == best.block:
            continue
        candidate = replace(plan, block=block, batches=tuple(batches_for(plan.shape, block, plan.point_group)))
        excess = tail_excess(candidate, workers)
        if excess < best_excess:
            best, best_excess = candidate, excess
        if excess <= TAIL_TOLERANCE:
            break
    return best


def batch_priorities(plan: Plan, indices) -> dict[int, int]:
    """Scheduler priority of each batch index (higher runs first): biggest batch first, then grid order."""
    order = sorted(indices, key=lambda i: (-plan.batch_grain_steps(plan.batches[i]), i))
    return {index: len(order) - rank for rank, index in enumerate(order)}
