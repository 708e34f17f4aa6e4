"""A store's manifest: the SHA-256 of every metadata file (each ``zarr.json``, the root's with its attributes and
consolidated metadata among them) and of every file of the arrays a store holds from its creation on (coordinates
and ``launch_group``), the batches finished when it was written, and the store's identity (schema, sweep
fingerprint, package and Warp versions). The manifest carries the SHA-256 of its own content.

Chunks carry a CRC-32C each (``store_format``), but a deleted chunk reads back as fill values, and a flipped byte in
a ``zarr.json`` can change an attribute or a name unnoticed; the manifest closes both. It is written when the store
is created and each time its metadata is consolidated (``sweep_store.finalize``), never while batches run: batches
write chunks only, and which chunks a finished batch owns follows from the plan (``integrity``).
"""

from __future__ import annotations

import hashlib
import json
import os
from dataclasses import dataclass
from pathlib import Path

from hertzian.sweeping.storage import MANIFEST, PROJECT

FORMAT = 1
"""Version of the manifest's layout."""
FIXED_NAMES = ("t", "grain", "harmonic", "trace_t", "traced_grain", "mode", "mode_frequency", "launch_group")
"""Arrays written once, when the store is created (with every sweep axis's coordinate)."""
IDENTITY_KEYS = ("schema_version", "sweep_fingerprint", "sweep_block")
"""Root attributes the manifest keeps, so that a store whose root metadata is damaged can still be named."""


class ManifestError(ValueError):
    """The manifest is missing or damaged (one line)."""


@dataclass(frozen=True)
class Manifest:
    files: dict[str, str]
    """Relative path → SHA-256 of every metadata file and every file of the fixed arrays."""
    finished: frozenset[int]
    """Batches whose completion flag was set when the manifest was written."""
    identity: dict
    """The root attributes of :data:`IDENTITY_KEYS`, and the provenance's package and Warp versions."""


def digest(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def fixed_array_names(root_attrs: dict) -> list[str]:
    """Names of the arrays written at creation: every sweep axis's coordinate and :data:`FIXED_NAMES`."""
    return [*dict(root_attrs.get("sweep_axes", {})), *FIXED_NAMES]


def covered_files(path: Path, fixed: list[str]) -> list[str]:
    """Relative paths the manifest covers: every ``zarr.json`` and every file under a fixed array's folder."""
    files = {p.relative_to(path).as_posix() for p in path.rglob("zarr.json")}
    for name in fixed:
        folder = path / name
        if folder.is_dir():
            files |= {p.relative_to(path).as_posix() for p in folder.rglob("*") if p.is_file()}
    return sorted(f for f in files if not f.endswith(".partial"))


def _ranges(indices) -> list[list[int]]:
    out: list[list[int]] = []
    for i in sorted(indices):
        if out and out[-1][1] == i:
            out[-1][1] = i + 1
        else:
            out.append([i, i + 1])
    return out


def write_manifest(path: str | Path, finished=()) -> None:
    """Write the manifest of the store at ``path`` from its files as they are now (atomically: a temporary file
    renamed over the old one). ``finished``: the batches complete now."""
    path = Path(path)
    root = json.loads((path / "zarr.json").read_bytes())
    attrs = root.get("attributes", {})
    provenance = attrs.get("provenance", {})
    body = {
        "format": FORMAT,
        "project": PROJECT,
        "files": {rel: digest((path / rel).read_bytes()) for rel in covered_files(path, fixed_array_names(attrs))},
        "finished": _ranges(finished),
        "identity": {
            **{key: attrs.get(key) for key in IDENTITY_KEYS},
            "package_version": provenance.get("package_version"),
            "warp_version": provenance.get("warp_version"),
        },
    }
    text = json.dumps(body, sort_keys=True, separators=(",", ":"))
    tmp = path / f".{MANIFEST}.partial"
    tmp.write_text(json.dumps({"sha256": digest(text.encode()), "body": body}, indent=0, sort_keys=True))
    os.replace(tmp, path / MANIFEST)


def read_manifest(path: str | Path) -> Manifest:
    """The manifest of the store at ``path`` (:class:`ManifestError` if it is missing, unreadable or altered)."""
    file = Path(path) / MANIFEST
    try:
        data = json.loads(file.read_bytes())
        body, stored = data["body"], data["sha256"]
        text = json.dumps(body, sort_keys=True, separators=(",", ":"))
    except FileNotFoundError:
        raise ManifestError("missing") from None
    except (OSError, ValueError, KeyError, TypeError) as err:
        raise ManifestError(f"unreadable ({type(err).__name__})") from None
    if digest(text.encode()) != stored or body.get("format") != FORMAT or body.get("project") != PROJECT:
        raise ManifestError("altered: its content no longer matches its own checksum")
    finished = frozenset(i for start, stop in body["finished"] for i in range(start, stop))
    return Manifest(dict(body["files"]), finished, dict(body["identity"]))


def file_damage(path: str | Path, manifest: Manifest) -> list[tuple[str, str]]:
    """(relative path, reason) of every covered file that is missing, altered or not in the manifest."""
    path = Path(path)
    out = []
    for rel, expected in sorted(manifest.files.items()):
        try:
            actual = digest((path / rel).read_bytes())
        except FileNotFoundError:
            out.append((rel, "missing: a file the manifest lists"))
            continue
        except OSError as err:
            out.append((rel, f"unreadable ({os.strerror(err.errno) if err.errno else err})"))
            continue
        if actual != expected:
            out.append((rel, "altered: its SHA-256 differs from the manifest's"))
    root_attrs: dict = {}
    try:
        root_attrs = json.loads((path / "zarr.json").read_bytes()).get("attributes", {})
    except (OSError, ValueError, AttributeError):
        pass
    extra = set(covered_files(path, fixed_array_names(root_attrs) if isinstance(root_attrs, dict) else [])) - set(
        manifest.files
    )
    out += [(rel, "unexpected: a metadata or coordinate file the manifest does not list") for rel in sorted(extra)]
    return out


def is_project_store(path: str | Path) -> bool:
    """Whether the store at ``path`` says (in its root metadata or its manifest) that this project wrote it: then it
    must have a valid manifest."""
    path = Path(path)
    if (path / MANIFEST).exists():
        return True
    try:
        attrs = json.loads((path / "zarr.json").read_bytes()).get("attributes", {})
    except (OSError, ValueError, AttributeError):
        return False
    return isinstance(attrs, dict) and attrs.get("project") == PROJECT
