"""No import hidden inside a function without a reason, and a fast command line (issue 27).

An import inside a function hides an arrow of the import graph. One is allowed only where
both hold, in every module of ``postproc/`` (the languages included):

(a) it loads a slow-to-import dependency (``HEAVY``) that the module holding it does not
    load already when it is imported: the deferral keeps that dependency off the path of
    whatever imports the module (``postproc --version`` most of all). The check follows the
    module-level imports of postproc's own modules from the source (``ast``), through
    their packages' ``__init__``; a deferred import that saves nothing is named, to be
    moved to the module top;
(b) a comment on its line, or right above it, says why (``# Deferred ...``, ``# lazily ...``,
    ``lazy import``) and names what it keeps from loading (``scipy``, ``torch``, ``dask``...);
    a comment above the first of consecutive imports covers them all, but each of them
    must pass (a) on its own.

``test_the_command_line_starts_without_heavy_imports`` runs ``python -m postproc --version``
and ``--help`` in a fresh interpreter and fails if either loads one of them.
"""

from __future__ import annotations

import ast
import re
import subprocess
import sys
from functools import cache
from pathlib import Path

import pytest

import postproc

PACKAGE = Path(postproc.__file__).parent

# Dependencies worth keeping off the start-up path: each costs from a quarter of a second to
# two seconds to import on the reference machine (`python -X importtime -c "import NAME"`);
# `import scipy` itself and lark cost a few hundredths and are not here.
HEAVY = ("torch", "sklearn", "trimesh", "matplotlib", "dask", "distributed", "scipy.optimize", "scipy.interpolate",
         "scipy.spatial", "scipy.stats", "scipy.linalg", "scipy.sparse")
# What `postproc --version` / `--help` must not load (issue 27).
NOT_AT_START = ("torch", "scipy.optimize", "matplotlib", "dask", "distributed", "trimesh", "sklearn")
REASON = re.compile(r"deferred|lazil|lazy", re.IGNORECASE)
# How a comment may name a dependency it defers (by the top-level package).
SAID_AS = {"sklearn": ("sklearn", "scikit-learn"), "distributed": ("distributed", "dask")}


def _is_heavy(name: str) -> bool:
    return any(name == h or name.startswith(h + ".") for h in HEAVY)


def _modules() -> dict[str, Path]:
    """{dotted name: file} of every module of postproc (a package by its ``__init__.py``)."""
    out = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
        out[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return out


MODULES = _modules()


def _package_of(module: str) -> str:
    """Where ``from . import`` points inside ``module``."""
    return module if MODULES[module].name == "__init__.py" else module.rpartition(".")[0]


def _reached(node: ast.Import | ast.ImportFrom, module: str) -> list[str]:
    """The modules one import statement loads (postproc's by name, others as written)."""
    if isinstance(node, ast.Import):
        return [alias.name for alias in node.names]
    if node.level:
        base = _package_of(module).split(".")
        source = ".".join(base[: len(base) - node.level + 1] + ([node.module] if node.module else []))
    else:
        source = node.module or ""
    return [source] + [f"{source}.{alias.name}" for alias in node.names]


def _with_parents(name: str) -> list[str]:
    """Importing ``a.b.c`` runs ``a``, ``a.b`` and ``a.b.c``."""
    parts = name.split(".")
    return [".".join(parts[:i]) for i in range(1, len(parts) + 1)]


def _runs_at_import(body: list[ast.stmt]):
    """Import statements that run when the module is imported: not inside a function, nor
    under ``if TYPE_CHECKING:``."""
    for stmt in body:
        if isinstance(stmt, (ast.Import, ast.ImportFrom)):
            yield stmt
        elif isinstance(stmt, ast.If) and "TYPE_CHECKING" in ast.unparse(stmt.test):
            yield from _runs_at_import(stmt.orelse)
        elif not isinstance(stmt, (ast.FunctionDef, ast.AsyncFunctionDef)):
            for name in ("body", "orelse", "finalbody"):
                sub = getattr(stmt, name, None)
                if isinstance(sub, list) and sub and isinstance(sub[0], ast.stmt):
                    yield from _runs_at_import(sub)
            for handler in getattr(stmt, "handlers", []) or []:
                yield from _runs_at_import(handler.body)


@cache
def _tree(module: str) -> ast.Module:
    return ast.parse(MODULES[module].read_text(encoding="utf-8"), str(MODULES[module]))


def _loaded_by(node: ast.Import | ast.ImportFrom, module: str) -> list[str]:
    """The modules an import statement of ``module`` runs: postproc's (with their packages)
    and other libraries' names."""
    return [n for reached in _reached(node, module) for n in _with_parents(reached) if n in MODULES or n.split(".")[0] != "postproc"]


@cache
def _direct(module: str) -> tuple[str, ...]:
    """What ``module``'s own module-level imports run."""
    return tuple(n for node in _runs_at_import(_tree(module).body) for n in _loaded_by(node, module))


@cache
def loads(module: str) -> frozenset[str]:
    """Every module importing ``module`` (a postproc module, with its packages) loads, by
    the module-level imports of postproc's sources; other libraries as their names."""
    seen, todo = set(), [module]
    while todo:
        name = todo.pop()
        if name not in seen:
            seen.add(name)
            todo += _direct(name) if name in MODULES else ()
    return frozenset(seen)


def heavy_saved(module: str, node: ast.Import | ast.ImportFrom) -> set[str]:
    """The heavy dependencies the deferred import ``node`` of ``module`` keeps from loading
    when ``module`` is imported."""
    already = {name for name in loads(module) if _is_heavy(name)}
    return {name for r in _loaded_by(node, module) for name in loads(r) if _is_heavy(name)} - already


def names_one(reason: str, saved: set[str]) -> bool:
    """Whether the comment ``reason`` names a dependency the import keeps from loading (its
    top-level package: "scipy" for scipy.optimize, "dask" for distributed)."""
    said = reason.lower()
    return any(alias in said for name in saved for alias in SAID_AS.get(name.split(".")[0], (name.split(".")[0],)))


def _statement_lists(fn: ast.AST):
    """Statement lists directly inside ``fn`` (nested functions are walked on their own)."""
    stack = [fn.body]
    while stack:
        body = stack.pop()
        yield body
        for stmt in body:
            if isinstance(stmt, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                continue
            for name in ("body", "orelse", "finalbody"):
                sub = getattr(stmt, name, None)
                if isinstance(sub, list) and sub and isinstance(sub[0], ast.stmt):
                    stack.append(sub)
            stack.extend(handler.body for handler in getattr(stmt, "handlers", []) or [])


def imports_in_functions(source: str, tree: ast.Module | None = None):
    """(import node, the comment that explains it or None) of every import inside a function
    (``tree``: ``source`` parsed already)."""
    lines = source.splitlines()
    for fn in ast.walk(ast.parse(source) if tree is None else tree):
        if not isinstance(fn, (ast.FunctionDef, ast.AsyncFunctionDef)):
            continue
        for body in _statement_lists(fn):
            reason = None  # the comment above the first import of a run covers the run
            for stmt in body:
                if not isinstance(stmt, (ast.Import, ast.ImportFrom)):
                    reason = None
                    continue
                own = [lines[i - 1].partition("#")[2] for i in range(stmt.lineno, stmt.end_lineno + 1) if "#" in lines[i - 1]]
                above = lines[stmt.lineno - 2].strip() if stmt.lineno > 1 else ""
                reason = (own[0] if own else None) or (above[1:] if above.startswith("#") else None) or reason
                yield stmt, (reason if reason is not None and REASON.search(reason) else None)


def hidden_imports(source: str) -> list[tuple[int, str]]:
    """(line, text) of every import inside a function that no comment explains (rule b)."""
    lines = source.splitlines()
    return [(stmt.lineno, lines[stmt.lineno - 1].strip()) for stmt, reason in imports_in_functions(source) if reason is None]


def test_the_check_sees_a_hidden_import():
    source = ("def f():\n    import json\n    return json\n\n"
              "def g():\n    # Deferred: torch loads in seconds.\n    import torch\n    import numpy\n    return torch, numpy\n\n"
              "def h():\n    x = 1\n    import os  # lazily: why\n    import re  # noqa: F401\n    return os, x\n")
    assert hidden_imports(source) == [(2, "import json"), (14, "import re  # noqa: F401")]


def test_the_check_sees_a_deferred_import_that_saves_nothing():
    """postproc.jobs.target_file loads scipy.optimize (model_io); the CLI's compensate module
    does not load it at the top, so its deferral saves it; the standard library saves nothing."""
    module = "postproc.cli.compensate"
    deferred, light = ast.parse("from postproc.jobs.target_file import load_target").body[0], ast.parse("from pathlib import Path").body[0]
    assert "scipy.optimize" in heavy_saved(module, deferred)
    assert heavy_saved(module, light) == set()
    assert names_one("Deferred import: it loads scipy (slow)", {"scipy.optimize"}) and names_one("lazily: dask", {"distributed"})
    assert not names_one("Deferred: slow to import", {"scipy.optimize"})


def test_no_import_inside_a_function_without_a_heavy_dependency_and_a_reason():
    bad = []
    for module, path in MODULES.items():
        rel = path.relative_to(PACKAGE.parent).as_posix()
        for stmt, reason in imports_in_functions(path.read_text(encoding="utf-8"), _tree(module)):
            text = ast.unparse(stmt)
            if reason is None:
                bad.append(f"{rel}:{stmt.lineno}: {text}: no comment saying why it is deferred")
            elif not (saved := heavy_saved(module, stmt)):
                bad.append(f"{rel}:{stmt.lineno}: {text}: loads nothing slow ({', '.join(HEAVY)}) that {module} does not load already")
            elif not names_one(reason, saved):
                bad.append(f"{rel}:{stmt.lineno}: {text}: the comment names none of what it keeps from loading ({', '.join(sorted(saved))})")
    assert not bad, "imports inside functions (move them to the module top):\n" + "\n".join(bad)


RUNNER = """
import runpy, sys
sys.argv = ["postproc", *sys.argv[1:]]
try:
    runpy.run_module("postproc", run_name="__main__", alter_sys=True)
except SystemExit as exc:
    assert exc.code in (0, None), exc.code
print("LOADED", *sorted(m for m in sys.modules if m in {NOT_AT_START!r} or m.split(".")[0] in {NOT_AT_START!r}))
"""


@pytest.mark.parametrize("option", ["--version", "--help"])
def test_the_command_line_starts_without_heavy_imports(option):
    run = subprocess.run([sys.executable, "-c", RUNNER.replace("{NOT_AT_START!r}", repr(set(NOT_AT_START))), option],
                         capture_output=True, text=True, timeout=120, check=False)
    assert run.returncode == 0, run.stderr[-2000:]
    loaded = run.stdout.strip().splitlines()[-1].split()[1:]
    assert loaded == [], f"postproc {option} imports {', '.join(loaded)}: keep it off the start-up path (defer the import, say why)"
