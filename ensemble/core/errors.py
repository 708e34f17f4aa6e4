"""The errors bad input raises: one line naming the key, the value and what is allowed.

:class:`SceneError` is a bad scene value (``chain.l0 = -1.0: must be ≥ 0``; re-exported by
:mod:`hertzian.core.scene`); :class:`OptionError` a bad keyword argument of the Python API, which the command line
prints with the option spelled as a flag (``batch_size`` → ``--batch-size``); :class:`RefusedError` a request
refused as a whole.
"""

from __future__ import annotations

from typing import Any


class SceneError(ValueError):
    """Invalid scene input: names the key, the value given and what is allowed."""

    def __init__(self, key: str, value: Any, allowed: str):
        self.key, self.value, self.allowed = key, value, allowed
        super().__init__(f"{key} = {value!r}: {allowed}")


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


def check_path(key: str, value: Any, *, optional: bool = False) -> None:
    """Refuse (:class:`OptionError`) a path argument that is not a ``str`` or ``os.PathLike`` (or None, when
    ``optional``)."""
    import os

    if isinstance(value, (str, os.PathLike)) or (optional and value is None):
        return
    raise OptionError(key, type(value).__name__, "a path (a str or a pathlib.Path)")
