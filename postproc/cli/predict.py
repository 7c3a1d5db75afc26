"""postproc predict: where a program will put the TCP under a model, before it runs."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Optional

import numpy as np
import typer

from postproc.errors import InputError
from postproc.jobs.compensate import predicted_positions
from postproc.jobs.program_check import check_model_fits
from postproc.programs.content import require_program
from postproc.programs.dialects import of as dialect_of
from postproc.programs.ir import Kind
from postproc.programs.program_io import parse_program
from postproc.progress import ProgressLine

from .app import app, err, handles_errors, out
from .common import FORCE_OPTION, FRAME_OPTION, START_JOINTS_OPTION, TEMP_OPTION, TOOL_OPTION, floats, named_frames
from .plugin_option import with_plugins


@app.command("predict")
@handles_errors
@with_plugins
def predict_cmd(
    program: Path = typer.Argument(..., help="Robot program to run under the model (e.g. a compensated one)."),
    model: Path = typer.Option(..., "--model", help="Model JSON: a validation model, or a simulated robot's truth (simulate --truth)."),
    intended: Optional[Path] = typer.Option(None, "--intended", help="The program whose targets are where the TCP should go (the program before compensation); default: PROGRAM's own targets."),
    dialect: Optional[str] = typer.Option(None, "--dialect", help="Language of PROGRAM and --intended (default: from the extension or content)."),
    frame: Optional[list[str]] = FRAME_OPTION,
    tool: Optional[list[str]] = TOOL_OPTION,
    start_joints: Optional[str] = START_JOINTS_OPTION,
    temp: Optional[float] = TEMP_OPTION,
    force: Optional[str] = FORCE_OPTION,
    allow_mismatch: bool = typer.Option(False, "--allow-model-mismatch", help="Predict although the program's robot, tool or payload differ from the model's (printed as notes)."),
    json_out: bool = typer.Option(False, "--json", help="Per-target predictions as JSON on standard output."),
):
    """Predict where the TCP goes when the controller runs PROGRAM, by its rules, on the
    robot MODEL describes, and how far that is from the intended targets. Exit 1 when a
    target cannot be reached."""
    tp = parse_program(program, dialect)
    require_program(tp)
    if dialect_of(tp).machine_program:
        raise InputError(f"{program}: predict runs robot programs (a five-axis machine's program: 'postproc compensate --model MACHINE.toml')")
    goal_tp = tp if intended is None else parse_program(intended, dialect)
    frames, tools = named_frames(frame, "--frame"), named_frames(tool, "--tool")
    # Deferred import: it loads scipy.optimize (slow to import); `postproc --help` must stay fast.
    from postproc.model.model_io import load_model

    error_model, _ = load_model(model)
    for note in check_model_fits(tp, error_model, str(model), None, allow_mismatch):
        err.print(f"note: {note} (--allow-model-mismatch)")
    with ProgressLine("predicting", console=err) as progress:  # a long program takes more than a few seconds
        progress(f"the controller's postures and the model's TCP at {len(tp)} targets")
        rows, predicted, why = predicted_positions(tp, error_model, frames=frames, tools=tools, temp_c=temp,
                                                   force_n=None if force is None else floats(force, 3, "--force"),
                                                   start_joints=None if start_joints is None else floats(start_joints, 6, "--start-joints"))
    goal = _intended_positions(goal_tp, tp, rows, frames, tools, intended)
    error = np.linalg.norm(predicted - goal, axis=1)
    where = [f"{tp.sources[int(tp.file[r])].path}:{int(tp.line[r])}" for r in rows]
    unreached = np.isnan(error)
    if json_out:
        out.print_json(json.dumps(_as_json(where, predicted, goal, error, why)))
    else:
        _print_summary(error, where, why, model, intended or program)
    if unreached.any():
        raise typer.Exit(1)


def _intended_positions(goal_tp, tp, rows: np.ndarray, frames, tools, intended) -> np.ndarray:
    """(M, 3) base-frame positions the Cartesian targets should reach: the intended program's,
    target for target (the same motions in the same order, as compensate writes them)."""
    if frames or tools:
        goal_tp = goal_tp.with_frames(frames, tools)
    goal_rows = np.nonzero(goal_tp.kind != Kind.ABSJ)[0]
    if len(goal_rows) != len(rows) or not np.array_equal(goal_tp.kind[goal_rows], tp.kind[rows]):
        raise InputError(f"{intended}: its Cartesian targets ({len(goal_rows)}) are not the program's ({len(rows)}) motion for motion: "
                         "give the program it was compensated from")
    return goal_tp.base_poses()[goal_rows, :3, 3]


def _as_json(where: list[str], predicted: np.ndarray, goal: np.ndarray, error: np.ndarray, why: list) -> list[dict]:
    def xyz(v):
        return None if np.isnan(v).any() else [round(float(c), 6) for c in v]

    return [{"target": w, "predicted_xyz": xyz(p), "intended_xyz": xyz(g), "error_mm": None if np.isnan(e) else round(float(e), 6),
             "unreached": reason} for w, p, g, e, reason in zip(where, predicted, goal, error, why)]


def _print_summary(error: np.ndarray, where: list[str], why: list, model: Path, intended: Path) -> None:
    for w, reason in [(w, reason) for w, reason in zip(where, why) if reason is not None][:50]:
        err.print(f"{w}: {reason}", highlight=False)
    reached = error[~np.isnan(error)]
    if not len(reached):
        return
    worst = int(np.nanargmax(error))
    out.print(f"{len(reached)} of {len(error)} targets under {model}: TCP error against {intended}'s targets "
              f"RMS {np.sqrt(np.mean(reached ** 2)):.4f} mm, mean {reached.mean():.4f} mm, max {reached.max():.4f} mm ({where[worst]})",
              highlight=False)
