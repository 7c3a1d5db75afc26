"""Fuzzing the Fanuc TP reader: generated and mutated .ls programs, and the judge (as
tests/fuzzing.py does for RAPID, KRL and G-code; kept apart so that the languages' fuzzers
change independently). Used by tests/test_fanuc_fuzz.py and benchmarks/fuzz_fanuc.py."""

from __future__ import annotations

import random
from pathlib import Path

import fuzzing

HERE = Path(__file__).parent
NAME = "fuzz.ls"
TOKENS = ["J ", "L ", "C ", "A ", "P[1]", "PR[2]", " 100%", " 500mm/sec", " 60cm/min", " FINE", " CNT100", " CNT R[1]", " Offset,PR[3]",
          " Tool_Offset,PR[4]", " INC", " Wjnt", " ACC80", " COORD", ";", ":", "\n", "/POS", "/MN", "/END", "P[2]{", "};", "GP1:", "GP2:",
          "UF : 1, UT : 2,", "CONFIG : 'F D B, 1, 0, -1',", "X = 1.5 mm,", "J3= -10 deg,", "E1 = 5 mm", "UFRAME_NUM=3 ;", "UTOOL[1]=PR[1] ;",
          "!comment ;", "//L P[1] ;", "JMP LBL[1] ;", "IF R[1]=1,JMP LBL[2] ;", "CALL SUB ;", "\"", "'", "{", "}", "-", ".", "e5"]


def number(rng: random.Random) -> str:
    return rng.choice([f"{rng.uniform(-2000, 2000):.3f}", f"{rng.uniform(-180, 180):.3f}", "0.000", "-.500", "12", "1e3"])


def position(rng: random.Random, n: int) -> list[str]:
    label = rng.choice(["", ':"pt"'])
    head = [f"P[{n}{label}]{{", "   GP1:"]
    uf, ut = rng.choice(["0", "1", "F"]), rng.choice(["0", "1", "2"])
    if rng.random() < 0.75:
        conf = rng.choice(["N U T, 0, 0, 0", "F D B, 1, -1, 0", "N U T"])
        return head + [f"\tUF : {uf}, UT : {ut},\t\tCONFIG : '{conf}',",
                       f"\tX = {number(rng)}  mm,\tY = {number(rng)}  mm,\tZ = {number(rng)}  mm,",
                       f"\tW = {number(rng)} deg,\tP = {number(rng)} deg,\tR = {number(rng)} deg", "};"]
    return head + [f"\tUF : {uf}, UT : {ut},\t", ",\t".join(f"J{i}= {number(rng)} deg" for i in (1, 2, 3)) + ",",
                   ",\t".join(f"J{i}= {number(rng)} deg" for i in (4, 5, 6)), "};"]


def program(rng: random.Random) -> bytes:
    """A TP listing the reader accepts (before mutations)."""
    n_pos = rng.randint(1, 6)
    mn = [rng.choice(["  UFRAME_NUM=0", "  UFRAME_NUM=1", "  !setup"]), "  UTOOL_NUM=1"]
    for _ in range(rng.randint(1, 10)):
        p = rng.randint(1, n_pos)
        motion = rng.choice(["J", "L", "L", "C", "A"])
        speed = "100%" if motion == "J" else rng.choice(["500mm/sec", "60cm/min", "R[1]mm/sec"])
        term = rng.choice([" FINE", " CNT100", " CNT R[2]"])
        option = rng.choice(["", "", " ACC80", " Offset,PR[1]", " Wjnt"])
        if motion == "C":
            mn.append(f"C P[{p}]    ")
            mn.append(f"    :  P[{rng.randint(1, n_pos)}] {speed}{term}{option}")
        else:
            mn.append(f"{motion} P[{p}] {speed}{term}{option}")
        if rng.random() < 0.2:
            mn.append(rng.choice(["  JMP LBL[1]", "  LBL[1]", "  R[1]=R[1]+1", "  CALL SUB", "  WAIT DI[1]=ON", "  UFRAME[1]=PR[5]"]))
    body, k = [], 0
    for line in mn:
        if line.startswith("    :"):  # the end point of a C motion: its first line stays open
            body.append(line + " ;")
            continue
        k += 1
        body.append(f"{k:4d}:{line}" + ("" if line.startswith("C ") else " ;"))
    pos = [row for n in range(1, n_pos + 1) for row in position(rng, n)]
    lines = ["/PROG  FUZZ", "/ATTR", "OWNER\t\t= MNEDITOR;", "DEFAULT_GROUP\t= 1,*,*,*,*;", "/MN", *body, "/POS", *pos, "/END", ""]
    return ("\r\n" if rng.random() < 0.3 else "\n").join(lines).encode("latin-1")


def seeds() -> list[bytes]:
    return [p.read_bytes() for p in sorted((HERE / "corpus" / "fanuc").glob("*.ls"))] + [(HERE / "data" / "fanuc_sample.ls").read_bytes()]


def mutate(rng: random.Random, data: bytes) -> bytes:
    """``data`` with 0-4 of tests/fuzzing.py's mutations, TP tokens inserted."""
    return fuzzing.mutate_with(rng, data, TOKENS)


def make_program(rng: random.Random, seed_texts: list[bytes]) -> bytes:
    return mutate(rng, program(rng) if rng.random() < 0.6 else rng.choice(seed_texts))


def judge(data: bytes) -> str:
    """tests/fuzzing.py's judge of a .ls file: 'accepted' (round-tripped byte-identically) or
    'refused' with a line and column (or naming the file); AssertionError otherwise."""
    verdict = fuzzing.judge_file(NAME, "fanuc", data)
    return "refused" if verdict == "refused-file" else verdict