"""The ``device`` fixture: CPU always, CUDA when present (shared helpers are in ``tests.helpers``)."""

from __future__ import annotations

import pytest

from tests.helpers import DEVICES


@pytest.fixture(params=DEVICES)
def device(request):
    """Every test that takes ``device`` runs on the CPU, and on CUDA when there is one."""
    return request.param
