"""Hypothesis strategies that write and break programs in the three dialects, and the judge.

Used by tests/test_fuzz_grammars.py (a few hundred examples in CI) and benchmarks/fuzz.py
(10^5). A program comes from one of two sources:
- generated: statements built from each grammar's constructs (moves with literal, named
  and computed targets, declarations, nested blocks, comments, CRLF or LF);
- seeded: a real public program of tests/corpus/real (where it is placed) or one of the
  project's own corpus files, or a window of its lines;
and is then mutated zero or more times: lines deleted, duplicated or swapped, characters
flipped, dialect tokens inserted, the text truncated.

The judge (``judge``): the parser either accepts the bytes, and parse + unchanged emit gives
the same bytes back, or refuses them with a ParseError naming the file, a line of the
input and a column (or a file-level InputError naming the file). Anything else is a crash.
"""

from __future__ import annotations

import os
import random
from pathlib import Path

from hypothesis import strategies as st

from postproc.errors import InputError, ParseError
from postproc.programs import emit_texts, parse_program

HERE = Path(__file__).parent
DIALECTS = ("rapid", "krl", "gcode")
FILE_NAME = {"rapid": "fuzz.mod", "krl": "fuzz.src", "gcode": "fuzz.ngc"}
SEED_LINES = 30  # a longer seed is cut to a window of this many lines (keeps one example fast)

TOKENS = {
    "rapid": ["MoveL ", "MoveJ ", "MoveC ", "MoveAbsJ ", "MoveLDO ", "SearchL ", "TriggL ", "MoveQ ", "IF ", " THEN", "ELSE",
              "ENDIF", "PROC main()", "ENDPROC", "FOR i FROM 1 TO 3 DO", "ENDFOR", "WHILE TRUE DO", "ENDWHILE", "TEST a",
              "CASE 1:", "DEFAULT:", "ENDTEST", ";", ":=", "\\WObj:=", "\\V:=", "\\Conc", "[", "]", ",", "(", ")", "{", "}",
              "!", '"', '""', "9E9", "CONNECT ", " WITH ", "ERROR", "ERROR (ERR_A)", "TRAP t", "ENDTRAP", "RECORD r",
              "ENDRECORD", "LOCAL ", "VAR ", "PERS ", "CONST ", "robtarget ", "wobjdata ", "tooldata ", "Offs(", "RelTool(",
              "MODULE M", "ENDMODULE", "%%%", ".trans", ".oframe", "MOD ", "NOT ", "\n", "\r\n", "1e308", "-", "0", "\t"],
    "krl": ["LIN ", "PTP ", "CIRC ", "SLIN ", "LIN_REL ", "{X 1", ", Y 2", ", A 0", "}", " C_DIS", " C_VEL", " C_PTP",
            "DECL ", "E6POS ", "FRAME ", "POS ", "INT ", "IF ", " THEN", "ELSE", "ENDIF", "FOR I=1 TO 3", "ENDFOR",
            "SWITCH I", "CASE 1", "DEFAULT", "ENDSWITCH", "LOOP", "ENDLOOP", "REPEAT", "UNTIL TRUE", "WHILE TRUE",
            "ENDWHILE", "$BASE=", "$TOOL=", "BASE_DATA[1]", "TOOL_DATA[1]", "DEF f( )", "END", "DEFDAT f", "ENDDAT",
            ";FOLD ", ";ENDFOLD", "&ACCESS RVP", "=", ":", "#", "GOTO M1", "M1:", "WAIT FOR ", "WAIT SEC 1",
            "TRIGGER WHEN DISTANCE=0 DELAY=0 DO ", "$OUT[1]=TRUE", "XP1", "\n", "\r\n", "1e308", "-", "0", "\t", '"'],
    "gcode": ["G0 ", "G1 ", "G2 ", "G3 ", "X", "Y", "Z", "A", "B", "C", "I", "J", "K", "R", "F", "P", "Q", "L", "G90",
              "G91", "G92 ", "G92.1", "G54", "G59.3", "G10 L2 P1 ", "G10 L20 P1 ", "G81 ", "G83 ", "G80", "G98", "G99",
              "#1=", "#<x>=", "#<_g>", "#5220", "[", "]", "o100 sub", "o100 endsub", "o100 call", "o1 while [#1 LT 3]",
              "o1 endwhile", "o1 do", "o1 if [1]", "o1 endif", "o1 repeat [2]", "o1 endrepeat", "(", ")", ";", "%", "/",
              "N10 ", "M2", "M30", "M98 P1", "G20", "G21", "G17", "G18", "G19", "G43 H1", "T1 M6", "sin[", "^", "G93",
              "G999", "\n", "\r\n", "1e308", "-", ".", "0", "\t"],
}

# ------------------------------------------------------------------ generators
# A generated program is drawn from one hypothesis-chosen seed (st.randoms): thousands of
# per-token draws through hypothesis cost ~100 ms a program, one Random costs nothing, and
# the failing bytes are reported with hypothesis.note by the caller.

NUMBER_WORDS = ["0", "-0", "0.0", ".5", "-.5", "1e3", "1E-3", "9E9", "9E+09", "1e308", "+1", "00012"]
NAMES = ["p1", "p2", "pA", "Target_10", "home", "XP1", "XP2", "wobj1", "tool1", "q", "n", "i"]


def number(rng: random.Random) -> str:
    r = rng.random()
    if r < 0.4:
        return str(rng.randint(-3000, 3000))
    if r < 0.85:
        return f"{rng.uniform(-3000, 3000):.{rng.randint(0, 6)}f}"
    return rng.choice(NUMBER_WORDS)


def numbers(rng: random.Random, n: int, sep: str = ",") -> str:
    return sep.join(number(rng) for _ in range(n))


def _body(rng: random.Random, simple, blocks, depth: int) -> list[str]:
    """1-4 statements; a statement is a block (with its own body) with a chance that falls with depth."""
    out = []
    for _ in range(rng.randint(1, 4)):
        if depth < 3 and rng.random() < 0.3 / (depth + 1):
            out += rng.choice(blocks)(rng, lambda: _body(rng, simple, blocks, depth + 1))
        else:
            out.append(simple(rng))
    return out


def _program_body(rng, simple, blocks, most: int) -> list[str]:
    return [s for _ in range(rng.randint(0, most)) for s in _body(rng, simple, blocks, 0)]


# RAPID ------------------------------------------------------------

def rapid_robtarget(rng: random.Random) -> str:
    q = rng.choice(["[1,0,0,0]", "[0,0,1,0]", "[0.7071,0,0.7071,0]"])
    ext = rng.choice(["[9E9,9E9,9E9,9E9,9E9,9E9]", "[0,9E9,9E9,9E9,9E9,9E9]"])
    return f"[[{numbers(rng, 3)}],{q},{rng.choice(['[0,0,0,0]', '[-1,0,-1,1]'])},{ext}]"


def rapid_target(rng: random.Random) -> str:
    return rng.choice([
        lambda: rapid_robtarget(rng),
        lambda: rng.choice(["p1", "p2", "path{2}", "path{i}"]),
        lambda: f"Offs({rng.choice(['p1', 'path{1}'])},{numbers(rng, 3)})",
        lambda: f"RelTool(Offs(p1,{numbers(rng, 3)}),0,0,10\\Rz:={number(rng)})",
    ])()


def rapid_move(rng: random.Random) -> str:
    tail = rng.choice([", v100, z1, tool0;", ", v500, fine, tool1\\WObj:=wobj1;", ", v200\\V:=300, z10\\Z:=5, tool0;"])
    return rng.choice([
        lambda: rng.choice(["MoveL ", "MoveJ ", "MoveL \\Conc, "]) + rapid_target(rng) + tail,
        lambda: f"MoveLDO {rapid_target(rng)}, v100, z1, tool0, do1, 1;",
        lambda: f"MoveC {rapid_target(rng)}, {rapid_target(rng)}{tail}",
        lambda: f"SearchL \\Stop, di1, sp, {rapid_target(rng)}, v100, tool0;",
        lambda: f"TriggL {rapid_target(rng)}, v500, trigg1, z50, tool0;",
        lambda: f"MoveAbsJ [[{numbers(rng, 6)}],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, tool0;",
    ])()


def rapid_simple(rng: random.Random) -> str:
    return rng.choice([
        lambda: rapid_move(rng), lambda: rapid_move(rng), lambda: rapid_move(rng),
        lambda: f"{rng.choice(NAMES)} := {number(rng)} * 2 + (3 MOD 2);",
        lambda: f"wobj1.oframe.trans := [{numbers(rng, 3)}];",
        lambda: "CONNECT intno1 WITH on_trap;", lambda: 'TPWrite "a ""quoted"" text";',
        lambda: "IF n > 1 RETURN;", lambda: f"IF n > 2 {rapid_move(rng)}",
        lambda: "WaitTime 0.5;  ! a comment", lambda: "Incr n;",
    ])()


RAPID_BLOCKS = [
    lambda rng, body: ["IF n > 0 THEN", *body(), "ENDIF"],
    lambda rng, body: ["IF n = 1 THEN", *body(), "ELSEIF n = 2 THEN", *body(), "ELSE", "ENDIF"],
    lambda rng, body: ["FOR i FROM 1 TO 4 DO", *body(), "ENDFOR"],
    lambda rng, body: ["WHILE n < 3 DO", *body(), "ENDWHILE"],
    lambda rng, body: ["TEST n", "CASE 1, 2:", *body(), "DEFAULT:", *body(), "ENDTEST"],
]


def rapid_program(rng: random.Random) -> bytes:
    data = [f"  CONST robtarget p1 := {rapid_robtarget(rng)};", f"  PERS robtarget p2 := {rapid_robtarget(rng)};",
            f"  CONST robtarget path{{2}} := [{rapid_robtarget(rng)},\n    {rapid_robtarget(rng)}];",
            "  PERS tooldata tool1 := [TRUE,[[0,0,150],[1,0,0,0]],[1,[0,0,1],[1,0,0,0],0,0,0]];",
            f"  PERS wobjdata wobj1 := [FALSE,TRUE,\"\",[[{numbers(rng, 3)}],[1,0,0,0]],[[0,0,0],[1,0,0,0]]];",
            "  VAR intnum intno1;"]
    body = _program_body(rng, rapid_simple, RAPID_BLOCKS, 4)
    lines = ["MODULE Fuzz", *rng.sample(data, rng.randint(0, len(data))), "  PROC main()", *("    " + s for s in body),
             "  ERROR (ERR_A, ERR_B)", "    RETRY;", "  ENDPROC", "  TRAP on_trap", "    n := 0;", "  ENDTRAP", "ENDMODULE", ""]
    return _join(lines, rng.random() < 0.5)


# KRL ---------------------------------------------------------------

def krl_pos(rng: random.Random) -> str:
    keys = rng.sample("XYZABC", rng.randint(1, 6))
    return "{" + ", ".join(f"{k} {number(rng)}" for k in keys) + (", S 6, T 27" if rng.random() < 0.5 else "") + "}"


def krl_simple(rng: random.Random) -> str:
    target = lambda: krl_pos(rng) if rng.random() < 0.7 else rng.choice(["XP1", "XP2", "XHOME"])  # noqa: E731
    approx = lambda: rng.choice(["", " C_DIS", " C_VEL", " C_PTP", " C_ORI"])  # noqa: E731
    return rng.choice([
        lambda: f"{rng.choice(['LIN ', 'PTP ', 'LIN_REL ', 'PTP_REL '])}{target()}{approx()}",
        lambda: f"{rng.choice(['LIN ', 'PTP '])}{target()}{approx()}",
        lambda: f"CIRC {target()}, {target()}{approx()}",
        lambda: f"$BASE = {krl_pos(rng)}", lambda: "$TOOL = TOOL_DATA[1]", lambda: "BAS(#BASE, 1)",
        lambda: f"XP1.X = XP1.X + {number(rng)}", lambda: "$VEL.CP = 0.2 ; comment",
        lambda: "WAIT SEC 0.5", lambda: "$OUT[3] = TRUE",
    ])()


KRL_BLOCKS = [
    lambda rng, body: ["IF N > 0 THEN", *body(), "ELSE", "ENDIF"],
    lambda rng, body: ["FOR I = 1 TO 3 STEP 1", *body(), "ENDFOR"],
    lambda rng, body: ["WHILE N < 3", *body(), "ENDWHILE"],
    lambda rng, body: ["REPEAT", *body(), "UNTIL N > 3"],
    lambda rng, body: ["LOOP", *body(), "EXIT", "ENDLOOP"],
    lambda rng, body: ["SWITCH N", "CASE 1", *body(), "DEFAULT", *body(), "ENDSWITCH"],
    lambda rng, body: [";FOLD moves", *body(), ";ENDFOLD"],
]


def krl_program(rng: random.Random) -> bytes:
    decls = ["DECL INT N", "DECL INT I", f"DECL E6POS XP1 = {krl_pos(rng)}", f"DECL FRAME F1 = {krl_pos(rng)}"]
    head = ["&ACCESS RVP", "&REL 1"] if rng.random() < 0.5 else []
    body = _program_body(rng, krl_simple, KRL_BLOCKS, 4)
    lines = [*head, "DEF fuzz( )", *rng.sample(decls, rng.randint(0, len(decls))), *body, "END", ""]
    return _join(lines, rng.random() < 0.5)


# G-code -------------------------------------------------------------

def gnumber(rng: random.Random) -> str:
    """A G-code number: no exponent ('X1e3' is X1 and an E word, which rs274 refuses)."""
    word = number(rng)
    return word if "e" not in word.lower() else str(rng.randint(-3000, 3000))


def gcode_simple(rng: random.Random) -> str:
    axes = lambda: " ".join(f"{k}{gnumber(rng)}" for k in rng.sample("XYZABC", rng.randint(1, 5)))  # noqa: E731
    return rng.choice([
        lambda: f"{rng.choice(['G0 ', 'G1 ', 'G01 ', 'N10 G1 ', '/G1 '])}{axes()}{rng.choice(['', ' F1500', ' F#1'])}",
        lambda: f"{rng.choice(['G0 ', 'G1 '])}{axes()}",
        lambda: f"{rng.choice(['G2 ', 'G3 '])}X{gnumber(rng)} Y{gnumber(rng)} I{gnumber(rng)} J{gnumber(rng)}",
        lambda: f"{rng.choice(['G2 ', 'G3 '])}X{gnumber(rng)} Y{gnumber(rng)} R{gnumber(rng)}",
        lambda: f"G81 X{gnumber(rng)} Y{gnumber(rng)} Z-1 R2 F100", lambda: "G80",
        lambda: rng.choice(["G90", "G91", "G20", "G21", "G17", "G18", "G19", "G54", "G55", "G59.3", "G93", "G94", "G43 H1", "T1 M6", "M3 S1000"]),
        lambda: f"G92 X{gnumber(rng)}", lambda: f"G10 L2 P1 X{gnumber(rng)} Y{gnumber(rng)}",
        lambda: f"#1 = [#1 + {gnumber(rng)}]", lambda: "#<depth> = -1.5", lambda: "G1 Z#<depth>",
        lambda: "(a comment)", lambda: "; comment", lambda: "G1 X[sin[30]*10] Y[2*#1]",
    ])()


GCODE_BLOCKS = [
    lambda rng, body: ["o10 if [#1 GT 0]", *body(), "o10 else", "o10 endif"],
    lambda rng, body: ["#2 = 0", "o20 while [#2 LT 3]", *body(), "#2 = [#2 + 1]", "o20 endwhile"],
    lambda rng, body: ["o30 repeat [2]", *body(), "o30 endrepeat"],
    lambda rng, body: ["o40 sub", *body(), "o40 endsub", "o40 call"],
]


def gcode_program(rng: random.Random) -> bytes:
    marks = rng.random() < 0.5
    body = _program_body(rng, gcode_simple, GCODE_BLOCKS, 5)
    lines = [*(["%"] if marks else []), "G21 G90 G17", "#1 = 1", *body, "M2", *(["%"] if marks else []), ""]
    return _join(lines, rng.random() < 0.5)


GENERATED = {"rapid": rapid_program, "krl": krl_program, "gcode": gcode_program}


def _join(lines: list[str], crlf: bool) -> bytes:
    return ("\r\n" if crlf else "\n").join(lines).encode("latin-1")


# ------------------------------------------------------------------ seeds and mutations

def seed_files(dialect: str) -> list[Path]:
    """The project's own corpus files of ``dialect`` and the real corpus where it is placed
    (tests/corpus/real/<dialect>, $POSTPROC_SHARED/corpus/real or ../shared beside the checkout)."""
    own = sorted((HERE / "corpus" / dialect).glob("*"))
    shared = Path(os.environ.get("POSTPROC_SHARED", HERE.parents[1] / "shared"))
    real = [p for root in (HERE / "corpus" / "real" / dialect, shared / "corpus" / "real" / dialect) if root.is_dir() for p in sorted(root.glob("*"))]
    return [p for p in own + real if p.is_file() and p.suffix.lower() != ".dat"]


def seeded_program(rng: random.Random, seeds: list[bytes]) -> bytes:
    """A seed program, or a window of SEED_LINES of its lines."""
    lines = rng.choice(seeds).splitlines(keepends=True)
    if len(lines) > SEED_LINES:
        first = rng.randint(0, len(lines) - SEED_LINES)
        lines = lines[first:first + SEED_LINES]
    return b"".join(lines)


MUTATIONS = ("delete lines", "duplicate a line", "swap lines", "flip a character", "insert a token", "truncate")


def mutate(rng: random.Random, data: bytes, dialect: str) -> bytes:
    """``data`` with 0-4 mutations."""
    return mutate_with(rng, data, TOKENS[dialect])


def mutate_with(rng: random.Random, data: bytes, tokens) -> bytes:
    """``data`` with 0-4 mutations, inserted tokens drawn from ``tokens`` (every language's fuzzer uses it)."""
    for _ in range(rng.randint(0, 4)):
        op = rng.choice(MUTATIONS)
        lines = data.splitlines(keepends=True)
        at_line = rng.randrange(len(lines)) if lines else 0
        at = rng.randint(0, len(data))
        if op == "delete lines":
            data = b"".join(lines[:at_line] + lines[at_line + rng.randint(1, 3):])
        elif op == "duplicate a line":
            data = b"".join(lines[:at_line + 1] + lines[at_line:])
        elif op == "swap lines" and len(lines) > 1:
            other = rng.randrange(len(lines))
            lines[at_line], lines[other] = lines[other], lines[at_line]
            data = b"".join(lines)
        elif op == "flip a character" and data:
            at = min(at, len(data) - 1)
            data = data[:at] + bytes([rng.randrange(256)]) + data[at + 1:]
        elif op == "insert a token":
            data = data[:at] + rng.choice(tokens).encode("latin-1") + data[at:]
        elif op == "truncate":
            data = data[:at]
    return data


def make_program(rng: random.Random, dialect: str, seeds: list[bytes]) -> bytes:
    """A generated program (half the time, or always without seeds) or a seed; then mutated."""
    data = GENERATED[dialect](rng) if not seeds or rng.random() < 0.5 else seeded_program(rng, seeds)
    return mutate(rng, data, dialect)


def programs(dialect: str, seeds: list[bytes]) -> st.SearchStrategy:
    """Hypothesis strategy: generated or seeded programs of ``dialect``, mutated."""
    return st.randoms(use_true_random=True).map(lambda rng: make_program(rng, dialect, seeds))


# ------------------------------------------------------------------ the judge

def judge(dialect: str, data: bytes) -> str:
    """``judge_file`` under the dialect's usual file name."""
    return judge_file(FILE_NAME[dialect], dialect, data)


def judge_file(name: str, dialect: str, data: bytes) -> str:
    """'accepted' (and round-tripped), 'refused' (ParseError with file, line and column) or
    'refused-file' (InputError naming the file). Raises AssertionError on a wrong refusal or a
    changed text; any other exception is the parser's crash and propagates."""
    try:
        tp = parse_program(name, dialect, data)
    except ParseError as exc:
        n_lines = data.count(b"\n") + 1
        assert exc.path == name and 1 <= exc.line <= n_lines and exc.column >= 1, f"refused without a usable position: {exc!r}"
        assert str(exc).startswith(f"{name}:{exc.line}:{exc.column}: "), str(exc)
        return "refused"
    except InputError as exc:
        assert name in str(exc), f"a refusal that does not name the file: {exc}"
        return "refused-file"
    texts = emit_texts(tp, tp)
    assert len(texts) == 1 and texts[0].encode("latin-1") == data, "accepted, but parse + emit changed the text"
    return "accepted"