"""The record reductions (kernels/records.py) on chains longer than one part of RECORD_PART grains.

Energy, largest overlap and the status flags are computed in parts of consecutive grains and then
added per chain; here they are checked against the NumPy reference's energy (tests/reference.py,
docs/model.md §5) and against overlaps computed with NumPy, on a chain of three parts whose impurities, largest
overlap and non-finite grain sit in the later parts (a reduction that dropped or repeated a part fails).
"""

import numpy as np
import warp as wp
from hertzian.core.model import build_model
from hertzian.core.recorder import Recorder
from hertzian.core.status import Status
from hertzian.kernels.records import PART_TILE, RECORD_PART, record_part_count

from tests.helpers import make_scene
from tests.reference import static_overlaps, total_energy

GRAINS = 2 * RECORD_PART + 44
SECTIONS = dict(
    chain={"grains": GRAINS, "l0": 1e-4},
    impurities=[{"grains": [RECORD_PART + 3], "mass": 0.5}, {"grains": [GRAINS - 7], "mass": 3.0}],
    excitation={"impact": 1e-2},
)


def _set_state(model, state, u, v):
    x = state.x.numpy()
    x[:] = 0.0
    x[0, 0] = u
    x[1, 0] = v * model.dt
    state.x.assign(x)


def _check(model, recorder, state, u, v):
    _set_state(model, state, u, v)
    recorder.check(state, 1)
    wp.synchronize_device(model.device)
    return recorder.energy_now.numpy()[0], recorder.max_overlap_now.numpy()[0], int(state.status.numpy()[0])


def test_record_sums_every_part_of_a_long_chain(device):
    assert record_part_count(GRAINS) == 3
    scene = make_scene(**SECTIONS)
    model = build_model([scene], device)
    recorder = Recorder(model)
    state = model.state()
    rng = np.random.default_rng(7)
    delta_sw, delta_in, delta_bw = static_overlaps(scene.to_dict())
    energies, references = [], []
    for trial in range(3):
        u = rng.normal(scale=2e-5, size=GRAINS)
        v = rng.normal(scale=1e-2, size=GRAINS)
        u[GRAINS - 30] += 3e-4 * (trial + 1)  # the largest overlap, in the last part
        energy, largest, status = _check(model, recorder, state, u, v)
        energies.append(energy)
        references.append(total_energy(scene.to_dict(), u, v))
        overlaps = np.concatenate([[delta_sw - u[0]], delta_in + u[:-1] - u[1:], [delta_bw + u[-1]]])
        np.testing.assert_allclose(largest, overlaps.max(), rtol=1e-14)
        assert np.argmax(overlaps) > 2 * RECORD_PART
        assert status == Status.OK
    # the recorded energy is docs/model.md's up to a constant per chain: compare differences between states
    got, want = np.diff(energies), np.diff(references)
    np.testing.assert_allclose(got, want, rtol=1e-11, atol=1e-13 * np.max(np.abs(references)))
    assert np.min(np.abs(want)) > 1e-3 * np.max(np.abs(references))


def test_record_flags_a_non_finite_grain_in_a_later_part(device):
    model = build_model([make_scene(**SECTIONS)], device)
    recorder = Recorder(model)
    state = model.state()
    u, v = np.zeros(GRAINS), np.zeros(GRAINS)
    v[GRAINS - 3] = np.nan
    _, _, status = _check(model, recorder, state, u, v)
    assert status == Status.NON_FINITE


STAGED_CASES = {
    "impact, walls, impurities": SECTIONS,
    "driven, gravity, fixed bottom, viscous": dict(  # 3 grains more: a last part of 47, not a multiple of 4
        chain={"grains": GRAINS + 3, "gravity": 1.0},
        boundary={"surface": "driven", "bottom": "fixed"},
        excitation={"drive_amplitude": 0.5, "drive_period": 3.0},
        damping={"model": "viscous", "gamma": 0.1},
    ),
    # more parts than record_long copies to shared memory at once: its second copy holds the last 4 parts
    "driven column of 36 parts": dict(
        chain={"grains": (PART_TILE + 3) * RECORD_PART + 17, "gravity": 1.0},
        boundary={"surface": "driven", "bottom": "fixed"},
        excitation={"drive_amplitude": 0.5, "drive_period": 3.0},
    ),
}


def test_long_chains_two_stage_reduction_equals_the_parts(device, monkeypatch):
    """Chains of STAGED_GRAINS grains or more evaluate each grain's terms in a thread of its own, then sum them per
    part in the same order (kernels/records.py): energy, work, largest overlap, dissipated energy and status equal
    the one-stage parts' bit for bit on the CPU, to rounding on CUDA (where each kernel contracts as its compiler
    chooses), on states whose largest overlap lies in the last part, with a non-finite grain there too."""
    import hertzian.core.recorder as recorder_module

    for name, sections in STAGED_CASES.items():
        model = build_model([make_scene(**sections)] * 2, device)
        n = model.grain_count
        monkeypatch.setattr(recorder_module, "STAGED_GRAINS", n + 1)
        one_stage = Recorder(model)
        monkeypatch.setattr(recorder_module, "STAGED_GRAINS", n)
        staged = Recorder(model)
        monkeypatch.undo()
        assert staged.staged and not one_stage.staged, name
        rng = np.random.default_rng(3)
        for trial in range(3):
            state = model.state()
            x = state.x.numpy()
            x[0] = rng.normal(scale=2e-5, size=(2, n))
            x[1] = rng.normal(scale=1e-2, size=(2, n)) * model.dt
            x[0, :, n - 30] += 3e-4
            if trial == 2:
                x[1, 1, n - 2] = np.nan
            state.x.assign(x)
            if state.dissipated.shape[0]:
                state.dissipated.assign(rng.uniform(size=state.dissipated.shape))
            got = []
            for recorder in (one_stage, staged):
                status = state.status.numpy().copy()
                recorder.check(state, 40)
                wp.synchronize_device(model.device)
                got.append(
                    [
                        recorder.energy_now.numpy(),
                        recorder.work_now.numpy(),
                        recorder.max_overlap_now.numpy(),
                        recorder.dissipated_now.numpy(),
                        recorder.parts.numpy(),
                        state.status.numpy().copy(),
                    ]
                )
                state.status.assign(status)
            assert got[1][5].tolist() == ([Status.OK, Status.NON_FINITE] if trial == 2 else [Status.OK] * 2), name
            for a, b in zip(*got):
                if wp.get_device(device).is_cpu:
                    np.testing.assert_array_equal(b, a, err_msg=name)
                else:
                    np.testing.assert_allclose(b, a, rtol=1e-14, err_msg=name)


def test_traces_of_one_value_equal_those_of_both(device):
    """``trace_values=("v",)`` (a detection library) copies and unpacks only the velocity half of the trace ring:
    the velocity traces equal those of a run keeping both, bit for bit, with several records (ring slots reused,
    wrapping) and with one record after t = 0 (the whole trace in one ring); a bad value is refused."""
    from dataclasses import replace

    import pytest
    from hertzian.core.runner import Runner

    for every in (0.014, 0.05):
        scene = make_scene(
            chain={"grains": 30, "l0": 1e-4},
            excitation={"impact": 1e-2},
            integrator={"method": "gear4", "dt": 1e-3, "duration": 0.07 if every < 0.05 else 0.05},
            record={"every": every, "traces": [0, 7, 29], "trace_every": 0.002},
        )
        both = Runner(build_model([scene, scene], device)).run()
        only_v = Runner(build_model([scene, scene], device), trace_values=("v",)).run()
        assert set(only_v.traces) == {"v"}
        # independent of the ring's unpacking: the samples at record times are the snapshots of those grains
        stride = round(0.002 / 1e-3)
        at_records = (np.asarray(scene.record_steps) // stride).astype(int)
        fields = Runner(
            build_model([replace(scene, record=replace(scene.record, fields=("u", "v")))] * 2, device)
        ).run()
        for name in ("u", "v"):
            np.testing.assert_array_equal(both.traces[name][:, at_records], fields.fields[name][:, :, [0, 7, 29]])
        assert np.max(np.abs(both.traces["v"][:, -1, 0])) > 1e-4  # the surface grain moved
        np.testing.assert_array_equal(only_v.traces["v"], both.traces["v"])
    with pytest.raises(ValueError, match="trace_values"):
        Recorder(build_model([scene], device), trace_values=("x",))


def test_staging_depth_keeps_every_record_in_order(device, monkeypatch):
    """Small records get up to MAX_STAGING_DEPTH staging buffers (the host may run that many records ahead of the
    device), large ones two (STAGING_BYTES); each record copies only the state rows the scene keeps. A run of more
    records than buffers, with snapshots of v only and traces, gives the same result with 8 buffers as with 2, bit
    for bit, and hands its records to ``on_unpacked`` in order."""
    import hertzian.core.recorder as recorder_module
    from hertzian.core.runner import Runner

    scene = make_scene(
        chain={"grains": 30, "l0": 1e-4},
        excitation={"impact": 1e-2},
        integrator={"method": "gear4", "dt": 1e-3, "duration": 0.2},
        record={"every": 0.01, "fields": ["v"], "traces": [0, 29], "trace_every": 0.002},
    )
    assert len(scene.record_steps) == 21
    results, orders = {}, {}
    for staging_bytes in (recorder_module.STAGING_BYTES, 0):
        monkeypatch.setattr(recorder_module, "STAGING_BYTES", staging_bytes)
        order = []
        runner = Runner(build_model([scene, scene], device), on_unpacked=lambda rec, r: order.append(r))
        depth = runner.recorder.depth
        results[depth], orders[depth] = runner.run(), order
    assert set(results) == {recorder_module.MAX_STAGING_DEPTH, 2}
    deep, double = results[recorder_module.MAX_STAGING_DEPTH], results[2]
    assert set(deep.fields) == {"v"} and np.max(np.abs(deep.fields["v"][:, -1])) > 0
    for name in ("v",):
        np.testing.assert_array_equal(deep.fields[name], double.fields[name])
    for name in ("u", "v"):
        np.testing.assert_array_equal(deep.traces[name], double.traces[name])
    np.testing.assert_array_equal(deep.energy, double.energy)
    assert orders[2] == orders[recorder_module.MAX_STAGING_DEPTH] == list(range(21))
    # without traces a record copies v alone (with them, u too: the traces' t = 0 values come from the snapshot)
    from dataclasses import replace

    untraced = replace(scene, record=replace(scene.record, traces=()))
    assert set(Recorder(build_model([untraced], device)).staging[0]) == {"energy", "v"}


def test_host_pages_mapped_in_the_background_keep_every_record(device, monkeypatch):
    """On CUDA a background thread writes the new host arrays once (mapping their pages) while the first records
    run, in blocks along the record axis; an unpack waits only for the blocks it writes. Made slow here, the first
    unpack comes before the mapping ends, and no record is overwritten by it: the records equal those of a run that
    maps nothing in the background, bit for bit."""
    import time

    from hertzian.core import recorder as recorder_module
    from hertzian.core import runner as runner_module

    scene = make_scene(
        chain={"grains": 30, "l0": 1e-4},
        excitation={"impact": 1e-2},
        integrator={"method": "gear4", "dt": 1e-3, "duration": 0.05},
        record={"every": 0.01, "fields": ["u", "v"], "traces": [0, 29], "trace_every": 0.002},
    )
    model = build_model([scene, scene], device)
    runs, mapped_at_first_unpack = [], []

    def first_unpack(recorder, r):
        if r == 0:
            mapped_at_first_unpack.append(recorder._mapping.blocks_done if recorder._mapping else None)

    for background in (False, True):
        if background:
            slow = recorder_module._map_block
            monkeypatch.setattr(
                recorder_module,
                "_map_block",
                lambda arrays, block: (time.sleep(0.6 / recorder_module.MAP_BLOCKS), slow(arrays, block)),
            )
        rec = Recorder(model, map_in_background=background, on_unpacked=first_unpack)
        monkeypatch.setattr(runner_module, "Recorder", lambda m, **kw: rec)
        runs.append(runner_module.Runner(model).run())
    recorder_module._MAPPER.submit(lambda: None).result()  # any mapping still running has finished
    assert mapped_at_first_unpack[0] is None
    assert 0 < mapped_at_first_unpack[1] < recorder_module.MAP_BLOCKS
    assert np.max(np.abs(runs[0].fields["v"][:, -1])) > 1e-4  # the records hold motion
    for name in ("u", "v"):
        np.testing.assert_array_equal(runs[1].fields[name], runs[0].fields[name])
        np.testing.assert_array_equal(runs[1].traces[name], runs[0].traces[name])


def test_a_failed_page_mapping_is_raised_at_the_unpack_that_waits_for_it(monkeypatch):
    """The background mapping of the host arrays fails part-way: an unpack waiting for a block it never mapped raises
    the mapping's error instead of waiting for ever."""
    import threading
    import time

    from hertzian.core import recorder as recorder_module

    release = threading.Event()

    def fail_at_block_3(arrays, block):
        if block == 3:
            release.wait()  # fail once the unpack below is waiting
            raise MemoryError("no pages left")

    monkeypatch.setattr(recorder_module, "_map_block", fail_at_block_3)
    mapping = recorder_module.PageMapping([np.empty((2, recorder_module.MAP_BLOCKS, 4))])
    raised = []

    def unpack():
        try:
            mapping.wait_for([10])  # block 9: never mapped
        except MemoryError as err:
            raised.append(err)

    waiter = threading.Thread(target=unpack, daemon=True)
    waiter.start()
    time.sleep(0.2)
    release.set()
    waiter.join(timeout=10)
    assert not waiter.is_alive(), "the unpack waits for ever"
    assert len(raised) == 1 and "no pages left" in str(raised[0])
