"""Option parsing and checks shared by several commands."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Optional

import numpy as np
import typer

from postproc.errors import InputError, OutputError
from postproc.model.measurements import ESTIMATED_LIMIT_MARGIN_DEG, check_joint_limits, outside_limits, read_measurements
from postproc.model.session_offsets import session_column
from postproc.programs import dialects
from postproc.robot.frames import abc_to_matrix, make_transform

from .app import err

# The built-in languages, for help texts (plugin dialects load later, with the command's --plugins).
LANGUAGES = ", ".join(dialects.names())
ROBOT_LANGUAGES = ", ".join(name for name in dialects.names() if not dialects.get(name).machine_program)
MACHINE_LANGUAGES = ", ".join(name for name in dialects.names() if dialects.get(name).machine_program)
PROGRAM_FILES = "; ".join(f"{name} {'/'.join(dialects.get(name).extensions)}" for name in dialects.names())
DIALECT_HELP = f"The program's language: {LANGUAGES} (default: from the extension or content)."

# Options several program commands take, declared once (typer reads only their metadata).
FRAME_OPTION = typer.Option(None, "--frame", help="NAME=X,Y,Z,A,B,C: a frame the program uses but does not define (G54, BASE_DATA[1]), mm and KUKA A,B,C degrees. Repeatable.")
TOOL_OPTION = typer.Option(None, "--tool", help="NAME=X,Y,Z[,A,B,C]: a tool the program uses but does not define (H1, TOOL_DATA[2]). Repeatable.")
TOOL_RADIUS_OPTION = typer.Option(None, "--tool-radius", help="TOOL=R: Klartext: the tool table's radius plus its DR (mm) of a tool the program calls but does not define (T5 for TOOL CALL 5), so RL / RR targets are followed. Repeatable.")
START_JOINTS_OPTION = typer.Option(None, "--start-joints", help="Q1,...,Q6 degrees: the robot's posture when the program starts (for targets before the program's first joint target or configuration data).")
TEMP_OPTION = typer.Option(None, "--temp", help="Cell temperature, degC (needs a model effect that uses it, e.g. thermal).")
FORCE_OPTION = typer.Option(None, "--force", help="Constant process force fx,fy,fz in N, tool frame (needs a model effect that uses it, e.g. external_load).")


def floats(text: str, count: int, what: str) -> np.ndarray:
    """'X,Y,Z' (commas or semicolons) -> `count` numbers; an InputError naming the option `what` otherwise."""
    parts = [p for p in text.replace(";", ",").split(",") if p.strip()]
    try:
        values = np.array([float(p) for p in parts])
    except ValueError:
        raise InputError(f"{what}: expected {count} comma-separated numbers, got '{text}'") from None
    if values.shape != (count,):
        raise InputError(f"{what}: expected {count} comma-separated numbers, got {len(parts)} in '{text}'")
    return values


GP_FEATURES = ("pose", "tcp+joints", "joints", "tcp+joints+travel")  # = postproc.model.learn.features.GP_KINDS; not imported: importing postproc.model.learn loads torch (seconds)
GP_FEATURES_HELP = "gpr: what the learner sees: pose (TCP position + KUKA ABC), tcp+joints (TCP position + the 6 joint angles: tells postures apart), joints, or tcp+joints+travel (tcp+joints and the TCP travel of the last three moves: the pose's history in the path; rows in measured order)."

GP_GLOBAL_SIZE_HELP = "gpr local: poses drawn over the whole workspace whose kernel fit starts the shared fit (--gp-shared-experts)."
GP_SHARED_EXPERTS_HELP = ("gpr local: experts whose data together fit the kernel every expert starts from (their summed likelihood; "
                          "0: the --gp-global-size sample's fit alone, which is sparse where the experts' data are dense).")


SESSION_OFFSETS_HELP = ("Estimate each measuring session's frame shift (one translation per id in the 'session' column) from the physics residual "
                        "and take it out before a predictor is fitted; applied to measurements of those sessions, never to programs.")


def session_offsets_line(offsets) -> str:
    """One line for the terminal: how many sessions, the largest shift and where."""
    sizes = np.linalg.norm(offsets.offsets_mm, axis=1)
    k = int(np.argmax(sizes))
    return (f"session offsets: {len(offsets.ids)} sessions, largest {sizes[k]:.3f} mm (session {offsets.ids[k]}, {offsets.counts[k]} poses), "
            f"median {float(np.median(sizes)):.3f} mm")


def sessions_as_asked(data, model, apply: bool, path):
    """``data`` as the model's session offsets should see it. A session id means the fit's
    session only where the user says so (``--session-offsets``): another file's session 0 is
    another set-up. Otherwise its ``session`` column is set aside, with a note."""
    if apply and model.session_offsets is None:
        raise InputError("--session-offsets: the model has no session offsets (fit it with --session-offsets)")
    if apply:  # asked for: a file without session ids, or ids the fit never saw, would silently get none
        unseen = model.session_offsets.unknown(session_column(data))
        if unseen:
            err.print(f"note: {path}: {unseen} of {len(data)} poses are of sessions the model has no offset for: none applied to them", highlight=False)
        return data
    if model.session_offsets is None or "session" not in data.extra:
        return data
    err.print(f"note: {path}: the model's session offsets are not applied to this file (--session-offsets applies them "
              "where its session ids are the fit's sessions)", highlight=False)
    return replace(data, extra={k: v for k, v in data.extra.items() if k != "session"})


def gp_options_given(features: str, leaf_size: int, global_size: int, shared_experts: int) -> dict[str, bool]:
    """Which of the GPR options that ``fit`` and ``validate`` share were given (not at their
    defaults), by flag: for refuse_unused where no gpr is fitted."""
    return {"--gp-features": features != "pose", "--gp-leaf-size": leaf_size != 500, "--gp-global-size": global_size != 600,
            "--gp-shared-experts": shared_experts != 4}


def gp_options_checked(features: str, leaf_size: int, global_size: int, shared_experts: int) -> dict:
    """The shared GPR options as GPRPredictor / fit_predictor take them, each checked."""
    return {"features": gp_features_checked(features), "leaf_size": leaf_size, "global_size": gp_global_size_checked(global_size),
            "shared_experts": gp_shared_experts_checked(shared_experts)}


def gp_shared_experts_checked(value: int) -> int:
    if value < 0:
        raise InputError(f"--gp-shared-experts: a number of experts, 0 or more, got {value}")
    return value


def gp_global_size_checked(value: int) -> int:
    if value < 10:
        raise InputError(f"--gp-global-size: a kernel needs at least 10 poses to fit, got {value}")
    return value


NOISE_MODEL_HELP = ("How far each training pose is trusted: none (all alike) or settle (the first poses after a TCP move > 10 mm, in row order, "
                    "get their own noise level, estimated from the training poses: weights in the physics fit, noise levels in gpr).")


def gp_features_checked(value: str) -> str:
    if value not in GP_FEATURES:
        raise InputError(f"--gp-features: '{value}' is not one of {', '.join(GP_FEATURES)}")
    return value


def refuse_unused(why: str, options: dict[str, bool]) -> None:
    """Options given (True) that this use of the command would not use are an error, not a no-op."""
    unused = [name for name, given in options.items() if given]
    if unused:
        raise InputError(f"{', '.join(unused)}: not used {why}; leave {'it' if len(unused) == 1 else 'them'} out")


def load_measurements(path: Path, robot=None, drop_invalid: bool = False):
    """Read a measurement set; with a robot, rows beyond its joint limits are an error
    (or, with --drop-invalid, dropped and listed on stderr)."""
    data = read_measurements(path)
    if robot is None:
        return data
    # Limits a robot file marks as estimates are not grounds to refuse measured data just
    # beyond them: rows within a margin of them are listed as warnings and kept.
    estimated = robot.estimates.get("limits", False)
    data, dropped = check_joint_limits(data, robot.lower_deg, robot.upper_deg, drop_invalid,
                                       margin_deg=ESTIMATED_LIMIT_MARGIN_DEG if estimated else 0.0)
    warned = outside_limits(data, robot.lower_deg, robot.upper_deg) if estimated else []
    if warned:
        err.print(f"warning: {path}: {len(warned)} row(s) outside {robot.name}'s joint limits, which {robot.source_path} marks as estimates; "
                  f"kept, as within {ESTIMATED_LIMIT_MARGIN_DEG:g} deg of them (first: {warned[0]})")
    for message in dropped:
        err.print(f"dropped: {path}, {message}")
    if dropped and len(data) == 0:
        raise InputError(f"{path}: every row is outside the robot's joint limits; nothing left to use")
    return data


DROP_INVALID_HELP = "Drop (and list) rows whose joints are outside the robot's limits instead of stopping."


def check_output_folder(path: Optional[Path], option: str) -> None:
    """Fail before any computation when an output cannot be written where asked."""
    if path is None or str(path) == "-":
        return
    folder = path.parent if str(path.parent) else Path(".")
    if not folder.is_dir():
        raise OutputError(f"{option} {path}: folder {folder} does not exist")
    if path.is_dir():
        raise OutputError(f"{option} {path}: is a folder, expected a file name")


def named_frames(items: list[str] | None, option: str) -> dict:
    """'NAME=X,Y,Z[,A,B,C]' options -> {name: 4x4}."""
    out = {}
    for item in items or []:
        name, eq, values = item.partition("=")
        if not eq or not name.strip():
            raise InputError(f"{option}: expected NAME=X,Y,Z[,A,B,C], got '{item}'")
        parts = [p for p in values.split(",") if p.strip()]
        nums = floats(values, len(parts) if len(parts) in (3, 6) else 6, option)
        abc = nums[3:6] if len(nums) == 6 else np.zeros(3)
        out[name.strip()] = make_transform(abc_to_matrix(abc[None])[0], nums[:3])
    return out
