"""The command line from tests: in-process (``invoke``, ``sweep_cli``) or as the installed entry point in a
subprocess (``hertzian``), a small TOML writer, and the check that a refusal is one line, exit code 2 and
nothing written."""

from __future__ import annotations

import json
import math
import subprocess
import sys
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


def invoke(*args, **options):
    """``hertzian ARGS`` in this process (arguments may be paths or numbers); ``options`` go to CliRunner.invoke."""
    return CliRunner().invoke(app, [str(a) for a in args], **options)


def sweep_cli(*args):
    """``hertzian sweep ARGS`` in this process."""
    return invoke("sweep", *args)


HERTZIAN = (sys.executable, "-c", "from hertzian.cli import main; main()")
"""The ``hertzian`` script's entry point as a command line for a subprocess."""


def hertzian(*args, cwd=None, env=None) -> subprocess.CompletedProcess:
    """``hertzian ARGS`` in a subprocess (its own interpreter: exit codes, stderr and environment as a user sees
    them); output captured as text."""
    return subprocess.run([*HERTZIAN, *map(str, args)], capture_output=True, text=True, cwd=cwd, env=env)


def assert_refused(result, out: Path, key: str | None = None) -> None:
    """An in-process refusal: exit code 2, one line ``error: KEY…`` and no traceback, ``out`` not written."""
    text = (result.stdout + result.stderr).strip()
    assert result.exit_code == 2, (result.exit_code, text, result.exception)
    assert result.exception is None or isinstance(result.exception, SystemExit), result.exception
    assert "Traceback" not in text
    assert len(text.splitlines()) == 1, text
    assert text.startswith("error: " + (key or "")), text
    assert not out.exists()
