"""The ``hertzian`` script ends its process without the interpreter's teardown: what a command printed (to a pipe,
block-buffered) still arrives, exit codes are the command's, and exit handlers run."""

from __future__ import annotations

import os

from tests.helpers import hertzian


def test_piped_output_exit_codes_and_exit_handlers_survive(tmp_path):
    shown = hertzian("--help")
    assert shown.returncode == 0, shown.stderr
    assert "Commands" in shown.stdout and "warmup" in shown.stdout, shown.stdout
    refused = hertzian("run", "--set", "chain.grains=-1", "--out", tmp_path / "o.zarr")
    assert refused.returncode == 2 and refused.stderr.startswith("error: chain.grains = -1"), refused.stderr
    timeline = tmp_path / "t.json"  # written by an exit handler
    checked = hertzian("check", env={**os.environ, "HERTZIAN_TIMELINE": str(timeline)})
    assert checked.returncode == 0 and checked.stdout.strip(), checked.stderr
    assert timeline.is_file()
