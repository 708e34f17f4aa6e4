"""Inputs shipped with the package: the example scenes (``hertzian.examples``) and sweep files (``hertzian.sweeps``).

A name that is not an existing path is looked up among them, so ``hertzian sweep example.toml`` works anywhere, and
so does the repository's own path of a shipped sweep (``sweeps/example.toml``, as the README writes it).
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path

SHIPPED = ("hertzian.sweeps", "hertzian.examples")
"""Packages whose TOML files are found by bare name, in this order."""
REPOSITORY_FOLDERS = {Path("sweeps"): "hertzian.sweeps"}
"""The repository's folders of shipped files, by their path relative to its root: a missing ``sweeps/NAME`` is the
shipped sweep NAME."""


def example_path(name: str = "impact") -> Path:
    """A built-in example scene shipped with the package."""
    return Path(str(resources.files("hertzian.examples") / f"{name}.toml"))


def shipped_file(path: str | Path) -> Path:
    """``path`` itself if it exists or names a folder, else the shipped sweep or example scene of that name
    (``.toml`` optional; ``sweeps/NAME``: the shipped sweep); a name found nowhere comes back unchanged (its reader
    then says it does not exist)."""
    path = Path(path)
    if path.exists() or path.parent not in (Path("."), *REPOSITORY_FOLDERS):
        return path
    for package in SHIPPED if path.parent == Path(".") else [REPOSITORY_FOLDERS[path.parent]]:
        for name in (path.name, f"{path.name}.toml"):
            candidate = Path(str(resources.files(package) / name))
            if candidate.is_file():
                return candidate
    return path


def shipped_names() -> list[str]:
    """File names of every shipped sweep and example scene."""
    return sorted(p.name for package in SHIPPED for p in resources.files(package).iterdir() if p.name.endswith(".toml"))
