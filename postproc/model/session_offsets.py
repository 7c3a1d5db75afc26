"""Where each measuring session's instrument frame sat: a shift of the measurements, not an error of the robot.

A laser tracker is set up and registered to the robot once per session; between sessions
(days) its frame moves by hundredths to tenths of a millimetre (temperature, the set-up
itself). A model fitted on several sessions takes each session's shift for an error of
the robot at the poses that session measured, and a predictor learns it as if it belonged
to the workspace. On the UR10's Series A the sessions protocol finds session 3 (17 July)
moved as a whole by 0.42 mm (docs/guide/validate.md).

With ``session_offsets`` (``fit`` / ``validate --session-offsets``) the fit estimates one
translation per session from the physics residual of the training poses, the mean shrunk
towards zero as n / (n + SHRINK_POSES) so that a session of a few poses does not take its
own noise for a shift. The offsets are taken out before a predictor is fitted, and
``ErrorModel.predict`` adds them to predictions of *measurements* that carry session ids:
they are part of how that session measured. The CLI lets a file's ids count as the fit's
sessions only where that is sure (``validate``'s split of one file) or said
(``evaluate --session-offsets``). A program has no session, so compensation never applies
them, and a measurement of a session the fit did not see gets none (a new set-up is a
new frame).

Session ids come from the measurement file's ``session`` column (``postproc import-ur10``
writes it): whole numbers, the same id the same session in every file.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from .measurements import MeasurementSet, group_column

COLUMN = "session"
#: poses whose weight a session's own mean gets in its offset: n / (n + SHRINK_POSES)
SHRINK_POSES = 10.0
KEY = "session_offsets"  # in the model file


def session_column(meas: MeasurementSet, required: bool = True) -> np.ndarray | None:
    """The ``session`` column as whole numbers; None where it is absent and not required."""
    if COLUMN not in meas.extra and not required:
        return None
    return group_column(meas, COLUMN, "session offsets need each pose's measuring session, a whole number per row")


@dataclass(frozen=True)
class SessionOffsets:
    """One translation (mm, measurement frame) per session id, and the poses it came from."""

    ids: np.ndarray  # (S,) int64, ascending
    offsets_mm: np.ndarray  # (S, 3)
    counts: np.ndarray  # (S,) training poses per session

    @classmethod
    def estimate(cls, sessions: np.ndarray, residual_mm: np.ndarray) -> "SessionOffsets":
        """Shrunk mean of ``residual_mm`` (measured - predicted, (N, 3)) per session."""
        ids, inverse, counts = np.unique(np.asarray(sessions, dtype=np.int64), return_inverse=True, return_counts=True)
        sums = np.zeros((len(ids), 3))
        np.add.at(sums, inverse.ravel(), np.asarray(residual_mm, dtype=float))
        return cls(ids, sums / (counts + SHRINK_POSES)[:, None], counts)

    def at(self, sessions: np.ndarray) -> np.ndarray:
        """(N, 3) each pose's session offset; zero for a session not estimated."""
        sessions = np.asarray(sessions, dtype=np.int64)
        where = np.clip(np.searchsorted(self.ids, sessions), 0, max(len(self.ids) - 1, 0))
        known = (self.ids[where] == sessions) if len(self.ids) else np.zeros(len(sessions), dtype=bool)
        out = np.zeros((len(sessions), 3))
        out[known] = self.offsets_mm[where[known]]
        return out

    def unknown(self, sessions: np.ndarray) -> int:
        """Poses whose session has no offset."""
        return int(np.count_nonzero(~np.isin(np.asarray(sessions, dtype=np.int64), self.ids)))

    def to_document(self) -> list[dict]:
        return [{"session": int(s), "poses": int(n), "offset_mm": [float(v) for v in o]} for s, n, o in zip(self.ids, self.counts, self.offsets_mm)]

    @classmethod
    def from_document(cls, doc, fail) -> "SessionOffsets":
        """From the model file's list; ``fail(key, why)`` makes the error to raise."""
        try:
            rows = sorted(((int(r["session"]), int(r["poses"]), [float(v) for v in r["offset_mm"]]) for r in doc), key=lambda r: r[0])
        except (KeyError, TypeError, ValueError):
            raise fail(KEY, "each entry needs session (a whole number), poses and offset_mm (three numbers)") from None
        if any(len(r[2]) != 3 for r in rows) or len({r[0] for r in rows}) != len(rows):
            raise fail(KEY, "each session once, with three numbers in offset_mm")
        return cls(np.array([r[0] for r in rows], dtype=np.int64), np.array([r[2] for r in rows], dtype=float).reshape(-1, 3),
                   np.array([r[1] for r in rows], dtype=np.int64))


def with_session_offsets(model, meas: MeasurementSet):
    """``model`` (an ErrorModel without a predictor) with each session's offset estimated from
    its residual on ``meas``: fit it before a predictor, which then learns what is left."""
    if model.residual is not None:
        raise ValueError("session offsets are estimated on the physics residual, before a predictor is fitted")
    sessions = session_column(meas)
    residual = meas.measured_mm - replace(model, session_offsets=None).predict(meas)
    return replace(model, session_offsets=SessionOffsets.estimate(sessions, residual))
