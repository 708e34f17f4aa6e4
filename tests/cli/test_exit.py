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


RUN_MARKED = """
import os, sys

from hertzian.cli import main

real_exit = os._exit


def marked(code):
    sys.stderr.write("quick exit\\n")
    sys.stderr.flush()
    real_exit(code)


os._exit = marked
sys.argv = ["hertzian", "run", "--device", "cpu", "--set", "integrator.duration=0.2", "--out", sys.argv[1]]
main()
"""


def test_a_run_on_the_cpu_chain_kernel_takes_the_quick_exit(tmp_path):
    """The CPU chain kernel's thread pool (one chain cut over the cores) is stopped when the command returns, so the
    process ends without the interpreter's teardown (about 0.15 s of the README command's 1.5 s on 2 cores)."""
    out = tmp_path / "impact.zarr"
    done = subprocess.run([sys.executable, "-c", RUN_MARKED, str(out)], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert out.is_dir()
    assert "quick exit" in done.stderr, done.stderr
