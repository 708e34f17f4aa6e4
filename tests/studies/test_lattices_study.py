"""The β-FPUT study's reductions (hertzian.studies.lattices) on inputs whose answers are known."""

import math

import numpy as np
import pytest
from hertzian.studies.lattices import EULER_GAMMA, equilibration_times, fit


def test_equilibration_time_is_the_first_record_at_the_threshold():
    """η = (S_eq − S)/(S_eq − S(0)) with S_eq = ln N − (1 − γ): a chain whose entropy climbs linearly to S_eq at
    t = 10.5 has η = 1 − t/10.5, at most 0.1 from t = 9.45: at the record t = 9.5; one that stays at S(0) never
    gets there."""
    modes = 32
    equilibrium = math.log(modes) - (1.0 - EULER_GAMMA)
    t = np.arange(0.0, 20.0, 0.5)
    climbing = np.minimum(t / 10.5, 1.0) * equilibrium
    times = equilibration_times(t, np.stack([climbing, np.zeros_like(t)]), modes, 0.1)
    assert times[0] == 9.5 and np.isnan(times[1])


def test_fit_recovers_a_power_law():
    points = [{"density": d, "mean": 7.0 * d**-3.0, "standard_error": 0.02 * 7.0 * d**-3.0} for d in (0.02, 0.05, 0.1)]
    result = fit(points)
    assert result["exponent"] == pytest.approx(-3.0, abs=1e-12)
    assert result["prefactor"] == pytest.approx(7.0, rel=1e-10)
    assert result["exponent_error"] > 0
