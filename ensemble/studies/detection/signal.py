"""The measured signal: grain 0's velocity sampled uniformly from the impact at t = 0, read from a CSV file or a
hertzian store, checked, and written back as CSV (program units)."""

from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from hertzian.core.scene import SceneError
from hertzian.sweeping.store import open_store


@dataclass(frozen=True)
class Signal:
    """Surface grain velocity sampled uniformly from the impact at t = 0 (program units)."""

    t: np.ndarray
    """Sample times [time], shape (S,), t[0] = 0, uniform spacing."""
    v: np.ndarray
    """Velocity of grain 0 [length/time], positive toward the bottom, shape (S,)."""
    source: str = ""

    @property
    def spacing(self) -> float:
        """Sample spacing [time]."""
        return float(self.t[1] - self.t[0])

    @property
    def sample_count(self) -> int:
        return int(self.t.size)


def signal_from_arrays(t, v, source: str = "signal") -> Signal:
    """Check and wrap sampled data: finite, at least 3 samples, uniform t from 0 (relative 1e-6)."""
    t = np.asarray(t, dtype=np.float64).ravel()
    v = np.asarray(v, dtype=np.float64).ravel()
    if t.size != v.size:
        raise SceneError(source, f"{t.size} times, {v.size} values", "t and v must have the same length")
    if t.size < 3:
        raise SceneError(source, f"{t.size} samples", "needs at least 3 samples")
    for name, values in (("t", t), ("v", v)):
        bad = np.flatnonzero(~np.isfinite(values))
        if bad.size:
            raise SceneError(f"{source}: {name}[{bad[0]}]", float(values[bad[0]]), "values must be finite numbers")
    spacing = (t[-1] - t[0]) / (t.size - 1)
    if not spacing > 0:
        raise SceneError(f"{source}: t", f"{t[0]} … {t[-1]}", "times must increase")
    steps = np.diff(t)
    worst = int(np.argmax(np.abs(steps - spacing)))
    if abs(steps[worst] - spacing) > 1e-6 * spacing:
        raise SceneError(
            f"{source}: t[{worst + 1}] − t[{worst}]",
            float(steps[worst]),
            f"samples must be uniform (spacing {spacing:.6g}, tolerance 1e-6 relative)",
        )
    if abs(t[0]) > 1e-6 * spacing:
        raise SceneError(f"{source}: t[0]", float(t[0]), "the signal must start at the impact, t = 0")
    return Signal(t=np.arange(t.size) * spacing, v=v, source=source)


def read_signal(path: str | Path) -> Signal:
    """A CSV file with the header ``t,v``, or a hertzian store (Zarr) with a trace of grain 0."""
    path = Path(path)
    if not path.exists():
        raise SceneError("SIGNAL", str(path), "no such file or store")
    if path.is_dir():
        return _signal_from_store(path)
    try:
        with path.open(newline="") as handle:
            rows = list(csv.reader(handle))
    except (OSError, UnicodeDecodeError) as err:
        raise SceneError(
            "SIGNAL",
            str(path),
            f"not a text file ({err.__class__.__name__}): give a CSV file with the header t,v, or a store that "
            "hertzian run wrote with grain 0 traced",
        ) from None
    rows = [row for row in rows if row and any(cell.strip() for cell in row)]
    if not rows:
        raise SceneError("SIGNAL", str(path), "is empty; expected a header line t,v and samples")
    header = [cell.strip().lower() for cell in rows[0]]
    if header != ["t", "v"]:
        raise SceneError(f"{path}: header", ",".join(rows[0]), "the first line must be the header t,v")
    t, v = [], []
    for number, row in enumerate(rows[1:], start=2):
        if len(row) != 2:
            raise SceneError(f"{path}: line {number}", ",".join(row), "must hold two numbers t,v")
        try:
            t.append(float(row[0]))
            v.append(float(row[1]))
        except ValueError:
            raise SceneError(f"{path}: line {number}", ",".join(row), "must hold two numbers t,v") from None
    return signal_from_arrays(t, v, source=str(path))


def _signal_from_store(path: Path) -> Signal:

    try:
        group = open_store(path)
    except (ValueError, FileNotFoundError, OSError) as err:
        raise SceneError("SIGNAL", str(path), f"is not a hertzian store ({err})") from None
    members = set(group.array_keys())
    if not {"trace_t", "trace_v", "traced_grain"} <= members:
        raise SceneError("SIGNAL", str(path), "the store has no traces (record.traces = [0] in its scene)")
    traced = list(np.asarray(group["traced_grain"][...]))
    if 0 not in traced:
        raise SceneError("SIGNAL", str(path), f"the store traces grains {traced}, not grain 0")
    data = np.asarray(group["trace_v"][...])
    if data.ndim != 2 and int(np.prod(data.shape[:-2])) != 1:
        raise SceneError(
            "SIGNAL", str(path), f"the store holds {int(np.prod(data.shape[:-2]))} points; give a store of one run"
        )
    data = data.reshape(data.shape[-2:])
    return signal_from_arrays(np.asarray(group["trace_t"][...]), data[:, traced.index(0)], source=str(path))


def write_signal_csv(path: str | Path, signal: Signal) -> None:
    """Write a signal as CSV with the header ``t,v`` (full float64 precision)."""
    with Path(path).open("w") as handle:
        handle.write("t,v\n")
        for t, v in zip(signal.t, signal.v):
            handle.write(f"{float(t)!r},{float(v)!r}\n")
