"""KRL inline forms read where they stand: the $TOOL and $BASE of a motion whose own fold sets them.

A smartPAD inline form is ``FDAT_ACT=FP1``, ``BAS(#PTP_PARAMS, v)`` and the motion, in a row
(with ``$BWDSTART``, ``PDAT_ACT`` / ``LDAT_ACT`` between). BAS.SRC's ``FRAMES()`` sets both
``$TOOL`` and ``$BASE`` from FDAT_ACT alone (inline_forms.py), so what ran before the fold
(a SWITCH jump table, a GOTO, a call of another module's routine) does not matter to that
motion: the controller runs the three lines in order whenever it runs the motion (KSS 8,
Operating and Programming Instructions for System Integrators, "Program execution": the
statements of a routine run one after the other; only a label can be reached from elsewhere,
"GOTO": the jump target is a label). That holds when, between ``FDAT_ACT=`` and the motion:

- no label (no jump lands inside the fold) and no other statement than the fold's own;
- BAS.SRC's corrections are off: ``TOOL_CORR_ON``, ``TOOL_CORR_W_ON``, ``BASE_CORR_ON`` and
  ``M_BAS_COR_ON`` are declared FALSE in $config.dat (a data list: the value kept on the
  controller, KSS 8 "Data lists") and no code that may run sets one: not the program, not
  a routine it calls (given with ``--data``; BAS.SRC itself only sets them FALSE). A call of
  a routine or function that is not in the given files (and not a KRL system function)
  may set them: then nothing is claimed;
- no INTERRUPT/TRIGGER routine the program names may change the frames, FDAT_ACT or the
  data they come from (its body is read: no such assignment, no call);
- the FDAT, TOOL_DATA, BASE_DATA and $ROBROOT are changed by no code that may run (assigned,
  or passed to a routine: an :OUT parameter is the caller's variable).

Data lists are read as the program starts with them (as everywhere postproc reads KRL): what
other programs ran before it, or the submit interpreter (SPS.SUB, not read here), may have
written into them is not known here; what the program itself may run is checked.

``BASE_NO 0`` is ``$BASE = $WORLD``: the robot base frame when ``$ROBROOT`` (KRC/R1/Mada/
$machine.dat, "robot in world coordinates") is given and is the null frame; otherwise unknown.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from .inline_forms import CORRECTION_SWITCHES

_NAME = r"[A-Za-z_$][\w$]*"
_DEF = re.compile(rf"^[ \t]*(?:GLOBAL[ \t]+)?DEF(?:FCT[ \t]+{_NAME}(?:\[[^\]\n]*\])?)?[ \t]+({_NAME})[ \t]*\(", re.I | re.M)
_END = re.compile(r"^[ \t]*END(?:FCT)?\b", re.I | re.M)
_CALLED = re.compile(rf"({_NAME})[ \t]*\(")
_ASSIGNED = re.compile(rf"^[ \t]*({_NAME})[ \t]*(?:\[[^\]\n]*\])?[ \t]*(?:\.[ \t]*{_NAME}[ \t]*)*=(?!=)", re.I)
_HANDLER = re.compile(rf"\bDO[ \t]+({_NAME})[ \t]*\(", re.I)
_KEYWORDS = {"IF", "WHILE", "UNTIL", "AND", "OR", "NOT", "EXOR", "B_AND", "B_OR", "B_NOT", "B_EXOR", "WHEN", "CASE",
             "SWITCH", "RETURN", "WAIT", "FOR", "DELAY", "DISTANCE", "PATH", "PRIO", "DO", "TO", "STEP"}
# KRL system functions (KSS 8 manual, "System functions" / "String functions") and VARSTATE:
# they read values; none writes a variable of the program.
SYSTEM_FUNCTIONS = {"VARSTATE", "SQRT", "ABS", "SIN", "COS", "TAN", "ASIN", "ACOS", "ATAN2", "STRLEN", "STRDECLLEN",
                    "STRCOMP", "STRFIND", "STRCLEAR", "STRCOPY", "STRADD", "GET_SIG_INF"}
_FRAME_DATA = {"$BASE", "$TOOL", "FDAT_ACT", "TOOL_DATA", "BASE_DATA", "$ROBROOT", "MACHINE_FRAME_DAT", "MACHINE_DEF", "MAX_BASE"}
_BAS = re.compile(r"^BAS[ \t]*\([ \t]*#(\w+)", re.I)
_FOLD_LINE = re.compile(r"^(?:\$BWDSTART|PDAT_ACT|LDAT_ACT)[ \t]*=[^=]", re.I)
_FDAT_SET = re.compile(rf"^FDAT_ACT[ \t]*=[ \t]*({_NAME}|\{{[^}}]*\}})[ \t]*$", re.I)
_MOTION = re.compile(rf"^(?:PTP|LIN|CIRC|SPTP|SLIN|SCIRC)[ \t]+{_NAME}\b(?![^\n]*\bWITH\b)", re.I)
_ROBROOT = re.compile(r"^[ \t]*(?:DECL[ \t]+)?FRAME[ \t]+\$ROBROOT[ \t]*=[ \t]*\{([^}\n]*)\}", re.I | re.M)


def code_of(line: str) -> str:
    return line.split(";", 1)[0].strip()


@dataclass
class Routines:
    """DEF / DEFFCT bodies of the program and of the given module sources (upper name -> code lines)."""

    bodies: dict[str, list[str]]

    @classmethod
    def read(cls, texts: list[str]) -> "Routines":
        bodies: dict[str, list[str]] = {}
        for text in texts:
            for m in _DEF.finditer(text):
                end = _END.search(text, m.end())
                body = text[m.end():end.start() if end else len(text)]
                bodies.setdefault(m.group(1).upper(), [code_of(x) for x in body.split("\n")[1:]])
        return cls(bodies)


def _calls(code: list[str]) -> set[str]:
    names = set()
    for line in code:
        if _DEF.match(line):
            continue
        names |= {n.upper() for n in _CALLED.findall(line)}
    return names - _KEYWORDS


def _assigned(code: list[str]) -> set[str]:
    """Names a routine's lines may change: assigned, or passed to a routine (an :OUT parameter
    is the caller's variable itself, KSS 8 "Parameter transfer")."""
    names = {m.group(1).upper() for m in map(_ASSIGNED.match, code) if m}
    for line in code:
        if _DEF.match(line):
            continue
        for m in _CALLED.finditer(line):
            if m.group(1).upper() not in _KEYWORDS | SYSTEM_FUNCTIONS | {"BAS"}:
                names |= {n.upper() for n in re.findall(_NAME, line[m.end():])}
    return names


def reached(program_code: list[str], routines: Routines) -> tuple[set[str], str | None]:
    """Routines the program may run (calls, handlers, functions, transitively); None or why
    some code that may run is not in the given files."""
    seen: set[str] = set()
    todo = list(_calls(program_code))
    while todo:
        name = todo.pop()
        if name in seen or name == "BAS" or name in SYSTEM_FUNCTIONS:
            continue
        if name not in routines.bodies:
            return seen, f"{name}() is not in the given files (it may set what BAS.SRC reads)"
        seen.add(name)
        todo += list(_calls(routines.bodies[name]))
    return seen, None


@dataclass
class Window:
    """What the given files prove for every inline form of the program (see the docstring)."""

    why_not: str | None  # None: the corrections are off and nothing that may run changes the frame data
    changed: set[str]  # names assigned by code that may run (upper case, base names)
    world: bool  # $WORLD is the robot base frame ($ROBROOT given, null, never changed)

    @classmethod
    def read(cls, program_text: str, config_text: str | None, module_texts: list[str]) -> "Window":
        program_code = [code_of(x) for x in program_text.split("\n")]
        routines = Routines.read([program_text, *module_texts])
        names, why = reached(program_code, routines)
        changed = _assigned(program_code)
        for name in names:
            changed |= _assigned(routines.bodies[name])
        world = _robroot_is_null(module_texts) and "$ROBROOT" not in changed
        if why is None:
            why = _corrections_why(config_text, changed)
        if why is None:
            code = program_code + [line for name in names for line in routines.bodies[name]]  # handlers a called routine declares too
            why = _handlers_why("\n".join(code), routines)
        return cls(why, changed, world)

    def fdat_of(self, code_lines: list[str], motion_line: int) -> tuple[str, int] | None:
        """(the FDAT (a name or an aggregate's text), the BAS line) the inline form of the motion
        on ``motion_line`` (1-based) sets its frames from; None where the fold is not whole."""
        if self.why_not is not None or not _MOTION.match(code_lines[motion_line - 1]):
            return None
        bas = 0
        for number in range(motion_line - 1, 0, -1):
            code = code_lines[number - 1]
            if not code:
                continue
            m = _BAS.match(code)
            if m and m.group(1).upper() in ("PTP_PARAMS", "CP_PARAMS", "FRAMES") and not bas:
                bas = number
            elif m and m.group(1).upper() in ("VEL_PTP", "ACC_PTP", "VEL_CP", "ACC_CP"):
                continue
            elif _FOLD_LINE.match(code):
                continue
            elif (f := _FDAT_SET.match(code)) and bas:
                name = f.group(1)
                return None if name.upper() in self.changed else (name, bas)
            else:
                return None
        return None


def _corrections_why(config_text: str | None, changed: set[str]) -> str | None:
    for switch in CORRECTION_SWITCHES:
        if not re.search(rf"^[ \t]*(?:DECL[ \t]+)?(?:GLOBAL[ \t]+)?BOOL[ \t]+{switch}[ \t]*=[ \t]*FALSE\b", config_text or "", re.I | re.M):
            return f"{switch} is not declared FALSE in the given $config.dat"
        if switch in changed:
            return f"{switch} is set by code that may run"
    return None


def _handlers_why(program_text: str, routines: Routines) -> str | None:
    for name in {n.upper() for n in _HANDLER.findall(program_text)}:
        body = routines.bodies.get(name)
        if body is None:
            return f"the INTERRUPT/TRIGGER routine {name}() is not in the given files"
        if _assigned(body) & (_FRAME_DATA | set(CORRECTION_SWITCHES)) or _calls(body) - SYSTEM_FUNCTIONS:
            return f"the INTERRUPT/TRIGGER routine {name}() may change the frames or call a routine"
    return None


def _robroot_is_null(texts: list[str]) -> bool:
    found = [m.group(1) for t in texts for m in _ROBROOT.finditer(t)]
    if len(found) != 1:
        return False
    values = dict(re.findall(r"([XYZABC])[ \t]+([-+\d.eE]+)", found[0].upper()))
    return set(values) == set("XYZABC") and all(float(v) == 0.0 for v in values.values())
