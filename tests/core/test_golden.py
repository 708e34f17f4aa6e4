"""Bitwise regression: every solver kind and feature against outputs stored before the solver refactor.

The cases and the stored arrays are in tests/golden/ (``make_golden.py`` says how the file was made).
A change that alters any bit of u, v, energy, work, traces, status, largest overlap or energy error
in any case fails here; a change meant to alter results must regenerate the file and say so.

The kernels are bitwise deterministic, but part of a run's start is computed on the host with NumPy
(static overlaps ``F^(1/(n-1))``, the Taylor start's ``δ0^(n-1)``), and NumPy evaluates float64 powers with
AVX-512 SIMD code where the CPU has it: that code differs from the C library's ``pow`` in the last bit of
a few per cent of the values. The stored file was made with the C library's ``pow``. On a machine whose
NumPy powers differ from ``math.pow`` the cases are therefore rerun in a subprocess with NumPy's AVX-512
dispatch switched off (``NPY_DISABLE_CPU_FEATURES``), so the comparison stays bit for bit on any CPU.
"""

from __future__ import annotations

import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from tests.golden.make_golden import CASES, GOLDEN, arrays_of, run_case

ROOT = Path(__file__).resolve().parents[2]
"""The repository root: ``tests.golden.make_golden`` imports from there, in this process and in the subprocesses."""

STORED = np.load(GOLDEN)


def numpy_power_is_libm() -> bool:
    """Whether this process's NumPy float64 power gives the C library's bits on a probe of 4096 values."""
    probe = np.linspace(1e-9, 3.0, 4096)
    return all(
        np.power(probe, p).tolist() == [math.pow(x, p) for x in probe.tolist()] for p in (1.5, 2.0 / 3.0, 2.5, 0.4)
    )


def simd_features_to_disable() -> str:
    """The AVX-512 features NumPy dispatches to on this CPU (names for ``NPY_DISABLE_CPU_FEATURES``)."""
    from numpy._core._multiarray_umath import __cpu_dispatch__, __cpu_features__

    return " ".join(
        name
        for name in __cpu_dispatch__
        if __cpu_features__.get(name) and (name.startswith("AVX512") or name == "X86_V4")
    )


@pytest.fixture(scope="module")
def computed(tmp_path_factory):
    """name → arrays of every golden case, computed here, or in a subprocess when NumPy's power is not libm's."""
    if numpy_power_is_libm():
        return None
    out = tmp_path_factory.mktemp("golden") / "golden_here.npz"
    env = dict(os.environ, NPY_DISABLE_CPU_FEATURES=simd_features_to_disable())
    code = (
        "import sys, numpy as np; sys.path.insert(0, sys.argv[1]); "
        "from tests.golden.make_golden import CASES, arrays_of, run_case; "
        "np.savez(sys.argv[2], **{f'{n}/{k}': v for n, c in CASES.items() for k, v in arrays_of(run_case(c)).items()})"
    )
    subprocess.run([sys.executable, "-c", code, str(ROOT), str(out)], env=env, check=True, timeout=600)
    here = np.load(out)
    return {
        name: {key.split("/", 1)[1]: here[key] for key in here.files if key.split("/", 1)[0] == name} for name in CASES
    }


@pytest.mark.parametrize("name", list(CASES))
def test_golden_case_is_bitwise_unchanged(name, computed):
    got = arrays_of(run_case(CASES[name])) if computed is None else computed[name]
    want = {key.split("/", 1)[1]: STORED[key] for key in STORED.files if key.split("/", 1)[0] == name}
    assert sorted(got) == sorted(want)
    assert np.max(np.abs(np.nan_to_num(want["u"]))) > 0  # something moved
    for key, value in want.items():
        np.testing.assert_array_equal(got[key], value, err_msg=f"{name}/{key}")
        assert got[key].dtype == value.dtype, f"{name}/{key}"


def test_power_probe_tells_the_simd_power_apart():
    """The probe above is what decides where the golden cases run: with AVX-512 dispatch switched off NumPy's
    power must be libm's (otherwise the subprocess would not help)."""
    env = dict(os.environ, NPY_DISABLE_CPU_FEATURES=simd_features_to_disable())
    code = (
        f"import sys; sys.path.insert(0, {str(ROOT)!r}); import tests.core.test_golden as t; "
        "sys.exit(0 if t.numpy_power_is_libm() else 1)"
    )
    if simd_features_to_disable():
        subprocess.run([sys.executable, "-c", code], env=env, check=True, timeout=300)
    else:
        assert numpy_power_is_libm()
