"""Refuse what is no program to compensate or convert: an empty file, a KRL .src without a
DEF, a RAPID module without MODULE, a program without a single motion.

Before, such a file was "compensated" with exit 0 into a copy of itself (an empty file for
an empty input): the user believed a program had been corrected. The controller would not
run it either: KSS starts a .src at its DEF, the RAPID loader needs MODULE ... ENDMODULE.
"""

from __future__ import annotations

from postproc.errors import ParseError

from . import dialects
from .dialects.base import first_statement
from .ir import Toolpath


class NoProgramError(ParseError):
    """The input holds no program, or a program without any motion."""


def _located(text: str, offset: int) -> tuple[int, int, str]:
    """1-based line, column and the line's text at ``offset``."""
    line = text.count("\n", 0, offset) + 1
    start = text.rfind("\n", 0, offset) + 1
    end = text.find("\n", offset)
    return line, offset - start + 1, text[start : end if end >= 0 else len(text)].rstrip("\r")


def require_program(tp: Toolpath) -> None:
    """Raise NoProgramError (file:line:column and why) unless ``tp`` is a program with at
    least one motion; the language says what its program must start with."""
    lang = dialects.of(tp)
    doc = tp.sources[0]
    text = doc.text[3:] if doc.text.startswith("\xef\xbb\xbf") else doc.text  # byte order mark: no column
    if first_statement(text, lang.comment_pattern) == len(text):
        raise NoProgramError(doc.path, 1, 1, "the file is empty (blank lines and comments only): there is no program to compensate or convert")
    missing = lang.missing_program(doc.role, text)
    if missing is not None:
        offset, why = missing
        line, column, excerpt = _located(text, offset)
        raise NoProgramError(doc.path, line, column, why, excerpt)
    if len(tp) == 0:
        offset = first_statement(text, lang.comment_pattern)
        line, column, excerpt = _located(text, min(offset, len(text)))
        raise NoProgramError(doc.path, line, column, f"the program has no motion ({lang.motion_words}): nothing to compensate or convert", excerpt)
