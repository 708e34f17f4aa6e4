"""Shared fixtures: a ``device`` fixture (CPU always, CUDA when present) and scene builders."""

from __future__ import annotations

import pytest
import warp as wp
from hertzian.core.scene import scene_from_dict

wp.config.log_level = wp.LOG_WARNING
wp.init()

DEVICES = ["cpu"] + (["cuda:0"] if wp.is_cuda_available() else [])


@pytest.fixture(params=DEVICES)
def device(request):
    """Every test that takes ``device`` runs on the CPU, and on CUDA when there is one."""
    return request.param


def make_scene(**sections):
    """A small scene from keyword sections, e.g. make_scene(chain={"grains": 20}, integrator={...})."""
    data = {k: v for k, v in sections.items()}
    data.setdefault("integrator", {}).setdefault("duration", 0.01)
    return scene_from_dict(data)
