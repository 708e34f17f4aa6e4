"""A one-line CPU kernel compiled only to build Warp's precompiled header ahead of the kernels a run needs.

Warp's clang builds a precompiled header of Warp's native headers on a process's first CPU compile (about 1 s on a
2-core machine). ``hertzian.core.devices`` compiles this kernel in a background thread as soon as Warp starts on a
machine whose kernel cache has no header yet, so that the header is built while the process loads its scene and
generates its kernels' source. Its module options are the package's (``KERNEL_OPTIONS``), so the header it leaves
is the one every other CPU module compiles against.
"""

import warp as wp
from hertzian.kernels.features import KERNEL_OPTIONS


@wp.kernel(module="unique", module_options=KERNEL_OPTIONS, enable_backward=False)
def header_primer(values: wp.array(dtype=wp.float64)):
    values[wp.tid()] = values[wp.tid()] + wp.float64(1.0)
