"""The order a TP program's statements run in, where its jumps are fixed by the text
(R-30iB Operator's Manual, "Branching instructions": LBL[n], JMP LBL[n], IF ..., JMP LBL[n];
"Register instructions": R[n]=...).

Followed: labels, unconditional ``JMP LBL[n]`` (forward or back), ``CALL NAME`` (no
arguments) of a program of the file set (``calls.py``: NAME.ls beside the program), registers set to an integer
literal or changed by one (``R[i]=R[i]+k``, ``R[i]=R[i]-k``, k a literal) and ``IF R[i] op k,JMP
LBL[n]`` (op one of < <= > >= = <>, k a literal) on a register the program has set: a counted
loop, or a jump over code. Anything else that changes the flow (another CALL, SELECT, FOR, RUN, an
IF on anything else, a register set otherwise or used before the program sets it, a jump to
a label that is not there), or a run longer than ``MAX_STEPS`` statements, is not followed:
``order`` returns None and the caller reads the statements in text order, as before.
"""

from __future__ import annotations

import operator
import re

MAX_STEPS = 200_000  # statements run before the program is judged not to end by its text
MAX_CALL_DEPTH = 16  # programs calling programs deeper than this: taken for a recursion, not followed

_R = r"R\[[ \t]*(\d+)[ \t]*(?::[^\]\n]*)?\]"
_LBL = re.compile(r"[ \t]*LBL\[[ \t]*(\d+)[ \t]*(?::[^\]\n]*)?\][ \t]*$", re.IGNORECASE)
_JMP = re.compile(r"[ \t]*JMP[ \t]+LBL\[[ \t]*(\d+)[ \t]*(?::[^\]\n]*)?\][ \t]*$", re.IGNORECASE)
_SET = re.compile(rf"[ \t]*{_R}[ \t]*=[ \t]*([-+]?\d+)[ \t]*$", re.IGNORECASE)
_STEP = re.compile(rf"[ \t]*{_R}[ \t]*=[ \t]*{_R}[ \t]*([-+])[ \t]*(\d+)[ \t]*$", re.IGNORECASE)
_IF = re.compile(rf"[ \t]*IF[ \t]+{_R}[ \t]*(<=|>=|<>|<|>|=)[ \t]*([-+]?\d+)[ \t]*,[ \t]*JMP[ \t]+LBL\[[ \t]*(\d+)[ \t]*(?::[^\]\n]*)?\][ \t]*$", re.IGNORECASE)
_CALL = re.compile(r"[ \t]*CALL[ \t]+(\w+)[ \t]*$", re.IGNORECASE)
_ANY_R_SET = re.compile(rf"[ \t]*{_R}[ \t]*=", re.IGNORECASE)
_COMPARE = {"<": operator.lt, "<=": operator.le, ">": operator.gt, ">=": operator.ge, "=": operator.eq, "<>": operator.ne}


def order(texts: list[str], changes_flow: list[bool]) -> list[int] | None:
    """Indices of the statements ``texts`` of one program in the order they run (each as often
    as it runs), or None where the flow is not fixed by the text (see the module's docstring).
    ``changes_flow``: the statements the reader takes for jumps or calls."""
    run = order_with_calls([(texts, changes_flow)], {})
    return None if run is None else [i for _, i in run]


def order_with_calls(programs: list[tuple[list[str], list[bool]]], names: dict[str, int]) -> list[tuple[int, int]] | None:
    """(program, statement) indices in the order they run, from program 0; ``names``: the
    index of each other program by its name (upper case), which ``CALL NAME`` runs (its
    statements, then back after the CALL; registers are one set for all). None where the flow
    is not fixed by the text."""
    labels = []
    for texts, _ in programs:
        found = {}
        for k, text in enumerate(texts):
            m = _LBL.match(text)
            if m:
                if int(m.group(1)) in found:
                    return None  # a label twice: the controller refuses the program
                found[int(m.group(1))] = k
        labels.append(found)
    out: list[tuple[int, int]] = []
    try:
        _run(0, programs, labels, names, {}, out, [0], depth=0)
    except _NotFixed:
        return None
    return out


class _NotFixed(Exception):
    """The flow from here is not fixed by the text."""


def _run(program: int, programs, labels, names, registers: dict[int, int], out: list, steps: list[int], depth: int) -> None:
    """Append the statements program ``program`` runs, from its first to its end, to ``out``."""
    texts, changes_flow = programs[program]
    pc = 0
    while pc < len(texts):
        steps[0] += 1
        if steps[0] > MAX_STEPS:
            raise _NotFixed
        text = texts[pc]
        jump, test, set_, step, call = (p.match(text) for p in (_JMP, _IF, _SET, _STEP, _CALL))
        if jump:
            pc = _label(labels[program], jump.group(1))
            continue
        if test:
            value = registers.get(int(test.group(1)))
            if value is None:
                raise _NotFixed
            if _COMPARE[test.group(2)](value, int(test.group(3))):
                pc = _label(labels[program], test.group(4))
                continue
        elif set_:
            registers[int(set_.group(1))] = int(set_.group(2))
        elif step:
            if step.group(1) != step.group(2) or int(step.group(1)) not in registers:
                raise _NotFixed
            registers[int(step.group(1))] += int(step.group(4)) * (1 if step.group(3) == "+" else -1)
        elif call:
            callee = names.get(call.group(1).upper())
            if callee is None or depth >= MAX_CALL_DEPTH:
                raise _NotFixed  # a program not in the file set (or calls deeper than any real program's)
            out.append((program, pc))
            _run(callee, programs, labels, names, registers, out, steps, depth + 1)
            pc += 1
            continue
        elif changes_flow[pc]:
            raise _NotFixed  # SELECT, FOR, RUN, another IF, a CALL with arguments: not followed
        elif _ANY_R_SET.match(text):
            registers.pop(int(_ANY_R_SET.match(text).group(1)), None)  # set otherwise: its value is not known from the text
        out.append((program, pc))
        pc += 1


def _label(labels: dict[int, int], number: str) -> int:
    if int(number) not in labels:
        raise _NotFixed
    return labels[int(number)]
