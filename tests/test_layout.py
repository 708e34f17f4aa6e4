"""The repository's layout promises: CLI command modules import no other command module (no circle),
and nothing in the code, README or docs points outside the repository (raw logs excepted)."""

from __future__ import annotations

import ast
import re
import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_cli_command_modules_import_only_the_app():
    package = ROOT / "ensemble" / "cli"
    commands = {p.stem for p in package.glob("*.py")} - {"__init__", "__main__", "app"}
    assert {"run", "plot", "sweep"} <= commands
    for path in package.glob("*.py"):
        if path.stem in ("__init__", "__main__"):
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and node.level == 1:
                assert node.module == "app", f"{path.name} imports .{node.module}"
                assert path.stem != "app", "app.py imports a command module"


def test_repository_refers_to_nothing_outside_itself():
    files = subprocess.run(["git", "ls-files"], cwd=ROOT, capture_output=True, text=True, check=True).stdout.split()
    pattern = re.compile(r"\.\./shared|/tmp/|/work/|/home/|/root/")
    offenders = []
    for name in files:
        if not name.endswith((".py", ".md", ".toml", ".txt", ".yml", ".yaml")) or name == "tests/test_layout.py":
            continue
        if name.startswith(("docs/gpu_logs/", "docs/logs/")) and not name.endswith((".md", ".py")):
            continue  # raw logs keep the commands exactly as they were typed
        for number, line in enumerate((ROOT / name).read_text(errors="replace").splitlines(), 1):
            if pattern.search(line):
                offenders.append(f"{name}:{number}: {line.strip()[:100]}")
    assert not offenders, "\n".join(offenders)
