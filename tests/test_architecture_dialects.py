"""A dialect is one object: no code outside postproc/programs/dialects/ branches on a dialect's name.

What a language does (its files, parsing, frames, configuration rules, emitting) lives in
its package under postproc/programs/dialects/; everything else asks the registry. Branching on
``tp.dialect == "krl"``, ``{"rapid": ...}[name]`` or a source file's role elsewhere is how a
compensated $config.dat target came to be never written. CLI option values are fine as
long as they go through the registry (``dialects.get``), which this test does not flag.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from postproc.programs import dialects

PACKAGE = Path(dialects.__file__).parents[2]  # postproc/programs/dialects -> postproc
DIALECTS_DIR = Path(dialects.__file__).parent
NAMES = set(dialects.names())
# File names a language gives its files: deciding by them is the dialect's business too.
EXTENSIONS = {e for d in dialects.REGISTRY.values() for e in d.extensions} | {".dat", "$config.dat"}
NAMED_ATTRIBUTES = {"dialect", "role"}  # Toolpath.dialect, SourceDoc.role
# Words that name something else in one package: the five-axis writers' --rtcp modes
# (postproc/jobs/five_axis) include "fanuc" (a Fanuc CNC's G43.4 G-code), not the Fanuc TP
# robot language.
OTHER_MEANING = {"five_axis": {"fanuc"}}


def _names_a_dialect(node: ast.AST, not_dialects: frozenset = frozenset()) -> bool:
    """A string constant that is a dialect's name, or a tuple/list/set holding one."""
    if isinstance(node, ast.Constant) and isinstance(node.value, str):
        word = node.value.lower()
        return word not in not_dialects and (word in NAMES or word in EXTENSIONS)
    if isinstance(node, (ast.Tuple, ast.List, ast.Set)):
        return any(_names_a_dialect(e, not_dialects) for e in node.elts)
    return False


def _is_dialect_value(node: ast.AST) -> bool:
    """``x.dialect`` / ``x.role`` or a variable called ``dialect``."""
    return (isinstance(node, ast.Attribute) and node.attr in NAMED_ATTRIBUTES) or (isinstance(node, ast.Name) and node.id == "dialect")


def branching_by_name(source: str, not_dialects: frozenset = frozenset()) -> list[tuple[int, str]]:
    """(line, what) of every place in ``source`` that tests or looks up a dialect by name
    (``not_dialects``: words that mean something else there)."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Compare):
            operands = [node.left, *node.comparators]
            none_test = all(isinstance(op, (ast.Is, ast.IsNot)) for op in node.ops) and any(isinstance(o, ast.Constant) and o.value is None for o in operands)
            if any(_names_a_dialect(o) for o in operands):
                found.append((node.lineno, "comparison with a dialect name"))
            elif any(_is_dialect_value(o) for o in operands) and not none_test:
                found.append((node.lineno, "comparison of a dialect or file role"))
        elif isinstance(node, ast.Dict) and any(k is not None and _names_a_dialect(k, not_dialects) for k in node.keys):
            found.append((node.lineno, "dict keyed by dialect name"))
        elif isinstance(node, ast.MatchValue) and _names_a_dialect(node.value):
            found.append((node.lineno, "match case on a dialect name"))
        elif isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr == "with_suffix" and any(_names_a_dialect(a) for a in node.args):
            found.append((node.lineno, "a language's file name chosen outside its dialect"))
    return found


def _modules_outside_dialects():
    return sorted(p for p in PACKAGE.rglob("*.py") if DIALECTS_DIR not in p.parents)


def test_no_dialect_branching_outside_the_dialects_package():
    offences = [f"{path.relative_to(PACKAGE.parent)}:{line}: {what}" for path in _modules_outside_dialects() for line, what in branching_by_name(path.read_text(encoding="utf-8"), frozenset(OTHER_MEANING.get(path.parent.name, ())))]
    assert not offences, "dialect knowledge outside postproc/programs/dialects/:\n" + "\n".join(offences)


@pytest.mark.parametrize(
    "snippet",
    [
        'if tp.dialect == "krl":\n    pass\n',
        'if original.dialect in ("rapid", "krl"):\n    pass\n',
        'writer = {"rapid": A, "krl": B}.get(name)\n',
        'outputs = [p for doc in docs if doc.role == "dat"]\n',
        'match name:\n    case "gcode":\n        pass\n',
        'if dialect != other:\n    pass\n',
        'if path.suffix.lower() in (".mod", ".modx"):\n    pass\n',
        'outputs = [output, output.with_suffix(".dat")]\n',
    ],
)
def test_the_checker_finds_each_kind_of_branching(snippet):
    assert branching_by_name(snippet), snippet


@pytest.mark.parametrize(
    "snippet",
    [
        'lang = dialects.get(dialect)\n',
        'if dialect is None:\n    pass\n',
        'KIND = {5: "rapid"}\n',  # a G0 move is a "rapid" move: a value, not a dialect test
        'help_text = "rapid, krl or gcode"\n',
    ],
)
def test_the_checker_lets_registry_use_through(snippet):
    assert not branching_by_name(snippet), snippet


def test_every_dialect_is_a_registered_object():
    for name, lang in dialects.REGISTRY.items():
        assert lang.name == name and isinstance(lang, dialects.Dialect)
        assert lang.extensions and all(e.startswith(".") and e == e.lower() for e in lang.extensions)


class ToyDialect(dialects.Dialect):
    """A language of 'MOVE x y z' lines: all it takes to add one is this class."""

    name, extensions = "toy", (".toy",)

    def parse_sources(self, sources):
        import numpy as np

        from postproc.programs.ir import NF, Kind
        from postproc.programs.parse.common import Builder, LineIndex, scan_numbers

        doc = sources[0]
        builder, numbers, lines = Builder(self.name, "none", [doc]), scan_numbers(doc.text), LineIndex(doc.text)
        for start in (s for s in lines.starts.tolist() if doc.text.startswith("MOVE", s)):
            sl = numbers.between(start, doc.text.find("\n", start) % (len(doc.text) + 1))
            values, spans = np.full(NF, np.nan), np.full((NF, 3), -1)
            values[:3], spans[:3, 0], spans[:3, 1], spans[:3, 2] = numbers.value[sl], 0, numbers.start[sl], numbers.end[sl]
            builder.add(start, kind=Kind.LINEAR, line=lines.line(start), values=values, spans=spans)
        return builder.build()


def test_a_new_dialect_is_one_class_and_one_registry_entry(tmp_path, monkeypatch):
    import json

    from typer.testing import CliRunner

    from postproc.cli import app

    monkeypatch.setitem(dialects.REGISTRY, "toy", ToyDialect())
    program = tmp_path / "p.toy"
    program.write_bytes(b"START\nMOVE 1 2 3\nMOVE 4.5 -6 7 ; done\n")
    result = CliRunner().invoke(app, ["inspect", str(program), "--json"])
    assert result.exit_code == 0, result.output
    assert [m["xyz"] for m in json.loads(result.stdout)["moves"]] == [[1, 2, 3], [4.5, -6, 7]]
    assert CliRunner().invoke(app, ["roundtrip", str(program)]).exit_code == 0
    out = tmp_path / "moved.toy"
    tp = dialects.get("toy").parse(program)
    files = dialects.of(tp).emit(tp, tp.with_positions(tp.position + 0.25), out)
    assert files == {out: "START\nMOVE 1.25 2.25 3.25\nMOVE 4.75 -5.75 7.25 ; done\n"}


def test_the_exceptions_name_folders_that_exist():
    """A renamed folder would leave its exception matching nothing, and the test above blind there."""
    folders = {p.name for p in PACKAGE.rglob("*") if p.is_dir()}
    assert set(OTHER_MEANING) <= folders and DIALECTS_DIR.is_dir()
