"""Every command of the tutorials (docs/tutorials/*.md, and pages marked with ``CHECKED``) runs as written, in one fresh shell
per page, and every output line the page shows is what the command prints.

A page's ```console blocks hold ``$ command`` lines (a here-document's lines belong to its
command) and the output shown under each; ``…`` stands for output left out (a line of
only ``…`` skips any lines, a ``…`` inside a line any text). Whitespace runs count as one.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
CHECKED = "<!-- checked by tests/test_tutorials.py -->"  # a how-to page outside docs/tutorials asks for the same check
PAGES = sorted((ROOT / "docs" / "tutorials").glob("*.md")) + sorted(
    p for p in (ROOT / "docs").rglob("*.md") if p.parent.name != "tutorials" and CHECKED in p.read_text(encoding="utf-8"))
_BLOCK = re.compile(r"```console\n(.*?)```", re.DOTALL)
_HEREDOC = re.compile(r"<<\s*'?(\w+)'?")
_NEEDS = re.compile(r"<!-- needs: ([\w\- ]+) -->")  # programs a page needs (skipped without them)


def _commands(page: Path) -> list[tuple[str, list[str]]]:
    """(command, the output lines the page shows for it) in page order."""
    steps: list[tuple[str, list[str]]] = []
    for block in _BLOCK.findall(page.read_text(encoding="utf-8")):
        lines = block.splitlines()
        i = 0
        while i < len(lines):
            line = lines[i]
            i += 1
            if line.startswith("$ "):
                command = [line[2:]]
                heredoc = _HEREDOC.search(line)
                if heredoc:
                    while i < len(lines):
                        command.append(lines[i])
                        i += 1
                        if lines[i - 1].strip() == heredoc.group(1):
                            break
                steps.append(("\n".join(command), []))
            elif line.strip() and steps:
                steps[-1][1].append(line)
    return steps


def _normal(text: str) -> str:
    return " ".join(text.split())


def _shown_in(shown: str, printed: list[str]) -> bool:
    pieces = [re.escape(_normal(p)) for p in shown.split("…")]
    pattern = re.compile(".*?".join(pieces))
    return any(pattern.search(_normal(line)) for line in printed)


@pytest.mark.slow
@pytest.mark.parametrize("page", PAGES, ids=[p.stem for p in PAGES])
def test_tutorial_runs_as_written(page, tmp_path):
    needs = _NEEDS.search(page.read_text(encoding="utf-8"))
    missing = [tool for tool in (needs.group(1).split() if needs else []) if shutil.which(tool) is None]
    if missing:
        pytest.skip(f"{page.name} needs {', '.join(missing)}")
    steps = _commands(page)
    assert steps, f"{page.name}: no console commands"
    script = ["exec 2>&1", "set +e"]
    for k, (command, _) in enumerate(steps):
        script += [command, f"echo \"@@step {k} exit $?\""]
    home = tmp_path / "home"  # what a page installs for the user (FreeCAD's macro folder) goes here, not into ~
    home.mkdir()
    run = subprocess.run(["bash", "-c", "\n".join(script)], cwd=ROOT, capture_output=True, text=True, timeout=1200,
                         env={**os.environ, "HOME": str(home)})
    parts = re.split(r"@@step (\d+) exit (\d+)\n", run.stdout)
    printed = {int(parts[j]): (int(parts[j + 1]), parts[j - 1].splitlines()) for j in range(1, len(parts) - 1, 3)}
    for k, (command, shown) in enumerate(steps):
        assert k in printed, f"{page.name}: the shell stopped before `{command}`:\n{run.stdout[-2000:]}"
        status, lines = printed[k]
        assert status == 0, f"{page.name}: `{command}` exited {status}:\n" + "\n".join(lines[-30:])
        for line in shown:
            if line.strip() != "…":
                assert _shown_in(line, lines), f"{page.name}: `{command}` did not print\n  {line}\nit printed:\n" + "\n".join(lines[-40:])
