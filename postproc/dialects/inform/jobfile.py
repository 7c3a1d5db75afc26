"""The layout of an INFORM job file (.JBI): its sections, the position data and the
instruction lines, found with their offsets.

A job file (DX100 / YRC1000 "Data transmission function" manual, "Job data"):

    /JOB                        the file is a job
    //NAME name
    //POS                       position data follow
    ///NPOS c,bc,ec,p,bp,ex     how many of each kind of position
    ///TOOL n  ///USER n        tool / user frame number of the positions below
    ///POSTYPE PULSE|BASE|ROBOT|USER|TOOL|MTOOL
    ///PULSE  or  ///RECTAN     joint pulses, or Cartesian X,Y,Z (mm) Rx,Ry,Rz (deg)
    ///RCONF l,m,n,o,p,q,...    the form (figure) of the Cartesian positions below
    C00000=...                  one position (also BC/EC: base and station axes)
    //INST                      instructions follow
    ///DATE ... ///ATTR ... ///GROUP1 RB1
    NOP
    MOVJ C00000 VJ=50.00
    END

Every header line (``///``) in the POS section holds until the next of its kind.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

import numpy as np

from ...parse.common import LineIndex

# C00000= (robot), BC (base axes), EC (station axes); four or more digits (older files: C0000=)
POSITION = re.compile(r"(C|BC|EC)(\d{4,})=")
NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)")
NUMBER_LIST = re.compile(r"[ \t]*[-+]?(?:\d+\.?\d*|\.\d+)(?:[ \t]*,[ \t]*[-+]?(?:\d+\.?\d*|\.\d+))*[ \t]*\r?")
POSTYPES = ("PULSE", "BASE", "ROBOT", "USER", "TOOL", "MTOOL")


@dataclass
class PositionState:
    """The header values in force at a position line of the POS section."""

    postype: str | None = None
    form: str | None = None  # "PULSE" or "RECTAN"
    tool: int | None = None
    user: int | None = None
    rconf: tuple[int, ...] | None = None


@dataclass
class Position:
    """One position of the POS section: its numbers and their (start, end) offsets."""

    name: str
    line: int
    values: list[float]
    spans: list[tuple[int, int]]
    state: PositionState


@dataclass
class JobFile:
    """A job's lines split into its sections: positions by name, instruction lines."""

    name: str
    positions: dict[str, Position] = field(default_factory=dict)
    instructions: list[tuple[int, int, str]] = field(default_factory=list)  # (line, offset, text)
    inst_headers: list[tuple[int, int, str]] = field(default_factory=list)  # ///DATE ... in //INST


def line_starts(text: str) -> np.ndarray:
    raw = np.frombuffer(text.encode("latin-1"), dtype=np.uint8)
    return np.concatenate([[0], np.nonzero(raw == 10)[0] + 1]).astype(np.int64)


def read_job(text: str, path: str, lines: LineIndex) -> JobFile:
    """The sections of the job ``text``; a ParseError at the line of anything that is not an INFORM job's."""
    starts = lines.starts.tolist()
    rows = text.split("\n")
    first = next((i for i, row in enumerate(rows) if row.strip()), None)
    if first is None or rows[first].strip().upper() != "/JOB":
        at = starts[first] if first is not None else 0
        raise lines.error(path, at, "not an INFORM job: the first line must be /JOB (Yaskawa job file format)")
    job = JobFile(name="")
    section = "JOB"
    state = PositionState()
    for number in range(first + 1, len(rows)):
        row = rows[number]
        start = starts[number]
        stripped = row.rstrip("\r")
        if section == "POS" and stripped[:1] in "CBE" and stripped[:1]:
            _position(job, stripped, start, number + 1, state, path, lines)
            continue
        if stripped.startswith("//") and not stripped.startswith("///"):
            section = _section(job, stripped, start, path, lines)
            continue
        if stripped.startswith("///"):
            if section == "POS":
                state = _pos_header(stripped, start, state, path, lines)
            elif section == "INST":
                job.inst_headers.append((number + 1, start, stripped))
            continue
        if section == "INST":
            job.instructions.append((number + 1, start, stripped))
        elif stripped.strip():
            raise lines.error(path, start, f"not part of the {section} section of an INFORM job")
    if section != "INST":
        raise lines.error(path, len(text), "no //INST section: the job has no instructions")
    return job


def _section(job: JobFile, row: str, start: int, path: str, lines: LineIndex) -> str:
    word, _, rest = row[2:].partition(" ")
    word = word.strip().upper()
    if word == "NAME":
        job.name = rest.strip()
        return "JOB"
    if word in ("POS", "INST"):
        return word
    raise lines.error(path, start, f"//{word}: not a section of an INFORM job (//NAME, //POS, //INST)")


def _pos_header(row: str, start: int, state: PositionState, path: str, lines: LineIndex) -> PositionState:
    """The state after one ``///`` line of the POS section."""
    word, _, rest = row[3:].strip().partition(" ")
    word, rest = word.upper(), rest.strip()
    new = PositionState(**vars(state))
    if word in ("NPOS",):
        return new
    if word in ("PULSE", "RECTAN"):
        new.form = word
    elif word == "POSTYPE":
        if rest.upper() not in POSTYPES:
            raise lines.error(path, start + row.find(rest), f"///POSTYPE {rest}: not one of {', '.join(POSTYPES)}")
        new.postype = rest.upper()
        new.form = "PULSE" if new.postype == "PULSE" else new.form
    elif word in ("TOOL", "USER"):
        if not rest.isdigit():
            raise lines.error(path, start + row.find(rest), f"///{word} needs a number, got '{rest}'")
        setattr(new, word.lower(), int(rest))
    elif word == "RCONF":
        bits = rest.split(",")
        if len(bits) < 6 or not all(b.strip().isdigit() for b in bits):
            raise lines.error(path, start + row.find(rest), "///RCONF needs at least six whole numbers (flip, arm, front/back, R, T, S)")
        new.rconf = tuple(int(b) for b in bits)
    else:
        raise lines.error(path, start, f"///{word}: a position header postproc does not read (it reads NPOS, TOOL, USER, POSTYPE, PULSE, RECTAN, RCONF)")
    return new


def _position(job: JobFile, row: str, start: int, line: int, state: PositionState, path: str, lines: LineIndex) -> None:
    match = POSITION.match(row)
    if not match:
        raise lines.error(path, start, "not a position line (C00000=..., BC00000=..., EC00000=...)")
    body_start = match.end()
    if not NUMBER_LIST.fullmatch(row, body_start):
        raise lines.error(path, start + body_start, "a position is numbers separated by commas")
    numbers = list(NUMBER.finditer(row, body_start))
    name = f"{match.group(1)}{match.group(2)}"
    if name in job.positions:
        raise lines.error(path, start, f"{name} is defined twice (first on line {job.positions[name].line})")
    job.positions[name] = Position(name, line, [float(m.group()) for m in numbers],
                                   [(start + m.start(), start + m.end()) for m in numbers], state)
