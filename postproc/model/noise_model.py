"""Per-pose measurement noise by the pose's place after the last large move (``--noise-model settle``).

On the UR10's Series A the first three poses measured after the probe moved to a new grid
point miss by three to four times what the later poses at the point do (0.195 / 0.136 /
0.100 mm held out, then about 0.06), in directions unrelated from one pose to the next
(mean cosine 0.04 over 439 visits): the arm has not settled yet. Such a pose is a
measurement with a larger, unpredictable error, and a fit that trusts it as much as a
settled pose is pulled off by it. This module tells the places apart and estimates how
much noisier each is:

- ``settle_place``: 0 for a pose whose move into it was large (the TCP travelled more than
  ``SETTLE_MM``), 1 for the pose after that, ..., ``depth`` (settled) when none of the last
  ``depth`` moves was large. It reads only the targets before each pose (their order in the
  measurement set or in a program: ``postproc.model.path_history``), never a measurement time;
- ``NoiseRatios.estimate``: each place's variance relative to the settled poses', from a
  residual of the training poses (mean squared 3-D residual per place); a place with too
  few poses keeps the settled variance.

The physics least squares weighs each pose by 1 / ratio (``identify.fit(noise="settle")``),
the GP gets one noise level per place by its marginal likelihood (``learn.gp_lml``), and a
plugin predictor that takes ``sample_weight`` gets the weights. Predictions stay the mean.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from postproc.errors import InputError

from .path_history import path_travel_mm

NOISE_MODELS = ("none", "settle")
#: a move of the TCP longer than this starts a new visit. On Series A the moves within a
#: visit (orientation changes about the probe point) are below 1 mm and the moves to a new
#: grid point above 50 mm, so any threshold in that gap gives the same places.
SETTLE_MM = 10.0
#: a place needs this many poses for its own variance; fewer keep the settled one
MIN_PLACE_POSES = 20
#: the ratios are kept within these bounds (a place can be trusted at most 4 times more, or
#: 100 times less, than the settled poses): a handful of wild poses cannot zero a weight
RATIO_BOUNDS = (0.25, 100.0)


def checked(noise: str) -> str:
    if noise not in NOISE_MODELS:
        raise InputError(f"--noise-model: '{noise}' is not one of {', '.join(NOISE_MODELS)}")
    return noise


def settle_place(robot, tool_mm, q_deg: np.ndarray, previous_q_deg: np.ndarray, threshold_mm: float = SETTLE_MM) -> np.ndarray:
    """(N,) int: how many targets ago the TCP's last large move (> threshold_mm) ended, 0 for
    the pose it moved into; ``depth`` (= previous_q_deg.shape[1]) where none of the last
    ``depth`` moves was large (the settled poses). ``previous_q_deg`` (N, depth, 6): the
    targets before each pose, nearest first."""
    depth = previous_q_deg.shape[1]
    large = path_travel_mm(robot, tool_mm, q_deg, previous_q_deg) > threshold_mm  # (N, depth): move into this pose, then back
    return np.where(large.any(axis=1), np.argmax(large, axis=1), depth).astype(np.int64)


@dataclass(frozen=True)
class NoiseRatios:
    """Variance of each place (0 .. depth) relative to the settled poses' (the last, 1)."""

    ratios: tuple[float, ...]

    @classmethod
    def estimate(cls, place: np.ndarray, residual_mm: np.ndarray, depth: int) -> NoiseRatios:
        """From a residual (N, 3) of the training poses and their places."""
        square = np.sum(np.asarray(residual_mm, dtype=float) ** 2, axis=1)
        counts = np.bincount(place, minlength=depth + 1)
        sums = np.bincount(place, weights=square, minlength=depth + 1)
        if counts[depth] < MIN_PLACE_POSES:
            return cls((1.0,) * (depth + 1))
        settled = sums[depth] / counts[depth]
        ratios = np.where(counts >= MIN_PLACE_POSES, sums / np.maximum(counts, 1) / max(settled, 1e-300), 1.0)
        return cls(tuple(float(r) for r in np.clip(ratios, *RATIO_BOUNDS)))

    def weights(self, place: np.ndarray) -> np.ndarray:
        """(N,) least-squares weight of each pose: 1 / its place's variance ratio."""
        return 1.0 / np.asarray(self.ratios)[place]

    def describe(self) -> str:
        return " / ".join(f"{r:.2f}" for r in self.ratios)
