"""Siemens SINUMERIK (828D / 840D) statements that are not G-code words, for flow.py.

Sources: SINUMERIK 840D sl / 828D "Job Planning" programming manual (6FC5398-2BP40),
sections "Flexible NC programming": DEF (variable definition; an INT or REAL without an
initial value is 0), arithmetic and comparison operators (== <> < > <= >=, AND OR NOT,
DIV MOD), IF/ELSE/ENDIF, WHILE/ENDWHILE, FOR var = a TO b / ENDFOR (the counter steps by 1
and the body runs while var <= b), REPEAT/UNTIL, MSG; and "Subprogram technique": PROC
name(type param, ...) heads a subprogram, EXTERN declares one in another file (NAME.SPF), a
call is ``NAME(args)``, RET or M17 returns; and SUPA (block-wise suppression of all frames:
machine coordinates). G70/G700 inch, G71/G710 metric ("Fundamentals", 6FC5398-1BP40).

Each statement is translated into the O-word machinery of flow.py: a Line with a keyword
and its expressions rewritten in LinuxCNC syntax (``CYCLES < 1`` -> ``[#<cycles> LT 1]``)
and parsed by the same grammar, so one evaluator serves both dialects.
"""

from __future__ import annotations

import re

_STATEMENT = re.compile(
    r"^[ \t]*(?:[Nn]\d+[ \t]+)?(?P<kw>EXTERN|PROC|DEF|IF|ELSE|ENDIF|WHILE|ENDWHILE|FOR|ENDFOR|REPEAT|UNTIL|RET|MSG|GOTOF|GOTOB|GOTOC|GOTO|LOOP|ENDLOOP)\b(?P<rest>[^;\n]*)",
    re.IGNORECASE)
_ASSIGN = re.compile(r"^[ \t]*(?:[Nn]\d+[ \t]+)?(?P<name>[A-Za-z_][A-Za-z0-9_]{1,})[ \t]*=(?![=])(?P<expr>[^;\n]*)")
_CALL = re.compile(r"^[ \t]*(?:[Nn]\d+[ \t]+)?(?P<name>[A-Za-z_][A-Za-z0-9_]{2,})[ \t]*(?:\((?P<args>[^;\n]*)\))?[ \t]*(?:;[^\n]*)?$")
_DETECT = re.compile(r"(?im)^[ \t]*(?:PROC|EXTERN|DEF)[ \t]")
_EXTERN = re.compile(r"(?im)^[ \t]*EXTERN[ \t]+([A-Za-z_][A-Za-z0-9_]*)")
_PROC = re.compile(r"(?i)^\s*([A-Za-z_][A-Za-z0-9_]*)\s*(?:\((.*)\))?")
_TOKEN = re.compile(r"\s*(==|<>|<=|>=|<|>|\+|-|\*|/|\(|\)|,|#\d+|\d+\.?\d*|\.\d+|\$?[A-Za-z_][A-Za-z0-9_]*(?:\[[^\]]*\])?)")
_OPS = {"==": " EQ ", "<>": " NE ", "<=": " LE ", ">=": " GE ", "<": " LT ", ">": " GT ", "(": "[", ")": "]"}
_WORD_OPS = {"AND": " AND ", "OR": " OR ", "XOR": " XOR ", "MOD": " MOD "}
# TRUNC (towards zero) and ROUND (half away from zero) are not LinuxCNC's FIX (floor) and
# ROUND: left out, so an expression using them is unknown rather than off by one.
_FUNCS = {"SIN", "COS", "TAN", "ASIN", "ACOS", "ABS", "SQRT", "EXP", "LN"}
_KEYWORDS = {"EXTERN", "PROC", "DEF", "IF", "ELSE", "ENDIF", "WHILE", "ENDWHILE", "FOR", "ENDFOR", "REPEAT", "UNTIL", "RET", "MSG",
             "GOTOF", "GOTOB", "GOTOC", "GOTO", "LOOP", "ENDLOOP", "SUPA", "TRAORI", "TRAFOOF"}


# A jump label heading a block ("N40 LOOP_START: X=R1"; Job Planning, "Program jumps to jump
# markers"): its name; and a jump "GOTOF LABEL" / "IF cond GOTOB N100" (direction, target).
LABEL = re.compile(r"^(?P<head>[ \t]*(?:[Nn](?P<n>\d+)[ \t]+)?)(?P<name>[A-Za-z_]\w*):(?!=)")
_JUMP = re.compile(r"(?i)^(?P<cond>.*?)\b(?P<kw>GOTO[FBC]?)[ \t]+(?P<target>[A-Za-z_0-9]+)[ \t]*$")
_BLOCK_NUMBER = re.compile(r"^[ \t]*[Nn](\d+)\b")


def label_of(line: str) -> tuple[str | None, int | None, int]:
    """(jump label, block number, length of the label prefix to blank) of a block."""
    m = LABEL.match(line)
    if m:
        return m.group("name").lower(), int(m.group("n")) if m.group("n") else None, m.end()
    n = _BLOCK_NUMBER.match(line)
    return None, int(n.group(1)) if n else None, 0


def jump(kw: str, rest: str) -> tuple[str, str, str] | None:
    """(condition or '', GOTOF/GOTOB/GOTO/GOTOC, target) of a jump statement, or None."""
    m = _JUMP.match(f"{kw} {rest}" if kw.upper().startswith("GOTO") else rest)
    return (m.group("cond").strip(), m.group("kw").upper(), m.group("target")) if m else None


def is_siemens(path: str, text: str) -> bool:
    if path.lower().endswith((".mpf", ".spf")):
        return True
    low = text.lower()
    return any(w in low for w in ("proc", "extern", "def")) and _DETECT.search(text) is not None


def externs(text: str) -> list[str]:
    """Subprograms the program declares as in other files (EXTERN NAME(...))."""
    return _EXTERN.findall(text)


def expression(text: str) -> str:
    """A Siemens expression in LinuxCNC syntax; ValueError where it cannot be translated."""
    out, pos, text = [], 0, text.strip()
    while pos < len(text):
        m = _TOKEN.match(text, pos)
        if not m:
            raise ValueError(f"cannot read the expression at '{text[pos:]}'")
        tok, pos = m.group(1), m.end()
        up = tok.upper()
        if tok in _OPS:
            out.append(_OPS[tok])
        elif up in _WORD_OPS:
            out.append(_WORD_OPS[up])
        elif up in _FUNCS:
            out.append(up)
        elif up in ("TRUE", "FALSE"):
            out.append("1" if up == "TRUE" else "0")  # the 840D's BOOL constants
        elif tok[0] == "#":
            out.append(tok)  # an R parameter the sinumerik dialect has already written as a # parameter
        elif up in ("NOT", "DIV"):
            raise ValueError(f"{up} is not evaluated")  # DIV: the 840D's integer division (7 DIV 3 = 2), not LinuxCNC's /
        elif tok[0].isalpha() or tok[0] in "_$":
            # a variable; system variables ($AA_IM[X], $P_...) are the machine's: unknown here
            out.append(f"#<{'_sys' + re.sub(r'[^A-Za-z0-9_]', '_', tok) if tok[0] == '$' else tok}>")
        else:
            out.append(tok)
    return "[" + "".join(out) + "]"


def classify(line: str) -> tuple[str, dict] | None:
    """(keyword, details) of a Siemens statement line, or None for a G-code block."""
    m = _STATEMENT.match(line)
    if m:
        kw, rest = m.group("kw").upper(), m.group("rest").strip()
        return kw, {"rest": rest}
    m = _ASSIGN.match(line)
    if m and m.group("name").upper() not in _KEYWORDS and not re.fullmatch(r"[A-Za-z]\d*", m.group("name")):
        return "ASSIGN", {"name": m.group("name"), "expr": m.group("expr").strip()}
    m = _CALL.match(line)
    if m and m.group("name").upper() not in _KEYWORDS and not re.match(r"(?i)^[A-Z]{1,2}\d", m.group("name")) and "(" in line:
        return "CALL", {"name": m.group("name"), "args": split_args(m.group("args") or "")}
    return None


def split_args(text: str) -> list[str]:
    """Comma-separated arguments at bracket depth 0."""
    args, depth, cur = [], 0, ""
    for ch in text:
        if ch == "," and depth == 0:
            args.append(cur.strip())
            cur = ""
            continue
        depth += ch in "([" and 1 or (-1 if ch in ")]" else 0)
        cur += ch
    if cur.strip():
        args.append(cur.strip())
    return args


def proc_signature(rest: str) -> tuple[str, list[str]]:
    """PROC NAME(REAL _A, INT _B) -> ('name', ['_a', '_b'])."""
    m = _PROC.match(rest)
    name = m.group(1).lower() if m else ""
    params = [p.split()[-1].lower() for p in split_args(m.group(2) or "")] if m else []
    return name, [re.sub(r"\[.*", "", p) for p in params]


def definitions(rest: str) -> tuple[str, list[tuple[str, str | None]]]:
    """DEF INT A, B=2 -> ('INT', [('a', None), ('b', '2')])."""
    parts = rest.split(None, 1)
    kind = parts[0].upper() if parts else ""
    names = []
    for item in split_args(parts[1] if len(parts) > 1 else ""):
        name, _, value = item.partition("=")
        names.append((re.sub(r"\[.*", "", name.strip()).lower(), value.strip() or None))
    return kind, names
