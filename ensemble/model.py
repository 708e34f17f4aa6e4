"""Scenes → an immutable ensemble *model* on a device → *state* buffers.

``build_model(scenes, device)`` checks that the scenes can share one launch (same grain
count, boundaries, integrator, dt and record layout), derives the kernel
:class:`~kernels.features.Features` from what the chains actually use, and uploads only the
arrays those features need. ``model.state()`` allocates one state buffer; a stepper
ping-pongs between two.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import warp as wp

from kernels.features import EVENT_WINDOW, Features

from .scene import Scene, SceneError
from .static import StaticState, static_state

SHARED_KEYS = (
    ("chain.grains", lambda s: s.chain.grains),
    ("boundary.surface", lambda s: s.boundary.surface),
    ("boundary.bottom", lambda s: s.boundary.bottom),
    ("integrator.method", lambda s: s.integrator.method),
    ("integrator.precision", lambda s: s.integrator.precision),
    ("integrator.dt", lambda s: s.integrator.dt),
    ("integrator.events", lambda s: s.integrator.events),
    ("steps per record", lambda s: s.steps_per_record),
    ("record count", lambda s: s.record_count),
    ("trace stride", lambda s: s.trace_stride),
    ("record.traces", lambda s: s.record.traces),
    ("record.fields", lambda s: s.record.fields),
)


def features_of(scenes: list[Scene], statics: list[StaticState] | None = None) -> Features:
    """The smallest feature set that covers every scene (they must share the SHARED_KEYS)."""
    first = scenes[0]
    for key, get in SHARED_KEYS:
        values = {get(s) for s in scenes}
        if len(values) > 1:
            raise SceneError(key, sorted(map(str, values)), "chains in one ensemble must share this")
    statics = statics or [static_state(s) for s in scenes]
    any_static = any(np.any(st.static_overlap > 0) for st in statics)
    heterogeneous = any(s.impurities for s in scenes)
    if not any_static:
        static = "none"
    elif heterogeneous or any(s.chain.gravity > 0 for s in scenes):
        static = "profile"
    else:
        static = "uniform"
    return Features(
        method=first.integrator.method,
        precision=first.integrator.precision,
        surface=first.boundary.surface,
        bottom=first.boundary.bottom,
        static=static,
        heterogeneous=heterogeneous,
        hertz=all(s.chain.exponent == 2.5 for s in scenes),
        traces=bool(first.record.traces),
        event_window=EVENT_WINDOW if first.integrator.events == "auto" and first.integrator.method != "verlet"
        and any(contact_can_open(s, st) for s, st in zip(scenes, statics)) else 0.0,
    )


def contact_can_open(scene: Scene, static: StaticState) -> bool:
    """Whether some contact of the scene may open (or close) during the run, by an energy bound.

    Opening contact k from its static overlap δ0 > 0 stores at least the excess potential
    V(0) − V(δ0) + V'(δ0)·δ0 = (n − 1)·a_c·δ0^n in it; every contact's excess potential is ≥ 0 and
    their sum is at most the injected energy (energy is conserved), so if that exceeds the injected
    energy for every contact, none can open. A drive (energy not bounded) or a contact without static
    overlap may always open.
    """
    if scene.boundary.surface == "driven":
        return True
    present = static.contact_constant > 0
    if not np.any(present):
        return False
    delta0 = static.static_overlap[present]
    a_c = static.contact_constant[present]
    n = static.exponent
    if np.any(delta0 <= 0):
        return True
    return bool(np.any((n - 1) * a_c * delta0**n <= scene.injected_energy))


@dataclass(frozen=True)
class State:
    """One state buffer of an ensemble."""

    x: wp.array
    """Scaled Nordsieck values, shape (values, chains, grains): u, dt·v, dt²/2·a, …"""
    clock: wp.array
    """Steps taken, shape (1,), int32."""
    work: wp.array
    """Driver's work up to the previous step, shape (chains,) or (0,) without a drive."""
    power: wp.array
    """Driver's power at the previous step, shape (chains,) or (0,)."""


@dataclass(frozen=True)
class Model:
    """An ensemble of chains ready to integrate on one device. Arrays a feature doesn't use have size 0."""

    scenes: tuple[Scene, ...]
    features: Features
    device: wp.context.Device
    chain_count: int
    grain_count: int
    dt: float
    inverse_mass: wp.array
    """1/m, shape (chains, grains) with impurities, else (chains, 1)."""
    contact_constant: wp.array
    """a_c per padded contact, shape (chains, grains + 1) with impurities, else (chains, 1)."""
    static_overlap: wp.array
    """δ0 per padded contact (chains, grains + 1) ('profile'), (chains, 1) ('uniform') or (0, 0)."""
    exponent: wp.array
    """n per chain, shape (chains,), or (0,) for Hertz (n = 5/2 compiled in)."""
    drive: wp.array
    """(amplitude, angular frequency) per chain, shape (chains, 2), float64, or (0, 2)."""
    trace_slot: wp.array
    """For each grain its column in the trace buffer, or -1; shape (grains,) or (0,)."""
    validity_overlap: wp.array
    """Overlap beyond which the Hertz law is not trusted (0.1·diameter), shape (chains,), float64."""
    injected_energy: np.ndarray
    """½ m_0 v_imp² per chain (0 without an impact), float64."""

    @property
    def real(self):
        return wp.float64 if self.features.precision == "float64" else wp.float32

    def state(self) -> State:
        """A zeroed state buffer (all grains at their static positions, at rest, clock 0)."""
        c, n = self.chain_count, self.grain_count
        driven = self.features.surface == "driven"
        return State(
            x=wp.zeros((self.features.values, c, n), dtype=self.real, device=self.device),
            clock=wp.zeros(1, dtype=wp.int32, device=self.device),
            work=wp.zeros(c if driven else 0, dtype=wp.float64, device=self.device),
            power=wp.zeros(c if driven else 0, dtype=wp.float64, device=self.device),
        )

    def initial_state(self) -> State:
        """State at t = 0: static positions, v_0 = v_imp (impact) or the drive's, exact higher derivatives."""
        from .startup import initial_nordsieck

        state = self.state()
        x = np.zeros((self.features.values, self.chain_count, self.grain_count))
        for c, scene in enumerate(self.scenes):
            # exact Taylor start: keeps each Gear method at its own order (see ensemble/startup.py)
            x[:, c, :] = initial_nordsieck(scene, self.features.values, self.dt)
        state.x.assign(x.astype(np.float64 if self.features.precision == "float64" else np.float32))
        return state


STATIC_LEVELS = ("none", "uniform", "profile")


def covers(wider: Features, needed: Features) -> bool:
    """Whether a kernel variant ``wider`` can run scenes that need ``needed`` (a kernel with event-aware
    steps also runs scenes in which no contact can open)."""
    return (wider.method, wider.precision, wider.surface, wider.bottom, wider.traces) == (
        needed.method, needed.precision, needed.surface, needed.bottom, needed.traces) and (
        needed.event_window in (0.0, wider.event_window)) and (
        STATIC_LEVELS.index(wider.static) >= STATIC_LEVELS.index(needed.static)
        and wider.heterogeneous >= needed.heterogeneous and (needed.hertz or not wider.hertz))


def build_model(scenes: list[Scene], device: str | None = None, *, features: Features | None = None) -> Model:
    """Upload an ensemble of compatible scenes to ``device`` (default: CUDA if present, else CPU).

    ``features`` forces a wider kernel variant than the scenes need (e.g. to run one member of an
    ensemble alone with the ensemble's kernel).
    """
    device = wp.get_device(device)
    if not scenes:
        raise SceneError("scenes", [], "an ensemble needs at least one scene")
    statics = [static_state(s) for s in scenes]
    f = features_of(scenes, statics)
    if features is not None:
        if not covers(features, f):
            raise ValueError(f"kernel features {features} cannot run scenes that need {f}")
        f = features
    np_real = np.float64 if f.precision == "float64" else np.float32
    real = wp.float64 if f.precision == "float64" else wp.float32
    c_count, n = len(scenes), scenes[0].chain.grains

    def upload(array, dtype=real):
        return wp.array(np.ascontiguousarray(array), dtype=dtype, device=device)

    if f.heterogeneous:
        inverse_mass = np.stack([1.0 / st.mass for st in statics])
        contact_constant = np.stack([st.contact_constant for st in statics])
    else:
        inverse_mass = np.array([[1.0 / s.chain.mass] for s in scenes])
        contact_constant = np.array([[s.chain.a] for s in scenes])
    if f.static == "profile":
        static_overlap = np.stack([st.static_overlap for st in statics])
    elif f.static == "uniform":
        static_overlap = np.array([[st.static_overlap.max()] for st in statics])
    else:
        static_overlap = np.zeros((0, 0))
    exponent = np.zeros(0) if f.hertz else np.array([s.chain.exponent for s in scenes])
    if f.surface == "driven":
        drive = np.array([[s.excitation.drive_amplitude, 2.0 * math.pi / s.excitation.drive_period]
                          for s in scenes])
    else:
        drive = np.zeros((0, 2))
    trace_slot = np.full(n if f.traces else 0, -1, dtype=np.int32)
    for slot, grain in enumerate(scenes[0].record.traces):
        trace_slot[grain] = slot

    return Model(
        scenes=tuple(scenes),
        features=f,
        device=device,
        chain_count=c_count,
        grain_count=n,
        dt=scenes[0].integrator.dt,
        inverse_mass=upload(inverse_mass.astype(np_real)),
        contact_constant=upload(contact_constant.astype(np_real)),
        static_overlap=upload(static_overlap.astype(np_real)),
        exponent=upload(exponent.astype(np_real)),
        drive=upload(drive, wp.float64),
        trace_slot=upload(trace_slot, wp.int32),
        validity_overlap=upload(np.array([0.1 * s.chain.diameter for s in scenes]), wp.float64),
        injected_energy=np.array([s.injected_energy for s in scenes]),
    )
