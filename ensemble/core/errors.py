"""The error every bad scene value raises (re-exported by :mod:`hertzian.core.scene`)."""

from __future__ import annotations

from typing import Any


class SceneError(ValueError):
    """Invalid scene input: names the key, the value given and what is allowed."""

    def __init__(self, key: str, value: Any, allowed: str):
        self.key, self.value, self.allowed = key, value, allowed
        super().__init__(f"{key} = {value!r}: {allowed}")
