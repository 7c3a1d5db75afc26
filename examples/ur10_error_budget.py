"""What carries the UR10's error on Series B, and what bounds any model fitted on Series A.

Data: data/ur10_ipa (Landgraf et al., CASE 2021, MIT licence). Prints, with the numbers
behind each statement:

1. the protocols: when each series was measured (Series A: five days in July 2020, one x
   slab of the grid per day; Series B: November 2020 by its mangled time stamp, about 1 K
   colder, every goal pose in two joint configurations, each configuration measured twice);
2. repeatability: the same joint configuration measured twice (the noise floor);
3. time: is Series A's drift over the days a rigid move of the tracker (one 6-DOF frame per
   measuring session) or the workspace region each day measured? A grid point's
   orientations on one day against its other orientations on another day mix the two;
   like with like, pose pairs close in joint space on the same day against different days;
4. the validation protocol: Series B re-registered on all of its rows (6 DOF) against
   registered on half and scored on the other half, and with the probe offset re-fitted too;
5. the ceiling: physics models fitted on Series B itself. No model of the same effects
   fitted on Series A can do better on Series B than this.

Run: .venv/bin/python examples/ur10_error_budget.py [path/to/ur10_ipa] [--quick]   (about 1 min CPU)
"""

from __future__ import annotations

import csv
import sys
from pathlib import Path

import numpy as np

import postproc
from postproc.model.effects import parse_effects
from postproc.model.formats.ur10_ipa import read_series
from postproc.model.identify import fit, refit_base, residuals

args = [a for a in sys.argv[1:] if a != "--quick"]
QUICK = "--quick" in sys.argv  # the test suite: every 20th pose of Series A, two of the ceiling fits
EVERY = 20 if QUICK else 3
root = Path(args[0]) if args else Path(__file__).resolve().parents[2] / "shared" / "data" / "ur10_ipa"
robot = postproc.load_robot("ur10")
series_a, tool = read_series(root / "Series_A")
series_b, _ = read_series(root / "Series_B")
GEOMETRIC = "base_frame,geometric,tool_offset,joint_compliance"


def stats(resid: np.ndarray) -> str:
    norm = np.linalg.norm(resid, axis=1)
    return f"mean {norm.mean():.3f}  RMS {np.sqrt((norm**2).mean()):.3f}  max {norm.max():.3f} mm"


def raw_column(series: str, name: str) -> list[str]:
    path = next((root / series).glob("measurements_*.csv"))
    with open(path, newline="", encoding="utf-8") as fh:
        rows = list(csv.reader(fh, delimiter=";"))
    return [r[rows[0].index(name)] for r in rows[1:]]


def repeats(meas) -> list[tuple[int, int]]:
    """Pairs of rows with the same joint configuration (to 0.1 degree)."""
    _, inverse, counts = np.unique(np.round(meas.q_deg, 1), axis=0, return_inverse=True, return_counts=True)
    inverse = inverse.ravel()
    return [tuple(np.nonzero(inverse == g)[0][:2]) for g in np.nonzero(counts > 1)[0]]


def rigid_residual(pred: np.ndarray, resid: np.ndarray) -> np.ndarray:
    """What is left of resid after the best small rigid motion (6 DOF) of the predicted points."""
    centred = pred - pred.mean(axis=0)
    jac = np.zeros((len(pred), 3, 6))
    jac[:, :, :3] = np.eye(3)
    for k, axis in enumerate(np.eye(3)):
        jac[:, :, 3 + k] = np.cross(axis, centred)
    coef, *_ = np.linalg.lstsq(jac.reshape(-1, 6), resid.reshape(-1), rcond=None)
    return resid - jac @ coef


print("1. protocols")
days_a = sorted({s[:8] for s in raw_column("Series_A", "Timestamp")})
print(f"   Series A: {len(series_a)} poses on {len(days_a)} days {days_a[0]}..{days_a[-1]}, {series_a.temp_c.min():.2f}-{series_a.temp_c.max():.2f} degC")
print(f"   Series B: {len(series_b)} poses, time stamp as stored '{raw_column('Series_B', 'Timestamp')[0]}' (2020-11), {series_b.temp_c.min():.2f}-{series_b.temp_c.max():.2f} degC")
goals_b = np.round(np.array([[float(v.replace(',', '.')) for v in raw_column('Series_B', c)] for c in ('Goal x', 'Goal y', 'Goal z', 'Goal roll', 'Goal pitch', 'Goal yaw')]).T, 3)
_, goal_counts = np.unique(goals_b, axis=0, return_counts=True)
print(f"   Series B: {np.sum(goal_counts == 2)} goal poses reached in two joint configurations, {np.sum(goal_counts == 1)} in one")

model_a = fit(robot, tool, parse_effects(GEOMETRIC), series_a.subset(np.arange(len(series_a)) % EVERY == 0), cv_folds=0).model
resid_a = residuals(model_a, series_a)
resid_b = residuals(refit_base(model_a, series_b), series_b)

print("2. repeatability (same joints measured twice; residual difference of the pair)")
for label, meas, resid in (("A", series_a, resid_a), ("B", series_b, resid_b)):
    diff = np.array([np.linalg.norm(resid[i] - resid[j]) for i, j in repeats(meas)])
    print(f"   Series {label}: {len(diff)} pairs, median {np.median(diff):.3f} mm, {np.sum(diff > 0.3)} pairs apart by more than 0.3 mm (max {diff.max():.2f})")

print("3. time: one rigid tracker frame per measuring session of Series A (sessions split at gaps > 30 min)")
session = np.cumsum(np.r_[True, np.diff(series_a.time_s) > 1800]) - 1
pred_a = model_a.predict(series_a)
left = resid_a.copy()
for s in np.unique(session):
    rows = session == s
    if rows.sum() >= 10:
        left[rows] = rigid_residual(pred_a[rows], resid_a[rows])
print(f"   {session.max() + 1} sessions; Series A residual {stats(resid_a)} -> with a frame per session {stats(left)}")
day = np.floor(series_a.time_s / 86400 + 0.69).astype(int)  # calendar day (the series starts at 16:39)
point = series_a.extra["point"].astype(int)  # commanded position (read_series groups the goal poses)
across, within = [], []
for g in range(point.max() + 1):
    rows = np.nonzero(point == g)[0]
    days = np.unique(day[rows])
    if len(days) > 1:
        across.append(np.linalg.norm(resid_a[rows[day[rows] == days[0]]].mean(0) - resid_a[rows[day[rows] == days[-1]]].mean(0)))
    elif len(rows) >= 10:
        half = len(rows) // 2
        within.append(np.linalg.norm(resid_a[rows[:half]].mean(0) - resid_a[rows[half:]].mean(0)))
print(f"   same grid point, mean residual of its orientations: {len(across)} points measured on two days differ by median {np.median(across):.3f} mm,")
print(f"   but that compares different orientations: {len(within)} points measured on one day, first against second half of their orientations, median {np.median(within):.3f} mm")
# Like with like: pairs of poses close in joint space, measured on the same day or on different days.
from scipy.spatial import cKDTree  # noqa: E402

pairs = cKDTree(np.radians(series_a.q_deg)).query_pairs(0.05, output_type="ndarray")
gap = np.linalg.norm(resid_a[pairs[:, 0]] - resid_a[pairs[:, 1]], axis=1)
apart = np.linalg.norm(np.radians(series_a.q_deg[pairs[:, 0]] - series_a.q_deg[pairs[:, 1]]), axis=1)
same_day = day[pairs[:, 0]] == day[pairs[:, 1]]
print("   pose pairs closer than 0.05 rad in joint space, residual difference (median mm):")
for lo, hi in ((0.0, 0.025), (0.025, 0.05)):
    near = (apart >= lo) & (apart < hi)
    one, two = np.median(gap[near & same_day]), np.median(gap[near & ~same_day])
    print(f"     {lo:.3f}-{hi:.3f} rad: same day {one:.3f} ({np.sum(near & same_day)} pairs), different days {two:.3f} ({np.sum(near & ~same_day)} pairs):"
          f" {two - one:+.3f} mm across days, a day-to-day part of about {np.sqrt(max(two**2 - one**2, 0.0)):.3f} mm")
print("   held-out sessions and each session's rigid offset: postproc validate A.csv --protocol sessions (docs/guide/validate.md)")
print(f"   elbow configuration q3 > 0: {np.mean(series_a.q_deg[:, 2] > 0):.0%} of Series A, {np.mean(series_b.q_deg[:, 2] > 0):.0%} of Series B")
print(f"4. validation protocol on Series B (model fitted on one pose in {EVERY} of Series A)")
print(f"   re-registered on all rows (evaluate --reregister): {stats(resid_b)}")
even, odd = series_b.subset(np.arange(len(series_b)) % 2 == 0), series_b.subset(np.arange(len(series_b)) % 2 == 1)
print(f"   registered on the even rows, scored on the odd:    {stats(residuals(refit_base(model_a, even), odd))}")

print("5. ceiling: physics fitted on Series B itself (training error on B; a model fitted on A cannot beat it)")
CEILING = ("", ",axis_tilt", ",joint_harmonics[joints=1,2,3,4,5,6;orders=1,2]", ",link_bending")
for extra in CEILING[:2] if QUICK else CEILING:
    own = fit(robot, tool, parse_effects(GEOMETRIC + extra), series_b, cv_folds=0).model
    print(f"   {(GEOMETRIC + extra):<80} {stats(residuals(own, series_b))}")
    if not extra:
        own_resid = residuals(own, series_b)
# A data-driven ceiling: neighbours in joint space (sin/cos of the six joints), 5 folds that keep a
# configuration and its repeat together, predicting what geometry + compliance fitted on B leave.
from sklearn.model_selection import GroupKFold  # noqa: E402
from sklearn.neighbors import KNeighborsRegressor  # noqa: E402

angles = np.deg2rad(series_b.q_deg)
features = np.hstack([np.sin(angles), np.cos(angles)])
_, same_config = np.unique(np.round(series_b.q_deg, 1), axis=0, return_inverse=True)
guess = np.zeros_like(own_resid)
for train, test in GroupKFold(5).split(features, groups=same_config.ravel()):
    guess[test] = KNeighborsRegressor(30, weights="distance").fit(features[train], own_resid[train]).predict(features[test])
print(f"   + 30 nearest neighbours in joint space, cross-validated within B:{'':<15} {stats(own_resid - guess)}")
model_t = fit(robot, tool, parse_effects(GEOMETRIC + ",axis_tilt"), series_a.subset(np.arange(len(series_a)) % EVERY == 0), cv_folds=0).model
print(f"   for comparison, fitted on A with axis_tilt, B re-registered: {stats(residuals(refit_base(model_t, series_b), series_b))}")
