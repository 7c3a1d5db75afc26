"""The page of ``compensate --report PAGE.html``: what a user checks before running a
compensated program. The model (robot, measured region), the predicted error as written
and compensated, the path in 3-D, the error and the reach, singularity and joint-limit
margins along it, and the region the model was measured in against the program's."""

from __future__ import annotations

import html

import numpy as np

from postproc.model.coverage_text import describe_model
from postproc.robot import posture

from . import compensation_figures as figs
from .html import CSS, _img


def compensation_report(report, summary: dict, model, program: str, model_path: str) -> str:
    """The HTML page (self-contained: figures embedded) of one compensated program.
    ``report``: compensate's Report made with ``detail=True``; ``summary``: the CLI's summary."""
    d = report.detail
    cart = ~np.isnan(d.goal_mm).any(axis=1)
    goal, before, after, q = d.goal_mm[cart], d.before_mm[cart], d.after_mm[cart], d.joints_deg[cart]
    distance = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(goal, axis=0), axis=1))])
    outside_rows = np.zeros(len(cart), dtype=bool)
    outside_rows[list(report.outside_region or {})] = True
    outside = outside_rows[cart]
    title = f"Compensation of {program}"
    parts = [f"<!doctype html><html><head><meta charset='utf-8'><title>{html.escape(title)}</title><style>{CSS}</style></head><body>",
             f"<h1>{html.escape(title)}</h1>",
             f"<p>Model <code>{html.escape(model_path)}</code>: {html.escape(describe_model(summary['model']))}.</p>",
             _summary_table(summary, report, outside)]
    if len(goal):
        gain = figs.path_gain(goal, before)
        parts.append("<h2>The path</h2>")
        parts.append(_img(figs.path_3d(goal, before, after, gain),
                          f"Programmed path (black) and where the model predicts the robot goes as written (orange) and compensated (blue, dashed); errors drawn {gain:g} times their size."))
        between = None if report.path_mm is None else report.path_mm[cart]
        parts.append(_img(figs.errors_along(distance, np.linalg.norm(before, axis=1), np.linalg.norm(after, axis=1), between),
                          "Predicted 3-D error at each target as written and compensated, and between targets (controller interpolation of the compensated commands)."))
        parts.append("<h2>Reach and singularities</h2>")
        parts.append(_img(_margins(model.robot, distance, q),
                          "Margins at the compensated targets: the elbow margin is the distance from the edge of reach; compensation refuses targets closer than the dashed lines."))
    parts.append("<h2>The region the model was measured in</h2>")
    if model.coverage is None:
        parts.append("<p>The model file records no measured region (it was fitted before postproc recorded one): refit it to have targets outside it found.</p>")
    parts.append(_img(figs.region_views(model.coverage, goal, outside),
                      "The measured region (the hull of the measured TCP positions, projected) and the program's targets; red: outside it."))
    parts.append(_img(figs.joint_ranges(model.coverage, model.robot.lower_deg, model.robot.upper_deg, q),
                      "Per joint: the robot's limits, the range the model was fitted on, and the range the compensated program uses."))
    parts.append(_failures(report))
    parts.append("</body></html>")
    return "\n".join(parts)


def _margins(robot, distance, q):
    wrist, elbow, shoulder = posture.singularity_margins(robot, q)
    limit = np.minimum(q - robot.lower_deg, robot.upper_deg - q).min(axis=1)
    return figs.margins_along(distance, wrist, elbow, limit, shoulder, posture.SINGULAR_DEG, posture.SHOULDER_MM)


def _summary_table(summary: dict, report, outside: np.ndarray) -> str:
    b, a = summary["predicted_before"], summary["predicted_after"]
    fmt = lambda v: "-" if v is None else f"{v:.4f}"  # noqa: E731
    rows = [("targets", str(summary["targets"])), ("compensated", str(summary["compensated"])),
            ("predicted error RMS, as written / compensated (mm)", f"{fmt(b['rms_mm'])} / {fmt(a['rms_mm'])}"),
            ("predicted error max, as written / compensated (mm)", f"{fmt(b['max_mm'])} / {fmt(a['max_mm'])}"),
            ("largest correction (mm)", fmt(summary["max_correction_mm"]))]
    if summary.get("path") is not None:
        rows.append(("largest predicted distance from the path between targets (mm)", f"{summary['path']['max_mm']:.4f} (segment into line {summary['path']['line']})"))
    region = "not checked (--allow-extrapolation, or a model without a recorded region)" if report.outside_region is None else str(int(outside.sum()))
    rows.append(("targets outside the measured region", region))
    rows.append(("targets that cannot be compensated", str(summary["failed"])))
    body = "".join(f"<tr><td class='l'>{html.escape(k)}</td><td>{html.escape(v)}</td></tr>" for k, v in rows)
    return f"<table>{body}</table>"


def _failures(report) -> str:
    failures = report.failures()
    if not failures:
        return ""
    items = "".join(f"<li>line {line}: {html.escape(reason)}</li>" for line, reason in failures[:200])
    more = f"<p>... and {len(failures) - 200} more</p>" if len(failures) > 200 else ""
    return f"<h2>Targets that cannot be compensated (nothing was written)</h2><ul>{items}</ul>{more}"
