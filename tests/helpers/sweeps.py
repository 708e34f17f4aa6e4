"""Sweep files shared by the sweeping tests, and the shipped sweeps' folder."""

from __future__ import annotations

from pathlib import Path

from tests.helpers.cli import sweep_cli

SWEEPS = Path(__file__).resolve().parents[2] / "sweeps"
"""The shipped sweep files (package ``hertzian.sweeps``)."""

GRID_SWEEP = """
[scene.chain]
grains = 12

[scene.excitation]
impact = 1e-2

[scene.integrator]
dt = 1e-4
duration = 0.02

[scene.record]
every = 0.01
traces = [0, 11]
trace_every = 0.001

[[axis]]
name = "v_imp"
key = "excitation.impact"
logspace = [-3, -1, 3]

[[axis]]
name = "l0"
key = "chain.l0"
values = [0.0, 1e-4]
"""
"""A 3 × 2 grid (v_imp × l0) of 12-grain chains, run to t = 0.02, with traces."""


def write_sweep(tmp_path: Path, text: str = GRID_SWEEP, name: str = "sweep.toml") -> Path:
    """``text`` written to ``tmp_path / name``; returns the file's path."""
    path = tmp_path / name
    path.write_text(text)
    return path


def run_store(tmp_path: Path, text: str = GRID_SWEEP, *flags, name: str = "out.zarr") -> Path:
    """``hertzian sweep`` of ``text`` on the CPU (with ``flags``) into ``tmp_path / name``, asserted to succeed."""
    out = tmp_path / name
    result = sweep_cli(write_sweep(tmp_path, text, name=f"{name}.toml"), "--out", out, "--device", "cpu", *flags)
    assert result.exit_code == 0, result.stderr + result.stdout
    return out


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
