"""Numbers the physics tests derive from runs."""

from __future__ import annotations

import numpy as np


def slope(dts, errors) -> float:
    """Order of accuracy: the least-squares slope of log(error) against log(dt)."""
    return float(np.polyfit(np.log(dts), np.log(errors), 1)[0])
