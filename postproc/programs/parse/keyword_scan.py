"""A pattern's matches where a keyword stands: ``finditer``'s, without running it over the text.

A statement pattern run over a long program (``re.IGNORECASE``, 10^5-10^6 lines) costs a
second or more; the statements it looks for (a load, a tool) stand on a few lines. Each match
begins at one of its keywords (or at the start of the line holding one, for a pattern
anchored with ``^``), so the pattern is tried only there: ``str.find`` on the lowered text
finds the few places.
"""

from __future__ import annotations

import re


def keyword_matches(pattern: re.Pattern, text: str, lowered: str, keywords: tuple[str, ...], line_start: bool = False) -> list[re.Match]:
    """The matches ``pattern.finditer(text)`` gives, where every match begins at an occurrence
    of one of ``keywords`` (lower case) in ``lowered`` (``text.lower()``: one character per
    character, Latin-1), or with ``line_start`` at the start of the line holding one. Tried in
    text order; a place inside an earlier match is skipped, as ``finditer`` skips it."""
    places = set()
    for keyword in keywords:
        at = lowered.find(keyword)
        while at >= 0:
            places.add(text.rfind("\n", 0, at) + 1 if line_start else at)
            at = lowered.find(keyword, at + 1)
    out, end = [], 0
    for start in sorted(places):
        if start < end:
            continue
        m = pattern.match(text, start)
        if m is not None:
            out.append(m)
            end = max(m.end(), start + 1)
    return out
