"""UTF-8 byte order marks: read past them, keep them in the text that is written back.

Windows tools (Notepad, some CAM posts, WorkVisual exports) start a file with the three
bytes EF BB BF. Sources are decoded as Latin-1 (one character per byte), so the mark is
three characters ``ï»¿`` in front of the first statement. Every parser reads a copy of the
text with the mark blanked to three spaces, which keeps every offset and span the same;
the toolpath keeps the original text, so writing back splices numbers into text that
still starts with the mark, byte for byte.

Columns in error messages count what an editor shows: the mark takes no column, so on a
file's first line the column is three less than the byte offset would give.
"""

from __future__ import annotations

from dataclasses import replace

from postproc.errors import ParseError

from ..ir import SourceDoc, Toolpath

MARK = "\xef\xbb\xbf"  # U+FEFF in UTF-8, decoded as Latin-1


def has_mark(doc: SourceDoc) -> bool:
    return doc.text.startswith(MARK)


def blanked(sources: list[SourceDoc]) -> list[SourceDoc]:
    """The sources with each leading mark replaced by three spaces (same length)."""
    return [replace(doc, text=" " * len(MARK) + doc.text[len(MARK):]) if has_mark(doc) else doc for doc in sources]


def restored(tp: Toolpath, sources: list[SourceDoc]) -> Toolpath:
    """``tp`` (read from ``blanked(sources)``) holding the original texts again.

    Parsers may add sources of their own after the ones they were given (none do today);
    those are kept as they are."""
    kept = tuple(sources) + tuple(tp.sources[len(sources):])
    return replace(tp, sources=kept)


def editor_columns(exc: ParseError, sources: list[SourceDoc]) -> ParseError:
    """``exc`` with the column an editor shows (the mark takes none) on a marked file's first line."""
    marked = {doc.path for doc in sources if has_mark(doc)}
    if exc.line != 1 or exc.path not in marked:
        return exc
    excerpt = exc.excerpt[len(MARK):] if exc.excerpt.startswith(" " * len(MARK)) else exc.excerpt
    return ParseError(exc.path, 1, max(exc.column - len(MARK), 1), exc.message, excerpt)
