"""Helpers of the CLI refusal tests (test_refusals.py, test_drive.py): a small TOML writer, the CLI
in-process, and the check that a refusal is one line, exit code 2 and nothing written.

A plain module next to the tests (imported as ``cli_cases``), so no test imports another test file.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

from hertzian.cli import app
from typer.testing import CliRunner


def toml_value(value) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return "nan" if math.isnan(value) else ("inf" if value > 0 else "-inf") if math.isinf(value) else repr(value)
    if isinstance(value, int):
        return str(value)
    if isinstance(value, str):
        return json.dumps(value, ensure_ascii=False)  # JSON's escapes are TOML's
    if isinstance(value, list):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k} = {toml_value(v)}" for k, v in value.items()) + "}"
    raise TypeError(value)


def toml_text(data: dict, *, prefix: str = "") -> str:
    """A small TOML writer (tables, arrays of tables, inline values) for the generated files."""
    lines, tables = [], []
    for key, value in data.items():
        if isinstance(value, dict):
            tables.append((key, value))
        elif isinstance(value, list) and value and all(isinstance(v, dict) for v in value):
            for item in value:
                lines.append(f"\n[[{prefix}{key}]]\n" + toml_text(item))
        else:
            lines.insert(0, f"{key} = {toml_value(value)}")
    for key, value in tables:
        lines.append(f"\n[{prefix}{key}]\n" + toml_text(value, prefix=f"{prefix}{key}."))
    return "\n".join(lines) + "\n"


def invoke(*args):
    return CliRunner().invoke(app, [str(a) for a in args])


def assert_refused(result, out: Path, key: str | None = None) -> None:
    text = (result.stdout + result.stderr).strip()
    assert result.exit_code == 2, (result.exit_code, text, result.exception)
    assert result.exception is None or isinstance(result.exception, SystemExit), result.exception
    assert "Traceback" not in text
    assert len(text.splitlines()) == 1, text
    assert text.startswith("error: " + (key or "")), text
    assert not out.exists()
