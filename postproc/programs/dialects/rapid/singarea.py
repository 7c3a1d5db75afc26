"""RAPID SingArea: where the controller leaves the programmed interpolation between targets."""

from __future__ import annotations

import re

from .parse import blank_comments

_SINGAREA = re.compile(r"^[ \t]*SingArea[ \t]*\\(Wrist|LockAxis4)\b", re.IGNORECASE | re.MULTILINE)


def wrist_singularity_avoidance(tp) -> str | None:
    """``file:line: why`` of the first SingArea \\Wrist or \\LockAxis4 in the program's modules
    (comments ignored), else None. The controller then interpolates the wrist so as to avoid
    singularities, and the orientation between targets is not the programmed interpolation:
    a predicted path between targets would not be the robot's."""
    for doc in tp.sources:
        text = blank_comments(doc.text)  # (strings kept: a "!" in a TPWrite text is no comment)
        found = _SINGAREA.search(text)
        if found:
            line = text.count("\n", 0, found.start()) + 1
            return (f"{doc.path}:{line}: SingArea \\{found.group(1)}: between targets the controller may turn the wrist off the "
                    "programmed orientation (RAPID technical reference, SingArea), so the path between compensated targets cannot be "
                    "predicted; use SingArea \\Off for a program compensated along its path")
    return None
