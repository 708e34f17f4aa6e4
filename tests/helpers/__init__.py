"""What the tests share, imported one way: ``from tests.helpers import invoke, make_scene, slope``.

* ``cli``: the command line in-process (``invoke``, ``sweep_cli``) or in a subprocess (``hertzian``), a TOML
  writer and the one-line refusal check;
* ``scenes``: ``DEVICES`` and ``make_scene``;
* ``numerics``: ``slope`` (order of accuracy);
* ``fused``: the fused kernels against the per-step kernel (cases, states after n steps, agreement checks);
* ``source``: the C++ Warp generates for a kernel, for the tests of what a kernel leaves out;
* ``sweeps``: sweep files shared by the sweeping tests.
"""

from tests.helpers.cli import HERTZIAN, assert_refused, hertzian, invoke, sweep_cli, toml_text, toml_value
from tests.helpers.fused import (
    CASES,
    COMPOSED_CASES,
    CUDA_ROUNDING,
    CUDA_ROUNDING_FLOAT32,
    MOVED,
    assert_every_window_moved,
    assert_kernels_agree,
    bitwise,
    chains,
    fused,
    per_step,
    sweep,
    window_ranges,
)
from tests.helpers.numerics import slope
from tests.helpers.scenes import DEVICES, make_scene
from tests.helpers.source import accessed_arrays, call_count, function_body, generated_source
from tests.helpers.sweeps import GRID_SWEEP, RESUME_BATCHES, RESUME_FLAGS, RESUME_SWEEP, SWEEPS, run_store, write_sweep

__all__ = [
    "CASES",
    "COMPOSED_CASES",
    "CUDA_ROUNDING",
    "CUDA_ROUNDING_FLOAT32",
    "DEVICES",
    "GRID_SWEEP",
    "HERTZIAN",
    "MOVED",
    "RESUME_BATCHES",
    "RESUME_FLAGS",
    "RESUME_SWEEP",
    "SWEEPS",
    "accessed_arrays",
    "assert_every_window_moved",
    "assert_kernels_agree",
    "assert_refused",
    "bitwise",
    "call_count",
    "chains",
    "fused",
    "function_body",
    "generated_source",
    "hertzian",
    "invoke",
    "make_scene",
    "per_step",
    "run_store",
    "slope",
    "sweep",
    "sweep_cli",
    "toml_text",
    "toml_value",
    "window_ranges",
    "write_sweep",
]
