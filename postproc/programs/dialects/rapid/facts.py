"""RAPID: the controller facts a program states, written into the IR by the parser.

The ABB controller (``controller.py``) reads these columns of ``Toolpath.extras`` and never
the program text:

- ``rapid.confl_off`` / ``rapid.confj_off`` (N,) bool: ``ConfL\\Off`` / ``ConfJ\\Off`` is in
  force at the target (RAPID reference, 'ConfL', 'ConfJ': with \\Off the robot takes the
  configuration nearest the current one). The switch in force follows the program's
  execution from ``main`` (``confswitch.py``); without ``main`` the module's text order.
- ``rapid.conf_refused`` (N,) str: where the switches give no single state (a switch under a
  condition, a motion reached with both states), the reason with its file and line; the
  controller refuses the targets' posture rule with it ('' where the state is known).
- ``rapid.singarea`` (N,) str: the program's first ``SingArea \\Wrist`` / ``\\LockAxis4`` as
  ``file:line: SingArea \\Wrist`` ('' where it has none): from there the controller may turn
  the wrist off the programmed orientation between targets (RAPID technical reference,
  SingArea). A program-wide fact, repeated per target so that ``take`` keeps it.
"""

from __future__ import annotations

import re
from dataclasses import replace

import numpy as np

from postproc.errors import InputError

from ...ir import Toolpath
from .confswitch import switch_states
from .parse import blank_comments

CONFL_OFF = "rapid.confl_off"
CONFJ_OFF = "rapid.confj_off"
CONF_REFUSED = "rapid.conf_refused"
SINGAREA = "rapid.singarea"

_SINGAREA = re.compile(r"^[ \t]*SingArea[ \t]*\\(Wrist|LockAxis4)\b", re.IGNORECASE | re.MULTILINE)


def with_controller_facts(tp: Toolpath) -> Toolpath:
    """``tp`` with the ConfL/ConfJ and SingArea columns in its extras."""
    n = len(tp)
    # A plain substring test first: most programs name neither instruction, and the regular
    # expressions below scan a 10^6-line module several times slower than str.lower and `in`.
    lowered = [doc.text.lower() for doc in tp.sources]
    refused = ""
    named = any("conf" in t for t in lowered) and any("confl" in t or "confj" in t for t in lowered)
    text_order = {switch: _text_order_state(tp, switch) if named else np.zeros(n, bool) for switch in ("CONFL", "CONFJ")}
    states = text_order
    if named:
        try:
            states = switch_states(tp, text_order)
        except InputError as why:  # refused only where a posture rule is asked for (the controller)
            refused = str(why)
    singarea = _first_singarea(tp) if any("singarea" in t for t in lowered) else ""
    facts = {CONFL_OFF: states["CONFL"], CONFJ_OFF: states["CONFJ"],
             CONF_REFUSED: np.full(n, refused, dtype=object), SINGAREA: np.full(n, singarea, dtype=object)}
    return replace(tp, extras={**tp.extras, **facts})


def _text_order_state(tp: Toolpath, switch: str) -> np.ndarray:
    """(N,) True where the last ``ConfL``/``ConfJ`` instruction before the target's line in
    its own module's text was ``\\Off``."""
    pattern = re.compile(rf"^[ \t]*{switch}[ \t]*\\(ON|OFF)[ \t]*;", re.IGNORECASE | re.MULTILINE)
    off_now = np.zeros(len(tp.line), dtype=bool)
    for f, doc in enumerate(tp.sources):
        events = [(doc.text.count("\n", 0, m.start()) + 1, m.group(1).upper() == "OFF") for m in pattern.finditer(doc.text)]
        mine = tp.file == f
        if not events or not mine.any():
            continue
        lines = np.array([line for line, _ in events])
        off = np.array([state for _, state in events])
        last = np.searchsorted(lines, tp.line[mine], side="right") - 1
        off_now[mine] = np.where(last >= 0, off[np.maximum(last, 0)], False)
    return off_now


def _first_singarea(tp: Toolpath) -> str:
    """``file:line: SingArea \\Wrist`` of the first SingArea \\Wrist or \\LockAxis4 in the
    program's modules (comments ignored, strings kept: a "!" in a TPWrite text is no comment)."""
    for doc in tp.sources:
        text = blank_comments(doc.text)
        found = _SINGAREA.search(text)
        if found:
            return f"{doc.path}:{text.count(chr(10), 0, found.start()) + 1}: SingArea \\{found.group(1)}"
    return ""
