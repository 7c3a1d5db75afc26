"""The words of a Klartext path block (L, LN, C, CC, CR, CT, LP, CP): each with its span.

TNC 640 User's Manual, "Path contours - Cartesian coordinates" and "- polar coordinates":
an axis word is the letter, an optional I (incremental) and a signed number or a Q
parameter (``X+10``, ``IZ-2.5``, ``X+Q11``, ``Z + Q13``); ``R0``/``RL``/``RR`` radius
compensation; ``F``/``FMAX``/``FAUTO``/``FQ5`` feed; ``M`` functions; ``DR+``/``DR-``
direction of rotation; ``R`` the arc radius of CR; ``PR``/``PA`` polar radius and angle."""

from __future__ import annotations

import re
from dataclasses import dataclass

from .qparams import QNAME

NUM = r"\d+\.?\d*|\.\d+"
_WORD = re.compile(
    r"\s*(?:"
    r"(?P<m>M)(?P<mnum>\d+)"
    rf"|(?P<fmax>FMAX|FAUTO|FU|FZ)(?![A-Z])"
    rf"|(?P<f>F)\s*(?P<fval>[+]?(?:{NUM})|{QNAME})"
    r"|(?P<comp>R0|RL|RR)(?![\d.])"
    r"|(?P<dr>DR)\s*(?P<drs>[+-])"
    rf"|(?P<word>I?(?:PR|PA|NX|NY|NZ|TX|TY|TZ|X|Y|Z|A|B|C|U|V|W|R))\s*(?P<val>[+-]?(?:{NUM})|[+-]?\s*{QNAME}|[+-]\s+(?:{NUM}))"
    r")",
    re.IGNORECASE)


@dataclass
class Word:
    letter: str  # upper case, without the I: X, Y, Z, A, B, C, PR, PA, R, NX ...
    incremental: bool
    text: str  # the value as written ('+10', 'Q5', '-Q5')
    start: int  # offset of the value in the file (where a number is spliced)
    end: int
    plain: bool  # a plain number (sign attached): it can be rewritten in place


@dataclass
class PathWords:
    words: dict[str, Word]
    comp: str | None = None  # R0 / RL / RR
    feed: Word | None = None
    rapid: bool = False  # FMAX
    feed_other: tuple[str, int] | None = None  # FAUTO / FU / FZ and its offset
    m: list[tuple[int, int]] | None = None  # (M number, offset)
    dr: str | None = None


class WordError(Exception):
    def __init__(self, at: int, message: str):
        self.at = at
        super().__init__(message)


def read_words(text: str, start: int, base: int) -> PathWords:
    """Words of ``text[start:]``; ``base`` is the file offset of text[0]."""
    out = PathWords({}, m=[])
    pos, n = start, len(text)
    while pos < n:
        if text[pos:].strip() == "":
            break
        m = _WORD.match(text, pos)
        if not m:
            at = pos + len(text[pos:]) - len(text[pos:].lstrip())
            raise WordError(base + at, f"'{text[at:].split()[0]}' is not a word of this block the reader knows")
        pos = m.end()
        if m.group("m"):
            out.m.append((int(m.group("mnum")), base + m.start("m")))
        elif m.group("fmax"):
            key = m.group("fmax").upper()
            if key == "FMAX":
                out.rapid = True
            else:
                out.feed_other = (key, base + m.start("fmax"))
        elif m.group("f"):
            if out.feed is not None:  # M103 F20 (a plunging feed factor) or a second feed
                raise WordError(base + m.start("f"), "a second F in one block (M103 F.. feed factor?) is not read")
            out.feed = _word("F", False, m, "fval", base)
        elif m.group("comp"):
            out.comp = m.group("comp").upper()
        elif m.group("dr"):
            out.dr = m.group("drs")
        else:
            name = m.group("word").upper()
            inc = name.startswith("I")
            letter = name[1:] if inc else name
            if letter in out.words:
                raise WordError(base + m.start("word"), f"{letter} twice in one block")
            out.words[letter] = _word(letter, inc, m, "val", base)
    return out


def _word(letter: str, inc: bool, m: re.Match, group: str, base: int) -> Word:
    value = m.group(group)
    plain = re.fullmatch(rf"[+-]?(?:{NUM})", value) is not None
    return Word(letter, inc, value, base + m.start(group), base + m.end(group), plain)
