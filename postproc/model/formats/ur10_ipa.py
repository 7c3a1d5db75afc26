"""The IPA UR10 laser-tracker data set (Landgraf et al., CASE 2021; data/ur10_ipa).

Each series folder holds ``measurements_*.csv`` (';'-separated, decimal comma): commanded
probe pose, joints in radians, temperature, and the probe's measured pose in the tracker
frame (mm, degrees), sometimes with standard deviations; and ``Trafo_TM_F_init.txt``,
the T-Mac probe's transform from which the measured point's offset from the flange
follows. Timestamps are YYYYMMDDhhmmss: rows are put in measurement order (the ids keep
each row's number in the file); a series whose timestamps were mangled into one number
(Series B) keeps its file order and gets no time column.

Three group columns are added for the evaluation protocols (``postproc validate``):
``point`` (one id per commanded position, all its orientations), ``pose`` (one id per
commanded probe pose: Series B reaches each in two arm configurations) and, where the
timestamps survive, ``session`` (a new session after a pause of more than 30 minutes).
The probe's measured orientation in the tracker frame is kept as ``probe_rx``,
``probe_ry``, ``probe_rz`` (degrees, as the file gives them): what a tracker- or
probe-side error would depend on.
"""

from __future__ import annotations

import csv
import datetime as dt
import math
from pathlib import Path

import numpy as np

from postproc.errors import MeasurementError

from ..measurements import MeasurementSet

GOAL_COLUMNS = ("Goal x", "Goal y", "Goal z", "Goal roll", "Goal pitch", "Goal yaw")
GOAL_DECIMALS = 4  # commanded poses are planned in metres and radians: equal to 0.1 mm / 0.1 mrad are one
SESSION_GAP_S = 1800.0  # as postproc.model.validate: a pause of more than 30 min starts a new session
JOINT_COLUMNS = ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint", "wrist_3_joint")
MEASURED_COLUMNS = ("measurement_x", "measurement_y", "measurement_z")
ORIENTATION_COLUMNS = ("measurement_rx", "measurement_ry", "measurement_rz")


def probe_offset(trafo_path: str | Path) -> np.ndarray:
    """Measured point in the flange frame (mm) from Trafo_TM_F_init.txt (the flange pose in the probe frame)."""
    path = Path(trafo_path)
    try:
        rows = [line.split() for line in path.read_text().splitlines() if line.strip()]
        mat = np.array(rows, dtype=float)
    except (OSError, ValueError) as exc:
        raise MeasurementError(path, None, None, f"expected a 4x4 matrix of numbers ({exc})") from None
    if mat.shape != (4, 4):
        raise MeasurementError(path, None, None, f"expected a 4x4 matrix, got shape {mat.shape}")
    rot, trans = mat[:3, :3], mat[:3, 3]
    return -rot.T @ trans


def _number(text: str, path, line: int, column: str) -> float:
    try:
        value = float(text.strip().replace(",", "."))
    except ValueError:
        raise MeasurementError(path, line, column, f"not a number: '{text}'") from None
    if not math.isfinite(value):
        raise MeasurementError(path, line, column, f"not a finite number: '{text}'")
    return value


def read_series(series_dir: str | Path) -> tuple[MeasurementSet, np.ndarray]:
    """One series folder -> (measurement set in the shared schema, tool offset in mm).

    Joints become degrees; positions stay in the tracker frame (fit a ``base_frame``).
    """
    folder = Path(series_dir)
    files = sorted(folder.glob("measurements_*.csv"))
    if not files:
        raise MeasurementError(folder, None, None, "no measurements_*.csv in this folder")
    path = files[0]
    with open(path, newline="", encoding="utf-8") as fh:
        rows = list(csv.reader(fh, delimiter=";"))
    if not rows:
        raise MeasurementError(path, 1, None, "empty file")
    header = [h.strip() for h in rows[0]]
    col = {name: i for i, name in enumerate(header)}
    for name in ("Timestamp",) + GOAL_COLUMNS + JOINT_COLUMNS + MEASURED_COLUMNS + ORIENTATION_COLUMNS + ("measurement_temperature",):
        if name not in col:
            raise MeasurementError(path, 1, name, "column missing")
    n = len(rows) - 1
    q = np.empty((n, 6))
    measured = np.empty((n, 3))
    temp = np.empty(n)
    goal = np.empty((n, 6))
    probe = np.empty((n, 3))
    stamps = []
    for r, row in enumerate(rows[1:]):
        line = r + 2
        if len(row) != len(header):
            raise MeasurementError(path, line, None, f"{len(row)} cells, the header has {len(header)}")
        for j, name in enumerate(JOINT_COLUMNS):
            q[r, j] = math.degrees(_number(row[col[name]], path, line, name))
        for j, name in enumerate(MEASURED_COLUMNS):
            measured[r, j] = _number(row[col[name]], path, line, name)
        for j, name in enumerate(ORIENTATION_COLUMNS):
            probe[r, j] = _number(row[col[name]], path, line, name)
        for j, name in enumerate(GOAL_COLUMNS):
            goal[r, j] = _number(row[col[name]], path, line, name)
        temp[r] = _number(row[col["measurement_temperature"]], path, line, "measurement_temperature")
        stamps.append(row[col["Timestamp"]].strip())
    ids = tuple(str(i + 1) for i in range(n))  # the row number in the source file
    meas = MeasurementSet(q_deg=q, measured_mm=measured, ids=ids, temp_c=temp, source=str(path), extra={**_groups(goal), **{f"probe_{axis}": probe[:, k] for k, axis in enumerate(("rx", "ry", "rz"))}})
    if len(set(stamps)) > 1 and all(len(s) == 14 and s.isdigit() for s in stamps):
        moments = np.array([dt.datetime.strptime(s, "%Y%m%d%H%M%S").timestamp() for s in stamps])
        # The shared schema wants rows in measurement order; Series A's file is not.
        order = np.argsort(moments, kind="stable")
        meas = meas.subset(order)
        time_s = moments[order] - moments[order[0]]
        session = np.cumsum(np.r_[True, np.diff(time_s) > SESSION_GAP_S]) - 1.0
        meas = MeasurementSet(**{**meas.__dict__, "time_s": time_s, "extra": {**meas.extra, "session": session}})
    return meas, probe_offset(folder / "Trafo_TM_F_init.txt")


def _groups(goal: np.ndarray) -> dict[str, np.ndarray]:
    """Group ids from the commanded poses: 'point' (position) and 'pose' (position and orientation)."""
    rounded = np.round(goal, GOAL_DECIMALS)
    _, point = np.unique(rounded[:, :3], axis=0, return_inverse=True)
    _, pose = np.unique(rounded, axis=0, return_inverse=True)
    return {"point": point.ravel().astype(float), "pose": pose.ravel().astype(float)}
