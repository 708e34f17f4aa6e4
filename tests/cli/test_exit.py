"""The ``hertzian`` script ends its process without the interpreter's teardown: what a command printed (to a pipe,
block-buffered) still arrives, exit codes are the command's, and exit handlers run."""

from __future__ import annotations

import os
import subprocess
import sys

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


LEFT_POOL = """
import sys
from concurrent.futures import ThreadPoolExecutor

from hertzian.cli import app, main

pool = ThreadPoolExecutor(1)


@app.command("left-pool")
def left_pool():
    pool.submit(print, "worked")  # its worker thread idles after this, never shut down by the command


sys.argv = ["hertzian", "left-pool"]
main()
"""


def test_a_command_leaving_a_thread_pool_still_exits():
    """The interpreter's shutdown stops a pool's idle workers before joining them; the script must not wait on them."""
    done = subprocess.run([sys.executable, "-c", LEFT_POOL], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0 and done.stdout.strip() == "worked", done.stderr
