"""A pattern's matches where a keyword stands: ``finditer``'s, without running it over the text.

A statement pattern run over a long program (``re.IGNORECASE``, 10^5-10^6 lines) costs a
second or more; the statements it looks for (a load, a tool) stand on a few lines. Each match
begins at one of its keywords (or at the start of the line holding one, for a pattern
anchored with ``^``), so the pattern is tried only there: ``str.find`` on the lowered text
finds the few places, each keyword once per text (``KeywordIndex``).
"""

from __future__ import annotations

import re


class KeywordIndex:
    """Where keywords stand in one text: lowered once (Latin-1: one character per character),
    each keyword looked for once."""

    def __init__(self, text: str):
        self.text, self.lowered = text, text.lower()
        self._places: dict[str, tuple[int, ...]] = {}

    def places(self, keyword: str) -> tuple[int, ...]:
        """Every offset where ``keyword`` (lower case) stands, in text order."""
        if keyword not in self._places:
            found, at = [], self.lowered.find(keyword)
            while at >= 0:
                found.append(at)
                at = self.lowered.find(keyword, at + 1)
            self._places[keyword] = tuple(found)
        return self._places[keyword]

    def has(self, *keywords: str) -> bool:
        return any(self.places(k) for k in keywords)

    def matches(self, pattern: re.Pattern, keywords: tuple[str, ...], line_start: bool = False) -> list[re.Match]:
        """The matches ``pattern.finditer(text)`` gives, where every match begins at one of
        ``keywords`` or, with ``line_start``, at the start of the line holding one. Tried in
        text order; a place inside an earlier match is skipped, as ``finditer`` skips it."""
        text = self.text
        starts = sorted({text.rfind("\n", 0, at) + 1 if line_start else at for k in keywords for at in self.places(k)})
        out, end = [], 0
        for start in starts:
            if start < end:
                continue
            m = pattern.match(text, start)
            if m is not None:
                out.append(m)
                end = max(m.end(), start + 1)
        return out

