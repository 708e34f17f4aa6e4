"""The per-chain error estimate (record.error_estimate, docs/accuracy.md) against the true error, measured with the
independent NumPy reference (tests/reference.py): gear6 at a step ``REFERENCE_REFINEMENT`` times smaller, itself
checked by running it again at twice its step (its error must be far below the error it judges)."""

import numpy as np
import pytest
from hertzian.core.error_estimate import ensemble_can_open, opened_at_records
from hertzian.core.runner import run_ensemble, run_scene
from hertzian.core.scene import SceneError
from hertzian.core.status import Status

from tests.helpers import make_scene
from tests.reference import reference_run

GRAINS = 12
DURATION = 2.0
EVERY = 0.5
FACTOR = 3.0
"""The estimate must lie within this factor of the true error (the accuracy the estimate promises)."""
REFERENCE_REFINEMENT = 32
IMPURITIES = [{"grains": [3, 4], "mass": 0.5, "a": 2000.0}, {"grains": [8], "mass": 2.0, "a": 1e4}]

SMOOTH = dict(chain={"l0": 1e-2}, excitation={"impact": 1e-4})
"""No contact can open (hertzian.core.model.contact_can_open): the methods keep their smooth orders."""
CASES = {
    "smooth, gear4": (SMOOTH, "gear4", "auto", 2.5e-3),
    "smooth, verlet": (SMOOTH, "verlet", "auto", 1e-3),
    "walls, precompressed": (dict(chain={"l0": 1e-4}, excitation={"impact": 1e-2}), "gear4", "auto", 1e-3),
    "walls, precompressed, verlet": (dict(chain={"l0": 1e-4}, excitation={"impact": 1e-2}), "verlet", "auto", 5e-4),
    "gravity and impurities": (
        dict(chain={"gravity": 1.0, "l0": 1e-4}, impurities=IMPURITIES, excitation={"impact": 1e-2}),
        "gear4",
        "auto",
        1e-3,
    ),
    "loose chain, event-aware steps": (dict(chain={"l0": 0.0}, excitation={"impact": 1e-2}), "gear4", "auto", 1e-3),
    "loose chain, plain steps": (dict(chain={"l0": 0.0}, excitation={"impact": 1e-2}), "gear4", "off", 1e-3),
    "driven, precompressed": (
        dict(
            chain={"l0": 1e-4},
            boundary={"surface": "driven", "bottom": "wall"},
            excitation={"drive_amplitude": 1e-4, "drive_period": 0.5},
        ),
        "gear4",
        "auto",
        1e-3,
    ),
}


def estimated_scene(sections: dict, method: str, events: str, dt: float):
    return make_scene(
        chain={"grains": GRAINS, **sections.get("chain", {})},
        **{k: v for k, v in sections.items() if k != "chain"},
        integrator={"duration": DURATION, "dt": dt, "method": method, "events": events},
        record={"every": EVERY, "fields": ["u"], "error_estimate": True},
    )


def true_error(scene, u: np.ndarray) -> float:
    """max |u − u_exact| / max|u_exact| with u_exact from the NumPy reference's gear6 at dt/32 (checked)."""
    fine_dt = scene.integrator.dt / REFERENCE_REFINEMENT

    def reference(step):
        data = scene.to_dict()
        data["integrator"].update(method="gear6", dt=step)
        return reference_run(data)["u"]

    exact, coarser = reference(fine_dt), reference(2 * fine_dt)
    scale = np.max(np.abs(exact))
    error = np.max(np.abs(u - exact)) / scale
    assert np.max(np.abs(coarser - exact)) / scale < error / 30, "the reference does not resolve the error"
    return float(error)


@pytest.mark.parametrize("name", list(CASES))
def test_estimate_within_factor_of_true_error(name):
    scene = estimated_scene(*CASES[name])
    result = run_scene(scene, "cpu")
    estimate, error = float(result.error_estimate[0]), true_error(scene, result.u[0])
    assert error / FACTOR <= estimate <= FACTOR * error, f"{name}: estimate {estimate:.3g}, true error {error:.3g}"


def test_estimate_per_chain_in_an_ensemble():
    """Each chain of an ensemble gets its own estimate; a member's equals its run alone (bit for bit)."""
    scenes = [
        estimated_scene(CASES["walls, precompressed"][0] | {"excitation": {"impact": v}}, "gear4", "auto", 1e-3)
        for v in (1e-3, 1e-2)
    ]
    together = run_ensemble(scenes, "cpu").error_estimate
    alone = [run_scene(s, "cpu").error_estimate[0] for s in scenes]
    assert together.shape == (2,)
    np.testing.assert_array_equal(together, alone)
    assert together[0] != together[1]


def test_parted_trajectories_show():
    """Where the run and its shadow part, the estimate is of the order of the motion: no accuracy is claimed."""
    scene = estimated_scene(dict(chain={"l0": 0.0}, excitation={"impact": 1e-2}), "gear4", "off", 0.05)
    assert run_scene(scene, "cpu").error_estimate[0] > 1e-2


def test_no_estimate_unless_asked():
    scene = make_scene(chain={"grains": GRAINS}, excitation={"impact": 1e-2}, integrator={"duration": 0.1, "dt": 1e-3})
    assert run_scene(scene, "cpu").error_estimate is None


@pytest.mark.parametrize(
    "record, key",
    [({"every": 0.003}, "record.every"), ({"fields": ["v"]}, "record.fields")],
)
def test_refusals(record, key):
    with pytest.raises(SceneError, match=key.replace(".", r"\.")) as refused:
        make_scene(
            chain={"grains": GRAINS},
            integrator={"duration": 0.03, "dt": 1e-3},
            record={**record, "error_estimate": True},
        )
    assert "\n" not in str(refused.value)


@pytest.mark.parametrize("name, tolerance", [("walls, precompressed", 1e-6), ("loose chain, event-aware steps", 1e-6)])
def test_tolerance_met_with_the_largest_ladder_step(name, tolerance):
    """The kept run's true error is ≤ TOL, and twice its step (the next rung up) would miss TOL."""
    sections = CASES[name][0]
    scene = make_scene(
        chain={"grains": GRAINS, **sections["chain"]},
        excitation=sections["excitation"],
        integrator={"duration": DURATION, "tolerance": tolerance},
        record={"every": EVERY, "fields": ["u"]},
    )
    result = run_scene(scene, "cpu")
    chosen = result.scenes[0]
    assert chosen.integrator.tolerance is None and result.status[0] == 0
    assert true_error(chosen, result.u[0]) <= tolerance
    coarser = chosen.with_overrides({"integrator.dt": 2 * chosen.integrator.dt})
    assert true_error(coarser, run_scene(coarser, "cpu").u[0]) > tolerance


def test_tolerance_and_dt_refused_together():
    with pytest.raises(SceneError, match="integrator.tolerance"):
        make_scene(chain={"grains": GRAINS}, integrator={"duration": 1.0, "dt": 1e-3, "tolerance": 1e-6})


def test_an_overridden_tolerance_or_step_replaces_the_other(tmp_path):
    """The built-in example gives dt; --set integrator.tolerance=… replaces it (and dt a tolerance, l0 a load, a
    load l0). Both in one set of overrides stay refused, and a sweep's axis replaces nothing."""
    from hertzian.core.scene import load_scene
    from hertzian.core.shipped import example_path
    from hertzian.sweeping.spec import load_sweep, sweep_scenes

    impact = load_scene(example_path("impact"), {"integrator.tolerance": 1e-6})
    assert impact.integrator.tolerance == 1e-6  # the file's dt = 5e-5 gave way
    loaded = load_scene(example_path("impact"), {"chain.load": 0.01})
    assert (loaded.chain.load, loaded.chain.l0) == (0.01, 0.0)
    bare = tmp_path / "bare.toml"
    bare.write_text("[chain]\ngrains = 10\nload = 0.01\n[integrator]\nduration = 1.0\n")
    assert load_scene(bare, {"chain.l0": 0.0}).chain.load is None  # no precompression asked: the load gives way
    path = tmp_path / "loaded.toml"
    path.write_text("[chain]\ngrains = 10\nload = 0.01\n[integrator]\nduration = 1.0\ntolerance = 1e-6\n")
    stepped = load_scene(path, {"integrator.dt": 1e-3, "chain.l0": 1e-4})
    assert (stepped.integrator.tolerance, stepped.integrator.dt, stepped.chain.load) == (None, 1e-3, None)
    with pytest.raises(SceneError, match="not both"):
        load_scene(example_path("impact"), {"integrator.tolerance": 1e-6, "integrator.dt": 1e-4})
    sweep = tmp_path / "sweep.toml"
    sweep.write_text(
        "[scene.chain]\ngrains = 10\nload = 0.01\n[scene.integrator]\nduration = 1.0\ndt = 1e-3\n"
        '[[axis]]\nname = "l0"\nkey = "chain.l0"\nvalues = [0.0, 1e-4]\n'
    )
    with pytest.raises(SceneError, match="give either chain.l0 or chain.load, not both"):
        sweep_scenes(load_sweep(sweep))


def test_a_tolerance_run_puts_its_trace_samples_on_steps():
    """Records every 0.1 and traces every 0.01 over 0.5: the step ladder starts from trace_every, so every step it
    tries puts the samples on steps (from every, 0.1/2^8 = 0.000390625 would give 25.6 steps per sample)."""
    scene = make_scene(
        chain={"grains": GRAINS, "l0": 1e-4},
        excitation={"impact": 1e-2},
        integrator={"duration": 0.5, "tolerance": 1e-5},
        record={"every": 0.1, "fields": ["u"], "traces": [0], "trace_every": 0.01},
    )
    result = run_scene(scene, "cpu")
    chosen = result.scenes[0]
    assert result.status[0] == Status.OK
    steps = 0.01 / chosen.integrator.dt
    assert steps == round(steps) and result.traces["u"].shape[1] == 51


def test_smooth_chain_keeps_its_order_beside_a_loose_one():
    """With plain steps, a chain where no contact can open is estimated at its smooth order even when another
    chain of the ensemble opens contacts (the order is per chain): within 3× of its true error."""
    smooth = estimated_scene(SMOOTH, "gear4", "off", 2.5e-3)
    loose = estimated_scene(dict(chain={"l0": 0.0}, excitation={"impact": 1e-2}), "gear4", "off", 2.5e-3)
    result = run_ensemble([smooth, loose], "cpu")
    estimate, error = float(result.error_estimate[0]), true_error(smooth, result.u[0])
    assert error / FACTOR <= estimate <= FACTOR * error, f"estimate {estimate:.3g}, true error {error:.3g}"


def test_sweep_refuses_a_tolerance(tmp_path):
    """A sweep takes dt: a tolerance (in the scene or on an axis) is refused at load with one line, exit 2,
    nothing written."""
    from hertzian.cli import EXIT_BAD_INPUT, app
    from hertzian.sweeping.spec import sweep_from_dict
    from typer.testing import CliRunner

    scene = {"chain": {"grains": 4}, "integrator": {"tolerance": 1e-6, "duration": 0.1}, "record": {"every": 0.05}}
    axis = {"name": "v", "key": "excitation.impact", "values": [1e-3, 1e-2]}
    with pytest.raises(SceneError, match="integrator.tolerance") as refused:
        sweep_from_dict({"scene": scene, "axis": [axis]})
    assert "\n" not in str(refused.value)
    tolerance_axis = {"name": "tol", "key": "integrator.tolerance", "values": [1e-6, 1e-8]}
    with pytest.raises(SceneError, match="not a tolerance"):
        sweep_from_dict({"scene": {**scene, "integrator": {"duration": 0.1}}, "axis": [tolerance_axis]})
    path = tmp_path / "tol.toml"
    path.write_text(
        "[scene.chain]\ngrains = 4\n[scene.integrator]\ntolerance = 1e-6\nduration = 0.1\n"
        '[[axis]]\nname = "v"\nkey = "excitation.impact"\nvalues = [1e-3, 1e-2]\n'
    )
    out = tmp_path / "out.zarr"
    ran = CliRunner().invoke(app, ["sweep", str(path), "--out", str(out), "--device", "cpu"])
    assert ran.exit_code == EXIT_BAD_INPUT and "integrator.tolerance" in ran.output and not out.exists()


def test_contact_that_never_opens_keeps_the_smooth_order():
    """With plain steps, a chain the energy bound lets open but whose contacts stay closed (overlaps > 0 at every
    record) is estimated at the smooth order, within 3× of its true error, and is not marked uncertain."""
    scene = estimated_scene(dict(chain={"l0": 1e-4}, excitation={"impact": 1.9e-3}), "gear4", "off", 2.5e-3)
    assert ensemble_can_open([scene])[0]
    result = run_scene(scene, "cpu")
    estimate, error = float(result.error_estimate[0]), true_error(scene, result.u[0])
    assert error / FACTOR <= estimate <= FACTOR * error, f"estimate {estimate:.3g}, true error {error:.3g}"
    assert result.status[0] == Status.OK


@pytest.mark.parametrize("events, status", [("off", Status.ESTIMATE_UNCERTAIN), ("auto", Status.OK)])
def test_opening_contact_with_plain_steps_marks_the_estimate(events, status):
    """A loose chain opens contacts: with plain steps its estimate is marked ESTIMATE_UNCERTAIN, with event-aware
    steps it is not; a smooth chain beside it stays OK either way."""
    loose = estimated_scene(dict(chain={"l0": 0.0}, excitation={"impact": 1e-2}), "gear4", events, 2.5e-3)
    smooth = estimated_scene(SMOOTH, "gear4", events, 2.5e-3)
    assert list(run_ensemble([loose, smooth], "cpu").status) == [status, Status.OK]


def test_opened_at_records():
    """An overlap δ0 + u_(k−1) − u_k ≤ 0 at any record (walls at rest at both ends) counts; absent contacts do not."""
    static_overlap = np.full((1, 4), 1e-3)
    present = np.ones((1, 4))
    u = np.zeros((1, 2, 3))
    assert not opened_at_records(u, static_overlap, present)[0]
    pulled = u.copy()
    pulled[0, 1, 1] = 2e-3  # grain 1 moves 2e-3 toward the bottom: its contact with grain 0 opens
    assert opened_at_records(pulled, static_overlap, present)[0]
    lifted = u.copy()
    lifted[0, 0, :] = 2e-3  # all grains toward the bottom: only the top wall's contact opens
    assert opened_at_records(lifted, static_overlap, present)[0]
    assert not opened_at_records(lifted, static_overlap, np.array([[0.0, 1, 1, 1]]))[0]


def test_estimate_reductions_over_many_chains_equal_the_whole_array_formulas():
    # opened_at_records and richardson_error take chains in blocks (CHAIN_BLOCK): more chains than a block, with a
    # chain whose shadow is not finite, one at rest and one that opens, give the whole-array formulas' values
    from hertzian.core.error_estimate import CHAIN_BLOCK, richardson_error

    rng = np.random.default_rng(3)
    chains, records, grains = 2 * CHAIN_BLOCK + 37, 3, 5
    u = rng.normal(scale=1e-5, size=(chains, records, grains))
    u[7] = 0.0
    shadow = u + rng.normal(scale=1e-9, size=u.shape)
    shadow[400, 1, 2] = np.nan
    # every third chain barely compressed (its contacts open under the random motion), the others far from opening
    static_overlap = np.where(np.arange(chains)[:, None] % 3 == 0, 1e-7, 1e-3) * np.ones((chains, grains + 1))
    u[301, 2, 4] = 1.0  # grain 4 pulled far from grain 3: contact 4 opens
    present = np.ones((chains, grains + 1))
    relative = np.concatenate([-u[:, :, :1], u[:, :, :-1] - u[:, :, 1:], u[:, :, -1:]], axis=2)
    want_opened = ((static_overlap[:, None, :] + relative) <= 0).any(axis=(1, 2))
    assert want_opened[301] and 0 < want_opened.sum() < chains
    np.testing.assert_array_equal(opened_at_records(u, static_overlap, present), want_opened)
    order = np.where(np.arange(chains) % 2, 4.0, 2.5)
    with np.errstate(invalid="ignore"):
        scale = np.abs(u).max(axis=(1, 2))
        want = np.abs(u - shadow).max(axis=(1, 2)) / (2.0**order - 1.0) / np.where(scale > 0, scale, 1.0)
    want = np.where(np.isfinite(want), want, np.inf)
    got = richardson_error(u, shadow, order)
    np.testing.assert_array_equal(got, want)
    assert np.isinf(got[400]) and got[7] > 0


@pytest.mark.parametrize("method", ["gear4", "gear5", "verlet"])
def test_the_shadow_starts_as_a_model_built_at_twice_the_step(method):
    """The shadow of a sweep's model (a ChainSet: its start prepared with the model) starts from the state a model of
    the shadow's own scenes starts from, bit for bit: for gear5 and Verlet the run's start scaled by 2^k per row, for
    gear4 its own steady-state start (ensemble/core/startup.py), whose dt⁴ terms no such scaling gives."""
    from hertzian.core.chains import ChainSet
    from hertzian.core.error_estimate import shadow_chains, shadow_model
    from hertzian.core.model import build_model

    template = make_scene(
        chain={"grains": 16, "l0": 1e-4}, excitation={"impact": 1e-2}, integrator={"method": method, "dt": 1e-3}
    )
    chains = ChainSet.of(template, {"excitation.impact": [1e-2, 3e-2]}, 2)
    model = build_model(chains, "cpu")
    assert model._start is not None  # the prepared start, which the shadow may scale
    shadow = shadow_model(model).initial_state().x.numpy()
    alone = build_model(shadow_chains(chains), "cpu").initial_state().x.numpy()
    np.testing.assert_array_equal(shadow, alone)
    assert np.any(shadow[1])  # the struck grains move
