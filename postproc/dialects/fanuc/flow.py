"""The order a TP program's statements run in, where its jumps are fixed by the text
(R-30iB Operator's Manual, "Branching instructions": LBL[n], JMP LBL[n], IF ..., JMP LBL[n];
"Register instructions": R[n]=...).

Followed: labels, unconditional ``JMP LBL[n]`` (forward or back), registers set to an integer
literal or changed by one (``R[i]=R[i]+k``, ``R[i]=R[i]-k``, k a literal) and ``IF R[i] op k,JMP
LBL[n]`` (op one of < <= > >= = <>, k a literal) on a register the program has set: a counted
loop, or a jump over code. Anything else that changes the flow (CALL, SELECT, FOR, RUN, an
IF on anything else, a register set otherwise or used before the program sets it, a jump to
a label that is not there), or a run longer than ``MAX_STEPS`` statements, is not followed:
``order`` returns None and the caller reads the statements in text order, as before.
"""

from __future__ import annotations

import operator
import re

MAX_STEPS = 200_000  # statements run before the program is judged not to end by its text

_R = r"R\[[ \t]*(\d+)[ \t]*(?::[^\]\n]*)?\]"
_LBL = re.compile(r"[ \t]*LBL\[[ \t]*(\d+)[ \t]*(?::[^\]\n]*)?\][ \t]*$", re.IGNORECASE)
_JMP = re.compile(r"[ \t]*JMP[ \t]+LBL\[[ \t]*(\d+)[ \t]*(?::[^\]\n]*)?\][ \t]*$", re.IGNORECASE)
_SET = re.compile(rf"[ \t]*{_R}[ \t]*=[ \t]*([-+]?\d+)[ \t]*$", re.IGNORECASE)
_STEP = re.compile(rf"[ \t]*{_R}[ \t]*=[ \t]*{_R}[ \t]*([-+])[ \t]*(\d+)[ \t]*$", re.IGNORECASE)
_IF = re.compile(rf"[ \t]*IF[ \t]+{_R}[ \t]*(<=|>=|<>|<|>|=)[ \t]*([-+]?\d+)[ \t]*,[ \t]*JMP[ \t]+LBL\[[ \t]*(\d+)[ \t]*(?::[^\]\n]*)?\][ \t]*$", re.IGNORECASE)
_ANY_R_SET = re.compile(rf"[ \t]*{_R}[ \t]*=", re.IGNORECASE)
_COMPARE = {"<": operator.lt, "<=": operator.le, ">": operator.gt, ">=": operator.ge, "=": operator.eq, "<>": operator.ne}


def order(texts: list[str], changes_flow: list[bool]) -> list[int] | None:
    """Indices of the statements ``texts`` in the order they run (each as often as it runs),
    or None where the flow is not fixed by the text (see the module's docstring).
    ``changes_flow``: the statements the reader takes for jumps or calls."""
    labels = {}
    for k, text in enumerate(texts):
        m = _LBL.match(text)
        if m:
            if int(m.group(1)) in labels:
                return None  # a label twice: the controller refuses the program
            labels[int(m.group(1))] = k
    registers: dict[int, int] = {}
    out: list[int] = []
    pc, steps = 0, 0
    while pc < len(texts):
        steps += 1
        if steps > MAX_STEPS:
            return None
        text = texts[pc]
        jump = _JMP.match(text)
        test = _IF.match(text)
        set_ = _SET.match(text)
        step = _STEP.match(text)
        if jump:
            target = labels.get(int(jump.group(1)))
            if target is None:
                return None
            pc = target
            continue
        if test:
            value = registers.get(int(test.group(1)))
            target = labels.get(int(test.group(4)))
            if value is None or target is None:
                return None
            if _COMPARE[test.group(2)](value, int(test.group(3))):
                pc = target
                continue
        elif set_:
            registers[int(set_.group(1))] = int(set_.group(2))
        elif step:
            if step.group(1) != step.group(2) or int(step.group(1)) not in registers:
                return None
            registers[int(step.group(1))] += int(step.group(4)) * (1 if step.group(3) == "+" else -1)
        elif changes_flow[pc]:
            return None  # CALL, SELECT, FOR, RUN, another IF: not followed
        elif _ANY_R_SET.match(text):
            registers.pop(int(_ANY_R_SET.match(text).group(1)), None)  # set otherwise: its value is not known from the text
        out.append(pc)
        pc += 1
    return out
