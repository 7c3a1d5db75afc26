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
_CONTINUOUS = re.compile(r"(?im)^[^;\n]*(?:\bG64[1-5]?\b|\bCOMP(?:CAD|CURV|ON)\b|\bCYCLE832[ \t]*\()")


def with_controller_facts(tp: Toolpath) -> Toolpath:
    """``tp`` with the ``sinumerik.continuous`` column in its extras."""
    return replace(tp, extras={**tp.extras, CONTINUOUS: np.full(len(tp), _first_continuous(tp), dtype=object)})


def _first_continuous(tp: Toolpath) -> str:
    for doc in tp.sources:
        m = _CONTINUOUS.search(doc.text)
        if m:
            return f"{doc.path}:{doc.text.count(chr(10), 0, m.start()) + 1}"
    return ""
