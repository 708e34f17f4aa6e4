"""The comparison of two measurement records (``python -m hertzian.studies.events_effect``): every shared number is
paired by its path, and the largest change and each group's median are what the numbers give."""

import pytest
from hertzian.studies.events_effect import compare, numbers, relative_change


def group(measurements, energy=1e-8, seconds=1.0):
    return {"measurements": measurements, "energy_error_max": energy, "wall_seconds": seconds}


def test_numbers_are_paired_by_path_and_booleans_and_text_are_left_out():
    found = numbers({"echo": {"sign": "+", "ok": True, "amplitude": 2.0, "lobes": [1, 3.5, float("nan")]}})
    assert found == {"/echo/amplitude": 2.0, "/echo/lobes[0]": 1.0, "/echo/lobes[1]": 3.5}


def test_the_largest_change_and_the_medians():
    plain = {
        "groups": {
            "fig1": group({"c": 1.0, "w": [2.0, 4.0], "gone": 9.0}),
            "fig2": group({"c": 0.0}),
            "fig3": group({}),
        }
    }
    auto = {
        "groups": {
            "fig1": group({"c": 1.0, "w": [2.0, 5.0], "new": 7.0}, energy=1e-9, seconds=3.0),
            "fig2": group({"c": 0.0}),
        }
    }
    result = compare(plain, auto)
    assert result["numbers"] == 4 and set(result["groups"]) == {"fig1", "fig2"}
    assert result["largest_change"] == pytest.approx(0.2) and result["largest_at"] == "fig1/w[1]"
    fig1 = result["groups"]["fig1"]
    assert fig1["median_change"] == 0.0 and fig1["largest_change"] == pytest.approx(0.2)
    assert fig1["energy_error_max"] == {"off": 1e-8, "auto": 1e-9} and fig1["wall_seconds"] == {"off": 1.0, "auto": 3.0}
    assert relative_change(0.0, 0.0) == 0.0 and relative_change(-1.0, 1.0) == 2.0
