"""Sweep files shared by the sweeping tests, and the shipped sweeps' folder."""

from __future__ import annotations

from pathlib import Path

SWEEPS = Path(__file__).resolve().parents[2] / "sweeps"
"""The shipped sweep files (package ``hertzian.sweeps``)."""

RESUME_SWEEP = """
[scene.chain]
grains = 20

[scene.excitation]
impact = 1e-2

[scene.integrator]
dt = 1e-4
duration = 1.0

[scene.record]
every = 0.2
traces = [0, 19]
trace_every = 0.01

[[axis]]
name = "v_imp"
key = "excitation.impact"
logspace = [-3, -1, 3]

[[axis]]
name = "l0"
key = "chain.l0"
values = [0.0, 1e-5, 1e-4]
"""
"""A sweep of nine points, twenty grains each, run to t = 1: long enough to be killed mid-run."""
RESUME_FLAGS = ("--batch-size", "1", "--device", "cpu", "--quiet")
"""Flags of the resume tests: one point per batch on the CPU, quietly."""
RESUME_BATCHES = 9
"""Batches of RESUME_SWEEP with RESUME_FLAGS."""
