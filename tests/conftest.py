"""The ``device`` fixture: CPU always, CUDA when present (shared helpers are in ``tests.helpers``)."""

from __future__ import annotations

import os
from importlib.util import find_spec

import pytest

from tests.helpers import DEVICES

# Modules that need a test-only package (the `test` extra installs them). A GPU host set up by hand may lack it; none
# of these modules has a CUDA test, so there they are left out of the collection instead of failing it.
NEEDS = {
    "cli/test_refusals.py": "hypothesis",
    "sweeping/test_vectorised_expansion.py": "hypothesis",
    "sweeping/test_cluster_security.py": "psutil",
}
collect_ignore = [module for module, package in NEEDS.items() if find_spec(package) is None]

# An installed package carries the default family prebuilt for this CPU (hertzian/_install.py). Tests that look at
# compiling must see it happen, so no prebuilt folder is read unless a test names one.
os.environ["HERTZIAN_PREBUILT"] = "off"


@pytest.fixture(params=DEVICES)
def device(request):
    """Every test that takes ``device`` runs on the CPU, and on CUDA when there is one."""
    return request.param
