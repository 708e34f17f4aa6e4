"""Scenes → an immutable ensemble *model* on a device → *state* buffers.

``build_model(scenes, device)`` checks that the scenes can share one launch (same grain
count, boundaries, integrator, dt and record layout), derives the kernel
:class:`~hertzian.kernels.features.Features` from what the chains actually use, and uploads only the
arrays those features need. ``model.state_pair()`` allocates the two state buffers a solver
ping-pongs between (they share one ``status`` and one trace ring).
"""

from __future__ import annotations

import contextlib
import math
import time
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import warp as wp
from hertzian.core.chains import ChainSet, ChainStack, has_radii, per_unique
from hertzian.core.modes import injected_energy
from hertzian.core.scene import VALIDITY_FRACTION, Scene, SceneError
from hertzian.core.static import StaticState, static_state, validity_scale
from hertzian.kernels.features import EVENT_WINDOW, GEAR_CORRECTOR, GEAR_VALUES, Features


class LaunchKey(NamedTuple):
    """What every chain of one launch shares (a sweep's launch group): each field a scene property, by name."""

    grains: int
    surface: str
    bottom: str
    method: str
    precision: str
    dt: float
    events: str
    steps_per_record: int
    record_count: int
    record_steps: bytes
    trace_stride: int
    traces: tuple
    fields: tuple
    damping: str
    response_windows: tuple
    potential: str


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
    ("record steps", lambda s: s.record_steps.tobytes()),
    ("trace stride", lambda s: s.trace_stride),
    ("record.traces", lambda s: s.record.traces),
    ("record.fields", lambda s: s.record.fields),
    ("damping.model", lambda s: s.damping.model),
    ("response windows", lambda s: (s.record.response_start, s.record.response_windows, s.record.harmonics)),
    ("chain.potential", lambda s: s.chain.potential),
)
"""(name in messages, getter) of each :class:`LaunchKey` field, in its order."""


def launch_key(scene: Scene) -> LaunchKey:
    """What ``scene`` shares with every chain it may run with in one launch."""
    return LaunchKey(*(get(scene) for _, get in SHARED_KEYS))


def features_of(scenes: list[Scene], statics: list[StaticState] | None = None) -> Features:
    """The smallest feature set that covers every scene (they must share the SHARED_KEYS)."""
    first = scenes[0]
    for key, get in SHARED_KEYS:
        values = {get(s) for s in scenes}
        if len(values) > 1:
            raise SceneError(
                key,
                sorted(map(str, values)),
                "chains in one ensemble must share this (run them apart, or as a sweep, which groups them)",
            )
    statics = statics or [static_state(s) for s in scenes]
    return _features(
        first,
        any_static=any(np.any(st.static_overlap > 0) for st in statics),
        heterogeneous=any(
            s.impurities or s.chain.radius_ratios is not None or s.chain.material is not None for s in scenes
        ),
        gravity=any(s.chain.gravity > 0 for s in scenes),
        hertz=all(s.chain.exponent == 2.5 for s in scenes) and first.chain.potential == "hertz",
        can_open=lambda: any(contact_can_open(s, st) for s, st in zip(scenes, statics)),
    )


def _features(first: Scene, *, any_static: bool, heterogeneous: bool, gravity: bool, hertz: bool, can_open) -> Features:
    """The feature set from what the chains use (``can_open()`` is asked only where events may apply)."""
    if not any_static:
        static = "none"
    elif heterogeneous or gravity:
        static = "profile"
    else:
        static = "uniform"
    # event steps carry no damping: a damped scene takes plain steps (docs/drive.md); they are Gear steps
    # (Verlet and its composition yoshida4 take none)
    # a lattice law carries tension: its contacts never open, its force is smooth, no event steps
    events = (
        first.chain.potential == "hertz"
        and first.integrator.events == "auto"
        and first.integrator.method in GEAR_CORRECTOR
        and first.damping.model == "none"
        and can_open()
    )
    return Features(
        method=first.integrator.method,
        precision=first.integrator.precision,
        surface=first.boundary.surface,
        bottom=first.boundary.bottom,
        static=static,
        heterogeneous=heterogeneous,
        hertz=hertz,
        traces=bool(first.record.traces),
        event_window=EVENT_WINDOW if events else 0.0,
        damping=first.damping.model,
        potential=first.chain.potential,
    )


def law_parameters_of(scenes: list[Scene], f: Features) -> np.ndarray:
    """Model.law_parameters of ``scenes``: n per chain (a power law other than Hertz), (p0, p1) per chain (a lattice
    law, hertzian.core.potentials.law_of), or none."""
    if f.potential != "hertz":
        from hertzian.core.potentials import law_of

        return np.array([(law.p0, law.p1) for law in (law_of(s.chain) for s in scenes)], dtype=np.float64).ravel()
    return np.zeros(0) if f.hertz else np.array([s.chain.exponent for s in scenes])


def contact_can_open(scene: Scene, static: StaticState) -> bool:
    """Whether some contact of the scene may open (or close) during the run, by an energy bound.

    Opening contact k from its static overlap δ0 > 0 stores at least the excess potential
    V(0) − V(δ0) + V'(δ0)·δ0 = (n − 1)·a_c·δ0^n in it; every contact's excess potential is ≥ 0 and
    their sum is at most the injected energy (energy is conserved), so if that exceeds the injected
    energy for every contact, none can open. A drive (energy not bounded) or a contact without static
    overlap may always open.
    """
    if scene.chain.potential != "hertz":
        return False  # a lattice law's contacts carry tension: they never open
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
    return bool(np.any((n - 1) * a_c * delta0**n <= injected_energy(scene)))


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
    status: wp.array
    """Per-chain status code (hertzian.core.status.Status), shape (chains,), int32. Both halves of a ping-pong
    pair hold the *same* array: kernels read it to freeze a non-finite chain and the record kernel writes it."""
    traces: wp.array
    """Trace ring, shape (2, chains, samples per record, traced grains) [u and dt·v], or (2, 0, 0, 0);
    shared by both halves like ``status``; the record step reads it back once per record."""
    dissipated: wp.array = None
    """Energy dissipated by damping up to now per grain (its own viscous loss, or the dashpot of the
    contact above it), shape (chains, grains) float64, or (0, 0) without damping; shared by both
    halves (each thread updates only its own grain)."""


@dataclass(frozen=True)
class Model:
    """An ensemble of chains ready to integrate on one device. Arrays a feature doesn't use have size 0."""

    scenes: "tuple[Scene, ...] | ChainSet | ChainStack"
    """The chains' scenes: a tuple, or a ChainSet (template + per-chain arrays) or ChainStack indexed like one."""
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
    law_parameters: wp.array
    """The contact law's per-chain shape: n per chain, shape (chains,), for a power law other than Hertz; (α, β),
    (b, 0), (α, 0) or (σ, 0) per chain, shape (2·chains,), for fput, toda, morse or lj (kernels/physics.py
    ``contact_parameters``); (0,) for Hertz (n = 5/2 compiled in) and the harmonic law."""
    drive: wp.array
    """(amplitude, angular frequency) per chain, shape (chains, 2), float64, or (0, 2)."""
    trace_slot: wp.array
    """For each grain its column in the trace buffer, or -1; shape (grains,) or (0,)."""
    validity_overlap: wp.array
    """Overlap beyond which the Hertz law is not trusted between two R0 grains (ChainSpec.validity_overlap), shape
    (chains,), float64."""
    validity_scale: wp.array
    """R0/min(R_i, R_j) per padded contact (hertzian.core.static.validity_scale; 1 for equal grains), shape
    (chains, grains + 1), float64, with impurities or radii, else (0, 0): the record kernels compare each contact's
    overlap times its scale with ``validity_overlap``."""
    injected_energy: np.ndarray
    """½ m_0 v_imp² per chain (0 without an impact), float64."""
    _static: object = None
    """StaticArrays of a ChainSet model (reused by the Taylor start), else None."""
    damping: wp.array = None
    """γ per chain, shape (chains,), or (0,) without damping (damping.model in ``features``)."""
    _start: tuple | None = None
    """(features, initial state's leading grains in those features' layout, gear4's exact start in that layout or
    None) of a ChainSet model (prepare_model's ``start`` and ``exact_start``)."""

    @property
    def real(self):
        return wp.float64 if self.features.precision == "float64" else wp.float32

    @property
    def trace_capacity(self) -> int:
        """Trace samples kept between two records (the ring's length)."""
        scene = self.scenes[0]
        if not scene.record.traces:
            return 0
        # the most samples taken between two records (samples at steps k·stride, records at record_steps)
        per_gap = np.diff(np.asarray(scene.record_steps) // scene.trace_stride)
        return max(1, int(per_gap.max())) if per_gap.size else 1

    def state(self, *, like: State | None = None) -> State:
        """A zeroed state buffer (all grains at their static positions, at rest, clock 0).

        ``like``: the other half of a ping-pong pair, whose ``status`` and trace ring this one shares.
        """
        c, n = self.chain_count, self.grain_count
        driven = self.features.surface == "driven"
        if like is None:
            traced = len(self.scenes[0].record.traces)
            shape = (2, c, self.trace_capacity, traced) if traced else (2, 0, 0, 0)
            status = wp.zeros(c, dtype=wp.int32, device=self.device)
            traces = wp.zeros(shape, dtype=self.real, device=self.device)
            damped = self.features.damping != "none"
            dissipated = wp.zeros((c, n) if damped else (0, 0), dtype=wp.float64, device=self.device)
        else:
            status, traces, dissipated = like.status, like.traces, like.dissipated
        return State(
            x=wp.zeros((self.features.values, c, n), dtype=self.real, device=self.device),
            clock=wp.zeros(1, dtype=wp.int32, device=self.device),
            work=wp.zeros(c if driven else 0, dtype=wp.float64, device=self.device),
            power=wp.zeros(c if driven else 0, dtype=wp.float64, device=self.device),
            status=status,
            traces=traces,
            dissipated=dissipated,
        )

    def state_pair(self) -> tuple[State, State]:
        """(state at t = 0, a zeroed second half) sharing one ``status`` and one trace ring."""
        first = self.initial_state()
        return first, self.state(like=first)

    def initial_state(self, *, like: State | None = None) -> State:
        """State at t = 0: static positions, v_0 = v_imp (impact) or the drive's, exact higher derivatives (gear4's
        in the steady-state form of its corrector, ensemble/core/startup.py)."""
        state = self.state(like=like)
        self._assign_start(state, self._start_rows(steady=True))
        return state

    @contextlib.contextmanager
    def exact_start(self, state: State):
        """``state`` at t = 0 holding the exact Taylor start while the block runs, then gear4's steady-state form
        again: the two differ in dt·v and dt³/6·ȧ (startup.py), and the record at t = 0 keeps v(0) itself and the
        energy E(0) that every later record is compared with. Other methods start exactly: nothing changes."""
        if self.features.method != "gear4":
            yield state
            return
        self._assign_start(state, self._start_rows(steady=False))
        try:
            yield state
        finally:
            self._assign_start(state, self._start_rows(steady=True))

    def _start_rows(self, *, steady: bool) -> np.ndarray:
        """The start in the kernels' layout, shape (rows, chains, width): of the first grains that move
        (startup.taylor_window) for a ChainSet model, else of every grain."""
        from hertzian.core.startup import initial_nordsieck, initial_nordsieck_of

        if self._start is not None and self._start[0] == self.features:  # prepared for these features
            start, exact = self._start[1:]
            return start if steady or exact is None else exact
        values = self.features.nordsieck_values
        if isinstance(self.scenes, ChainSet):
            x = initial_nordsieck_of(self.scenes, values, self.dt, self._static, whole=False, steady=steady)
        elif isinstance(self.scenes, ChainStack):
            parts = self.scenes.parts
            x = _stacked_starts([initial_nordsieck_of(p, values, self.dt, whole=False, steady=steady) for p in parts])
        else:
            # exact Taylor start: keeps each Gear method at its own order (see ensemble/core/startup.py)
            x = np.stack([initial_nordsieck(s, values, self.dt, steady=steady) for s in self.scenes], axis=1)
        return state_layout(x, self.features)

    def _assign_start(self, state: State, rows: np.ndarray) -> None:
        """Upload ``rows`` (:meth:`_start_rows`) into ``state``'s first grains (a copy of the window only)."""
        width = rows.shape[2]
        (state.x if width == self.grain_count else state.x[:, :, :width]).assign(rows)


def state_layout(nordsieck: np.ndarray, features: Features) -> np.ndarray:
    """Scaled Nordsieck vectors in float64, shape (Q, chains, grains), as the kernels of ``features`` keep them:
    float64 as they are; float32 rounded, and (compensated, kernels/gear.py) rows Q and Q + 1 holding what
    the rounding of u and dt·v left out, so that hi + lo carries u and dt·v to about twice float32's digits."""
    if features.precision == "float64":
        return np.ascontiguousarray(nordsieck, dtype=np.float64)
    rounded = nordsieck.astype(np.float32)
    if not features.compensation:
        return rounded
    low = (nordsieck[:2] - rounded[:2].astype(np.float64)).astype(np.float32)
    return np.ascontiguousarray(np.concatenate([rounded, low]))


STATIC_LEVELS = ("none", "uniform", "profile")


def covers(wider: Features, needed: Features) -> bool:
    """Whether a kernel variant ``wider`` can run scenes that need ``needed``."""
    # event-aware steps may run chains that cannot open a contact (they then step as plain Gear would
    # wherever no contact comes near opening), not the other way round; ``compensated`` is not compared:
    # a forced plain float32 variant runs float32 scenes, less accurately (kept for comparison)
    return (
        (wider.method, wider.precision, wider.surface, wider.bottom, wider.traces, wider.damping, wider.potential)
        == (
            needed.method,
            needed.precision,
            needed.surface,
            needed.bottom,
            needed.traces,
            needed.damping,
            needed.potential,
        )
        and (wider.event_window == needed.event_window or needed.event_window == 0.0)
        and (
            STATIC_LEVELS.index(wider.static) >= STATIC_LEVELS.index(needed.static)
            and wider.heterogeneous >= needed.heterogeneous
            and (needed.hertz or not wider.hertz)
        )
    )


def build_model(
    scenes: "list[Scene] | ChainSet",
    device: str | None = None,
    *,
    features: Features | None = None,
    prepared: "HostModel | None" = None,
) -> Model:
    """Upload an ensemble of compatible scenes to ``device`` (default: CUDA if present, else CPU).

    ``scenes``: a list of scenes, or a :class:`~hertzian.core.chains.ChainSet` (a template scene and
    per-chain parameter arrays; built with numpy, no scene per chain, same bits as the list of its
    scenes). ``features`` forces a wider kernel variant than the scenes need (e.g. to run one member
    of an ensemble alone with the ensemble's kernel). ``prepared``: :func:`prepare_model` of the same
    ChainSet and ``features``, computed earlier (e.g. in a background thread): only the uploads remain.
    """
    device = wp.get_device(device)
    if isinstance(scenes, (ChainSet, ChainStack)):
        return _build_model_of(scenes, device, features, prepared)
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
    law_parameters = law_parameters_of(scenes, f)
    if f.surface == "driven":
        drive = np.array([[s.excitation.drive_amplitude, 2.0 * math.pi / s.excitation.drive_period] for s in scenes])
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
        inverse_mass=upload(inverse_mass.astype(np_real, copy=False)),
        contact_constant=upload(contact_constant.astype(np_real, copy=False)),
        static_overlap=upload(static_overlap.astype(np_real, copy=False)),
        law_parameters=upload(law_parameters.astype(np_real, copy=False)),
        drive=upload(drive, wp.float64),
        trace_slot=upload(trace_slot, wp.int32),
        validity_overlap=upload(np.array([s.chain.validity_overlap for s in scenes]), wp.float64),
        validity_scale=upload(_scales(f, _stacked_ratios(scenes), c_count, n), wp.float64),
        injected_energy=np.array([injected_energy(s) for s in scenes]),
        damping=upload(np.array([s.damping.gamma for s in scenes] if f.damping != "none" else [], dtype=np_real)),
    )


def chain_set_features(chains: ChainSet, static) -> Features:
    """features_of for a ChainSet, from its static arrays (no scene per chain)."""
    return _features(
        chains.template,
        any_static=bool(np.any(static.configurations.static_overlap > 0)),
        heterogeneous=bool(chains.template.impurities)
        or static.radius_ratio is not None
        or chains.template.chain.material is not None,
        gravity=bool(np.any(chains.column("chain.gravity") > 0)),
        hertz=bool(np.all(chains.column("chain.exponent") == 2.5)),
        can_open=lambda: chain_set_can_open(chains, static),
    )


def chain_set_can_open(chains: ChainSet, static) -> bool:
    """:func:`contact_can_open` for any chain of a ChainSet, vectorised over its static arrays."""
    return bool(np.any(chains_can_open(chains, static)))


def chains_can_open(chains: ChainSet, static) -> np.ndarray:
    """:func:`contact_can_open` per chain of a ChainSet (bool, shape (chains,)), vectorised over its static arrays.

    The contacts' bounds are computed once per static configuration: a chain can open a contact if one has no
    static overlap or the configuration's lowest bound is within the chain's injected energy."""
    if chains.template.boundary.surface == "driven":
        return np.ones(len(chains), dtype=bool)
    rows = static.configurations
    present = rows.contact_constant > 0
    delta0 = np.where(present, rows.static_overlap, 1.0)
    bound = (rows.exponent[:, None] - 1) * rows.contact_constant * delta0 ** rows.exponent[:, None]
    unloaded = np.any(present & (rows.static_overlap <= 0), axis=1)
    # fmin skips NaN: an absent contact (and a NaN bound, which no energy reaches) never counts
    lowest = np.fmin.reduce(np.where(present, bound, np.nan), axis=1)
    impact = chains.column("excitation.impact")
    impact = np.zeros(len(chains)) if impact is None else impact
    injected = 0.5 * static.per_chain(rows.mass[:, 0]) * impact**2
    return static.per_chain(unloaded) | (static.per_chain(lowest) <= injected)


@dataclass(frozen=True, eq=False)
class HostModel:
    """Everything :func:`build_model` computes on the host for a ChainSet, before any upload: the kernel
    variant, the static arrays, the per-chain arrays in the kernels' precision and the initial state's
    first grains (:func:`prepare_model`; a sweep computes the next batch's while the current one runs)."""

    chains: ChainSet
    features: Features
    static: object
    """StaticArrays of the chains."""
    arrays: dict
    """Name → numpy array to upload (``inverse_mass``, ``contact_constant``, …)."""
    injected_energy: np.ndarray
    start: np.ndarray
    """The initial state's leading grains in the kernels' layout, shape (values, chains, window)."""
    exact_start: np.ndarray | None = None
    """gear4's exact Taylor start in the same layout (``start`` is its steady-state form; the record at t = 0 keeps
    this one, ``Model.exact_start``); None for the other methods, whose start is exact."""
    seconds: float = 0.0
    """Host seconds it took."""


PER_SCENE_ONLY = (
    "detection and design build chain sets of the hertz law from an impact or a drive: run lattice laws, modal or "
    "thermal starts and mode records with hertzian run, hz.run or a sweep"
)
"""Why :func:`prepare_model` refuses a scene that :func:`scene_path_key` names."""


def scene_path_key(scene: Scene) -> str | None:
    """The key of ``scene`` that the vectorised chain sets do not build (a lattice law, a modal or thermal start,
    mode records), or None. Such scenes are built one by one (:func:`build_model` of a list of scenes): a sweep
    runs each of their points as a scene of its own (``hertzian.sweeping.spec.SweepPoints.chains``)."""
    if scene.chain.potential != "hertz":
        return "chain.potential"
    if scene.excitation.modes:
        return "excitation.modes"
    if scene.excitation.thermal:
        return "excitation.thermal"
    if scene.record.modes:
        return "record.modes"
    return None


def refuse_per_scene_only(scene: Scene) -> None:
    """One line (SceneError) when ``scene`` is one the vectorised chain sets do not build (:func:`scene_path_key`)."""
    key = scene_path_key(scene)
    if key is not None:
        raise SceneError(key, _key_value(scene, key), PER_SCENE_ONLY)


def _key_value(scene: Scene, key: str):
    section, name = key.split(".")
    value = getattr(getattr(scene, section), name)
    return list(value) if isinstance(value, tuple) else value


def prepare_model(chains: ChainSet, *, features: Features | None = None) -> HostModel:
    """The host half of ``build_model(chains, …)``: numpy only, no device (safe in a background thread)."""
    from hertzian.core.startup import initial_starts_of, start_order, taylor_window
    from hertzian.core.static import static_arrays

    clock = time.perf_counter()
    if len(chains) == 0:
        raise SceneError("scenes", [], "an ensemble needs at least one scene")
    scene = chains.template
    refuse_per_scene_only(scene)
    # Homogeneous chains without gravity carry the same static force on every contact, so their
    # static state (all a uniform or absent static overlap needs) and the Taylor start come from the
    # first grains alone; impurities, radii or gravity need every grain's.
    window = None
    if not scene.impurities and not has_radii(chains) and not np.any(chains.column("chain.gravity") > 0):
        window = taylor_window(scene.chain.grains, start_order(GEAR_VALUES[scene.integrator.method]))
    st = static_arrays(chains, grains=window)
    f = chain_set_features(chains, st)
    if features is not None:
        if not covers(features, f):
            raise ValueError(f"kernel features {features} cannot run scenes that need {f}")
        f = features
    if window is not None and (f.static == "profile" or f.heterogeneous):
        st = static_arrays(chains)  # a wider variant was asked for: it reads every contact
    np_real = np.float64 if f.precision == "float64" else np.float32
    n = scene.chain.grains

    # derived per-grain arrays are computed on the static configurations, then gathered per chain
    if f.heterogeneous:
        inverse_mass = st.per_chain(1.0 / st.configurations.mass)
        contact_constant = st.contact_constant
    else:
        inverse_mass = (1.0 / chains.column("chain.mass"))[:, None]
        contact_constant = chains.column("chain.a")[:, None]
    if f.static == "profile":
        static_overlap = st.static_overlap
    elif f.static == "uniform":
        static_overlap = st.per_chain(st.configurations.static_overlap.max(axis=1))[:, None]
    else:
        static_overlap = np.zeros((0, 0))
    exponent = np.zeros(0) if f.hertz else st.exponent
    if f.surface == "driven":
        drive = np.stack(
            [
                chains.column("excitation.drive_amplitude"),
                per_unique(lambda p: 2.0 * math.pi / p, chains.column("excitation.drive_period")),
            ],
            axis=1,
        )
    else:
        drive = np.zeros((0, 2))
    trace_slot = np.full(n if f.traces else 0, -1, dtype=np.int32)
    for slot, grain in enumerate(scene.record.traces):
        trace_slot[grain] = slot
    impact = chains.column("excitation.impact")
    injected = per_unique(lambda m0, v: 0.5 * m0 * v**2, st.per_chain(st.configurations.mass[:, 0]), impact)
    arrays = {
        "inverse_mass": inverse_mass.astype(np_real, copy=False),
        "contact_constant": contact_constant.astype(np_real, copy=False),
        "static_overlap": static_overlap.astype(np_real, copy=False),
        "law_parameters": exponent.astype(np_real, copy=False),
        "drive": drive,
        "trace_slot": trace_slot,
        "validity_overlap": per_unique(lambda d: VALIDITY_FRACTION * d, chains.column("chain.diameter")),
        "validity_scale": _gathered(st, _scales(f, st.configurations.radius_ratio, len(st.configurations.mass), n)),
        "damping": (chains.column("damping.gamma") if f.damping != "none" else np.zeros(0)).astype(np_real, copy=False),
    }
    # only the first grains move at t = 0 (startup.taylor_window); the others start at zero
    values = f.nordsieck_values
    leading = st.leading(taylor_window(n, start_order(values)))
    start, exact = initial_starts_of(chains, values, scene.integrator.dt, leading)
    return HostModel(
        chains=chains,
        features=f,
        static=st,
        arrays=arrays,
        injected_energy=injected,
        start=state_layout(start, f),
        exact_start=None if exact is None else state_layout(exact, f),
        seconds=time.perf_counter() - clock,
    )


def _scales(f: Features, ratios: np.ndarray | None, rows: int, grains: int) -> np.ndarray:
    """Model.validity_scale of ``rows`` chains with radius ratios ``ratios`` (rows, grains) or None (equal grains):
    (rows, grains + 1) with impurities or radii, else (0, 0)."""
    if not f.heterogeneous:
        return np.zeros((0, 0))
    if ratios is None:
        return np.ones((rows, grains + 1))
    return validity_scale(ratios)


def _stacked_ratios(scenes: list[Scene]) -> np.ndarray | None:
    """R_i/R0 of every scene's grains (chains, grains), 1 for equal grains; None when every chain's are equal."""
    ratios = [s.chain.radius_ratios for s in scenes]
    if all(r is None for r in ratios):
        return None
    return np.stack([np.ones(s.chain.grains) if r is None else r for s, r in zip(scenes, ratios, strict=True)])


def _gathered(static, rows: np.ndarray) -> np.ndarray:
    """``rows`` computed per static configuration, per chain (an empty array as it is)."""
    return static.per_chain(rows) if rows.size else rows


def stack_prepared(parts: list[HostModel]) -> HostModel:
    """One HostModel of several ChainSets' (:func:`prepare_model` of each, run with one kernel): their
    per-chain arrays and initial states concatenated, chains a :class:`ChainStack`. Every part must have
    the same features (give each ``prepare_model`` the same ``features``) and the same record layout;
    per-grain arrays of a part that needs none (shape (chains, 1)) are not widened, so the parts must agree
    in shape too. Each chain's arrays are its own part's, so a chain runs as it would in its own set."""
    if not parts:
        raise ValueError("stack_prepared needs at least one HostModel")
    first = parts[0]
    for part in parts[1:]:
        if part.features != first.features:
            raise ValueError(f"stacked chain sets need one kernel: {part.features} differs from {first.features}")
        template, other = first.chains.template, part.chains.template
        if (other.chain.grains, other.integrator, other.record, other.boundary) != (
            template.chain.grains,
            template.integrator,
            template.record,
            template.boundary,
        ):
            raise ValueError("stacked chain sets must share grains, integrator, record and boundaries")
    arrays = {}
    for name, array in first.arrays.items():
        if name == "trace_slot":  # per grain, shared
            arrays[name] = array
            continue
        pieces = [part.arrays[name] for part in parts]
        if array.size == 0 or array.ndim == 0:
            arrays[name] = array
            continue
        if any(p.shape[1:] != array.shape[1:] for p in pieces):
            raise ValueError(f"stacked chain sets disagree in the shape of {name}")
        arrays[name] = np.concatenate(pieces, axis=0)
    return HostModel(
        chains=ChainStack([p.chains for p in parts]),
        features=first.features,
        static=None,
        arrays=arrays,
        injected_energy=np.concatenate([p.injected_energy for p in parts]),
        start=_stacked_starts([p.start for p in parts]),
        exact_start=None if first.exact_start is None else _stacked_starts([p.exact_start for p in parts]),
        seconds=sum(p.seconds for p in parts),
    )


def _stacked_starts(starts: list[np.ndarray]) -> np.ndarray:
    """Leading-grain starts (values, chains, window) of consecutive parts, as one (the widest window, zero-padded)."""
    width = max(start.shape[2] for start in starts)
    out = np.zeros((starts[0].shape[0], sum(start.shape[1] for start in starts), width), dtype=starts[0].dtype)
    row = 0
    for start in starts:
        out[:, row : row + start.shape[1], : start.shape[2]] = start
        row += start.shape[1]
    return out


def _build_model_of(chains: ChainSet, device, features: Features | None, prepared: HostModel | None = None) -> Model:
    """build_model for a ChainSet: every per-chain array from numpy over the set (bitwise equal to the
    per-scene path, checked by tests/sweeping/test_vectorised_expansion.py), then uploaded."""
    if prepared is None:
        if isinstance(chains, ChainStack):
            raise ValueError("a ChainStack model is built from stack_prepared(...) of its sets' prepare_model")
        prepared = prepare_model(chains, features=features)
    elif prepared.chains is not chains or (features is not None and prepared.features != features):
        raise ValueError("prepare_model was given other chains or features than build_model")
    f, a = prepared.features, prepared.arrays
    real = wp.float64 if f.precision == "float64" else wp.float32

    def upload(array, dtype=real):
        # a CPU model reads the prepared arrays in place (HostModel's arrays are its own and never change)
        return wp.array(np.ascontiguousarray(array), dtype=dtype, device=device, copy=not device.is_cpu)

    return Model(
        scenes=chains,
        features=f,
        device=device,
        chain_count=len(chains),
        grain_count=chains.template.chain.grains,
        dt=chains.template.integrator.dt,
        inverse_mass=upload(a["inverse_mass"]),
        contact_constant=upload(a["contact_constant"]),
        static_overlap=upload(a["static_overlap"]),
        law_parameters=upload(a["law_parameters"]),
        drive=upload(a["drive"], wp.float64),
        trace_slot=upload(a["trace_slot"], wp.int32),
        validity_overlap=upload(a["validity_overlap"], wp.float64),
        validity_scale=upload(a["validity_scale"], wp.float64),
        injected_energy=prepared.injected_energy,
        _static=prepared.static,
        damping=upload(a["damping"]),
        _start=(f, prepared.start, prepared.exact_start),
    )
