"""Model files: the JSON that ``fit`` writes and ``evaluate``, ``diagnose`` and ``compensate`` read.

It records the robot, the tool, the effects (with the options the fit chose), every
parameter with its value, standard error and whether it was identified, the base-frame
registration, and the fit's statistics. It is all ``compensate`` needs.
"""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from postproc.errors import InputError, ModelFileError
from postproc.robot.robots import load_robot

from .coverage import COVERAGE_KEY, Coverage
from .effects import EffectSpecError, parse_effects
from .errormodel import ErrorModel
from .identify import FitResult
from .measurements import write_text_atomic
from .plugin_records import check_model_plugins, plugin_document
from .session_offsets import KEY as SESSION_KEY
from .session_offsets import SessionOffsets

FORMAT = "postproc-model"
VERSION = 1


def model_document(model: ErrorModel, result: FitResult | None = None, measurements: str | None = None) -> dict[str, Any]:
    params = {}
    for p, v in zip(model.params, model.values):
        entry: dict[str, Any] = {"value": float(v), "unit": p.unit}
        if result is not None:
            entry["std"] = result.std.get(p.name)
            entry["identified"] = p.name not in result.fixed
            if p.name in result.fixed:
                entry["why_fixed"] = result.fixed[p.name]
        params[p.name] = entry
    doc: dict[str, Any] = {
        "format": FORMAT,
        "version": VERSION,
        "robot": model.robot.name,
        "robot_file": model.robot.source_path,
        "tool_mm": model.tool_mm.tolist(),
        "effects": model.effects.spec(),
        "parameters": params,
        "base_registration": {"rotation": model.base_rotation.tolist(), "translation_mm": model.base_translation.tolist()},
        "predictor": None if model.residual is None else model.residual.to_state(),
        **plugin_document(model),  # "plugins": where each plugin effect / predictor came from (postproc.plugins)
    }
    doc.update(_coverage_document(model))
    if model.session_offsets is not None:
        doc[SESSION_KEY] = model.session_offsets.to_document()
    if result is not None:
        doc["fit"] = {
            "measurements": measurements,
            "before": result.before.as_dict(),
            "after": result.after.as_dict(),
            "cv_rms_mm": result.cv_rms_mm,
            "outliers": list(result.outliers),
            "notes": list(result.notes),
        }
    return doc


def save_model(path: str | Path, model: ErrorModel, result: FitResult | None = None, measurements: str | None = None) -> None:
    write_text_atomic(path, json.dumps(model_document(model, result, measurements), indent=2) + "\n")


def load_model(path: str | Path) -> tuple[ErrorModel, dict[str, Any]]:
    """Read and validate a model file; errors name the file and the key."""
    path = Path(path)
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise ModelFileError(f"{path}: cannot read model file ({exc.strerror})") from None
    except UnicodeDecodeError as exc:
        raise ModelFileError(f"{path}: not a model file: byte {exc.start} is not UTF-8 text (binary or damaged file)") from None
    except json.JSONDecodeError as exc:
        raise ModelFileError(f"{path}, line {exc.lineno}, column {exc.colno}: not valid JSON ({exc.msg})") from None
    return model_from_document(doc, str(path)), doc


def model_from_document(doc: Any, source: str) -> ErrorModel:
    def fail(key: str, message: str) -> ModelFileError:
        return ModelFileError(f"{source}: key '{key}': {message}")

    if not isinstance(doc, dict) or doc.get("format") != FORMAT:
        raise fail("format", f"not a postproc model file (expected format '{FORMAT}')")
    if doc.get("version") != VERSION:
        raise fail("version", f"unsupported version {doc.get('version')!r} (this postproc reads {VERSION})")
    robot_ref = doc.get("robot")
    if not isinstance(robot_ref, str):
        raise fail("robot", "must be a robot name")
    robot_file = doc.get("robot_file")
    try:
        robot = load_robot(robot_ref)
    except InputError:
        if isinstance(robot_file, str) and Path(robot_file).is_file():
            robot = load_robot(robot_file)
        else:
            raise fail("robot", f"robot '{robot_ref}' is neither bundled nor at robot_file {robot_file!r}") from None
    tool = doc.get("tool_mm")
    if not (isinstance(tool, list) and len(tool) == 3 and all(_finite(v) for v in tool)):
        raise fail("tool_mm", "must be three numbers (mm)")
    check_model_plugins(doc, source)
    try:
        effects = parse_effects(doc.get("effects", ""))
    except EffectSpecError as exc:
        raise fail("effects", str(exc)) from None
    for effect in effects:
        if not effect.resolved:
            raise fail("effects", f"{effect.name} must carry the terms the fit chose (its options)")
    model = ErrorModel.create(robot, tool, effects)
    params = doc.get("parameters")
    if not isinstance(params, dict):
        raise fail("parameters", "must be an object of name -> {value, ...}")
    values = {}
    for p in model.params:
        entry = params.get(p.name)
        if not isinstance(entry, dict) or not _finite(entry.get("value")):
            raise fail(f"parameters.{p.name}", "missing or not a finite number")
        values[p.name] = float(entry["value"])
    extra = set(params) - {p.name for p in model.params}
    if extra:
        raise fail(f"parameters.{sorted(extra)[0]}", "belongs to no effect of this model")
    reg = doc.get("base_registration", {})
    try:
        rot = np.array(reg.get("rotation", np.eye(3).tolist()), dtype=float)
        trans = np.array(reg.get("translation_mm", [0.0, 0.0, 0.0]), dtype=float)
    except (TypeError, ValueError):
        raise fail("base_registration", "rotation must be 3x3 and translation_mm three numbers") from None
    if rot.shape != (3, 3) or trans.shape != (3,) or not np.allclose(rot @ rot.T, np.eye(3), atol=1e-6):
        raise fail("base_registration", "rotation must be a 3x3 rotation matrix and translation_mm three numbers")

    residual = None
    if doc.get("predictor") is not None:
        # Deferred: postproc.model.learn loads torch (seconds), needed only for a model with a data-driven predictor.
        from .learn import Residual

        residual = Residual.from_state(doc["predictor"], source)
    sessions = None if doc.get(SESSION_KEY) is None else SessionOffsets.from_document(doc[SESSION_KEY], fail)
    return replace(model.with_values(values), base_rotation=rot, base_translation=trans, residual=residual,
                   coverage=_coverage_of(doc, source), session_offsets=sessions)


def _coverage_document(model: ErrorModel) -> dict[str, Any]:
    """The model's ``coverage`` key: the region it was fitted on (none for a model not fitted)."""
    return {} if model.coverage is None else {COVERAGE_KEY: model.coverage.to_document()}


def _coverage_of(doc: dict, source: str) -> Coverage | None:
    """The region a model file records; None for files written before it was recorded."""
    return None if doc.get(COVERAGE_KEY) is None else Coverage.from_document(doc[COVERAGE_KEY], source)


def _finite(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
