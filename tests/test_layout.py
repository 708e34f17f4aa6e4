"""The repository's layout promises: CLI command modules import no other command module (no circle),
and nothing in the code, README or docs points outside the repository."""

from __future__ import annotations

import ast
import re
import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def cli_imports(path: Path) -> set[str]:
    """The modules of ``hertzian.cli`` that the file at ``path`` imports, by name (absolute or relative, at any
    depth of the file: lazy imports count)."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom):
            module = node.module or ""
            if node.level == 1:
                found.add(module or "?")
            elif module.startswith("hertzian.cli."):
                found.add(module.removeprefix("hertzian.cli.").split(".")[0])
            elif module == "hertzian.cli":
                found |= {alias.name for alias in node.names}
        elif isinstance(node, ast.Import):
            found |= {a.name.removeprefix("hertzian.cli.") for a in node.names if a.name.startswith("hertzian.cli.")}
    return found


def test_cli_command_modules_import_only_the_app():
    package = ROOT / "ensemble" / "cli"
    commands = {p.stem for p in package.glob("*.py")} - {"__init__", "__main__", "app"}
    assert {"run", "plot", "sweep"} <= commands
    for path in package.glob("*.py"):
        if path.stem in ("__init__", "__main__"):
            continue
        imported = cli_imports(path)
        if path.stem == "app":
            assert not imported & commands, f"app.py imports command modules {sorted(imported & commands)}"
        else:
            assert imported <= {"app"}, f"{path.name} imports hertzian.cli modules {sorted(imported - {'app'})}"


def test_the_import_check_sees_absolute_and_lazy_imports(tmp_path):
    sample = tmp_path / "sample.py"
    sample.write_text("from hertzian.cli.app import app\ndef f():\n    from hertzian.cli.plot import plot\n")
    assert cli_imports(sample) == {"app", "plot"}


def test_repository_refers_to_nothing_outside_itself():
    files = subprocess.run(["git", "ls-files"], cwd=ROOT, capture_output=True, text=True, check=True).stdout.split()
    pattern = re.compile(r"\.\./shared|/tmp/|/work/|/home/|/root/")
    offenders = []
    for name in files:
        if not name.endswith((".py", ".md", ".toml", ".txt", ".yml", ".yaml")) or name == "tests/test_layout.py":
            continue
        for number, line in enumerate((ROOT / name).read_text(errors="replace").splitlines(), 1):
            if pattern.search(line):
                offenders.append(f"{name}:{number}: {line.strip()[:100]}")
    assert not offenders, "\n".join(offenders)


def test_architecture_names_every_module_and_command():
    """docs/architecture.md's module tables name every module of the package and of the kernels, and its cli row
    every command module."""
    text = (ROOT / "docs" / "architecture.md").read_text()
    prose = re.sub(r"```.*?```", "", text, flags=re.S)
    quoted = " ".join(re.findall(r"`([^`\n]+)`", prose))  # module names appear in code spans: `balance.py`, `step`
    words = set(re.findall(r"[A-Za-z_][A-Za-z0-9_]*", quoted))
    missing = []
    for folder in ("ensemble", "kernels"):
        for path in (ROOT / folder).rglob("*.py"):
            if path.stem not in ("__init__", "__main__") and path.stem not in words:
                missing.append(str(path.relative_to(ROOT)))
    assert not missing, f"docs/architecture.md does not name {missing}"
    from hertzian.cli import COMMANDS

    (cli_row,) = [line for line in text.splitlines() if line.startswith("| `cli/` |")]
    listed = set(re.findall(r"`([a-z_-]+)`", cli_row))
    assert set(COMMANDS) <= listed, sorted(set(COMMANDS) - listed)


def test_ci_runs_exactly_the_readmes_test_command():
    """.ci/run's test line is the README's test command (after its install step), word for word."""
    readme = (ROOT / "README.md").read_text()
    block = re.search(r"## Test\n\n```bash\n(.+?)\n```", readme).group(1)
    install, command = (part.strip() for part in block.split("&&"))
    assert install == 'pip install ".[test]"'
    ci_lines = [line.strip() for line in (ROOT / ".ci" / "run").read_text().splitlines()]
    assert command in ci_lines and ci_lines[-1] == command, command
    assert 'python -m pip install --quiet ".[test]"' in ci_lines


def test_every_record_the_docs_link_exists_or_is_said_to_be_missing():
    """A record path named in README.md or docs/*.md is a file in docs/records/, except the GPU suite's record,
    which the README says does not exist yet for as long as it does not."""
    docs = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
    texts = {str(doc.relative_to(ROOT)): doc.read_text() for doc in docs}  # docs/README.md is another README
    named = {path for text in texts.values() for path in re.findall(r"records/[A-Za-z0-9_/]+\.json", text)}
    missing = sorted(path for path in named if not (ROOT / "docs" / path).is_file())
    said = "so that record does not exist yet" in " ".join(texts["README.md"].split())
    assert missing == (["records/ci_gpu.json"] if said else []), missing
