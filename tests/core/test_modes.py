"""Normal modes, modal and thermal starts, and the mode energies recorded on the device (hertzian.core.modes,
kernels/spectrum.py), each against something independent:

* the basis diagonalises the chain's harmonic stiffness matrix, built here from the springs (linear algebra);
* on a harmonic lattice every mode's energy is a constant of the motion (linear theory), and a modal start puts
  exactly the asked energy in the asked mode;
* a thermal start over every mode has participation number N and entropy ln N (closed forms);
* the FPUT recurrence time of the α-chain (N = 32, α = 1/4, amplitude 1 in mode 1) against Zabusky's KdV estimate.
"""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr
from hertzian.core.modes import mode_energies, normal_modes, participation, spectral_entropy, start
from hertzian.core.runner import run_scene

from tests.helpers import assert_refused, invoke, make_scene, toml_text


def lattice(grains: int, ends: str = "wall", **sections):
    sections.setdefault("integrator", {})
    sections["integrator"] = {"method": "yoshida6", "dt": 0.05, "duration": 50.0, **sections["integrator"]}
    return make_scene(
        chain={"grains": grains, "a": 1.0, **sections.pop("chain", {"potential": "harmonic"})},
        boundary={"surface": ends, "bottom": ends},
        **sections,
    )


def result_modes(scene) -> np.ndarray:
    """The mode numbers in the recorded order."""
    return normal_modes(scene)[0]


@pytest.mark.parametrize("grains", [12, 13])
@pytest.mark.parametrize("ends", ["wall", "free", "periodic"])
def test_basis_diagonalises_the_stiffness_matrix(ends, grains):
    """S K Sᵀ = m diag(ω²) and S Sᵀ = 1, with K the matrix of springs 2.0 between neighbours, walls as springs to
    fixed points, and a ring's closing spring between the last grain and the first."""
    scene = lattice(grains, ends, chain={"potential": "harmonic", "a": 2.0})
    _, basis, omega = normal_modes(scene)
    pairs = [(i, i + 1) for i in range(grains - 1)] + ([(grains - 1, 0)] if ends == "periodic" else [])
    stiffness = np.zeros((grains, grains))
    for i, j in pairs:
        stiffness[[i, j, i, j], [i, j, j, i]] += 2.0 * np.array([1, 1, -1, -1])
    if ends == "wall":
        stiffness[0, 0] += 2.0
        stiffness[-1, -1] += 2.0
    np.testing.assert_allclose(basis @ basis.T, np.eye(grains), atol=1e-13)
    np.testing.assert_allclose(basis @ stiffness @ basis.T, np.diag(omega**2), atol=1e-12)


@pytest.mark.parametrize("ends", ["wall", "free", "periodic"])
def test_mode_energies_of_a_harmonic_lattice_are_constants_of_the_motion(ends):
    """A harmonic chain started in modes 1 and 3: E_1 and E_3 recorded on the device stay at the asked 0.02 each and
    every other mode at zero, for 50 time units (yoshida6 conserves each mode's modified energy: 1e-9 here)."""
    scene = lattice(16, ends, excitation={"modes": [1, 3], "mode_energy": 0.02}, record={"every": 1.0, "modes": True})
    result = run_scene(scene, "cpu")
    energy = result.spectrum["mode_energy"][0]
    chosen = [list(result_modes(scene)).index(k) for k in (1, 3)]
    assert energy.shape == (51, 16)
    np.testing.assert_allclose(energy[0, chosen], 0.02, rtol=1e-14)
    np.testing.assert_allclose(energy[:, chosen], 0.02, rtol=1e-9)
    assert np.abs(np.delete(energy, chosen, axis=1)).max() < 1e-9 * 0.02
    np.testing.assert_allclose(result.energy[0], 0.04, rtol=1e-9)


def test_device_energies_equal_the_host_projection():
    """The device's E_k, entropy and participation against numpy's projection of the recorded u and v (an FPUT-β
    chain with free ends, thermal phases in modes 2 … 6)."""
    scene = lattice(
        24,
        "free",
        chain={"potential": "fput", "beta": 1.0},
        excitation={"thermal": 0.05, "thermal_modes": [2, 6], "seed": 3},
        record={"every": 5.0, "modes": True},
    )
    result = run_scene(scene, "cpu")
    host = mode_energies(scene, result.u[0], result.v[0])
    _, _, omega = normal_modes(scene)
    scale = host.max()
    np.testing.assert_allclose(result.spectrum["mode_energy"][0], host, rtol=0, atol=1e-13 * scale)
    np.testing.assert_allclose(result.spectrum["spectral_entropy"][0], spectral_entropy(host, omega), rtol=1e-12)
    np.testing.assert_allclose(result.spectrum["participation"][0], participation(host, omega), rtol=1e-12)
    assert result.spectrum["participation"][0, 0] == pytest.approx(5.0, rel=1e-12)  # five equal modes at t = 0


def test_thermal_start_over_every_mode_is_at_equipartition():
    """Every mode with the same energy: participation N, entropy ln N; the harmonic energy N·ε; the seed decides."""
    scene = lattice(20, excitation={"thermal": 0.01, "seed": 7})
    u, v = start(scene)
    energies = mode_energies(scene, u, v)
    _, _, omega = normal_modes(scene)
    np.testing.assert_allclose(energies, 0.01, rtol=1e-12)
    assert participation(energies, omega) == pytest.approx(20.0, rel=1e-12)
    assert spectral_entropy(energies, omega) == pytest.approx(np.log(20.0), rel=1e-12)
    again = start(lattice(20, excitation={"thermal": 0.01, "seed": 7}))
    other = start(lattice(20, excitation={"thermal": 0.01, "seed": 8}))
    np.testing.assert_array_equal(again[0], u)
    assert np.abs(other[0] - u).max() > 1e-3 * np.abs(u).max()


def test_fput_recurrence_time():
    """N = 32, α = 1/4, u_n = sin(π (n+1)/33) (mode 1, amplitude a = 1): the energy of mode 1 falls below 10 % and
    returns to 98 % at T_R = 153.4 T_1 (the same at dt 0.1: docs/lattices.md's record). Zabusky's KdV estimate (N. J. Zabusky, in
    Nonlinear Partial Differential Equations, ed. W. F. Ames, Academic Press 1967; as quoted by G. P. Berman and
    F. M. Izrailev, Chaos 15, 015104 (2005)) is T_R ≈ 0.44 T_1 (N³ / (a α))^½ = 159 T_1: within 4 %."""
    grains, alpha = 32, 0.25
    omega1 = 2.0 * np.sin(np.pi / (2 * (grains + 1)))
    period = 2 * np.pi / omega1
    energy = 0.5 * omega1**2 * (grains + 1) / 2  # amplitude 1 of the normalised sine
    scene = lattice(
        grains,
        chain={"potential": "fput", "alpha": alpha},
        excitation={"modes": [1], "mode_energy": energy},
        integrator={"dt": 0.2, "duration": 170 * period},
        record={"every": period / 8, "modes": True, "fields": []},
    )
    result = run_scene(scene, "cpu")
    share = result.spectrum["mode_energy"][0, :, 0] / result.spectrum["mode_energy"][0].sum(axis=1)
    low = int(np.argmin(share[result.t < 120 * period]))
    back = low + int(np.argmax(share[low:]))
    assert share[low] < 0.1 and share[back] > 0.98
    y0, y1, y2 = share[back - 1 : back + 2]
    recurrence = (result.t[back] + 0.5 * (y0 - y2) / (y0 - 2 * y1 + y2) * (period / 8)) / period
    estimate = 0.44 * np.sqrt(grains**3 / alpha)
    assert abs(recurrence / estimate - 1) < 0.04, (recurrence, estimate)


def test_mode_energies_reach_the_store(tmp_path):
    scene = tmp_path / "fput.toml"
    data = {
        "chain": {"grains": 8, "potential": "fput", "a": 1.0, "alpha": 0.25},
        "excitation": {"modes": [1], "mode_energy": 0.01},
        "integrator": {"method": "yoshida6", "dt": 0.1, "duration": 10.0},
        "record": {"every": 1.0, "modes": True},
    }
    scene.write_text(toml_text(data))
    out = tmp_path / "out.zarr"
    assert invoke("run", scene, "--out", out).exit_code == 0
    ds = xr.open_zarr(out)
    assert ds.mode_energy.dims == ("record", "mode") and ds.mode.values.tolist() == list(range(1, 9))
    assert float(ds.mode_energy[0, 0]) == pytest.approx(0.01, rel=1e-12)
    assert ds.spectral_entropy.dims == ("record",) and ds.participation.dims == ("record",)


REFUSED = {
    "modes with impurities": (
        {"chain": {"potential": "fput"}, "impurities": [{"grains": [2], "mass": 2.0}], "record": {"modes": True}},
        "record.modes",
    ),
    "modes of an unloaded Hertz chain": ({"excitation": {"modes": [1], "mode_energy": 1.0}}, "excitation.modes"),
    "a mode beyond the chain": (
        {"chain": {"potential": "fput"}, "excitation": {"modes": [9], "mode_energy": 1.0}},
        "excitation.modes",
    ),
    "modes and an impact": (
        {"chain": {"potential": "fput"}, "excitation": {"modes": [1], "mode_energy": 1.0, "impact": 0.1}},
        "excitation.impact",
    ),
    "modes and thermal phases": (
        {"chain": {"potential": "fput"}, "excitation": {"modes": [1], "mode_energy": 1.0, "thermal": 0.1}},
        "excitation.thermal",
    ),
    "a ring with one periodic end": (
        {"chain": {"potential": "fput"}, "boundary": {"surface": "periodic", "bottom": "wall"}},
        "boundary.bottom",
    ),
    "a ring under gravity": (
        {"chain": {"potential": "fput", "gravity": 1.0}, "boundary": {"surface": "periodic", "bottom": "periodic"}},
        "chain.gravity",
    ),
    "a Hertz ring with event steps": (
        {"chain": {"l0": 1e-4}, "boundary": {"surface": "periodic", "bottom": "periodic"}},
        "integrator.events",
    ),
    "a negative seed": (
        {"chain": {"potential": "fput"}, "excitation": {"thermal": 0.1, "seed": -1}},
        "excitation.seed",
    ),
    "an infinite thermal energy": (
        {"chain": {"potential": "fput"}, "excitation": {"thermal": 1e400}},
        "excitation.thermal",
    ),
    "a wall and a free end": (
        {"chain": {"potential": "fput"}, "boundary": {"bottom": "free"}, "excitation": {"thermal": 0.1}},
        "excitation.thermal",
    ),
}


@pytest.mark.parametrize("case", list(REFUSED))
def test_modal_refusals(case, tmp_path):
    data, key = REFUSED[case]
    scene = tmp_path / "scene.toml"
    chain = {"grains": 8, **data.get("chain", {})}
    scene.write_text(toml_text({**data, "chain": chain, "integrator": {"duration": 1.0}}))
    out = tmp_path / "out.zarr"
    assert_refused(invoke("run", scene, "--out", out), out, key)


def test_a_users_start_replaces_the_files_start(tmp_path):
    """--set excitation.thermal on a file with a modal start (or modes on a thermal one, or an impact on either)
    runs the start given, not the file's: the other start's keys give way, as dt gives way to a tolerance. Both in
    one set of overrides stay refused, and setting a start to nothing drops nothing."""
    from hertzian.core.scene import SceneError, load_scene

    path = tmp_path / "fput.toml"
    path.write_text(
        toml_text(
            {
                "chain": {"grains": 8, "potential": "fput", "alpha": 0.25, "a": 1.0},
                "excitation": {"modes": [1], "mode_energy": 0.1},
                "integrator": {"method": "yoshida6", "dt": 0.05, "duration": 1.0},
            }
        )
    )
    thermal = load_scene(path, {"excitation.thermal": 0.2})
    assert (thermal.excitation.modes, thermal.excitation.mode_energy, thermal.excitation.thermal) == ((), 0.0, 0.2)
    u, v = start(thermal)
    assert np.any(v != 0.0)  # phases: a modal start has v = 0
    struck = load_scene(path, {"excitation.impact": 0.01})
    assert (struck.excitation.modes, struck.excitation.impact) == ((), 0.01) and start(struck) is None
    modal = load_scene(path, {"excitation.thermal": 0.0})
    assert modal.excitation.modes == (1,)
    with pytest.raises(SceneError, match=r"^excitation.thermal = 0.2: not with excitation.modes"):
        load_scene(path, {"excitation.thermal": 0.2, "excitation.modes": [2]})
