"""Measurement sets (spec/measurements.md): read, validate, write.

A measurement set holds commanded joints and measured TCP positions, plus the optional
columns the error effects need (forces, approach directions, temperature, time). Every
problem in a file is reported with the file, its line number and the column.
"""

from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from postproc.errors import MeasurementError
from postproc.files import write_all

from .path_history import previous_targets

JOINTS = tuple(f"q{i}" for i in range(1, 7))
MEASURED = ("mx", "my", "mz")
NOMINAL = ("x", "y", "z")
FORCES = ("fx", "fy", "fz")
APPROACH = tuple(f"s{i}" for i in range(1, 7))
OPTIONAL_GROUPS = {"nominal": NOMINAL, "force": FORCES, "approach": APPROACH, "temp": ("temp",), "t": ("t",)}


@dataclass(frozen=True)
class MeasurementSet:
    """One measured pose per row, in measurement order. Optional groups are None when absent."""

    q_deg: np.ndarray  # (N, 6) commanded joints
    measured_mm: np.ndarray  # (N, 3) measured TCP, robot base (or tracker) frame
    ids: tuple[str, ...]
    nominal_mm: np.ndarray | None = None  # (N, 3)
    force_n: np.ndarray | None = None  # (N, 3)
    approach: np.ndarray | None = None  # (N, 6) of +-1
    temp_c: np.ndarray | None = None  # (N,)
    time_s: np.ndarray | None = None  # (N,)
    source: str = "<memory>"
    extra: dict[str, np.ndarray] = field(default_factory=dict)
    lines: tuple[int, ...] | None = None  # file line of each row, for messages (None: not from a file)
    # (N, k, 6) the targets before each pose in measurement order (postproc.model.path_history):
    # derived from the whole set, kept by subset() (a subset's rows are no longer consecutive)
    previous_q_deg: np.ndarray | None = None

    def __len__(self) -> int:
        return self.q_deg.shape[0]

    def path_history(self) -> np.ndarray:
        """(N, k, 6) the targets before each pose: ``previous_q_deg`` where the set carries it (a
        subset of a larger set), else from its own rows, which are in the order they were measured."""
        return self.previous_q_deg if self.previous_q_deg is not None else previous_targets(self.q_deg)

    def has(self, group: str) -> bool:
        """Whether the optional column group ('force', 'approach', 'temp', 't', 'nominal') is present."""
        return getattr(self, _GROUP_FIELD[group]) is not None

    def subset(self, index) -> "MeasurementSet":
        """Rows selected by a boolean mask or an index array, order kept."""
        idx = np.asarray(index)
        pick = lambda a: None if a is None else a[idx]  # noqa: E731
        ids = np.asarray(self.ids, dtype=object)[idx]
        return MeasurementSet(
            q_deg=self.q_deg[idx],
            measured_mm=self.measured_mm[idx],
            ids=tuple(ids.tolist()),
            nominal_mm=pick(self.nominal_mm),
            force_n=pick(self.force_n),
            approach=pick(self.approach),
            temp_c=pick(self.temp_c),
            time_s=pick(self.time_s),
            source=self.source,
            extra={k: v[idx] for k, v in self.extra.items()},
            lines=None if self.lines is None else tuple(np.asarray(self.lines)[idx].tolist()),
            previous_q_deg=pick(self.previous_q_deg),
        )

    def line_of(self, row: int) -> int | None:
        """The file line of row ``row`` (0-based), when the set was read from a file."""
        return None if self.lines is None else self.lines[row]


_GROUP_FIELD = {"nominal": "nominal_mm", "force": "force_n", "approach": "approach", "temp": "temp_c", "t": "time_s"}


def group_column(meas: MeasurementSet, column: str, why: str) -> np.ndarray:
    """An integer group id per row from an extra column (e.g. 'point', 'session'); refuse its
    absence (``why``: what needs it) and any value that is not a whole number."""
    if column not in meas.extra:
        raise MeasurementError(meas.source, 1, column, f"column missing: {why} (postproc import-ur10 writes it)")
    values = meas.extra[column]
    bad = np.nonzero(~np.isfinite(values) | (values != np.round(values)))[0]
    if bad.size:
        raise MeasurementError(meas.source, meas.line_of(int(bad[0])), column, f"a group id must be a whole number, got {values[bad[0]]:g}")
    return values.astype(np.int64)


def read_measurements(path: str | Path) -> MeasurementSet:
    """Read and validate a measurement CSV; raise MeasurementError naming line and column."""
    path = Path(path)
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise MeasurementError(path, None, None, f"cannot read: {exc.strerror}") from None
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = raw[: exc.start].count(b"\n") + 1
        raise MeasurementError(path, line, None, "not UTF-8 text") from None
    return parse_measurements(text, str(path))


def parse_measurements(text: str, source: str) -> MeasurementSet:
    rows = list(csv.reader(io.StringIO(text)))
    # Keep the file line of each CSV row for messages (csv rows can span lines only when
    # quoted; measurement files never quote, so count physical lines).
    lines = [i + 1 for i, r in enumerate(rows)]
    if not rows or not any(cell.strip() for cell in rows[0]):
        raise MeasurementError(source, 1, None, "empty file: expected a header row")
    header = [h.strip() for h in rows[0]]
    if len(header) == 1 and (";" in header[0] or "\t" in header[0]):
        raise MeasurementError(source, 1, None, "header is not comma-separated (spec/measurements.md: ',' separator, '.' decimal mark)")
    seen = {}
    for col, name in enumerate(header):
        if name in seen:
            raise MeasurementError(source, 1, name, f"column appears twice (columns {seen[name] + 1} and {col + 1})")
        seen[name] = col
    missing = [c for c in JOINTS + MEASURED if c not in seen]
    if missing:
        raise MeasurementError(source, 1, missing[0], f"required column missing (missing: {', '.join(missing)})")
    for group, cols in OPTIONAL_GROUPS.items():
        present = [c for c in cols if c in seen]
        if present and len(present) != len(cols):
            absent = [c for c in cols if c not in seen]
            raise MeasurementError(source, 1, absent[0], f"incomplete column group: has {', '.join(present)} but not {', '.join(absent)}")

    body = [(line, row) for line, row in zip(lines[1:], rows[1:]) if any(cell.strip() for cell in row)]
    if not body:
        raise MeasurementError(source, 2, None, "no data rows")
    numeric_cols = [c for c in header if c != "id"]
    data = {c: np.empty(len(body)) for c in numeric_cols}
    ids = []
    for r, (line, row) in enumerate(body):
        if len(row) != len(header):
            raise MeasurementError(source, line, None, f"{len(row)} cells, the header has {len(header)}")
        for c in numeric_cols:
            cell = row[seen[c]].strip()
            try:
                value = float(cell)
            except ValueError:
                hint = " (use '.' as decimal mark)" if "," in cell else ""
                raise MeasurementError(source, line, c, f"not a number: '{cell}'{hint}") from None
            if not math.isfinite(value):
                raise MeasurementError(source, line, c, f"not a finite number: '{cell}'")
            data[c][r] = value
        ids.append(row[seen["id"]].strip() if "id" in seen else str(r + 1))
    if "id" in seen:
        first = {}
        for (line, _), ident in zip(body, ids):
            if ident == "":
                raise MeasurementError(source, line, "id", "empty id")
            if ident in first:
                raise MeasurementError(source, line, "id", f"duplicate id '{ident}' (first on line {first[ident]})")
            first[ident] = line

    _check_magnitudes(source, body, data)
    _check_joint_magnitudes(source, body, data)
    measured = np.column_stack([data[c] for c in MEASURED])
    _check_millimetres(source, body, measured, MEASURED)
    q = np.column_stack([data[c] for c in JOINTS])
    if np.abs(q).max() <= 2 * math.pi and np.abs(q).max() > 0 and len(q) >= 5:
        line = body[int(np.argmax(np.abs(q).max(axis=1)))][0]
        raise MeasurementError(source, line, "q1", "every joint value is within +-2*pi: these look like radians; the schema wants degrees")
    group = lambda cols: np.column_stack([data[c] for c in cols]) if cols[0] in seen else None  # noqa: E731
    nominal = group(NOMINAL)
    if nominal is not None:
        _check_millimetres(source, body, nominal, NOMINAL)
    approach = group(APPROACH)
    if approach is not None:
        bad = np.nonzero(np.abs(approach) != 1)
        if bad[0].size:
            raise MeasurementError(source, body[bad[0][0]][0], APPROACH[bad[1][0]], f"approach direction must be +1 or -1, got {approach[bad][0]:g}")
    extra_cols = [c for c in numeric_cols if c not in set(JOINTS + MEASURED + NOMINAL + FORCES + APPROACH + ("temp", "t"))]
    return MeasurementSet(
        q_deg=q,
        measured_mm=measured,
        ids=tuple(ids),
        nominal_mm=nominal,
        force_n=group(FORCES),
        approach=approach,
        temp_c=data["temp"] if "temp" in seen else None,
        time_s=data["t"] if "t" in seen else None,
        source=source,
        extra={c: data[c] for c in extra_cols},
        lines=tuple(line for line, _ in body),
    )


# Positions farther than this from the origin are no robot cell's (the largest industrial
# arms reach about 4 m): such a value is a unit or export error, never data to fit.
ABSURD_POSITION_MM = 10_000.0
_POSITION_COLUMNS = MEASURED + NOMINAL


def _check_magnitudes(source, body, data) -> None:
    """Refuse positions beyond 10 m (a unit or export error), naming the first such cell."""
    for col in _POSITION_COLUMNS:
        if col not in data:
            continue
        bad = np.nonzero(np.abs(data[col]) > ABSURD_POSITION_MM)[0]
        if bad.size:
            value = data[col][bad[0]]
            raise MeasurementError(source, body[bad[0]][0], col, f"{value:g} mm is more than 10 m from the origin: not a position of a robot cell")


# No revolute joint of an industrial arm turns further than one full turn either way (the
# widest, UR10's, is +-360 deg): a larger value is a unit or export error, whatever the limits.
ABSURD_JOINT_DEG = 360.0

# Limits a robot file marks as estimates may be wrong by this much before a measured joint
# beyond them is refused rather than kept with a warning. The bundled KR160 R1570's limits
# are commonly published data-sheet ranges converted into the file's DH convention, and
# the project's own KR160 sets (data/kr160_dev_*) reach up to 49.6 deg beyond them (A3 down
# to -149.6 against -100, A5 up to 169.3 against +120): 60 deg keeps such sets and still
# refuses values no error of a data sheet explains.
ESTIMATED_LIMIT_MARGIN_DEG = 60.0


def _check_joint_magnitudes(source, body, data) -> None:
    """Refuse joint values beyond +-360 deg (a unit or export error), naming the first such cell."""
    for col in JOINTS:
        bad = np.nonzero(np.abs(data[col]) > ABSURD_JOINT_DEG)[0]
        if bad.size:
            value = data[col][bad[0]]
            raise MeasurementError(source, body[bad[0]][0], col, f"{value:g} deg is beyond +-{ABSURD_JOINT_DEG:g} deg: "
                                   "no revolute joint turns that far (a unit or export error)")


def check_joint_limits(meas: MeasurementSet, lower_deg: np.ndarray, upper_deg: np.ndarray, drop_invalid: bool = False,
                       margin_deg: float = 0.0) -> tuple[MeasurementSet, list[str]]:
    """Rows whose joints lie more than ``margin_deg`` outside the robot's limits: an error
    naming the first row's line and column, or (``drop_invalid``) the set without them and
    one message per dropped row. (A margin is for limits that are only estimates; rows
    within it are ``outside_limits``' warnings.)"""
    lower, upper = lower_deg - margin_deg, upper_deg + margin_deg
    outside = (meas.q_deg < lower - 1e-9) | (meas.q_deg > upper + 1e-9)
    bad_rows = np.nonzero(outside.any(axis=1))[0]
    if bad_rows.size == 0:
        return meas, []
    beyond = f" by more than the {margin_deg:g} deg allowed for limits marked as estimates" if margin_deg else ""

    def message(row: int) -> tuple[int, str]:
        j = int(np.argmax(outside[row]))
        return j, f"{meas.q_deg[row, j]:g} deg is outside the robot's limits [{lower_deg[j]:g}, {upper_deg[j]:g}]{beyond}"

    if not drop_invalid:
        j, text = message(int(bad_rows[0]))
        raise MeasurementError(meas.source, meas.line_of(int(bad_rows[0])), f"q{j + 1}",
                               f"{text} ({bad_rows.size} row(s) in all; --drop-invalid drops and lists them)")
    messages = [f"{_row_name(meas, row)}: q{message(row)[0] + 1} = {message(row)[1]}" for row in bad_rows]
    return meas.subset(~outside.any(axis=1)), messages


def outside_limits(meas: MeasurementSet, lower_deg: np.ndarray, upper_deg: np.ndarray) -> list[str]:
    """One message per row with a joint outside the limits (the warnings of estimated limits)."""
    outside = (meas.q_deg < lower_deg - 1e-9) | (meas.q_deg > upper_deg + 1e-9)
    messages = []
    for row in np.nonzero(outside.any(axis=1))[0]:
        j = int(np.argmax(outside[row]))
        messages.append(f"{_row_name(meas, row)}: q{j + 1} = {meas.q_deg[row, j]:g} deg is outside the robot's limits [{lower_deg[j]:g}, {upper_deg[j]:g}]")
    return messages


def _row_name(meas: MeasurementSet, row: int) -> str:
    where = f"line {meas.line_of(row)}" if meas.lines is not None else f"row {row + 1}"
    return f"{where}, id {meas.ids[row]}"


def _check_millimetres(source, body, xyz, cols):
    """A set whose positions all lie within 5 units of the origin was written in metres."""
    if len(xyz) >= 3 and np.abs(xyz).max() < 5.0:
        row = int(np.argmax(np.abs(xyz).max(axis=1)))
        raise MeasurementError(source, body[row][0], cols[int(np.argmax(np.abs(xyz[row])))], "positions look like metres (all within 5 of the origin); the schema wants mm")


def write_measurements(path: str | Path, meas: MeasurementSet, decimals: int = 4) -> None:
    """Write a set in the shared schema, atomically (a temp file renamed into place)."""
    cols: list[tuple[str, np.ndarray]] = [(c, meas.q_deg[:, i]) for i, c in enumerate(JOINTS)]
    if meas.nominal_mm is not None:
        cols += [(c, meas.nominal_mm[:, i]) for i, c in enumerate(NOMINAL)]
    cols += [(c, meas.measured_mm[:, i]) for i, c in enumerate(MEASURED)]
    if meas.force_n is not None:
        cols += [(c, meas.force_n[:, i]) for i, c in enumerate(FORCES)]
    if meas.approach is not None:
        cols += [(c, meas.approach[:, i]) for i, c in enumerate(APPROACH)]
    if meas.time_s is not None:
        cols.append(("t", meas.time_s))
    if meas.temp_c is not None:
        cols.append(("temp", meas.temp_c))
    cols += list(meas.extra.items())  # e.g. group ids (point, session): read back as extra columns
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(["id"] + [c for c, _ in cols])
    for r in range(len(meas)):
        cells = [meas.ids[r]]
        for c, values in cols:
            v = values[r]
            whole = c in APPROACH or (c in meas.extra and float(v).is_integer())
            cells.append(f"{int(v):d}" if whole else f"{v:.{decimals if c not in JOINTS else 6}f}")
        writer.writerow(cells)
    write_text_atomic(path, buf.getvalue())


def write_text_atomic(path: str | Path, text: str, encoding: str = "utf-8") -> None:
    """Write a whole file or nothing: a temp file in the same folder, renamed over the target."""

    write_all({Path(path): text.encode(encoding)})
