"""A process force per motion block (``compensate --force-file FORCES.csv``).

The CSV (',' separator, '.' decimal mark, a header row) has the columns ``line``, ``fx``,
``fy``, ``fz`` and optionally ``file``:

    line,fx,fy,fz
    12,0,-150,40
    13,0,-180,45

Each row gives the force (N, tool frame, as ``--force``) on the tool during the motion
whose statement is on that line of the program (``file``: which of the program's files, by
name, where it spans several — a RAPID program's modules; default the program's own
file). Both targets of a circular motion get it. A motion without a row has no process
force (an air move), and the caller says how many those are. Every problem is an
``InputError`` naming the CSV file, row and column: unknown or missing columns, a cell
that is not a finite number, a force over ``MAX_FORCE_N``, a line twice, a line that holds
no Cartesian motion of the program.
"""

from __future__ import annotations

import csv
import io
import math
from pathlib import Path

import numpy as np

from postproc.errors import InputError, located
from postproc.programs.ir import Kind, Toolpath

COLUMNS = ("line", "fx", "fy", "fz")
MAX_FORCE_N = 50_000.0  # more than any robot's process force: a unit or column mix-up


class ForceFileError(InputError):
    """A force file is malformed: names the file, the CSV row and the column."""

    def __init__(self, path, row, column, message):
        super().__init__(f"{located(path, 'row', row, column)}: {message}")


def read_force_file(path: str | Path, tp: Toolpath) -> tuple[np.ndarray, int]:
    """Tool-frame forces (N, 3) of every target of ``tp`` from the CSV at ``path`` (zero where
    the file has no row), and how many Cartesian motions have no row."""
    path = Path(path)
    try:
        text = path.read_bytes().decode("utf-8-sig")
    except OSError as exc:
        raise ForceFileError(path, None, None, f"cannot read ({exc.strerror})") from None
    except UnicodeDecodeError as exc:
        raise ForceFileError(path, None, None, f"not UTF-8 text (byte {exc.start})") from None
    rows = list(csv.reader(io.StringIO(text)))
    header = _header(path, rows)
    forces = np.zeros((len(tp), 3))
    given = np.zeros(len(tp), dtype=bool)
    names = [Path(doc.path).name for doc in tp.sources]
    for number, row in enumerate(rows[1:], start=2):
        if not any(cell.strip() for cell in row):
            continue
        if len(row) != len(header):
            raise ForceFileError(path, number, None, f"{len(row)} cells, the header has {len(header)}")
        cells = {name: cell.strip() for name, cell in zip(header, row)}
        source = _source(path, number, cells.get("file"), names)
        line = _integer(path, number, cells["line"])
        force = np.array([_number(path, number, c, cells[c]) for c in ("fx", "fy", "fz")])
        targets = np.nonzero((tp.line == line) & (tp.file == source) & (tp.kind != Kind.ABSJ))[0]
        if not len(targets):
            raise ForceFileError(path, number, "line", f"line {line} of {names[source]} holds no Cartesian motion of the program")
        if given[targets].any():
            raise ForceFileError(path, number, "line", f"line {line} of {names[source]} has a force already")
        forces[targets], given[targets] = force, True
    if not given.any():
        raise ForceFileError(path, 2, None, "no data rows")
    return forces, int(((tp.kind != Kind.ABSJ) & ~given).sum())


def base_frame_forces(tp_placed: Toolpath, tool_frame: np.ndarray) -> np.ndarray:
    """The tool-frame forces (N, 3) as base-frame forces at each target's orientation."""
    return np.einsum("nij,nj->ni", tp_placed.base_poses()[:, :3, :3], tool_frame)


def _header(path: Path, rows: list[list[str]]) -> list[str]:
    if not rows or not any(cell.strip() for cell in rows[0]):
        raise ForceFileError(path, 1, None, "empty file: expected the header line,fx,fy,fz")
    header = [h.strip().lower() for h in rows[0]]
    for col, name in enumerate(header):
        if name not in COLUMNS + ("file",):
            raise ForceFileError(path, 1, name, f"unknown column (columns: {', '.join(COLUMNS)}, optional file)")
        if header.index(name) != col:
            raise ForceFileError(path, 1, name, "column appears twice")
    missing = [c for c in COLUMNS if c not in header]
    if missing:
        raise ForceFileError(path, 1, missing[0], f"required column missing (missing: {', '.join(missing)})")
    return header


def _source(path: Path, number: int, name: str | None, names: list[str]) -> int:
    if not name:
        return 0
    if name not in names:
        raise ForceFileError(path, number, "file", f"'{name}' is none of the program's files ({', '.join(names)})")
    return names.index(name)


def _integer(path: Path, number: int, cell: str) -> int:
    try:
        value = int(cell)
    except ValueError:
        raise ForceFileError(path, number, "line", f"'{cell}' is not a line number") from None
    if value < 1:
        raise ForceFileError(path, number, "line", f"line numbers start at 1, got {value}")
    return value


def _number(path: Path, number: int, column: str, cell: str) -> float:
    try:
        value = float(cell)
    except ValueError:
        raise ForceFileError(path, number, column, f"'{cell}' is not a number") from None
    if not math.isfinite(value):
        raise ForceFileError(path, number, column, f"'{cell}' is not a finite number")
    if abs(value) > MAX_FORCE_N:
        raise ForceFileError(path, number, column, f"{value:g} N is over {MAX_FORCE_N:g} N: a unit or column mix-up?")
    return value
