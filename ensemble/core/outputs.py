"""Files hertzian writes beside its stores, figures (PNG) and JSON records, and whether a file at a path may be
replaced: only one that hertzian wrote, as for stores (hertzian.sweeping.storage.check_replaceable).

A PNG that hertzian writes carries the text chunk ``Software = "hertzian <version>"``; a JSON record names the
command that wrote it (``"command": "hertzian …"``)."""

from __future__ import annotations

import json
import re
import struct
from pathlib import Path

from hertzian._version import __version__

SOFTWARE = f"hertzian {__version__}"
PNG_METADATA = {"Software": SOFTWARE}
"""``metadata`` of every ``savefig`` (matplotlib writes it as a PNG text chunk)."""

_PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def png_software(path: str | Path) -> str | None:
    """The ``Software`` text chunk of the PNG at ``path`` (read up to its image data), or None."""
    with open(path, "rb") as file:
        if file.read(8) != _PNG_SIGNATURE:
            return None
        while header := file.read(8):
            if len(header) < 8:
                return None
            length, kind = struct.unpack(">I4s", header)
            if kind == b"IDAT":
                return None
            data = file.read(length)
            file.read(4)  # the chunk's CRC
            if kind == b"tEXt" and b"\0" in data:
                key, value = data.split(b"\0", 1)
                if key == b"Software":
                    return value.decode("latin-1")
    return None


def written_by_hertzian(path: str | Path) -> bool:
    """Whether the file at ``path`` is a figure or JSON record that hertzian wrote."""
    suffix = Path(path).suffix.lower()
    if suffix == ".png":
        return (png_software(path) or "").startswith("hertzian")
    if suffix == ".json":
        return all(_HERTZIAN_COMMAND.match(command) for command in json_commands(path) or [""])
    return False


_HERTZIAN_COMMAND = re.compile(r"^(\w+=\S*\s+)*(hertzian\s|python3?\s+-m\s+hertzian[.\s])")
"""A command of this project's: ``hertzian …`` or ``python -m hertzian.…``, after any environment settings."""


def json_commands(path: str | Path) -> list[str]:
    """Every ``command`` string of the JSON record at ``path``, at any depth: its own, its parts', its runs' or its
    items' (a record whose parts were each written by one command)."""
    try:
        data = json.loads(Path(path).read_text())
    except (OSError, ValueError):
        return []
    found: list[str] = []
    pending = [data]
    while pending and len(found) < 1000:
        value = pending.pop()
        if isinstance(value, dict):
            command = value.get("command")
            if isinstance(command, str):
                found.append(command)
            pending.extend(v for k, v in value.items() if k != "command" and isinstance(v, (dict, list)))
        elif isinstance(value, list):
            pending.extend(v for v in value if isinstance(v, (dict, list)))
    return found


def why_not_writable(path: str | Path) -> str | None:
    """:func:`why_not_replaceable`, or a missing folder: why a record may not be written at ``path``; None if it may."""
    return why_not_replaceable(path) or (None if Path(path).parent.is_dir() else "its folder does not exist")


def exit_unless_replaceable(path: str | Path, option: str) -> None:
    """For a ``python -m hertzian.studies…`` writer: print one line and exit 2 when ``path`` may not be written
    (:func:`why_not_writable`)."""
    import sys

    why = why_not_writable(path)
    if why:
        print(f"error: {option} = {str(path)!r}: {why}", file=sys.stderr)
        sys.exit(2)


def provenance(device: str) -> dict:
    """Where and when a measurement ran: the date (UTC), the device and its name, the CPU count, the platform and
    Warp's version."""
    import os
    import platform
    from datetime import datetime, timezone

    import warp as wp

    return {
        "date": datetime.now(timezone.utc).isoformat(timespec="seconds"),
        "device": device,
        "device_name": wp.get_device(device).name,
        "cpu_count": os.cpu_count(),
        "platform": platform.platform(),
        "warp_version": wp.config.version,
    }


def _update_record(path: Path, change) -> None:
    record = json.loads(path.read_text()) if path.exists() else {}
    change(record.setdefault("parts", {}))
    path.write_text(json.dumps(record, indent=1, default=float) + "\n")


def write_part(path: str | Path, part: str, value: dict) -> None:
    """Put ``value`` under ``parts.<part>`` of the JSON record at ``path`` (created if missing; other parts kept)."""
    _update_record(Path(path), lambda parts: parts.__setitem__(part, value))


def add_run(path: str | Path, part: str, run: dict) -> None:
    """Append ``run`` (its command, date, device and records) to ``parts.<part>.runs`` of the JSON record at
    ``path``, created if missing; the record's other parts and runs are kept."""
    _update_record(Path(path), lambda parts: parts.setdefault(part, {}).setdefault("runs", []).append(run))


def why_not_replaceable(path: str | Path) -> str | None:
    """Why hertzian may not write a file at ``path``: a file there that it did not write, a folder or a link; None
    when nothing is there or the file is hertzian's own."""
    path = Path(path)
    if not (path.exists() or path.is_symlink()):
        return None
    if path.is_symlink() or not path.is_file():
        return "exists and is not a file hertzian wrote; choose another path"
    if written_by_hertzian(path):
        return None
    return "exists and hertzian did not write it; choose another path, or delete it yourself if you mean to"
