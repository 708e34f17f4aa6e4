"""Scenes: what a user writes (docs/model.md §8), as frozen dataclasses that validate themselves.

A scene file is TOML with the sections ``[chain]``, ``[boundary]``, ``[[impurities]]``,
``[excitation]``, ``[integrator]`` and ``[record]``. Every key has the paper's
program-unit default (length 1e-5 m, mass 2.36e-5 kg, time 1.0102e-3 s) except
``integrator.duration``, which is required. Bad input raises :class:`SceneError`
naming the key, the value and what is allowed.
"""

from __future__ import annotations

import difflib
import functools
import math
import tomllib
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path
from typing import Any

import numpy as np
from hertzian.core.errors import SceneError
from hertzian.core.radii import RadiiSpec, parse_radii, radius_ratios
from hertzian.kernels.features import POTENTIALS

SURFACE_KINDS = ("wall", "load", "free", "driven", "periodic")
BOTTOM_KINDS = ("wall", "fixed", "free", "periodic")
METHODS = ("gear4", "gear5", "gear6", "verlet", "yoshida4", "yoshida6")
AUTO_METHOD = "auto"
"""integrator.method with integrator.tolerance: the pilot (ensemble/core/error_estimate.py) picks the method."""
MIN_TOLERANCE = 1e-12
"""Smallest ``integrator.tolerance``: the error estimate reaches float64 rounding at about 1e-13
(ensemble/core/error_estimate.py), so a smaller tolerance can never be shown to be met."""
SHADOW_STEP_FACTOR = 2
"""record.error_estimate integrates a shadow ensemble at this many times dt (ensemble/core/error_estimate.py)."""
COMPOSED_METHODS = ("yoshida4", "yoshida6")
"""Methods composed of velocity-Verlet substeps (kernels/features.py SUBSTEP_WEIGHTS): no drive, no damping."""
EVENT_MODES = ("auto", "off")
PRECISIONS = ("float64", "float32")
CONTACT_RULES = ("harmonic", "own")
FIELDS = ("u", "v")
DAMPING_MODELS = ("none", "viscous", "contact")
RESPONSE_MIN_SAMPLES_PER_PERIOD = 256
"""Response windows sample v at least this many times per drive period (uniformly, a whole number
of samples per period) where the period has that many steps; see :attr:`Scene.response_stride`."""
MAX_HARMONICS = 64
MAX_STEPS = 2**31 - 1
"""Most steps a run may take: the kernels count steps in an int32 clock."""
VALIDITY_FRACTION = 0.1
"""Overlaps above this fraction of the grain diameter are beyond where the Hertz law holds
(status OVERLAP_BEYOND_VALIDITY; ``hertzian check`` warns)."""


@dataclass(frozen=True)
class ChainSpec:
    """The chain: ``grains`` equal spheres in contact (program units)."""

    grains: int = 1000
    """Grain count N (grain 0 is the surface)."""
    mass: float = 1.0
    """Grain mass [2.36e-5 kg]."""
    a: float = 5657.0
    """Self-constant of a grain: V = a·δ^n between two equal grains [mass·length^(2-n)/time²]."""
    exponent: float = 2.5
    """Contact-law exponent n (5/2 is Hertz)."""
    diameter: float = 100.0
    """Grain diameter [1e-5 m]; used for the validity check δ ≤ VALIDITY_FRACTION·diameter (0.1·diameter)."""

    @property
    def validity_overlap(self) -> float:
        """Largest overlap where the Hertz law is trusted between two grains of this diameter:
        VALIDITY_FRACTION·diameter [length]. Where the radii differ, a contact's limit is set by its smaller grain,
        VALIDITY_FRACTION·2·min(R_i, R_j): the runs compare each contact's overlap times R0/min(R_i, R_j)
        (hertzian.core.static.validity_scale) with this one."""
        return VALIDITY_FRACTION * self.diameter

    @functools.cached_property
    def radius_ratios(self) -> np.ndarray | None:
        """R_i/R0 of every grain (R0 = diameter/2), shape (grains,); None for equal grains (hertzian.core.radii)."""
        return radius_ratios(self.radii, self.grains, self.diameter)

    l0: float = 0.0
    """Precompression: static overlap of two equal grains under the load [length]."""
    load: float | None = None
    """Load F0 on the surface side [force]; alternative to ``l0``."""
    gravity: float = 0.0
    """Gravitational acceleration g (1 ≙ 9.8 m/s²), toward the bottom."""
    radii: RadiiSpec | None = None
    """Per-grain radii (docs/heterogeneous.md; hertzian.core.radii): None for equal grains of radius diameter/2."""
    potential: str = "hertz"
    """The contact law (docs/lattices.md): hertz (V = a·max(δ, 0)^n, no tension) | harmonic | fput | toda | morse |
    lj, the lattice laws, which carry tension. ``a`` is every law's strength: the spring constant of harmonic and
    fput, Toda's a, Morse's well depth D, Lennard-Jones' ε."""
    alpha: float = 0.0
    """fput: α of V(r) = r²/2 + α r³/3 + β r⁴/4 (times a); morse: α of D (1 − e^{−αr})² [1/length]."""
    beta: float = 0.0
    """fput: β."""
    b: float = 1.0
    """toda: b of V(r) = (a/b) e^{−br} + a r [1/length]."""
    sigma: float = 1.0
    """lj: σ of 4ε((σ/ρ)^12 − (σ/ρ)^6) [length]; the grains sit at the minimum, ρ = 2^(1/6) σ, at rest."""
    material: tuple[str, ...] | None = None
    """Grain materials (hertzian.core.materials): one name, or a pattern of names repeated along the chain; each
    grain's mass and each contact's Hertz constant then follow from E, ν and ρ (``mass`` and ``a`` are not given).
    None: the paper's grains (``mass``, ``a``)."""

    @property
    def surface_force(self) -> float:
        """F0: the constant force pushing on the surface side [force]."""
        if self.load is not None:
            return float(self.load)
        if self.l0 == 0.0:
            return 0.0
        if self.potential != "hertz":
            from hertzian.core.potentials import law_of

            with np.errstate(over="ignore", invalid="ignore"):  # an overflow is refused by the scene's checks
                return float(law_of(self).force(self.l0, self.a))
        return self.exponent * self.a * self.l0 ** (self.exponent - 1.0)


@dataclass(frozen=True)
class BoundarySpec:
    """How each end of the chain is held."""

    surface: str = "wall"
    """wall | load | free | driven | periodic (with a periodic bottom: a ring, grain N − 1 touching grain 0)."""
    bottom: str = "wall"
    """wall | fixed | free | periodic."""
    wall_material: str | None = None
    """With ``chain.material``: the walls' material (a flat wall); None: each wall of its grain's material."""


@dataclass(frozen=True)
class MaterialSpec:
    """A material of the scene's own ``[materials.NAME]`` table, in SI units (hertzian.core.materials)."""

    name: str
    E: float
    """Young's modulus [Pa]."""
    nu: float
    """Poisson's ratio."""
    rho: float
    """Density [kg/m³]."""

    def material(self):
        """The hertzian.core.materials.Material of these values."""
        from hertzian.core.materials import Material

        return Material(self.E, self.nu, self.rho, "the scene's [materials] table")


@dataclass(frozen=True)
class ImpuritySpec:
    """A block of grains with their own mass and self-constant."""

    grains: tuple[int, ...] = ()
    """Indices of the impurity grains (0 = surface)."""
    mass: float | None = None
    """Mass of each impurity grain; default: the chain's."""
    a: float | None = None
    """Self-constant of each impurity grain; default: the chain's."""
    contact: str = "harmonic"
    """Contact constant with a neighbour: harmonic mean of the two self-constants, or the impurity's ``own``."""


@dataclass(frozen=True)
class ExcitationSpec:
    """What sets the chain moving."""

    impact: float = 0.0
    """v_imp: initial velocity of grain 0 toward the bottom [length/time]."""
    drive_amplitude: float = 0.0
    """A in u_0(t) = A sin(2πt/τ) [length]; needs ``boundary.surface = "driven"``."""
    drive_period: float = 10.0
    """τ [time]."""
    modes: tuple[int, ...] = ()
    """Harmonic normal modes (hertzian.core.modes: 1 … N with walls at both ends, 1 … N − 1 with free ends) that
    start with ``mode_energy`` each, as displacements at rest: the Fermi–Pasta–Ulam–Tsingou experiment."""
    mode_energy: float = 0.0
    """Harmonic energy of each of ``modes`` at t = 0 [energy]."""
    thermal: float = 0.0
    """Energy per grain ε [energy] shared equally by the normal modes ``thermal_modes``, each with a random phase
    (``seed``): half kinetic, half potential on average."""
    thermal_modes: tuple[int, ...] = ()
    """[first, last] of the modes ``thermal`` fills; () for every mode."""
    seed: int = 0
    """Seed of the thermal phases (numpy's default generator): the same seed, the same start."""


@dataclass(frozen=True)
class IntegratorSpec:
    """Time stepping."""

    duration: float = math.nan
    """Simulated time [time]; required."""
    method: str = "gear4"
    """gear4 | gear5 | gear6 (Gear predictor–corrector, orders 4–6) | verlet (velocity Verlet, order 2) |
    yoshida4 | yoshida6 (three or seven velocity-Verlet substeps per step, symplectic, order 4 or 6; no drive or
    damping)."""
    dt: float = 1.25e-5
    """Time step [time]."""
    precision: str = "float64"
    """float64 | float32 (compensated: u and dt·v carried as float32 pairs hi + lo, kernels/gear.py)."""
    events: str = "auto"
    """auto: Gear steps near a contact opening/closing are event-aware (kernels/events.py) when some
    contact can open; off: plain Gear steps everywhere (the results before event-aware steps)."""
    accepted_steps_per_contact: float | None = None
    """A step chosen on purpose below the accuracy rule (e.g. a paper's own): ``hertzian check``, ``run`` and ``sweep``
    do not warn while dt gives at least this many steps per contact time (an unstable dt is always warned about);
    None: the method's rule (hertzian.core.check.ACCURATE_STEPS_PER_CONTACT_TIME)."""
    tolerance: float | None = None
    """Instead of ``dt``: the largest relative position error allowed (docs/accuracy.md) [relative]; a pilot run picks
    dt (and, with ``method = "auto"``, the method and events) before the run (ensemble/core/error_estimate.py)."""


@dataclass(frozen=True)
class DampingSpec:
    """Dissipation (absent from the kernels unless a scene uses it)."""

    model: str = "none"
    """none | viscous (force −γ m_i v_i on every integrated grain) | contact (dashpot −γ δ̇ on each
    closed contact, walls and the driver's contact included)."""
    gamma: float = 0.0
    """γ: [1/time] for viscous, [mass/time] for contact."""


@dataclass(frozen=True)
class RecordSpec:
    """What a run keeps."""

    every: float | None = None
    """Snapshot interval [time]; default: the whole duration (t = 0 and the end)."""
    fields: tuple[str, ...] = ("u", "v")
    """Snapshot fields: any of u, v."""
    traces: tuple[int, ...] = ()
    """Grains sampled at ``trace_every``."""
    trace_every: float | None = None
    """Trace interval [time]; default: every step. Must divide ``every``."""
    energy: bool = True
    """Record the total energy at every snapshot."""
    response_start: float | None = None
    """Time of the first response window [time] (driven scenes; None: no response windows).
    Must be a whole number of steps."""
    response_periods: int = 1
    """Drive periods per response window."""
    response_windows: int = 1
    """Consecutive response windows."""
    harmonics: int = 1
    """Highest harmonic H of the drive frequency kept in ``response`` (k = 0 … H)."""
    modes: bool = False
    """Record every chain's harmonic normal-mode energies E_k, spectral entropy and participation number at every
    record, computed on the device (hertzian.core.modes; the chain must have normal modes, as for
    ``excitation.modes``)."""
    error_estimate: bool = False
    """Estimate each chain's relative position error (docs/accuracy.md) from a shadow run at 2·dt
    (ensemble/core/error_estimate.py); needs ``u`` among ``fields`` and records on even steps."""


@dataclass(frozen=True)
class Scene:
    """A whole scene; built by :func:`scene_from_dict`/:func:`load_scene`, validated on creation."""

    chain: ChainSpec = field(default_factory=ChainSpec)
    boundary: BoundarySpec = field(default_factory=BoundarySpec)
    impurities: tuple[ImpuritySpec, ...] = ()
    excitation: ExcitationSpec = field(default_factory=ExcitationSpec)
    integrator: IntegratorSpec = field(default_factory=IntegratorSpec)
    record: RecordSpec = field(default_factory=RecordSpec)
    damping: DampingSpec = field(default_factory=DampingSpec)
    materials: tuple[MaterialSpec, ...] = ()
    """The scene's own materials (``[materials.NAME]``), beside the shipped ones."""

    def __post_init__(self):
        _validate(self)

    # ---- derived step counts -------------------------------------------------------
    # Records fall on the steps nearest to t = r·every (r = 0, 1, …) and the last one on the step
    # nearest to the duration, also when the duration is not a multiple of ``every``. Where
    # ``every`` is a whole number of steps (to 1e-9) the records are exactly that many steps apart.
    @property
    def _every(self) -> float:
        return self.record.every if self.record.every is not None else self.integrator.duration

    @property
    def _whole_steps_per_record(self) -> int | None:
        """``every/dt`` when it is a whole number (to 1e-9 relative), else None."""
        ratio = self._every / self.integrator.dt
        whole = round(ratio)
        return whole if whole >= 1 and abs(ratio - whole) <= 1e-9 * ratio else None

    @property
    def step_count(self) -> int:
        """Total integration steps: the step nearest to ``integrator.duration``."""
        return max(1, round(self.integrator.duration / self.integrator.dt))

    @property
    def steps_per_record(self) -> int:
        """Integration steps between two records (the longest such gap where they differ)."""
        whole = self._whole_steps_per_record
        return whole if whole is not None else math.ceil(self._every / self.integrator.dt)

    @property
    def record_count(self) -> int:
        """Records, including t = 0 and the end (computed without listing them)."""
        end, whole = self.step_count, self._whole_steps_per_record
        if whole is not None:
            return -(-end // whole) + 1
        ratio = self._every / self.integrator.dt
        last = int(end / ratio) + 2  # largest r with round(r·ratio) < end, found from above
        while last > 0 and round(last * ratio) >= end:
            last -= 1
        return last + 2

    @functools.cached_property
    def record_steps(self) -> np.ndarray:
        """Step index of each record, int64, shape (record_count,): round(r·every/dt), the last at
        round(duration/dt). Records are at t = record_steps·dt."""
        count, end, whole = self.record_count, self.step_count, self._whole_steps_per_record
        r = np.arange(count, dtype=np.int64)
        steps = r * whole if whole is not None else np.rint(r * (self._every / self.integrator.dt)).astype(np.int64)
        steps[-1] = end
        steps.flags.writeable = False
        return steps

    @property
    def record_times(self) -> np.ndarray:
        """Record times t = record_steps·dt [time], shape (record_count,)."""
        return self.record_steps * self.integrator.dt

    @property
    def trace_stride(self) -> int:
        """Steps between two trace samples."""
        te = self.record.trace_every
        return 1 if te is None else max(1, round(te / self.integrator.dt))

    @property
    def trace_sample_count(self) -> int:
        """Trace samples of a run (t = 0 included); 0 without traces."""
        return self.step_count // self.trace_stride + 1 if self.record.traces else 0

    # ---- response windows (driven scenes) -------------------------------------------
    @property
    def has_response(self) -> bool:
        """Whether the scene accumulates response windows (``record.response_start`` set)."""
        return self.record.response_start is not None

    @property
    def period_steps(self) -> int:
        """Steps per drive period, τ/dt (validated to be a whole number where responses are kept)."""
        return max(1, round(self.excitation.drive_period / self.integrator.dt))

    @property
    def response_start_step(self) -> int:
        """Step of the first response window's first sample."""
        return round((self.record.response_start or 0.0) / self.integrator.dt)

    @property
    def response_stride(self) -> int:
        """Steps between two response samples: the largest divisor s of the period's steps P with
        P/s ≥ RESPONSE_MIN_SAMPLES_PER_PERIOD (s = 1 when the period has fewer steps). Whole periods
        of uniform samples make the rectangle rule spectrally accurate for a periodic integrand."""
        return response_stride_of([self.period_steps])

    @property
    def response_end_step(self) -> int:
        """First step after the last response window."""
        r = self.record
        return self.response_start_step + r.response_windows * r.response_periods * self.period_steps

    @property
    def injected_energy(self) -> float:
        """Energy put in at t = 0 by an impact (½ m_0 v_imp²); 0 for other scenes (a modal or thermal start's is
        hertzian.core.modes.injected_energy)."""
        return 0.5 * grain_masses_at(self, 0) * self.excitation.impact**2

    def to_dict(self) -> dict:
        """The scene as plain data, every key filled (JSON/TOML-ready)."""
        d = asdict(self)
        # an impurity's unset mass or a is its grain's: the chain's in a uniform chain (filled in); with radii the
        # grain's own scaled value, so the key stays out (filling in the chain's would lose the radius scaling)
        fill = self.chain.radii is None
        d["impurities"] = [
            {
                **{k: v for k, v in imp.items() if v is not None},
                "grains": list(imp["grains"]),
                **({"mass": self.chain.mass if imp["mass"] is None else imp["mass"]} if fill else {}),
                **({"a": self.chain.a if imp["a"] is None else imp["a"]} if fill else {}),
            }
            for imp in d["impurities"]
        ]
        d["chain"]["radii"] = None if self.chain.radii is None else self.chain.radii.to_plain()
        d["record"]["fields"] = list(d["record"]["fields"])
        d["excitation"]["modes"] = list(d["excitation"]["modes"])
        d["excitation"]["thermal_modes"] = list(d["excitation"]["thermal_modes"])
        d["record"]["traces"] = list(d["record"]["traces"])
        if self.integrator.tolerance is not None:
            del d["integrator"]["dt"]  # not given: the pilot chooses it
        _materials_to_dict(self, d)
        return d

    def with_overrides(self, overrides: dict[str, Any]) -> "Scene":
        """A copy with dotted keys (``"chain.l0"``) replaced; validated."""
        return scene_from_dict(apply_overrides(self.to_dict(), overrides))


def _materials_to_dict(scene: Scene, d: dict) -> None:
    """The material keys of ``scene.to_dict()``: present only where used, so that scenes without materials keep
    their plain data; with ``chain.material`` the chain's ``mass`` and ``a`` are left out (they are not used)."""
    del d["materials"]
    if scene.materials:
        d["materials"] = {m.name: {"E": m.E, "nu": m.nu, "rho": m.rho} for m in scene.materials}
    if scene.chain.material is None:
        del d["chain"]["material"]
    else:
        d["chain"]["material"] = list(scene.chain.material)
        del d["chain"]["mass"], d["chain"]["a"]
    if scene.boundary.wall_material is None:
        del d["boundary"]["wall_material"]


def response_stride_of(period_steps) -> int:
    """A sample stride (steps) that divides every period in ``period_steps`` (a launch shares one):
    the largest divisor of their gcd leaving ≥ RESPONSE_MIN_SAMPLES_PER_PERIOD samples in the shortest."""
    steps = [int(p) for p in period_steps]
    g = 0
    for p in steps:
        g = math.gcd(g, p)
    shortest = min(steps)
    best = 1
    for s in range(1, int(math.isqrt(g)) + 1):
        if g % s == 0:
            for d in (s, g // s):
                if shortest // d >= RESPONSE_MIN_SAMPLES_PER_PERIOD and d > best:
                    best = d
    return best


def grain_masses_at(scene: Scene, index: int) -> float:
    """Mass of grain ``index`` [mass]: an impurity's, else m·r³ (r = R_i/R0), else the chain's; with
    ``chain.material``, ρ (4/3) π R_i³ of its material."""
    if scene.chain.material is not None:
        from hertzian.core.materials import scene_constants

        ratios = scene.chain.radius_ratios
        rows = None if ratios is None else ratios[None, :]
        return float(scene_constants(scene, np.array([scene.chain.diameter]), rows, scene.chain.grains)[0][0, index])
    for imp in scene.impurities:
        if index in imp.grains and imp.mass is not None:
            return imp.mass
    ratios = scene.chain.radius_ratios
    if ratios is None:
        return scene.chain.mass
    r = ratios[index]
    return float(scene.chain.mass * r * r * r)


# ---- parsing -----------------------------------------------------------------------

_SECTIONS = {
    "chain": ChainSpec,
    "boundary": BoundarySpec,
    "excitation": ExcitationSpec,
    "integrator": IntegratorSpec,
    "record": RecordSpec,
    "damping": DampingSpec,
}
_TOP_KEYS = tuple(_SECTIONS) + ("impurities", "materials")
SCENE_TABLES = frozenset(_TOP_KEYS)
"""Top-level tables of a scene file."""


def _did_you_mean(word: str, choices) -> str:
    close = difflib.get_close_matches(word, list(choices), n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""


class UnknownKeyError(SceneError):
    """A key the scene format does not have."""

    def __init__(self, key: str, choices):
        hint = _did_you_mean(key.split(".")[-1], choices)
        SceneError.__init__(self, key, None, "")
        self.args = (f"{key}: unknown key{hint}; allowed here: {', '.join(choices)}",)

    def __str__(self) -> str:
        return self.args[0]


def _unknown(key: str, choices) -> SceneError:
    return UnknownKeyError(key, choices)


def _coerce(key: str, value: Any, default: Any, annotation: str) -> Any:
    """Check a TOML value against a field's type (annotation text) and convert it."""
    if "RadiiSpec" in annotation:
        return parse_radii(key, value)
    if "tuple[int" in annotation:
        if not isinstance(value, (list, tuple)) or not all(
            isinstance(x, int) and not isinstance(x, bool) for x in value
        ):
            raise SceneError(key, value, "must be a list of integers")
        return tuple(value)
    if "tuple[str" in annotation:
        if isinstance(value, str):
            value = [value]
        if not isinstance(value, (list, tuple)) or not all(isinstance(x, str) for x in value):
            raise SceneError(key, value, "must be a list of strings")
        return tuple(value)
    if annotation == "bool":
        if not isinstance(value, bool):
            raise SceneError(key, value, "must be true or false")
        return value
    if annotation == "int":
        if isinstance(value, float) and value.is_integer():
            value = int(value)
        if not isinstance(value, int) or isinstance(value, bool):
            raise SceneError(key, value, "must be an integer")
        return value
    if annotation in ("str", "str | None"):
        if value is None and "None" in annotation:
            return None
        if not isinstance(value, str):
            raise SceneError(key, value, "must be a string")
        return value
    if "float" in annotation:
        if value is None and "None" in annotation:
            return None
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise SceneError(key, value, "must be a number")
        value = float(value)
        if not math.isfinite(value):
            raise SceneError(key, value, "must be a finite number")
        return value
    return value


def _build(cls, section: str, data: Any):
    if not isinstance(data, dict):
        raise SceneError(section, data, "must be a table")
    known = {f.name: f for f in fields(cls)}
    kwargs = {}
    for key, value in data.items():
        if key not in known:
            raise _unknown(f"{section}.{key}", known)
        kwargs[key] = _coerce(f"{section}.{key}", value, known[key].default, str(known[key].type))
    return cls(**kwargs)


def scene_from_dict(data: dict) -> Scene:
    """Build and validate a scene from nested plain data (a parsed TOML file)."""
    if not isinstance(data, dict):
        raise SceneError("scene", data, "must be a table")
    for key in data:
        if key not in _TOP_KEYS:
            raise _unknown(key, _TOP_KEYS)
    parts = {name: _build(cls, name, data.get(name, {})) for name, cls in _SECTIONS.items()}
    raw_imps = data.get("impurities", [])
    if isinstance(raw_imps, dict):
        raw_imps = [raw_imps]
    if not isinstance(raw_imps, list):
        raise SceneError("impurities", raw_imps, "must be an array of tables ([[impurities]])")
    imps = tuple(_build(ImpuritySpec, f"impurities[{k}]", imp) for k, imp in enumerate(raw_imps))
    materials = _parse_materials(data.get("materials", {}))
    chain = data.get("chain", {})
    if isinstance(chain, dict) and chain.get("material") is not None:
        for key in ("mass", "a"):
            if key in chain:
                raise SceneError(
                    f"chain.{key}",
                    chain[key],
                    "not with chain.material: the materials set each grain's mass and contacts",
                )
    integrator = data.get("integrator", {})
    if "duration" not in integrator:
        raise SceneError("integrator.duration", None, "is required (simulated time, > 0)")
    if integrator.get("tolerance") is not None and "dt" in integrator:
        raise SceneError(
            "integrator.tolerance",
            integrator["tolerance"],
            "give either integrator.dt or integrator.tolerance, not both",
        )
    return Scene(impurities=imps, materials=materials, **parts)


MATERIAL_KEYS = ("E", "nu", "rho")


def _parse_materials(table: Any) -> tuple[MaterialSpec, ...]:
    """The ``[materials]`` table: NAME → {E [Pa], nu, rho [kg/m³]}."""
    if not isinstance(table, dict):
        raise SceneError("materials", table, "must be a table of [materials.NAME] tables with E, nu and rho")
    out = []
    for name, values in table.items():
        key = f"materials.{name}"
        if not isinstance(values, dict):
            raise SceneError(key, values, "must be a table with E [Pa], nu and rho [kg/m³]")
        for k in values:
            if k not in MATERIAL_KEYS:
                raise _unknown(f"{key}.{k}", MATERIAL_KEYS)
        missing = [k for k in MATERIAL_KEYS if k not in values]
        if missing:
            raise SceneError(f"{key}.{missing[0]}", None, "is required (E [Pa], nu, rho [kg/m³])")
        numbers = {k: _coerce(f"{key}.{k}", values[k], None, "float") for k in MATERIAL_KEYS}
        out.append(MaterialSpec(name=name, **numbers))
    return tuple(out)


def parse_value(text: str) -> Any:
    """A ``--set`` value: TOML syntax (numbers, true/false, "strings", [lists]); bare words are strings."""
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text


_MODAL = ("excitation.modes", "excitation.mode_energy")
_THERMAL = ("excitation.thermal", "excitation.thermal_modes")
ALTERNATIVES = {
    "integrator.dt": ("integrator.tolerance",),
    "integrator.tolerance": ("integrator.dt",),
    "chain.l0": ("chain.load",),
    "chain.load": ("chain.l0",),
    "excitation.impact": (*_MODAL, *_THERMAL),
    "excitation.modes": ("excitation.impact", *_THERMAL),
    "excitation.thermal": ("excitation.impact", *_MODAL),
}
"""Keys of which a scene gives one or the other (a start: an impact, normal modes or thermal phases). A user's
overrides of a file (``--set``, ``hz.load_scene``'s ``overrides``) that give one with a value drop the others from
the file (the built-in example's ``dt`` gives way to ``--set integrator.tolerance=…``, a modal start to ``--set
excitation.thermal=…``); both in one set of overrides stay refused, and a sweep's axes replace nothing (a point
that gives both is refused)."""


def apply_overrides(data: dict, overrides: dict[str, Any], *, replacing: bool = False) -> dict:
    """Set dotted keys (``section.key`` or ``impurities.K.key``) in nested plain data; with ``replacing`` (a user's
    overrides of a file) an override of one of :data:`ALTERNATIVES` drops the others."""
    import copy

    if not isinstance(overrides, dict) or not all(isinstance(key, str) for key in overrides):
        raise SceneError(
            "overrides", repr(overrides)[:60], "a dict of dotted scene keys to values, e.g. {'chain.grains': 100}"
        )
    data = copy.deepcopy(data)
    if replacing:
        _drop_alternatives(data, overrides)
    for dotted, value in overrides.items():
        parts = dotted.split(".")
        if parts[0] not in _TOP_KEYS:
            raise _unknown(parts[0], _TOP_KEYS)
        if parts[0] == "impurities":
            if len(parts) != 3 or not parts[1].isdigit():
                raise SceneError(dotted, value, "impurity keys are written impurities.K.key (K = block index)")
            blocks = data.setdefault("impurities", [])
            k = int(parts[1])
            if k >= len(blocks):
                raise SceneError(dotted, value, f"there are {len(blocks)} impurity blocks")
            blocks[k][parts[2]] = value
            continue
        if parts[:2] == ["chain", "radii"] and len(parts) == 3:
            _set_radii_key(data, dotted, parts[2], value)
            continue
        if len(parts) != 2:
            raise SceneError(dotted, value, "keys are written section.key, e.g. chain.l0")
        section = data.setdefault(parts[0], {})
        if not isinstance(section, dict):
            raise SceneError(parts[0], section, "must be a table")
        section[parts[1]] = value
    return data


_STARTS = frozenset({"excitation.impact", "excitation.modes", "excitation.thermal"})
"""Alternatives whose zero or empty value means no start at all: such an override replaces nothing."""


def _drop_alternatives(data: dict, overrides: dict[str, Any]) -> None:
    """Remove from ``data`` the alternatives of each key ``overrides`` give a value (not when they give two of one
    group): any value but None, and for a start a non-zero one (``chain.l0 = 0`` still replaces a load)."""
    given = {
        key
        for key, value in overrides.items()
        if value is not None and not (key in _STARTS and value in (0, 0.0, [], ()))
    }
    for dotted in given & ALTERNATIVES.keys():
        if given & set(ALTERNATIVES[dotted]):
            continue  # both given at once: the scene refuses them
        for other in ALTERNATIVES[dotted]:
            section, key = other.split(".")
            if other not in overrides and isinstance(data.get(section), dict):
                data[section].pop(key, None)


def _set_radii_key(data: dict, dotted: str, name: str, value: Any) -> None:
    """``chain.radii.<name> = value`` in nested plain data (a table form of chain.radii)."""
    chain = data.setdefault("chain", {})
    radii = chain.get("radii")
    if radii is None:
        radii = chain["radii"] = {}
    if not isinstance(radii, dict):
        raise SceneError(dotted, value, "chain.radii is a list of radii here: only a table form has keys")
    radii[name] = value


def parse_overrides(items: list[str] | None) -> dict[str, Any]:
    """``["chain.l0=1e-4", …]`` → ``{"chain.l0": 1e-4, …}``."""
    out = {}
    for item in items or []:
        key, sep, text = item.partition("=")
        if not sep or not key.strip():
            raise SceneError("--set", item, "must be written key=value, e.g. chain.l0=1e-4")
        out[key.strip()] = parse_value(text.strip())
    return out


def read_toml(path: str | Path, kind: str = "scene file") -> dict:
    """The parsed TOML file at ``path``; a missing or malformed file is one line naming it as ``kind``."""
    path = Path(path)
    if path.is_dir() and (path / "zarr.json").is_file():
        raise SceneError(
            kind, str(path), "is a store, not a TOML file (hertzian summarize, plot and verify read stores)"
        )
    if path.is_dir():
        raise SceneError(kind, str(path), "is a folder, not a TOML file")
    if not path.is_file():
        raise SceneError(kind, str(path), "no such file")
    try:
        return tomllib.loads(path.read_text())
    except tomllib.TOMLDecodeError as err:
        raise SceneError(str(path), "…", f"is not valid TOML: {err}") from None
    except UnicodeDecodeError:
        raise SceneError(kind, str(path), "is not a text file (a TOML file is UTF-8 text)") from None


SWEEP_TABLES = frozenset({"scene", "axis", "zip"})
"""Top-level tables of a sweep file (a scene file has none of them)."""

FILE_KINDS = {
    "scene": ("tables such as [chain] and [integrator]", "hertzian run or hertzian check", "hertzian.load_scene"),
    "sweep": ("[scene] and [[axis]] tables", "hertzian sweep", "hertzian.sweep"),
    "design": ("[scene] and [design] tables", "hertzian design", "hertzian.design"),
    "detection study": ("[scene] and [study] tables", "hertzian detect-study", None),
}
"""Per kind of input file: the top-level tables that tell it, the commands and the Python function (if any) that
take it."""


def file_kind(data: Any) -> str | None:
    """The kind of a parsed input file by its top-level tables (a key of :data:`FILE_KINDS`), or None when the
    tables fit no kind (the file's own reader then names what is wrong)."""
    if not isinstance(data, dict):
        return None
    keys = data.keys()
    if "design" in keys and "scene" in keys:
        return "design"
    if "study" in keys and "scene" in keys:
        return "detection study"
    if keys & SWEEP_TABLES and not keys & SCENE_TABLES:
        return "sweep"
    if keys & SCENE_TABLES and not keys & SWEEP_TABLES:
        return "scene"
    return None


def refuse_other_kind(data: Any, path: str | Path, wanted: str) -> None:
    """One line (SceneError) when the file at ``path`` is plainly another kind than ``wanted``, naming what it is
    and which command takes it."""
    kind = file_kind(data)
    if kind is None or kind == wanted:
        return
    tables, commands, function = FILE_KINDS[kind]
    also = f" (or {function})" if function else ""
    raise SceneError(f"{wanted} file", str(path), f"is a {kind} file (it has {tables}): give it to {commands}{also}")


def load_scene(path: str | Path, overrides: dict[str, Any] | None = None) -> Scene:
    """Read a scene TOML file, apply ``--set`` overrides, validate. A ``chain.radii`` .npy path is relative to
    the file."""
    data = read_toml(path)
    refuse_other_kind(data, path, "scene")
    data = apply_overrides(data, overrides or {}, replacing=True)
    radii = data.get("chain", {}).get("radii") if isinstance(data.get("chain"), dict) else None
    if isinstance(radii, str) and not Path(radii).is_absolute():
        data["chain"]["radii"] = str(Path(path).parent / radii)
    return scene_from_dict(data)


# ---- validation --------------------------------------------------------------------


def _positive(key, value):
    if not (value > 0):
        raise SceneError(key, value, "must be > 0")


def _validate(s: Scene) -> None:
    """Raise SceneError for the first invalid value of ``s``."""
    _validate_chain(s)
    _validate_materials(s)
    _validate_boundary_and_excitation(s)
    _validate_impurities(s)
    _validate_modal_start(s)
    _validate_integrator(s)
    _validate_record(s)
    _validate_damping_and_response(s)
    _validate_error_estimate(s)
    _validate_composed_and_overflow(s)


def _validate_composed_and_overflow(s: Scene) -> None:
    c, b, e, i = s.chain, s.boundary, s.excitation, s.integrator
    if i.method in COMPOSED_METHODS:
        allowed = ", ".join(m for m in METHODS if m not in COMPOSED_METHODS)
        if b.surface == "driven":
            raise SceneError(
                "integrator.method",
                i.method,
                f'a driven surface (boundary.surface = "driven") is '
                f"not implemented for {i.method}: use one of {allowed}",
            )
        if s.damping.model != "none":
            raise SceneError(
                "integrator.method",
                i.method,
                f'damping (damping.model = "{s.damping.model}") is '
                f"not implemented for {i.method}: use one of {allowed}",
            )
    for key, value, derived in (
        ("chain.l0" if c.load is None else "chain.load", c.l0 if c.load is None else c.load, lambda: c.surface_force),
        ("excitation.impact", e.impact, lambda: s.injected_energy),
    ):
        try:
            finite = math.isfinite(derived())
        except OverflowError:
            finite = False
        if not finite:
            raise SceneError(key, value, "too large: the load or energy it gives overflows float64")


LAW_SHAPE_KEYS = {"alpha": ("fput", "morse"), "beta": ("fput",), "b": ("toda",), "sigma": ("lj",)}
"""The shape keys of the lattice laws and the laws that read each (hertzian.core.potentials.law_of)."""


def _validate_potential(s: Scene) -> None:
    """The contact law: a known name, the shape keys of that law only, and what a lattice law cannot carry."""
    c = s.chain
    if c.potential not in POTENTIALS:
        raise SceneError(
            "chain.potential",
            c.potential,
            f"must be one of {', '.join(POTENTIALS)}" + _did_you_mean(c.potential, POTENTIALS),
        )
    defaults = ChainSpec()
    for key, laws in LAW_SHAPE_KEYS.items():
        value = getattr(c, key)
        if value != getattr(defaults, key) and c.potential not in laws:
            raise SceneError(f"chain.{key}", value, f"is read by chain.potential = {' or '.join(laws)} only")
        if not math.isfinite(value):
            raise SceneError(f"chain.{key}", value, "must be finite")
    if c.potential == "hertz":
        return
    positive = {"toda": "b", "morse": "alpha", "lj": "sigma"}.get(c.potential)
    if positive and not getattr(c, positive) > 0:
        raise SceneError(f"chain.{positive}", getattr(c, positive), f"must be > 0 for chain.potential = {c.potential}")
    refused = {
        "chain.exponent": (c.exponent != 2.5, c.exponent, "is the hertz law's: a lattice law has its own shape keys"),
        "chain.radii": (c.radii is not None, "given", "sets Hertz contact constants: give a lattice law's a directly"),
        "chain.material": (c.material is not None, c.material, "sets Hertz contact constants: not with a lattice law"),
        "damping.model": (
            s.damping.model == "contact",
            "contact",
            "the dashpot acts on closed Hertz contacts: use damping.model = viscous with a lattice law",
        ),
    }
    for key, (bad, value, why) in refused.items():
        if bad:
            raise SceneError(key, value, f"{why} (chain.potential = {c.potential})")


def _validate_chain(s: Scene) -> None:
    _validate_potential(s)
    c = s.chain
    if c.grains < 2:
        raise SceneError("chain.grains", c.grains, "must be an integer ≥ 2")
    for key in ("mass", "a", "diameter"):
        _positive(f"chain.{key}", getattr(c, key))
    if not (c.exponent > 1.0):
        raise SceneError("chain.exponent", c.exponent, "must be > 1 (the force must vanish at zero overlap)")
    if c.l0 < 0:
        raise SceneError("chain.l0", c.l0, "must be ≥ 0")
    if c.load is not None:
        if c.load < 0:
            raise SceneError("chain.load", c.load, "must be ≥ 0")
        if c.l0 != 0:
            raise SceneError("chain.load", c.load, "give either chain.l0 or chain.load, not both")
    if c.gravity < 0:
        raise SceneError("chain.gravity", c.gravity, "must be ≥ 0 (it points toward the bottom)")
    c.radius_ratios  # raises SceneError for radii that are not > 0 and finite or a list of the wrong length


def _validate_materials(s: Scene) -> None:
    from hertzian.core.materials import MATERIALS

    c, b = s.chain, s.boundary
    for m in s.materials:
        if m.name in MATERIALS:
            raise SceneError(f"materials.{m.name}", m.name, "is a shipped material; give yours another name")
        if not (m.E > 0):
            raise SceneError(f"materials.{m.name}.E", m.E, "must be > 0 (Young's modulus in Pa)")
        if not (-1.0 < m.nu < 0.5):
            raise SceneError(f"materials.{m.name}.nu", m.nu, "must lie in (-1, 0.5) (Poisson's ratio)")
        if not (m.rho > 0):
            raise SceneError(f"materials.{m.name}.rho", m.rho, "must be > 0 (density in kg/m³)")
    known = [*MATERIALS, *(m.name for m in s.materials)]
    if b.wall_material is not None:
        if c.material is None:
            raise SceneError("boundary.wall_material", b.wall_material, "needs chain.material (the grains' materials)")
        if b.wall_material not in known:
            raise SceneError("boundary.wall_material", b.wall_material, f"must be one of {', '.join(known)}")
    if c.material is None:
        return
    if not c.material or len(c.material) > c.grains:
        raise SceneError("chain.material", list(c.material), f"must name 1 to {c.grains} materials (chain.grains)")
    for name in c.material:
        if name not in known:
            raise SceneError("chain.material", name, f"must be one of {', '.join(known)}" + _did_you_mean(name, known))
    if c.exponent != 2.5:
        raise SceneError(
            "chain.exponent", c.exponent, "must be 2.5 with chain.material (Hertz's law between materials)"
        )
    if c.l0 != 0:
        raise SceneError("chain.l0", c.l0, "not with chain.material: give the load as a force, chain.load")
    if s.impurities:
        raise SceneError("impurities", len(s.impurities), "not with chain.material: give those grains a material")


def _validate_boundary_and_excitation(s: Scene) -> None:
    c, b, e = s.chain, s.boundary, s.excitation
    if b.surface not in SURFACE_KINDS:
        raise SceneError(
            "boundary.surface",
            b.surface,
            f"must be one of {', '.join(SURFACE_KINDS)}" + _did_you_mean(b.surface, SURFACE_KINDS),
        )
    if b.bottom not in BOTTOM_KINDS:
        raise SceneError(
            "boundary.bottom",
            b.bottom,
            f"must be one of {', '.join(BOTTOM_KINDS)}" + _did_you_mean(b.bottom, BOTTOM_KINDS),
        )
    try:
        f0 = c.surface_force
    except OverflowError:
        f0 = math.inf
    if not math.isfinite(f0):
        raise SceneError(
            "chain.l0" if c.load is None else "chain.load",
            c.l0 if c.load is None else c.load,
            "too large: the load it gives overflows float64",
        )
    if (b.surface == "periodic") != (b.bottom == "periodic"):
        key, value = ("boundary.surface", b.surface) if b.surface != "periodic" else ("boundary.bottom", b.bottom)
        raise SceneError(key, value, 'a ring has both ends "periodic" (grain N − 1 touches grain 0)')
    if b.surface == "periodic":
        _validate_ring(s)
    if b.surface == "free" and f0 > 0:
        raise SceneError(
            "boundary.surface",
            "free",
            'a free surface cannot carry a load: set chain.l0 = 0 or use surface = "load" or "wall"',
        )
    if b.bottom == "free" and (f0 > 0 or c.gravity > 0):
        raise SceneError(
            "boundary.bottom", "free", 'a free bottom cannot hold a load or gravity: use bottom = "wall" or "fixed"'
        )
    if b.surface == "driven":
        _positive("excitation.drive_amplitude", e.drive_amplitude)
        _positive("excitation.drive_period", e.drive_period)
        if e.impact != 0:
            raise SceneError(
                "excitation.impact", e.impact, "a driven surface grain has a prescribed motion: impact must be 0"
            )
    elif e.drive_amplitude != 0:
        raise SceneError("excitation.drive_amplitude", e.drive_amplitude, 'a drive needs boundary.surface = "driven"')
    if e.impact < 0:
        raise SceneError("excitation.impact", e.impact, "must be ≥ 0 (toward the bottom)")
    if b.bottom == "fixed" and c.grains < 3 and b.surface == "driven":
        raise SceneError("chain.grains", c.grains, "a driven chain with a fixed bottom needs ≥ 3 grains")


def _validate_normal_modes(s: Scene, key: str, value) -> None:
    """The chain has harmonic normal modes (hertzian.core.modes): walls or free ends at both ends, equal grains and
    springs, a stiffness at rest."""
    c, b = s.chain, s.boundary
    if (b.surface, b.bottom) not in (("wall", "wall"), ("free", "free"), ("periodic", "periodic")):
        raise SceneError(key, value, "normal modes need walls, free ends or a ring at both ends (boundary)")
    if s.impurities or c.radii is not None or c.material is not None or c.gravity:
        raise SceneError(
            key, value, "normal modes need equal grains and springs: no impurities, radii, materials or gravity"
        )
    if c.potential == "hertz" and c.l0 == 0 and not c.load:
        raise SceneError(
            key, value, "normal modes of a Hertz chain need a precompression, chain.l0 (a stiffness at rest)"
        )


def _validate_modal_start(s: Scene) -> None:
    """Modes or thermal phases at t = 0: harmonic normal modes exist (equal grains and springs, walls or free ends at
    both ends, a stiffness at rest) and the numbers are in range."""
    e, c, b = s.excitation, s.chain, s.boundary
    if e.seed < 0:
        raise SceneError("excitation.seed", e.seed, "must be an integer ≥ 0")
    if not (e.modes or e.thermal or e.mode_energy or e.thermal_modes or s.record.modes):
        return
    given = [
        (name, value)
        for name, value in (
            ("excitation.modes", list(e.modes)),
            ("excitation.mode_energy", e.mode_energy),
            ("excitation.thermal", e.thermal),
            ("excitation.thermal_modes", list(e.thermal_modes)),
            ("record.modes", s.record.modes),
        )
        if value
    ]
    key, value = given[0]
    _validate_normal_modes(s, key, value)
    if bool(e.modes) != (e.mode_energy > 0):
        raise SceneError(
            "excitation.mode_energy", e.mode_energy, "give excitation.modes and a mode_energy > 0 together"
        )
    for key in ("mode_energy", "thermal"):
        if not math.isfinite(getattr(e, key)):
            raise SceneError(f"excitation.{key}", getattr(e, key), "must be finite")
    if e.thermal < 0 or (e.thermal_modes and not e.thermal):
        raise SceneError("excitation.thermal", e.thermal, "must be > 0 (energy per grain), with thermal_modes if given")
    if (e.modes or e.thermal) and (e.impact or b.surface == "driven"):
        raise SceneError("excitation.impact", e.impact, "not with excitation.modes or thermal: one start at a time")
    if e.modes and e.thermal:
        raise SceneError("excitation.thermal", e.thermal, "not with excitation.modes: one start at a time")
    first = 1
    last = c.grains if b.surface == "wall" else c.grains - 1  # free ends and rings: mode 0 is the translation
    for k in e.modes:
        if not first <= k <= last:
            raise SceneError("excitation.modes", k, f"mode numbers run {first} … {last} here")
    if e.thermal_modes:
        pair = e.thermal_modes
        if len(pair) != 2 or not first <= pair[0] <= pair[1] <= last:
            raise SceneError("excitation.thermal_modes", list(pair), f"must be [first, last] within {first} … {last}")


def _validate_ring(s: Scene) -> None:
    """What a ring cannot carry: gravity (no bottom holds it), a contact dashpot, Hertz event steps."""
    c = s.chain
    if c.gravity:
        raise SceneError("chain.gravity", c.gravity, "a ring (periodic ends) has no bottom to hold gravity")
    if s.damping.model == "contact":
        raise SceneError("damping.model", "contact", "the contact dashpot is not implemented on a ring: use viscous")
    if c.radii is not None or c.material is not None:
        key = "chain.radii" if c.radii is not None else "chain.material"
        raise SceneError(key, "given", "radii and materials are not implemented on a ring (periodic ends)")
    if c.potential == "hertz" and s.integrator.events != "off":
        raise SceneError(
            "integrator.events", s.integrator.events, 'event steps are not implemented on a ring: set "off"'
        )


def _validate_impurities(s: Scene) -> None:
    c = s.chain
    seen: dict[int, int] = {}
    for k, imp in enumerate(s.impurities):
        key = f"impurities[{k}]"
        if not imp.grains:
            raise SceneError(f"{key}.grains", list(imp.grains), "must list at least one grain index")
        for g in imp.grains:
            if not 0 <= g < c.grains:
                raise SceneError(f"{key}.grains", g, f"grain index outside the chain: allowed 0 … {c.grains - 1}")
            if g in seen:
                raise SceneError(f"{key}.grains", g, f"grain already in impurities[{seen[g]}]")
            seen[g] = k
        if imp.mass is not None:
            _positive(f"{key}.mass", imp.mass)
        if imp.a is not None:
            _positive(f"{key}.a", imp.a)
        if imp.contact not in CONTACT_RULES:
            raise SceneError(f"{key}.contact", imp.contact, "must be harmonic or own")


def _validate_integrator(s: Scene) -> None:
    i = s.integrator
    if not (i.duration > 0):
        raise SceneError("integrator.duration", i.duration, "is required and must be > 0")
    _positive("integrator.dt", i.dt)
    if i.dt > i.duration:
        raise SceneError("integrator.dt", i.dt, f"must not exceed integrator.duration = {i.duration}")
    if i.tolerance is not None and not (MIN_TOLERANCE <= i.tolerance < 1):
        raise SceneError(
            "integrator.tolerance",
            i.tolerance,
            f"must be a relative error in [{MIN_TOLERANCE:g}, 1), e.g. 1e-6 (below {MIN_TOLERANCE:g} the error "
            "estimate measures float64 rounding, not the step's error)",
        )
    if i.accepted_steps_per_contact is not None and not (
        isinstance(i.accepted_steps_per_contact, (int, float)) and i.accepted_steps_per_contact >= 1
    ):
        raise SceneError(
            "integrator.accepted_steps_per_contact",
            i.accepted_steps_per_contact,
            "must be a number of steps per contact time ≥ 1 (hertzian check prints a scene's)",
        )
    if i.method not in METHODS and not (i.method == AUTO_METHOD and i.tolerance is not None):
        allowed = ", ".join(METHODS) + ' (or "auto" with integrator.tolerance)'
        raise SceneError("integrator.method", i.method, f"must be one of {allowed}" + _did_you_mean(i.method, METHODS))
    if i.precision not in PRECISIONS:
        raise SceneError("integrator.precision", i.precision, "must be float64 or float32")
    steps = i.duration / i.dt
    if not (steps <= MAX_STEPS + 0.5):
        raise SceneError(
            "integrator.duration",
            i.duration,
            f"needs {steps:.3g} steps of integrator.dt = {i.dt:g}; the step counter holds at most "
            f"{MAX_STEPS} (int32): shorten the run or raise dt",
        )
    if i.events not in EVENT_MODES:
        raise SceneError("integrator.events", i.events, f"must be one of {', '.join(EVENT_MODES)}")


def _validate_record(s: Scene) -> None:
    c, i, r = s.chain, s.integrator, s.record
    if r.every is not None:
        _positive("record.every", r.every)
        if r.every > i.duration * (1 + 1e-12):
            raise SceneError("record.every", r.every, f"must not exceed integrator.duration = {i.duration}")
        if r.every < i.dt * (1 - 1e-9):
            raise SceneError("record.every", r.every, f"must be ≥ integrator.dt = {i.dt:g} (records fall on steps)")
    for name in r.fields:
        if name not in FIELDS:
            raise SceneError("record.fields", name, f"allowed fields: {', '.join(FIELDS)}")
    if len(set(r.fields)) != len(r.fields):
        raise SceneError("record.fields", list(r.fields), "fields must not repeat")
    for g in r.traces:
        if not 0 <= g < c.grains:
            raise SceneError("record.traces", g, f"grain index outside the chain: allowed 0 … {c.grains - 1}")
    if len(set(r.traces)) != len(r.traces):
        raise SceneError("record.traces", list(r.traces), "grains must not repeat")
    if r.trace_every is not None:
        _positive("record.trace_every", r.trace_every)
        if r.trace_every < i.dt * (1 - 1e-9):
            raise SceneError(
                "record.trace_every", r.trace_every, f"must be ≥ integrator.dt = {i.dt:g} (samples fall on steps)"
            )
        if r.trace_every > i.duration * (1 + 1e-12):
            raise SceneError("record.trace_every", r.trace_every, f"must not exceed integrator.duration = {i.duration}")
        steps = r.trace_every / i.dt
        if abs(steps - round(steps)) > 1e-9 * steps:
            raise SceneError(
                "record.trace_every",
                r.trace_every,
                f"must be a whole number of steps of integrator.dt = {i.dt:g} (here {steps:.6g}; samples fall on steps)",
            )
        if s.trace_stride > 1 and (
            s._whole_steps_per_record is None or s.steps_per_record % s.trace_stride or s.step_count % s.trace_stride
        ):
            raise SceneError(
                "record.trace_every",
                r.trace_every,
                f"must divide record.every and integrator.duration into whole steps (every = "
                f"{r.every if r.every is not None else i.duration:g}, duration = {i.duration:g}, "
                f"trace_every = {s.trace_stride} steps of dt = {i.dt:g})",
            )


def _validate_error_estimate(s: Scene) -> None:
    """record.error_estimate: positions recorded, every record on a step of the 2·dt shadow."""
    r = s.record
    if not r.error_estimate:
        return
    if "u" not in r.fields:
        raise SceneError("record.fields", list(r.fields), "record.error_estimate needs 'u' among them")
    odd = s.record_steps[s.record_steps % SHADOW_STEP_FACTOR != 0]
    if s.integrator.tolerance is None and odd.size:
        raise SceneError(
            "record.every" if int(odd[0]) != s.step_count else "integrator.duration",
            r.every if int(odd[0]) != s.step_count else s.integrator.duration,
            f"record.error_estimate needs every record on an even step (the 2·dt shadow's), but record step "
            f"{int(odd[0])} of dt = {s.integrator.dt:g} is odd; make record.every and duration even multiples of dt",
        )


def _validate_damping_and_response(s: Scene) -> None:
    d, r, i = s.damping, s.record, s.integrator
    if d.model not in DAMPING_MODELS:
        raise SceneError(
            "damping.model",
            d.model,
            f"must be one of {', '.join(DAMPING_MODELS)}" + _did_you_mean(d.model, DAMPING_MODELS),
        )
    if d.gamma < 0:
        raise SceneError("damping.gamma", d.gamma, "must be ≥ 0")
    if d.model == "none" and d.gamma != 0:
        raise SceneError("damping.gamma", d.gamma, 'needs damping.model = "viscous" or "contact"')
    if r.response_start is None:
        return
    if s.boundary.surface != "driven":
        raise SceneError(
            "record.response_start", r.response_start, 'response windows need a drive (boundary.surface = "driven")'
        )
    if r.response_start < 0:
        raise SceneError("record.response_start", r.response_start, "must be ≥ 0")
    for key in ("response_periods", "response_windows"):
        if getattr(r, key) < 1:
            raise SceneError(f"record.{key}", getattr(r, key), "must be an integer ≥ 1")
    if not 0 <= r.harmonics <= MAX_HARMONICS:
        raise SceneError("record.harmonics", r.harmonics, f"must be an integer 0 … {MAX_HARMONICS}")
    ratio = s.excitation.drive_period / i.dt
    if abs(ratio - round(ratio)) > 1e-9 * ratio:
        raise SceneError(
            "excitation.drive_period",
            s.excitation.drive_period,
            f"response windows need a whole number of steps per period (τ/dt = {ratio:.6g})",
        )
    ratio = r.response_start / i.dt
    if abs(ratio - round(ratio)) > 1e-9 * max(ratio, 1.0):
        raise SceneError(
            "record.response_start", r.response_start, f"must be a whole number of steps of integrator.dt = {i.dt:g}"
        )
    if s.response_end_step > s.step_count:
        raise SceneError(
            "record.response_windows",
            r.response_windows,
            f"the windows end at t = {s.response_end_step * i.dt:g}, after integrator.duration = "
            f"{i.duration:g}: shorten or start them earlier",
        )
