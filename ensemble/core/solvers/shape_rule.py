"""The fused launch shape a CUDA run takes without timing anything: a rule per compute capability, shipped as data
(``shape_rules.json`` beside this module: what it was measured on, and the shapes that timing every candidate chose
there). A run never calibrates; ``hertzian tune`` times the candidates of a job on the machine at hand, remembers
the fastest in the calibration cache (hertzian.core.solvers.calibrate), and prints the rule's shape beside it.

The rule picks among feasible candidates (``calibrate.whole_chain_configs`` and ``calibrate.window_configs``), so it
never names a shape the device cannot launch: by the chain length and count it takes a regime, then the first of
the regime's preferences that applies and that a candidate matches.
"""

from __future__ import annotations

import functools
import json
from dataclasses import dataclass
from pathlib import Path

RULES_FILE = Path(__file__).with_name("shape_rules.json")
MATCHED = ("kind", "grains_per_lane", "lanes_per_chain", "steps_per_launch")
"""The fields of a preference a candidate config must have (the others are conditions on the run)."""


@functools.cache
def shape_rules() -> dict:
    """The shipped rules (``shape_rules.json``)."""
    return json.loads(RULES_FILE.read_text())


def rule_for(arch: int | None) -> tuple[str, dict]:
    """(architecture key, rule) for a CUDA compute capability (e.g. 90); an architecture without its own
    measurements takes the fallback's."""
    rules = shape_rules()
    key = str(arch) if str(arch) in rules["architectures"] else rules["fallback"]
    return key, rules["architectures"][key]


def regime(rule: dict, grains: int, chains: int, sm_count: int) -> str:
    """``whole_chains`` (short chains filling the GPU), ``few_chains`` (fewer chains than a few per SM) or
    ``long_chains`` (many chains too long for one block)."""
    whole = rule["whole_chains"]
    if grains <= whole["max_grains"] and chains >= whole["min_chains_per_sm"] * sm_count:
        return "whole_chains"
    if chains < rule["few_chains"]["max_chains_per_sm"] * sm_count:
        return "few_chains"
    return "long_chains"


def applies(preference: dict, grains: int, features) -> bool:
    """Whether a preference's conditions hold for the run: ``max_grains`` and ``max_values`` (values per grain)."""
    return grains <= preference.get("max_grains", grains) and features.values <= preference.get(
        "max_values", features.values
    )


def matches(config, preference: dict) -> bool:
    """Whether ``config`` has the preference's kind, G, lanes and K (any not given), at most its
    ``max_lanes_per_chain`` lanes, one chain per block and no register cap."""
    shape = config.shape
    have = {
        "kind": config.kind,
        "grains_per_lane": shape.grains_per_lane,
        "lanes_per_chain": shape.lanes_per_chain,
        "steps_per_launch": config.steps_per_launch,
    }
    wanted = all(preference[k] == have[k] for k in MATCHED if k in preference)
    small = shape.lanes_per_chain <= preference.get("max_lanes_per_chain", shape.lanes_per_chain)
    return (
        wanted and small and shape.chains_per_block == preference.get("chains_per_block", 1) and not shape.max_registers
    )


def ruled_config(candidates: list, features, grains: int, chains: int, sm_count: int, arch: int | None):
    """The rule's choice among ``candidates`` (feasible tile and window configs), or None when no preference of the
    regime matches one."""
    _, rule = rule_for(arch)
    for preference in rule[regime(rule, grains, chains, sm_count)]["prefer"]:
        if not applies(preference, grains, features):
            continue
        for config in candidates:
            if matches(config, preference):
                return config
    return None


@dataclass(frozen=True)
class PlannedGPU:
    """A CUDA GPU that kernels are planned and compiled for on another machine (``hertzian prebuild --gpu-family``):
    what the planners read of a Warp device. Its launch shapes come from the shipped rule, as on the GPU itself."""

    arch: int
    """Compute capability, e.g. 90."""
    sm_count: int = 132
    is_cpu: bool = False
    is_cuda: bool = True

    @property
    def name(self) -> str:
        return f"sm_{self.arch}"

    def __str__(self) -> str:
        return self.name
