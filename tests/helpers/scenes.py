"""Scenes and devices for tests."""

from __future__ import annotations

import warp as wp
from hertzian.core.scene import scene_from_dict

wp.config.log_level = wp.LOG_WARNING
wp.init()

DEVICES = ["cpu"] + (["cuda:0"] if wp.is_cuda_available() else [])
"""The devices every device test runs on: the CPU always, CUDA when there is one."""


def make_scene(**sections):
    """A small scene from keyword sections, e.g. make_scene(chain={"grains": 20}, integrator={...});
    ``integrator.duration`` defaults to 0.01."""
    data = {k: v for k, v in sections.items()}
    data.setdefault("integrator", {}).setdefault("duration", 0.01)
    return scene_from_dict(data)
