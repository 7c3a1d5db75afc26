"""``post``: the library entry point CAM scripts call — a program in, a compensated robot program out.

It is ``postproc convert`` followed by ``postproc compensate`` as one call, through the
same library functions (parse, write a new program, parse it, compensate, splice), so a
CAM hook and the command line give byte-identical programs. This module is the one place
a CAM hook touches the parsers and emitters: re-point it when they move.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from postproc.compensation.request import CompensationRequest
from postproc.errors import InputError
from postproc.jobs.compensate import CompensationError, compensate_with
from postproc.jobs.program_check import check_model_fits
from postproc.jobs.targets import RobotTarget
from postproc.model.errormodel import ErrorModel
from postproc.model.model_io import load_model
from postproc.plugins import load_plugins
from postproc.programs.dialects import get as get_dialect
from postproc.programs.dialects import names as dialect_names
from postproc.programs.dialects import of as dialect_of
from postproc.programs.ir import Kind, Toolpath
from postproc.programs.program_io import emit_texts, parse_program, sniff, write_program, write_texts


def robot_languages() -> tuple[str, ...]:
    """The dialects a robot program can be written in (those with a writer for new programs)."""
    return tuple(name for name in dialect_names() if get_dialect(name).new_writer("p") is not None)


def post(
    program: str | bytes | Toolpath,
    model,
    to: str = "krl",
    *,
    output: str | Path | None = None,
    dialect: str | None = None,
    frames: dict | None = None,
    tools: dict | None = None,
    robot: str | None = None,
    tol_mm: float = 0.01,
    max_iter: int = 25,
    scheme: str = "broyden",
    temp_c: float | None = None,
    force_n=None,
    allow_model_mismatch: bool = False,
    allow_extrapolation: bool = False,
    plugins=(),
) -> dict[str, str]:
    """Compensated robot program for ``program`` under ``model``: ``{path: text}`` (KRL: .src and .dat).

    ``program``: program text (its dialect sniffed from the content unless ``dialect``
    is given) or a parsed Toolpath. ``model``: an ErrorModel or the path of a model JSON
    from ``postproc fit``. ``to``: ``krl`` or ``rapid``. ``output``: the program's path
    (names the files and the program; default ``postproc.src`` / ``postproc.mod``).
    ``frames`` / ``tools``: ``{name: 4x4}`` for work offsets and tools the program uses
    but does not define (``G54``, ``H1``). Nothing is written; see ``write_programs``.

    Raises InputError (bad input, naming the line) or CompensationError (targets that
    cannot be compensated, listed by line of ``program``), ModelMismatchError where the
    program's tool, payload or robot is not the model's (``allow_model_mismatch``: go on).
    Targets outside the region the model was measured in fail (``allow_extrapolation``: compensate them).
    ``plugins``: paths of effect / predictor plugins a model file needs (as ``--plugins``;
    ``POSTPROC_PLUGINS`` and installed entry points are loaded as well).
    """
    error_model = _model(model, plugins)
    request = CompensationRequest(
        RobotTarget(error_model, "the model" if isinstance(model, ErrorModel) else str(model)),
        output=None if output is None else str(output), dialect=dialect, frames=frames or {}, tools=tools or {}, robot=robot,
        tol_mm=tol_mm, max_iter=max_iter, scheme=scheme, temp_c=temp_c,
        force_n=None if force_n is None else tuple(np.ravel(force_n).tolist()),
        allow_mismatch=allow_model_mismatch, allow_extrapolation=allow_extrapolation)
    return post_request(request, program, to)


def post_request(request: CompensationRequest, program: str | bytes | Toolpath, to: str = "krl") -> dict[str, str]:
    """``post`` of a ``CompensationRequest`` (its robot model, ``output``, ``dialect``,
    frames, tools, ``robot``, solver options and ``allow_mismatch``)."""
    target = get_dialect(to, "--to")
    if to not in robot_languages():
        raise InputError(f"--to: '{to}' is not one of {', '.join(robot_languages())}"
                         + (" (five-axis machines: use 'postproc convert --to gcode --machine M --rtcp MODE')" if target.machine_program else ""))
    error_model = request.robot_model("postproc.post (a robot program)")
    if request.robot is not None and request.robot != error_model.robot.name:
        raise InputError(f"--robot {request.robot} does not match the model's robot {error_model.robot.name}")
    output = Path(request.output) if request.output is not None else Path("postproc" + target.extensions[0])
    tp = program if isinstance(program, Toolpath) else _parse(program, request.dialect)
    _refuse_what_a_robot_cannot_run(tp)
    tp = tp.with_frames(dict(request.frames) or None, dict(request.tools) or None)
    _require_placed(tp)
    # ``postproc convert``: a new robot program with every target (3-axis G-code gets the
    # writer's tool-down orientation), then parsed back, so that compensation edits
    # exactly the numbers of the text that is written.
    texts = write_program(tp, to, output.stem)
    converted = parse_program("-", to, texts[0].encode("latin-1"))  # "-": read nothing else from disk
    if len(converted) != len(tp):
        raise InputError(f"internal: the written program has {len(converted)} targets, the input {len(tp)}")
    check_model_fits(converted, error_model, *request.model_check())
    # The frames and tools are in ``converted`` already: compensate with the rest of the request.
    new, report = compensate_with(replace(request, frames={}, tools={}), converted)
    report = replace(report, line=tp.line.copy())  # failures name the lines of the input
    if report.failed.any():
        raise CompensationError(f"{int(report.failed.sum())} target(s) cannot be compensated; nothing was written", report)
    out = {str(output): emit_texts(converted, new)[0]}
    # Every target is inline: the program's other files (KRL's .dat) are as the writer made them.
    out.update({str(path): text for path, text in zip(target.new_program_paths(output)[1:], texts[1:])})
    return out


def write_programs(files: dict[str, str]) -> None:
    """Write the files of one program: each atomically, all encoded before any is written."""
    write_texts(list(files.values()), list(files.keys()))


def _model(model, plugins=()):
    if isinstance(model, ErrorModel):
        return model
    load_plugins(plugins)  # the same three ways as the command line: the model file names what it needs

    return load_model(Path(model))[0]


def _parse(program: str | bytes, dialect: str | None) -> Toolpath:
    data = program.encode("latin-1") if isinstance(program, str) else bytes(program)
    return parse_program("-", dialect or _sniff(data), data)


def _sniff(data: bytes) -> str:
    return sniff("-", data)


def _refuse_what_a_robot_cannot_run(tp: Toolpath) -> None:
    """Arcs (the writer would make chords of them) and rotary axes (they need a machine's kinematics)."""
    arcs = np.isin(tp.kind, (Kind.ARC_CW, Kind.ARC_CCW))
    if arcs.any():
        lines = ", ".join(str(v) for v in tp.line[arcs][:10])
        raise InputError(f"G2/G3 arcs on lines {lines}: a robot program needs them as straight moves; linearise them first "
                         "(the FreeCAD post does, within --arc-tol)")
    rotary = ~np.isnan(tp.ext[:, :3]).all(axis=1)
    if dialect_of(tp).machine_program and rotary.any():
        lines = ", ".join(str(v) for v in tp.line[rotary][:10])
        raise InputError(f"rotary axis words (A/B/C) on lines {lines}: they belong to a five-axis machine, "
                         "whose kinematics postproc cannot emit yet; give the tool axis as G43.5 I J K for a robot")


def _require_placed(tp: Toolpath) -> None:
    """Every Cartesian target known in the robot base frame (a new program would otherwise take the identity)."""
    cart = tp.kind != Kind.ABSJ
    bad = cart & ~(tp.placed() & ~np.isnan(tp.position).any(axis=1))
    if not bad.any():
        return
    rows = np.nonzero(bad)[0]
    frames = sorted({tp.frame_names[tp.frame[i]] for i in rows if tp.frame_known is not None and not tp.frame_known[tp.frame[i]]})
    tools = sorted({tp.tool_names[tp.tool[i]] for i in rows if tp.tool_known is not None and not tp.tool_known[tp.tool[i]]})
    hint = "".join(f" Give frame {f} (--frame {f}=X,Y,Z,A,B,C)." for f in frames) + "".join(f" Give tool {t} (--tool {t}=X,Y,Z,A,B,C)." for t in tools)
    if np.isnan(tp.position[rows]).any():
        hint += " Some axes have no value yet at these lines (a move before the first X, Y and Z)."
    lines = ", ".join(str(v) for v in tp.line[rows][:10])
    raise InputError(f"targets on lines {lines} cannot be placed in the robot base frame.{hint}")
