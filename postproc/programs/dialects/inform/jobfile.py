"""The layout of an INFORM job file (.JBI): its sections, the position table and the
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

Every header line (``///``) in the POS section holds until the next of its kind; a job
that states no ///POSTYPE has pulse positions (a teach pendant's job).

Bulk lines (a position of six plain numbers, a plain MOVJ / MOVL: CAM output's millions)
are recognised by shape (postproc.programs.parse.line_shapes) and read as arrays; every other line
is read one by one.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

import numpy as np

from ...parse.common import LineIndex, Numbers
from ...parse.line_shapes import LineShapes

NUM = r"[-+]?\d+(?:\.\d*)?"
DIGITS = re.compile("[0-9]+")  # (str.isdigit also takes '³')
# C00000= (robot), BC (base axes), EC (station axes), P / BP / EX (position variables saved
# with the job); four or more digits (older files: C0000=)
POSITION = re.compile(r"(C|BC|EC|P|BP|EX)(\d{4,})=")
NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)")
NUMBER_LIST = re.compile(r"[ \t]*[-+]?(?:\d+\.?\d*|\.\d+)(?:[ \t]*,[ \t]*[-+]?(?:\d+\.?\d*|\.\d+))*[ \t]*\r?")
BULK_POSITION = re.compile(rf"(?P<name>C\d+)=(?P<n0>{NUM}),(?P<n1>{NUM}),(?P<n2>{NUM}),(?P<n3>{NUM}),(?P<n4>{NUM}),(?P<n5>{NUM})\r?")
POSTYPES = ("PULSE", "BASE", "ROBOT", "USER", "TOOL", "MTOOL")
# Sections that hold no positions nor motions: a called job's argument types and comments, aliases.
SKIPPED = ("ARGINFO", "ALIAS")


@dataclass
class PositionState:
    """The header values in force at a position line of the POS section."""

    postype: str | None = None
    form: str = "PULSE"  # "PULSE" or "RECTAN"; PULSE where the job states neither (teach-pendant jobs)
    tool: int | None = None
    user: int | None = None
    rconf: tuple[int, ...] | None = None


@dataclass
class PositionTable:
    """Every position of the POS section: name -> row, its numbers, their spans, its state."""

    index: dict[str, int] = field(default_factory=dict)  # positions read one by one, by name
    bulk_numbers: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))  # the bulk block's C numbers (rows 0..)
    count_rows: int = 0
    lines: list[int] = field(default_factory=list)
    values: list = field(default_factory=list)  # per row: list of floats (any count), or a (M, 6) block
    spans: list = field(default_factory=list)
    state: list[int] = field(default_factory=list)


@dataclass
class JobFile:
    """A job's lines split into its sections: positions, instruction lines (not the bulk ones)."""

    name: str
    states: list[PositionState]
    positions: PositionTable
    instructions: list[tuple[int, int, str]] = field(default_factory=list)  # (line, offset, text)
    inst_headers: list[tuple[int, int, str]] = field(default_factory=list)  # ///DATE ... in //INST


def section_lines(text: str, lines: LineIndex) -> tuple[int, int]:
    """0-based line numbers of the //POS and //INST lines (-1 where absent)."""
    found = []
    for marker in ("//POS", "//INST"):
        at = text.find("\n" + marker)
        while at >= 0 and text[at + 1 + len(marker) : text.find("\n", at + 1) if text.find("\n", at + 1) >= 0 else len(text)].strip():
            at = text.find("\n" + marker, at + 1)  # a longer word (//POSX): not the section
        found.append(int(lines.line(at + 1)) - 1 if at >= 0 else -1)
    return found[0], found[1]


def c_numbers(raw: np.ndarray, start: np.ndarray, end: np.ndarray) -> np.ndarray:
    """The numbers of names 'C00012' spanning [start, end) (C, then digits): 12, vectorised."""
    width = end - start - 1
    if not len(width):
        return np.zeros(0, np.int64)
    k = np.arange(int(width.max()))
    digit = raw[np.minimum(start[:, None] + 1 + k[None, :], len(raw) - 1)].astype(np.int64) - 48
    power = np.where(k[None, :] < width[:, None], 10 ** np.maximum(width[:, None] - 1 - k[None, :], 0), 0)
    return (digit * power).sum(axis=1)


def read_job(text: str, path: str, lines: LineIndex, shapes: LineShapes, numbers: Numbers, bulk_moves: np.ndarray) -> JobFile:
    """The sections of the job ``text``; a ParseError at the line of anything that is not an
    INFORM job's. ``bulk_moves``: 0-based lines the caller reads as bulk motions (skipped here)."""
    starts = lines.starts.tolist()
    rows = text.split("\n")
    first = next((i for i, row in enumerate(rows) if row.strip()), None)
    if first is None or rows[first].strip().upper() != "/JOB":
        at = starts[first] if first is not None else 0
        raise lines.error(path, at, "not an INFORM job: the first line must be /JOB (Yaskawa job file format)")
    pos_line, inst_line = section_lines(text, lines)
    bulk = np.zeros(len(rows), bool)
    bulk[bulk_moves] = True
    job = JobFile(name="", states=[PositionState()], positions=PositionTable())
    bulk_pos = _bulk_positions(job, shapes, numbers, pos_line, inst_line, path, lines)
    bulk[bulk_pos] = True
    state_lines = [first]  # 0-based line where each state of job.states starts
    section = "JOB"
    for number in np.nonzero(~bulk[first + 1:])[0] + first + 1:
        number = int(number)
        start, stripped = starts[number], rows[number].rstrip("\r")
        if section == "POS" and stripped[:1] in ("C", "B", "E", "P"):
            _position(job, stripped, start, number + 1, path, lines)
        elif stripped.startswith("//") and not stripped.startswith("///"):
            section = _section(job, stripped, start, path, lines)
        elif stripped.startswith("///") and section == "POS":
            job.states.append(_pos_header(stripped, start, job.states[-1], path, lines))
            state_lines.append(number)
        elif stripped.startswith("///") and section == "INST":
            job.inst_headers.append((number + 1, start, stripped))
        elif section == "INST":
            job.instructions.append((number + 1, start, stripped))
        elif section not in SKIPPED and stripped.strip():
            raise lines.error(path, start, f"not part of the {section} section of an INFORM job")
    if section != "INST":
        raise lines.error(path, len(text), "no //INST section: the job has no instructions")
    # Bulk positions take the state in force at their line.
    table = job.positions
    if len(bulk_pos):
        states = np.searchsorted(np.array(state_lines), bulk_pos, side="right") - 1
        table.state[0] = states  # _bulk_positions left a placeholder first
    return job


def _bulk_positions(job: JobFile, shapes: LineShapes, numbers: Numbers, pos_line: int, inst_line: int, path: str, lines: LineIndex) -> np.ndarray:
    """Plain six-number C positions of the POS section, read as one block; their 0-based lines."""
    if pos_line < 0 or inst_line <= pos_line:
        return np.zeros(0, np.int64)
    found = shapes.match(BULK_POSITION, np.arange(pos_line + 1, inst_line))
    if not len(found):
        return np.zeros(0, np.int64)
    starts = np.stack([found.span(f"n{k}")[0] for k in range(6)], axis=1)
    ends = np.stack([found.span(f"n{k}")[1] for k in range(6)], axis=1)
    at = np.searchsorted(numbers.start, starts)
    values = numbers.value[np.minimum(at, len(numbers.value) - 1)]
    table = job.positions
    name_start, name_end = found.span("name")
    table.bulk_numbers = c_numbers(shapes.raw, name_start, name_end)
    table.count_rows = len(found)
    table.lines.append(found.line + 1)
    table.values.append(values)
    table.spans.append(np.stack([starts, ends], axis=2))
    table.state.append(None)  # set by read_job once the states are known
    ordered = np.sort(table.bulk_numbers, kind="stable")
    if len(ordered) > 1 and (np.diff(ordered) == 0).any():
        twice = np.nonzero(np.bincount(np.searchsorted(ordered, table.bulk_numbers), minlength=len(ordered)) > 1)[0]
        number = int(ordered[twice[0]])
        second = np.nonzero(table.bulk_numbers == number)[0][1]
        raise lines.error(path, int(found.start[second]), f"position C{number:05d} is defined twice")
    return found.line


@dataclass(frozen=True)
class Positions:
    """The position table as arrays: per row its line, state, count of numbers, the first six
    numbers (NaN-padded) and their (start, end) offsets (-1 padded)."""

    index: dict[str, int]
    bulk_numbers: np.ndarray
    line: np.ndarray
    state: np.ndarray
    count: np.ndarray
    values: np.ndarray
    spans: np.ndarray

    def rows_of_numbers(self, numbers: np.ndarray) -> np.ndarray:
        """Table rows of the bulk block's positions C<number> (-1 where none)."""
        if not len(self.bulk_numbers):
            return np.full(len(numbers), -1, np.int64)
        order = np.argsort(self.bulk_numbers, kind="stable")
        at = np.minimum(np.searchsorted(self.bulk_numbers, numbers, sorter=order), len(order) - 1)
        return np.where(self.bulk_numbers[order[at]] == numbers, order[at], -1)

    def row_of(self, name: str) -> int | None:
        """The table row of a position name (C00012, or a C0012 of the same number), None if absent."""
        if name in self.index:
            return self.index[name]
        if name[:1] == "C" and DIGITS.fullmatch(name[1:]):
            row = int(self.rows_of_numbers(np.array([int(name[1:])]))[0])
            return row if row >= 0 else None
        return None


def as_arrays(table: PositionTable) -> Positions:
    blocks = []
    for values, spans in zip(table.values, table.spans):
        if isinstance(values, np.ndarray):
            blocks.append((values, spans, np.full(len(values), 6)))
            continue
        row, span = np.full((1, 6), np.nan), np.full((1, 6, 2), -1, np.int64)
        k = min(len(values[0]), 6)
        row[0, :k], span[0, :k] = values[0][:k], np.array(spans[0][:k], np.int64).reshape(-1, 2)
        blocks.append((row, span, np.array([len(values[0])])))
    if not blocks:
        return Positions(table.index, table.bulk_numbers, np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros((0, 6)), np.zeros((0, 6, 2), np.int64))
    return Positions(table.index, table.bulk_numbers, np.concatenate(table.lines), np.concatenate(table.state), np.concatenate([b[2] for b in blocks]),
                     np.concatenate([b[0] for b in blocks]), np.concatenate([b[1] for b in blocks]))


def _section(job: JobFile, row: str, start: int, path: str, lines: LineIndex) -> str:
    word, _, rest = row[2:].partition(" ")
    word = word.strip().upper()
    if word == "NAME":
        job.name = rest.strip()
        return "JOB"
    if word in ("POS", "INST") or word in SKIPPED:
        return word
    raise lines.error(path, start, f"//{word}: not a section of an INFORM job (//NAME, //POS, //INST, {', '.join('//' + w for w in SKIPPED)})")


def _pos_header(row: str, start: int, state: PositionState, path: str, lines: LineIndex) -> PositionState:
    """The state after one ``///`` line of the POS section."""
    word, _, rest = row[3:].strip().partition(" ")
    word, rest = word.upper(), rest.strip()
    new = PositionState(**vars(state))
    if word == "NPOS":
        return new
    if word in ("PULSE", "RECTAN"):
        new.form = word
    elif word == "POSTYPE":
        if rest.upper() not in POSTYPES:
            raise lines.error(path, start + row.find(rest), f"///POSTYPE {rest}: not one of {', '.join(POSTYPES)}")
        new.postype = rest.upper()
        new.form = "PULSE" if new.postype == "PULSE" else new.form
    elif word in ("TOOL", "USER"):
        if not DIGITS.fullmatch(rest):
            raise lines.error(path, start + row.find(rest), f"///{word} needs a number, got '{rest}'")
        setattr(new, word.lower(), int(rest))
    elif word == "RCONF":
        bits = rest.split(",")
        if len(bits) < 6 or not all(DIGITS.fullmatch(b.strip()) for b in bits):
            raise lines.error(path, start + row.find(rest), "///RCONF needs at least six whole numbers (flip, arm, front/back, R, T, S)")
        new.rconf = tuple(int(b) for b in bits)
    else:
        raise lines.error(path, start, f"///{word}: a position header postproc does not read (it reads NPOS, TOOL, USER, POSTYPE, PULSE, RECTAN, RCONF)")
    return new


def _position(job: JobFile, row: str, start: int, line: int, path: str, lines: LineIndex) -> None:
    """One position line read on its own (blanks, another count of numbers, BC / EC / P)."""
    match = POSITION.match(row)
    if not match:
        raise lines.error(path, start, "not a position line (C00000=..., BC00000=..., EC00000=..., P00000=...)")
    body_start = match.end()
    if not NUMBER_LIST.fullmatch(row, body_start):
        raise lines.error(path, start + body_start, "a position is numbers separated by commas")
    numbers = list(NUMBER.finditer(row, body_start))
    name = f"{match.group(1)}{match.group(2)}"
    table = job.positions
    if name in table.index or (match.group(1) == "C" and (table.bulk_numbers == int(match.group(2))).any()):
        raise lines.error(path, start, f"{name} is defined twice")
    table.index[name] = table.count_rows
    table.count_rows += 1
    table.lines.append(np.array([line]))
    table.values.append([[float(m.group()) for m in numbers]])
    table.spans.append([[(start + m.start(), start + m.end()) for m in numbers]])
    table.state.append(np.array([len(job.states) - 1]))
