"""Fixtures of the resume and store-safety tests: RESUME_SWEEP's file and its store run undisturbed, once per session
(tests read the reference store, and copy it before they change anything)."""

import pytest

from tests.helpers import RESUME_FLAGS, RESUME_SWEEP, sweep_cli


@pytest.fixture(scope="session")
def sweep_file(tmp_path_factory):
    """RESUME_SWEEP written to a file of its own."""
    path = tmp_path_factory.mktemp("sweep") / "sweep.toml"
    path.write_text(RESUME_SWEEP)
    return path


@pytest.fixture(scope="session")
def reference(sweep_file):
    """The sweep in batches of one point (RESUME_FLAGS), undisturbed."""
    out = sweep_file.parent / "reference.zarr"
    result = sweep_cli(sweep_file, "--out", out, *RESUME_FLAGS)
    assert result.exit_code == 0, result.stderr
    return out
