"""Loading the lark grammars shipped in grammars/ (package postproc.grammar_files)."""

from __future__ import annotations

import functools
from importlib import resources

from lark import Lark, Tree


@functools.lru_cache(maxsize=None)
def grammar(name: str) -> Lark:
    """LALR parser with a contextual lexer and positions, built once per process."""
    path = resources.files("postproc.grammar_files") / f"{name}.lark"
    with resources.as_file(path) as real:
        # cache=True keeps the LALR tables in the temp folder, keyed by the grammar's hash.
        return Lark.open(str(real), parser="lalr", lexer="contextual", propagate_positions=True, maybe_placeholders=False, cache=True)


def literal_number(node) -> float:
    """The value of a (possibly negated) number literal: the `number` and `neg` rules every grammar in grammars/ defines. NaN for any other expression."""
    if isinstance(node, Tree) and node.data == "number":
        return float(node.children[0])
    if isinstance(node, Tree) and node.data == "neg":
        return -literal_number(node.children[0])
    return float("nan")
