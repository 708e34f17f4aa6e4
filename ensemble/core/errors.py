"""The error a bad option of the Python API raises: one line naming the option, the value and what is allowed.

The command line prints the same line with the option spelled as a flag (``batch_size`` → ``--batch-size``).
Scene keys raise :class:`hertzian.core.scene.SceneError` instead (``chain.l0 = -1.0: must be ≥ 0``).
"""

from __future__ import annotations

from typing import Any


class OptionError(ValueError):
    """A bad keyword argument (``device``, ``batch_size``, ``out``, …): ``key = value: allowed``, one line."""

    def __init__(self, key: str, value: Any, allowed: str):
        self.key, self.value, self.allowed = key, value, allowed
        super().__init__(f"{key} = {value!r}: {allowed}")

    def cli_message(self) -> str:
        """The same line with the key as its command-line flag."""
        return f"--{self.key.replace('_', '-')} = {self.value!r}: {self.allowed}"


class RefusedError(ValueError):
    """A request refused as a whole (more memory than there is, a dt unstable under ``strict``): one line, which
    already names the key, the value and the limit."""
