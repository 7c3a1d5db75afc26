"""Program commands: inspect, convert, roundtrip."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Optional

import numpy as np
import typer
from rich.table import Table

from postproc.errors import InputError, JobError, PostprocError
from postproc.jobs.convert_conf import converted_conf
from postproc.jobs.five_axis.commands import convert_five
from postproc.programs.arcs import describe
from postproc.programs.dialects import get
from postproc.programs.emit.feeds import describe as describe_feeds
from postproc.programs.emit.tool_load import parse_tool_load
from postproc.programs.program_io import emit_texts, parse_program, with_robot, write_program, write_texts
from postproc.robot.frames import matrix_to_quat_wxyz
from postproc.robot.robots import load_robot

from .app import app, err, exit_code, handles_errors, out
from .common import DIALECT_HELP, MACHINE_LANGUAGES, PROGRAM_FILES, ROBOT_LANGUAGES, named_frames, refuse_unused
from .plugin_option import with_plugins

_KIND_NAMES = {0: "joint", 1: "linear", 2: "circular_via", 3: "circular_end", 4: "joint_target", 5: "rapid", 6: "arc_cw", 7: "arc_ccw"}


@app.command("inspect")
@handles_errors
@with_plugins
def inspect_cmd(
    program: Path = typer.Argument(..., help=f"Program file: {PROGRAM_FILES}; other names by content."),
    json_out: bool = typer.Option(False, "--json", help="Machine-readable output (spec/cli.md)."),
    dialect: Optional[str] = typer.Option(None, "--dialect", help=DIALECT_HELP),
    data: Optional[list[Path]] = typer.Option(None, "--data", help="KRL: another module's data list (.dat: its GLOBAL points of a PUBLIC DEFDAT), module (.src: its functions) or a folder of them, that the program uses. Repeatable."),
    robot: Optional[str] = typer.Option(None, "--robot", help="The robot the program runs on (a name from robots/ or a file): what only its data determine is placed (INFORM: pulse positions, with the robot file's [pulses])."),
):
    """Motion targets of a program in the robot base frame (G-code: the machine frame), mm; a target the program text does not determine is listed and flagged."""
    tp = with_robot(parse_program(program, dialect, modules=data or ()), None if robot is None else load_robot(robot))
    poses = tp.base_poses()
    has_ori = ~np.isnan(tp.orientation).any(axis=1)
    quats = np.full((len(tp), 4), np.nan)
    if has_ori.any():
        quats[has_ori] = matrix_to_quat_wxyz(poses[has_ori, :3, :3])

    def num(v):
        return None if v is None or not np.isfinite(v) else round(float(v), 6)

    placed = tp.placed()

    arc_of = describe(tp)  # G2/G3: plane, direction, centre, radius

    feed_of = describe_feeds(tp)  # G-code: feed mode; G93 / G95: F, its unit and the derived mm/min
    moves = []
    for i in range(len(tp)):
        entry = {
            "line": int(tp.line[i]),
            "kind": _KIND_NAMES[int(tp.kind[i])],
            "xyz": [num(v) for v in poses[i, :3, 3]],
            "file": tp.sources[int(tp.file[i])].path,
            "target": tp.target_name[i] or None,
            "frame": tp.frame_names[int(tp.frame[i])],
            "tool": tp.tool_names[int(tp.tool[i])],
            "resolved": bool(placed[i]),
        }
        if has_ori[i]:
            entry["quaternion"] = [num(v) for v in quats[i]]
        if not np.isnan(tp.joints[i]).all():
            entry["joints"] = [num(v) for v in tp.joints[i]]
        if not np.isnan(tp.ext[i]).all():
            entry["ext"] = [num(v) for v in tp.ext[i]]
        if not np.isnan(tp.conf[i]).all():
            entry["conf"] = [num(v) for v in tp.conf[i]]
        if i in arc_of:
            entry["arc"] = arc_of[i]
        if tp.ccomp is not None and tp.ccomp[i]:  # G41/G42: the offset path (a corner arc: no block words of its own), or not followed
            entry["cutter_comp"] = ("corner" if tp.insert_at is not None and tp.insert_at[i, 1] < 0 else "offset") if tp.ccomp[i] == 1 else "not_followed"
        entry["speed"] = num(tp.speed[i])
        if i in feed_of:
            entry.update(feed_of[i])
            if "f_unit" in entry:
                entry["speed"] = None  # F is not a speed under G93 / G95 (see f, f_unit, speed_derived_mm_per_min)
        entry["zone"] = num(tp.zone[i])
        moves.append(entry)
    if json_out:
        print(json.dumps({"dialect": tp.dialect, "moves": moves, "notes": list(tp.notes)}))
        return
    table = Table(title=f"{program} ({tp.dialect}, {len(tp)} targets)", show_edge=False)
    for col in ("line", "kind", "x", "y", "z", "target", "frame", "tool", "ok"):
        table.add_column(col, justify="right" if col in ("line", "x", "y", "z") else "left")
    for m in moves[:200]:
        table.add_row(str(m["line"]), m["kind"], *(f"{v:.3f}" if v is not None else "-" for v in m["xyz"]), m["target"] or "", m["frame"], m["tool"], "yes" if m["resolved"] else "NO")
    out.print(table)
    if len(moves) > 200:
        out.print(f"... {len(moves) - 200} more (use --json)")
    for note in tp.notes:
        out.print(f"note: {note}")


@app.command("convert")
@handles_errors
@with_plugins
def convert_cmd(
    program: Path = typer.Argument(..., help="Program in any supported dialect."),
    to: str = typer.Option(..., "--to", help=f"The language of the new program: {ROBOT_LANGUAGES}; or a five-axis machine's ({MACHINE_LANGUAGES}) with --machine and --rtcp."),
    output: Path = typer.Option(..., "-o", "--output", help="New program (KRL: the .src; its .dat is written beside it)."),
    dialect: Optional[str] = typer.Option(None, "--dialect", help=DIALECT_HELP),
    machine: Optional[str] = typer.Option(None, "--machine", help="Five-axis machine (machines/ name or file): --to gcode, or a five-axis G-code input."),
    rtcp: Optional[str] = typer.Option(None, "--rtcp", help="With --to gcode: linuxcnc, fanuc (G43.4), siemens (TRAORI) or none (machine axes)."),
    input_axes: Optional[str] = typer.Option(None, "--input-axes", help="Five-axis G-code input: tip (tool tip + rotary angles) or machine (machine axes)."),
    max_deviation: Optional[float] = typer.Option(None, "--max-deviation", help="--to gcode: split moves until the tip stays this close (mm) to the straight path (default 0.01)."),
    frame: Optional[list[str]] = typer.Option(None, "--frame", help="NAME=X,Y,Z[,A,B,C]: a frame the program uses but does not define (G54, BASE_DATA[1]): the robot base (five-axis: the machine) -> the frame (mm; KUKA A B C, deg), written as the robot's base / work object. Repeatable. Five-axis G-code (--machine): A is its turn about Z (B, C zero), not a rotary-axis offset; the rotary axes' offsets are the program's own (G10 L2/L20, G92/G52 A B C), else zero."),
    tool: Optional[list[str]] = typer.Option(None, "--tool", help="NAME=X,Y,Z[,A,B,C]: a tool the program uses but does not define (H1: a G43 tool length): the flange -> the TCP (mm; KUKA A B C, deg), written as the robot's tool. Repeatable."),
    tool_load: Optional[str] = typer.Option(None, "--tool-load", help="MASS,CX,CY,CZ[,IX,IY,IZ]: the load every tool carries (kg; centre of gravity in the flange frame, mm; inertia about it, kg m^2), written as the tooldata's tload (rapid; tool0: a GripLoad) or $LOAD (krl). Without it the load the input program states is carried where it applies; with it, that load must be this one. Where neither gives one, RAPID tooldata get a 1 kg placeholder marked in a comment and KRL leaves $LOAD as the controller has it."),
    arc_tol: Optional[float] = typer.Option(None, "--arc-tol", help="mm: write helical and spiral arcs (G2/G3 with a move along the plane's normal, or a changing radius), which no circular move holds, as straight moves within this chord error (without it they are refused)."),
    robot: Optional[str] = typer.Option(None, "--robot", help="The robot the program runs on (a name from robots/ or a file): what only its data determine is placed (INFORM: pulse positions), and every target's configuration data in the new language's terms are computed from the joints the input's controller takes (needed for joint motions --to fanuc or inform; written also by --to rapid and val3's movej); a target whose joints the input does not determine is refused."),
):
    """Write a new robot program with every target of another program, or a five-axis G-code program (--to gcode --machine M --rtcp MODE)."""
    if machine is not None or rtcp is not None:
        if machine is None:
            raise InputError("--rtcp needs --machine (a name from machines/ or a machine file)")
        refuse_unused("without --to gcode", {"--max-deviation": max_deviation is not None and rtcp is None})
        refuse_unused("by a five-axis G-code program", {"--tool-load": tool_load is not None, "--arc-tol": arc_tol is not None, "--robot": robot is not None})
        for line in convert_five(program, to, output, machine, rtcp, dialect, input_axes, max_deviation_mm=0.01 if max_deviation is None else max_deviation,
                                 frames=named_frames(frame, "--frame"), tools=named_frames(tool, "--tool")):
            out.print(line)
        return
    refuse_unused("without --machine (five-axis only)", {"--input-axes": input_axes is not None, "--max-deviation": max_deviation is not None})

    load = None if tool_load is None else parse_tool_load(tool_load)
    outputs = get(to, "--to").new_program_paths(output)
    robot_model = None if robot is None else load_robot(robot)
    tp = with_robot(parse_program(program, dialect), robot_model)
    if frame or tool:  # work offsets and tool lengths the program leaves to the controller (refused when not given)
        tp = tp.with_frames(named_frames(frame, "--frame"), named_frames(tool, "--tool"))
    conf = None
    if robot_model is not None:  # the posture in the new language's terms, from the joints the input's controller takes
        conf, conf_notes = converted_conf(tp, get(to, "--to"), robot_model)
        for note in conf_notes:
            err.print(f"note: {note}")
    texts = write_program(tp, to, output.stem, tool_load=load, arc_tol_mm=arc_tol, conf=conf, robot=robot_model)
    write_texts(texts, outputs)
    out.print(f"{len(tp)} targets written to {', '.join(map(str, outputs))}")


@app.command("roundtrip")
def roundtrip_cmd(
    programs: list[Path] = typer.Argument(..., help="Program files."),
    dialect: Optional[str] = typer.Option(None, "--dialect", help=DIALECT_HELP),
):
    """Parse and re-emit programs unchanged; exit 0 only if every output is byte-identical."""
    status = 0
    for program in programs:
        try:
            tp = parse_program(program, dialect)
            texts = emit_texts(tp, tp)
        except PostprocError as exc:
            err.print(f"error: {exc}", style="bold red")
            out.print(f"ERROR      {program}")
            status = max(status, exit_code(exc) if isinstance(exc, JobError) else 2)
            continue
        same = all(t.encode("latin-1") == doc.encode() and doc.encode() == Path(doc.path).read_bytes() for t, doc in zip(texts, tp.sources))
        files = ", ".join(Path(d.path).name for d in tp.sources)
        out.print(f"{'IDENTICAL' if same else 'DIFFERS'}  {program} ({tp.dialect}, {len(tp)} targets; {files})")
        if not same:
            status = max(status, 1)
    raise typer.Exit(status)
