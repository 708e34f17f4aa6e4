"""The Hertz law's validity limit is per contact, 0.1 of its smaller grain's diameter (a wall contact: the grain's
own): a chain of unequal grains is flagged (status OVERLAP_BEYOND_VALIDITY) when some contact's overlap exceeds its
own limit, and its largest overlap is reported as max_k δ_k · R0/min(R_i, R_j), compared with 0.1·diameter.

Overlaps and limits come from the NumPy reference (tests/reference.py), given the radii as a list."""

from __future__ import annotations

import numpy as np
import pytest
from hertzian.core.check import check_scene
from hertzian.core.model import build_model
from hertzian.core.runner import Runner
from hertzian.core.status import Status

from tests.helpers import make_scene
from tests.reference import contact_overlaps, reference_run, validity_limits

GRAINS = 12
R0 = 50.0
"""Half the default diameter (100)."""
UNIFORM_LIMIT = 0.1 * 2 * R0


def _scene(radii: np.ndarray, **sections):
    sections["chain"] = {"grains": GRAINS, "radii": radii.tolist(), **sections.get("chain", {})}
    sections["integrator"] = {"dt": 2e-4, "duration": 0.2, "events": "off"}
    sections["record"] = {"every": 0.01}
    return make_scene(**sections)


def _reference(scene):
    """(largest overlap over own limit, largest overlap times R0/min(R_i, R_j)) over the record times, the
    reference's, and every contact's largest overlap over its own limit."""
    data = scene.to_dict()
    overlaps = np.nan_to_num(contact_overlaps(data, reference_run(data)["u"]), nan=-np.inf)  # no wall: never
    limits = validity_limits(data)
    worst = np.max(overlaps / limits, axis=0)
    return np.max(worst), np.max(overlaps * (UNIFORM_LIMIT / limits)), worst


def _run(scene, kernel: str):
    return Runner(build_model([scene], "cpu"), kernel=kernel, use_graph=False).run()


def test_a_tapered_column_within_each_contacts_limit_is_not_flagged():
    """Grains growing downward (R_i = R0·1.05^i) under strong gravity: the bottom wall contact's overlap is beyond
    the smallest grain's limit (the per-chain rule would flag the chain) but within its own, as is every contact."""
    radii = R0 * 1.05 ** np.arange(GRAINS)
    scene = _scene(radii, chain={"gravity": 28500.0}, boundary={"surface": "free"}, excitation={"impact": 1e-2})
    ratio, scaled, worst = _reference(scene)
    overlaps = contact_overlaps(scene.to_dict(), np.zeros((1, GRAINS)))[0]
    assert np.nanmax(overlaps) > 0.1 * 2 * radii.min()  # beyond the smallest grain's limit
    assert 0.7 < ratio < 1.0  # every contact within its own, the bottom one nearest to it
    assert np.argmax(worst) == GRAINS
    result = _run(scene, "step")
    assert result.status[0] == Status.OK
    # positions agree with the reference to 1e-10 of the largest displacement (tests/core/test_radii.py)
    assert result.max_overlap[0] == pytest.approx(scaled, rel=1e-10)
    check = check_scene(scene)
    assert not check.beyond_validity and check.validity_contact == GRAINS
    assert check.validity_overlap == pytest.approx(0.1 * 2 * radii[-1], rel=1e-14)


@pytest.mark.parametrize("kernel", ["step", "tile", "chain"])
def test_one_small_grain_beyond_its_own_limit_flags_the_chain(kernel):
    """One grain of 0.3·R0 in a loaded chain of R0 grains: its two contacts' overlaps exceed 0.1 of its diameter,
    though no overlap reaches 0.1·diameter; every kernel flags the chain and reports the same largest overlap."""
    radii = np.full(GRAINS, R0)
    radii[6] = 0.3 * R0
    scene = _scene(radii, chain={"l0": 2.5}, boundary={"surface": "load"}, excitation={"impact": 1e-2})
    ratio, scaled, worst = _reference(scene)
    assert 1.0 < ratio < 1.2 and set(np.flatnonzero(worst > 1)) == {6, 7}
    data = scene.to_dict()
    assert np.nanmax(contact_overlaps(data, reference_run(data)["u"])) < UNIFORM_LIMIT
    result = _run(scene, kernel)
    assert result.status[0] == Status.OVERLAP_BEYOND_VALIDITY
    assert result.max_overlap[0] == pytest.approx(scaled, rel=1e-10)
    if kernel != "step":
        np.testing.assert_array_equal(result.max_overlap, _run(scene, "step").max_overlap)
    check = check_scene(scene)
    assert check.beyond_validity and check.validity_contact in (6, 7)
    assert check.validity_overlap == pytest.approx(0.1 * 2 * radii[6], rel=1e-14)
