"""SINUMERIK: the controller facts a part program states, written into the IR by the reader.

The 840D controller (``controller.py``) reads this column of ``Toolpath.extras``, never the text:

- ``sinumerik.continuous`` (N,) str: the program's first continuous-path mode or compressor
  (G64 / G641..G645, COMPON / COMPCAD / COMPCURV, CYCLE832) as ``file:line`` ('' where it
  has none): the 840D then rounds the corners between blocks or fits a curve through them
  (Fundamentals, "Continuous-path mode"; Job Planning, "NC block compression"). A
  program-wide fact, repeated per target so that ``take`` keeps it.
"""

from __future__ import annotations

import re
from dataclasses import replace

import numpy as np

from ...ir import Toolpath

CONTINUOUS = "sinumerik.continuous"

# Continuous-path mode: G64 and the smoothing modes G641..G645 leave the programmed corner
# (Fundamentals, "Continuous-path mode G64, G641, G642, G643, G644, G645"); G60 / G9 / G601 /
# G602 / G603 stop exactly at the block end.
# Found by their literal start (``str.find`` on the upper-cased text), then matched there and the
# line checked for a comment before them: a regular expression tried at every position of a
# program that has none costs seconds on 10^6 lines.
_STARTS = ("G64", "COMP", "CYCLE832")
_CONTINUOUS = re.compile(r"G64[1-5]?\b|COMP(?:CAD|CURV|ON)\b|CYCLE832[ \t]*\(")


def with_controller_facts(tp: Toolpath) -> Toolpath:
    """``tp`` with the ``sinumerik.continuous`` column in its extras."""
    return replace(tp, extras={**tp.extras, CONTINUOUS: np.full(len(tp), _first_continuous(tp), dtype=object)})


def _first_continuous(tp: Toolpath) -> str:
    for doc in tp.sources:
        upper = doc.text.upper()
        found = [at for at in (_first_word(upper, start) for start in _STARTS) if at >= 0]
        if found:
            return f"{doc.path}:{doc.text.count(chr(10), 0, min(found)) + 1}"
    return ""


def _first_word(upper: str, start: str) -> int:
    """Offset of the first uncommented continuous-path word beginning with ``start``, or -1."""
    at = upper.find(start)
    while at >= 0:
        whole_word = at == 0 or not (upper[at - 1].isalnum() or upper[at - 1] == "_")
        line_start = upper.rfind("\n", 0, at) + 1
        if whole_word and _CONTINUOUS.match(upper, at) and ";" not in upper[line_start:at]:
            return at
        at = upper.find(start, at + 1)
    return -1
