"""What the G-code parser and its helpers (arcwords, flow) share: the word columns of a
block and the signal for a value the program text does not determine.

Kept apart from parse.py so that the helpers import it and not the parser (which imports
them): no import circle.
"""

from __future__ import annotations

# The address letters a block's value and span columns hold, in column order.
AXES = "XYZABCIJKRF"


class Unknown(Exception):
    """A parameter or expression whose value the program text does not determine."""
