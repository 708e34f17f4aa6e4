"""Helpers of the lean-kernel tests (test_core.py, test_drive.py): the C++ Warp generates for a kernel and
the arrays it touches. A plain module next to the tests (imported as ``kernel_source``).
"""

from __future__ import annotations


def generated_source(kernel, device="cpu") -> str:
    """The C++ Warp generated for a kernel's module (from the kernel cache)."""
    from warp._src.context import ModuleBuilder

    builder = ModuleBuilder(kernel.module, kernel.module.options, target=device)
    return builder.codegen(device)


def accessed_arrays(source: str) -> set[str]:
    """Kernel parameters whose elements the generated code reads or writes."""
    import re

    return set(re.findall(r"wp::\w+\(var_(\w+),", source))
