"""Generated kernel source, for the tests that check what a kernel leaves out: the C++ Warp generates for a
kernel, the arrays it touches, a ``@wp.func``'s body and its call sites."""

from __future__ import annotations

import re

from warp._src.context import ModuleBuilder


def generated_source(kernel, device="cpu", *, block_dim: int | None = None) -> str:
    """The C++ Warp generated for a kernel's module (from the kernel cache).

    ``block_dim``: the launch's threads per block, for tile kernels (their shared tiles are sized by it)."""
    options = dict(kernel.module.options)
    if block_dim is not None:
        options["block_dim"] = block_dim
    builder = ModuleBuilder(kernel.module, options, target=device)
    return builder.codegen(device)


def accessed_arrays(source: str) -> set[str]:
    """Kernel parameters whose elements the generated code reads or writes."""
    return set(re.findall(r"wp::\w+\(var_(\w+),", source))


def function_body(source: str, name: str) -> str:
    """The generated forward definition of the ``@wp.func`` called ``name`` (Warp's mangled
    ``…__locals__<name>_<n>``), from its signature to its closing brace at column 0."""
    match = re.search(rf"^static [^\n]*__locals__{name}_\d+\($", source, re.MULTILINE)
    if match is None:
        raise LookupError(f"no generated function {name!r}")
    end = source.index("\n}", match.end())
    return source[match.start() : end + 2]


def call_count(source: str, name: str) -> int:
    """Call sites of the ``@wp.func`` called ``name`` in a piece of generated source."""
    return len(re.findall(rf"(?:= |^\s+)[\w]*__locals__{name}_\d+\(", source, re.MULTILINE))
