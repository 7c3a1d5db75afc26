"""What a compensation summary says about the model: its robot and the region it was measured in.

Kept apart from ``postproc.model.coverage`` (which needs scipy's hull) so the command line can
import it at start-up.
"""

from __future__ import annotations


def model_summary(model) -> dict:
    """The summary's ``model`` entry: robot, and the measured region (None: the model file
    predates the record, so targets outside it cannot be found)."""
    coverage = model.coverage
    return {"model": {"robot": model.robot.name, "robot_description": model.robot.description,
                      "region": None if coverage is None else _region(coverage)}}


def _region(coverage) -> dict:
    """The recorded region without its hull (its vertices stay in the model file)."""
    doc = {k: v for k, v in coverage.to_document().items() if k != "hull_vertices_mm"}
    return doc | {"text": coverage.describe()}


def describe_model(entry: dict) -> str:
    """One line: 'model for ROBOT (description), measured region: ...'."""
    region = entry["region"]
    where = (region["text"] if region is not None
             else "unknown (the model file records none: refit it to have targets outside the measured region refused)")
    return f"model for {entry['robot']} ({entry['robot_description']}); measured region: {where}"
