"""What ``postproc place`` says: the program's current placement evaluated as a grid cell,
the infeasible candidates counted by reason, and the summary lines."""

from __future__ import annotations

import numpy as np

from . import placement as pl
from .place_program import current_frame, frame_xy_theta
from .placement_branch import REASONS, reason_counts

SNAP = 1e-6  # mm, deg: a frame this close to a grid node is that node (the program's numbers are rounded)
CONF_WORDS = {
    "rederive": "re-derived for each placement as a re-post would (the program's arm configuration kept, "
                "turn data from the joints there); --keep-conf keeps the program's",
    "keep": "kept as the program writes them (--keep-conf): a placement whose joints leave the written turn data is infeasible",
}


def _snap(value: float, axis: np.ndarray) -> tuple[float, bool]:
    near = np.abs(axis - value) <= SNAP
    return (float(axis[near][0]), True) if near.any() else (value, False)


def current_placement(tp, problem, result, z: float):
    """The program's own workpiece frame (None where the program leaves it undefined) and its
    summary: evaluated through the same call as every grid cell, on the frame built the same
    way from (x, y, theta, z); a frame within SNAP of a grid node is evaluated as that node."""
    frame0 = current_frame(tp)
    if frame0 is None:
        return None, None
    x0, y0, t0, z0 = frame_xy_theta(frame0)
    tilt = float(np.degrees(np.arccos(np.clip(frame0[2, 2], -1.0, 1.0))))
    (x0, in_x), (y0, in_y), (t0, in_t) = _snap(x0, result.xs), _snap(y0, result.ys), _snap(t0, result.thetas)
    in_grid = in_x and in_y and in_t and abs(z0 - z) <= SNAP and tilt <= SNAP
    frame = frame0 if tilt > SNAP else pl.placement_frames([[x0, y0, t0]], z0)[0]
    ev = pl.evaluate(problem, frame[None])
    mean = float(ev.mean_mm[0]) if ev.feasible[0] else None
    doc = {"x": x0, "y": y0, "theta": t0, "z": z0, "feasible": bool(ev.feasible[0]), "mean_normal_error_mm": mean,
           "reason": None if ev.feasible[0] else REASONS[ev.reason[0]], "grid_cell": in_grid}
    if tilt > SNAP:
        doc["tilt_deg"] = tilt  # not a placement the search can give (those turn about base z only)
    return frame, doc


def summary(result, problem) -> dict:
    """The counts of the search: feasible cells and the infeasible ones by reason."""
    return {"evaluated": int(result.evaluated), "feasible": int((result.grid_reason == 0).sum()),
            "grid": int(result.grid_reason.size), "infeasible": reason_counts(result.grid_reason),
            "configuration_data": "rederived" if problem.conf_mode == "rederive" else "kept"}


def lines(doc: dict, z: float) -> list[str]:
    """The human-readable summary of ``place``."""
    out = [f"{doc['evaluated']} placements evaluated ({doc['feasible']} of {doc['grid']} grid cells feasible)"]
    if doc["infeasible"]:
        out.append("infeasible grid cells by reason: " + ", ".join(f"{name} {n}" for name, n in doc["infeasible"].items()))
    out.append("configuration data: " + CONF_WORDS["rederive" if doc["configuration_data"] == "rederived" else "keep"])
    b, cur = doc["best"], doc["current"]
    if b is not None:
        out.append(f"best: x {b['x']:.1f} mm, y {b['y']:.1f} mm, theta {b['theta']:.2f} deg, z {z:g} mm: "
                   f"mean normal error {b['mean_normal_error_mm'] * 1000:.2f} um")
    if cur is not None:
        now = f"infeasible ({cur['reason']})" if cur["mean_normal_error_mm"] is None else f"{cur['mean_normal_error_mm'] * 1000:.2f} um"
        where = f"current: x {cur['x']:.1f}, y {cur['y']:.1f}, theta {cur['theta']:.2f}, z {cur['z']:g}"
        if "tilt_deg" in cur:
            where += f" (tilted {cur['tilt_deg']:.3g} deg: not a placement of the search)"
        out.append(f"{where}: {now}" + ("" if doc["reduction_percent"] is None else f"; reduction {doc['reduction_percent']:.1f} %"))
    if doc.get("written"):
        out.append(f"written: {doc['written']}" + (f" (configuration data of {doc['conf_written']} targets re-derived)" if doc.get("conf_written") else ""))
    return out


def counted(progress):
    """``placement.search``'s ``progress(done, total)`` as lines of a ``ProgressLine``."""
    return lambda done, total: progress("placements evaluated", done, total)
