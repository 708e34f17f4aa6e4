"""The ``device`` fixture: CPU always, CUDA when present (shared helpers are in ``tests.helpers``)."""

from __future__ import annotations

import os

import pytest

from tests.helpers import DEVICES

# An installed package carries the default family prebuilt for this CPU (hertzian/_install.py). Tests that look at
# compiling must see it happen, so no prebuilt folder is read unless a test names one.
os.environ["HERTZIAN_PREBUILT"] = "off"


@pytest.fixture(params=DEVICES)
def device(request):
    """Every test that takes ``device`` runs on the CPU, and on CUDA when there is one."""
    return request.param
