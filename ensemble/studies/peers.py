"""Peer implementations for ``hertzian bench``: what a user would otherwise write.

Both integrate the benchmark ensemble — gear4 (Allen & Tildesley coefficients), Hertz contacts
(n = 5/2) or the α–β FPUT law (``chain.potential = "fput"``, with tension), one contact constant, one mass and one
static overlap per chain, walls or free ends —
as whole-array operations on a (chains, grains) state, the same equation of motion as the
project's kernels (excess contact forces about the static state, ``docs/architecture.md``):

* :class:`NumpyGear4` — NumPy, vectorised over chains × grains, preallocated buffers and in-place
  ufuncs (one pass over the arrays per operation; runs on one core).
* :class:`JaxGear4` — JAX, one ``jax.jit``-compiled ``lax.scan`` over steps with a tuple carry, scalar
  constants and a searched ``unroll`` (XLA fuses each step's element-wise work); built only when JAX
  is importable.

State layout and units follow ``kernels/step.py``: x = (u, dt·v, dt²/2·a, dt³/6·ȧ), shape
(4, chains, grains), program units.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

GEAR4 = (1.0 / 6.0, 5.0 / 6.0, 1.0, 1.0 / 3.0)


@dataclass(frozen=True)
class PeerProblem:
    """The ensemble a peer integrates: per-chain constants as (chains, 1) float64 arrays."""

    x: np.ndarray
    """Initial scaled Nordsieck state, shape (4, chains, grains)."""
    contact_constant: np.ndarray
    """a_c per chain, shape (chains, 1)."""
    static_overlap: np.ndarray
    """δ0 per chain (uniform), shape (chains, 1); zeros when unloaded."""
    inverse_mass: np.ndarray
    """1/m per chain, shape (chains, 1)."""
    dt: float
    surface_wall: bool = True
    bottom_wall: bool = True
    fput: tuple[float, float] | None = None
    """(α, β) of the FPUT law F(δ) = a (δ − α δ² + β δ³), one for every chain; None: Hertz."""

    @property
    def chain_count(self) -> int:
        return self.x.shape[1]

    @property
    def grain_count(self) -> int:
        return self.x.shape[2]


def problem_from_model(model, x: np.ndarray | None = None) -> PeerProblem:
    """The peer problem equivalent to an ensemble :class:`~hertzian.core.model.Model` (benchmark features only),
    from state ``x`` (default: the model's initial state)."""
    f = model.features
    c = model.chain_count
    shapes = model.law_parameters.numpy().reshape(c, 2) if f.potential == "fput" else None
    if (
        f.method != "gear4"
        or f.heterogeneous
        or f.static == "profile"
        or not (f.hertz or f.potential == "fput")
        or (shapes is not None and np.any(shapes != shapes[0]))
        or f.traces
        or f.surface in ("driven", "periodic")
        or f.bottom == "fixed"
        or f.precision != "float64"
    ):
        raise ValueError(
            "peers implement gear4/float64, Hertz or one FPUT law, homogeneous, uniform static, walls or free ends; "
            f"got {f}"
        )
    static = model.static_overlap.numpy() if f.static == "uniform" else np.zeros((c, 1))
    return PeerProblem(
        x=model.initial_state().x.numpy() if x is None else x,
        contact_constant=model.contact_constant.numpy().reshape(c, 1),
        static_overlap=static.reshape(c, 1),
        inverse_mass=model.inverse_mass.numpy().reshape(c, 1),
        dt=model.dt,
        surface_wall=f.surface == "wall",
        bottom_wall=f.bottom == "wall",
        fput=None if shapes is None else (float(shapes[0, 0]), float(shapes[0, 1])),
    )


def _hertz(delta: np.ndarray, a_c: np.ndarray) -> np.ndarray:
    """5/2 a δ^(3/2) for δ > 0, else 0 (no tension), as in kernels/physics.py."""
    with np.errstate(invalid="ignore"):
        return np.where(delta > 0.0, 2.5 * a_c * delta * np.sqrt(np.where(delta > 0.0, delta, 1.0)), 0.0)


def _fput(delta: np.ndarray, a_c: np.ndarray, alpha: float, beta: float) -> np.ndarray:
    """a δ (1 + δ (β δ − α)), the FPUT force with tension."""
    return a_c * delta * (1.0 + delta * (beta * delta - alpha))


def _force0(p: PeerProblem) -> np.ndarray:
    """The static force of each chain's contacts, F(δ0)."""
    if p.fput is None:
        return _hertz(p.static_overlap, p.contact_constant)
    return _fput(p.static_overlap, p.contact_constant, *p.fput)


class NumpyGear4:
    """gear4 on NumPy arrays, in place, one step per call of :meth:`step`."""

    name = "numpy"

    def __init__(self, problem: PeerProblem):
        p = problem
        self.problem = p
        c, n = p.chain_count, p.grain_count
        self.x = p.x.astype(np.float64).copy()
        self.delta0 = p.static_overlap
        self.a_c = p.contact_constant
        self.force0 = _force0(p)
        self.half_h2 = 0.5 * p.dt * p.dt
        self.inverse_mass = p.inverse_mass
        self.u = np.zeros((c, n + 2))  # predicted positions with a virtual grain at rest at each end
        self.delta = np.empty((c, n + 1))  # padded contacts: k joins grains k-1 and k
        self.root = np.empty((c, n + 1))
        self.force = np.empty((c, n + 1))
        self.acc = np.empty((c, n))
        self.p = np.empty((c, n))
        self.corr = np.empty((c, n))

    def step(self) -> None:
        """Advance every chain by one step."""
        x0, x1, x2, x3 = self.x
        u, delta, root, force, acc, p, corr = self.u, self.delta, self.root, self.force, self.acc, self.p, self.corr
        inner = u[:, 1:-1]
        np.add(x0, x1, out=inner)
        inner += x2
        inner += x3
        np.subtract(u[:, :-1], u[:, 1:], out=delta)
        np.add(self.delta0, delta, out=delta)
        if self.problem.fput is None:
            np.maximum(delta, 0.0, out=root)
            np.sqrt(root, out=root)
            np.multiply(2.5 * self.a_c, delta, out=force)
            force *= root  # root = 0 where δ ≤ 0: no tension
        else:  # a δ (1 + δ (β δ − α)), with tension
            alpha, beta = self.problem.fput
            np.multiply(beta, delta, out=root)
            root -= alpha
            root *= delta
            root += 1.0
            np.multiply(self.a_c, delta, out=force)
            force *= root
        force -= self.force0
        if not self.problem.surface_wall:
            force[:, 0] = 0.0
        if not self.problem.bottom_wall:
            force[:, -1] = 0.0
        np.subtract(force[:, :-1], force[:, 1:], out=acc)
        np.multiply(self.half_h2, acc, out=acc)
        acc *= self.inverse_mass
        # corrector: corr = a_new − p2, p2 = x2 + 3 x3, p1 = x1 + 2 x2 + 3 x3
        np.multiply(3.0, x3, out=p)
        np.add(x2, p, out=corr)
        np.subtract(acc, corr, out=corr)
        np.multiply(2.0, x2, out=x2)  # x2 is replaced by acc below; use it as scratch
        np.add(x1, x2, out=x1)
        x1 += p  # x1 now holds p1
        np.multiply(GEAR4[0], corr, out=p)
        np.add(inner, p, out=x0)
        np.multiply(GEAR4[1], corr, out=p)
        x1 += p
        x2[...] = acc
        np.multiply(GEAR4[3], corr, out=p)
        x3 += p

    def run(self, steps: int) -> None:
        for _ in range(steps):
            self.step()

    def state(self) -> np.ndarray:
        return self.x


def jax_available() -> bool:
    """True when JAX can be imported here."""
    try:
        import jax  # noqa: F401  (optional: probed here, not required by the package)
    except Exception:
        return False
    return True


class JaxGear4:
    """gear4 in JAX, as a competent JAX user writes it: ``lax.scan`` inside one ``jax.jit``, float64.

    Specialised to the problem like the project kernel it is compared with: the carry is a tuple of the
    four Nordsieck arrays (no ``stack`` per step), constants shared by every chain are Python scalars
    (folded into the compiled code), the walls are concatenated constants instead of a pad-and-mask,
    and ``unroll`` is picked by a small timed search (``UNROLLS``) on the first run of each length.
    """

    name = "jax"
    UNROLLS = (1, 4, 8, 16)
    """Candidate ``lax.scan`` unroll factors; the fastest on a short timed run is kept."""

    def __init__(self, problem: PeerProblem, device: str | None = None):
        # optional and heavy: imported only when a JAX peer is benched
        import jax
        import jax.numpy as jnp

        jax.config.update("jax_enable_x64", True)
        p = problem
        self.problem = p
        platform = "gpu" if device and device.startswith("cuda") else ("cpu" if device == "cpu" else None)
        devices = jax.devices(platform) if platform else jax.devices()
        self.device = devices[0]
        put = lambda a: jax.device_put(jnp.asarray(a, dtype=jnp.float64), self.device)  # noqa: E731

        def constant(a: np.ndarray):
            # one value for every chain: a Python float XLA folds in; else a (chains, 1) device array
            return float(a.flat[0]) if np.all(a == a.flat[0]) else put(a)

        delta0, a_c, inv_m = (constant(a) for a in (p.static_overlap, p.contact_constant, p.inverse_mass))
        force0 = constant(_force0(p))
        half_h2 = 0.5 * p.dt * p.dt
        c0, c1, c3 = GEAR4[0], GEAR4[1], GEAR4[3]
        chains = p.chain_count
        surface_wall, bottom_wall = p.surface_wall, p.bottom_wall
        wall_u = jnp.zeros((chains, 1), dtype=jnp.float64)

        if p.fput is None:

            def excess(delta):
                closed = delta <= 0.0
                return jnp.where(closed, 0.0, 2.5 * a_c * delta * jnp.sqrt(jnp.where(closed, 1.0, delta))) - force0

        else:
            alpha, beta = p.fput

            def excess(delta):
                return a_c * delta * (1.0 + delta * (beta * delta - alpha)) - force0

        def step(carry, _):
            x0, x1, x2, x3 = carry
            up = x0 + x1 + x2 + x3
            inner = excess(delta0 + (up[:, :-1] - up[:, 1:]))  # contacts between grains
            top = excess(delta0 - up[:, :1]) if surface_wall else wall_u
            bottom = excess(delta0 + up[:, -1:]) if bottom_wall else wall_u
            above = jnp.concatenate([top, inner], axis=1)
            below = jnp.concatenate([inner, bottom], axis=1)
            acc = half_h2 * (above - below) * inv_m
            corr = acc - (x2 + 3.0 * x3)
            return (up + c0 * corr, x1 + 2.0 * x2 + 3.0 * x3 + c1 * corr, acc, x3 + c3 * corr), None

        self.x = tuple(put(p.x[q]) for q in range(4))
        self._step = step
        self._runs = {}
        self._jax = jax
        self.unroll: int | None = None
        """The unroll factor the search picked (None until the first run)."""

    def _compiled(self, steps: int, unroll: int):
        key = (steps, unroll)
        if key not in self._runs:
            jax = self._jax
            self._runs[key] = jax.jit(lambda x: jax.lax.scan(self._step, x, None, length=steps, unroll=unroll)[0])
        return self._runs[key]

    def _search_unroll(self) -> int:
        steps = 256
        x = self.x
        best, best_time = 1, float("inf")
        for unroll in self.UNROLLS:
            run = self._compiled(steps, unroll)
            self._jax.block_until_ready(run(x))  # compile, warm up
            start = time.perf_counter()
            self._jax.block_until_ready(run(x))
            seconds = time.perf_counter() - start
            if seconds < best_time:
                best, best_time = unroll, seconds
        return best

    def run(self, steps: int) -> None:
        if self.unroll is None:
            self.unroll = self._search_unroll()
        self.x = self._compiled(steps, self.unroll)(self.x)
        self._jax.block_until_ready(self.x)

    def state(self) -> np.ndarray:
        return np.stack([np.asarray(a) for a in self.x])
