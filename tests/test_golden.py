"""Bitwise regression: every solver kind and feature against outputs stored before the solver refactor.

The cases and the stored arrays are in tests/golden/ (``make_golden.py`` says how the file was made).
A change that alters any bit of u, v, energy, work, traces, status, largest overlap or energy error
in any case fails here; a change meant to alter results must regenerate the file and say so.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).with_name("golden")))
from make_golden import CASES, GOLDEN, arrays_of, run_case  # noqa: E402

STORED = np.load(GOLDEN)


@pytest.mark.parametrize("name", list(CASES))
def test_golden_case_is_bitwise_unchanged(name):
    got = arrays_of(run_case(CASES[name]))
    want = {key.split("/", 1)[1]: STORED[key] for key in STORED.files if key.split("/", 1)[0] == name}
    assert sorted(got) == sorted(want)
    assert np.max(np.abs(np.nan_to_num(want["u"]))) > 0  # something moved
    for key, value in want.items():
        np.testing.assert_array_equal(got[key], value, err_msg=f"{name}/{key}")
        assert got[key].dtype == value.dtype, f"{name}/{key}"
