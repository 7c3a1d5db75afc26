"""The FreeCAD post-processor's work, in postproc's own Python.

FreeCAD's post module (``freecad_post.py``, a shim running in FreeCAD's Python) sends the
job's path commands here as JSON on standard input and gets a JSON answer on standard
output: ``python -m postproc.cam.freecad``. Here the commands become G-code text (arcs
linearised, feeds in mm/min, tool changes as ``G43 H<n>``), which ``postproc.cam.post``
compensates and writes as a robot program — all files or none.

Input: ``{"argstring": "--model m.json --to krl ...", "filename": "out.src" or "-" (then "name"
names the program),
"objects": [{"label": "Profile", "commands": [["G1", {"X": 1.0, ...}], ...]}, ...]}``.
Output: ``{"ok": true, "files": [...], "text": "...", "messages": [...]}`` or
``{"ok": false, "error": "..."}``; exit status 0, 1 (job problem) or 2 (bad input).
"""

from __future__ import annotations

import argparse
import json
import re
import shlex
import sys
from dataclasses import dataclass, field

import numpy as np

from postproc.errors import InputError, JobError, PostprocError
from postproc.model.coverage_text import describe_model, model_summary
from postproc.programs import dialects
from postproc.programs.emit.writer import TOOL_DOWN
from postproc.programs.program_io import parse_program
from postproc.robot.frames import abc_to_matrix, make_transform

from .arcs import linearise_arc

FREECAD_FEED_TO_MM_MIN = 60.0  # FreeCAD keeps feeds in mm/s (its internal velocity unit)
_WCS = re.compile(r"^G5[4-9](\.[1-9])?$")
_PASS = {"G17", "G18", "G19", "G21", "G40", "G49", "G80", "G90", "G94", "G98", "G99", "M0", "M00", "M1", "M01", "M2", "M02", "M3", "M03",
         "M4", "M04", "M5", "M05", "M7", "M07", "M8", "M08", "M9", "M09", "M30"}
_CYCLES = {"G73", "G74", "G76", "G81", "G82", "G83", "G84", "G85", "G86", "G87", "G88", "G89"}


class _HelpAction(argparse.Action):
    def __call__(self, parser, namespace, values, option_string=None):
        raise _HelpRequested(parser.format_help())


class _HelpRequested(Exception):
    pass


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # argparse would exit; a post reports instead
        raise InputError(f"post arguments: {message}")


def argument_parser() -> argparse.ArgumentParser:
    p = _Parser(prog="postproc", add_help=False, description="FreeCAD post-processor of postproc: the job's paths, compensated "
                "under an error model, as a KUKA KRL or ABB RAPID program.")
    p.add_argument("--help", action=_HelpAction, nargs=0, help="print this help and write nothing")
    p.add_argument("--model", help="model JSON from 'postproc fit' (required)")
    p.add_argument("--to", default="krl", help="krl (default) or rapid; gcode (five-axis machines) is not available yet")
    p.add_argument("--robot", help="robot name: checked against the model's robot")
    p.add_argument("--frame", action="append", default=[], metavar="G54=X,Y,Z[,A,B,C]",
                   help="work offset in the robot base frame, mm and KUKA A,B,C degrees (repeatable; every offset the job uses)")
    p.add_argument("--tool", action="append", default=[], metavar="N=X,Y,Z[,A,B,C]",
                   help="FreeCAD tool number N as the robot's TCP in the flange frame (repeatable; every tool the job uses)")
    p.add_argument("--initial-tool", type=int, metavar="N", help="the tool in the spindle before the first tool change")
    p.add_argument("--start", metavar="X,Y,Z", help="where the TCP is when the program begins (work offset G54, mm): "
                   "FreeCAD jobs start with a Z-only move")
    p.add_argument("--arc-tol", type=float, default=0.01, help="arcs become straight moves within this chord error, mm (default 0.01)")
    p.add_argument("--tol", type=float, default=0.01, help="compensation tolerance, mm (default 0.01)")
    p.add_argument("--max-iter", type=int, default=25, help="compensation iterations per point (default 25)")
    p.add_argument("--scheme", default="broyden", help="broyden (default) or seed000")
    p.add_argument("--temp", type=float, help="cell temperature, degC (models with a thermal effect)")
    p.add_argument("--allow-model-mismatch", action="store_true",
                   help="go on when the program's tool, payload or robot is not the model's (printed as a note)")
    p.add_argument("--allow-extrapolation", action="store_true",
                   help="compensate targets outside the joint ranges and region the model was measured in (refused by default)")
    p.add_argument("--force", metavar="FX,FY,FZ", help="process force in N, base frame (models with external_load)")
    return p


def help_text() -> str:
    return argument_parser().format_help()


def _numbers(text: str, counts: tuple[int, ...], what: str) -> np.ndarray:
    try:
        values = np.array([float(v) for v in text.split(",") if v.strip()])
    except ValueError:
        raise InputError(f"{what}: expected numbers separated by commas, got '{text}'") from None
    if len(values) not in counts:
        raise InputError(f"{what}: expected {' or '.join(map(str, counts))} numbers, got {len(values)} in '{text}'")
    return values


def _transforms(items: list[str], option: str, rename=lambda name: name) -> dict:
    """'NAME=X,Y,Z[,A,B,C]' -> {name: 4x4} (KUKA A,B,C: R = Rz(A) Ry(B) Rx(C))."""

    out = {}
    for item in items:
        name, eq, values = item.partition("=")
        if not eq or not name.strip():
            raise InputError(f"{option}: expected NAME=X,Y,Z[,A,B,C], got '{item}'")
        v = _numbers(values, (3, 6), option)
        abc = v[3:6] if len(v) == 6 else np.zeros(3)
        out[rename(name.strip())] = make_transform(abc_to_matrix(abc[None])[0], v[:3])
    return out


@dataclass
class GcodeText:
    """G-code written from FreeCAD commands, and for each of its lines where it came from."""

    lines: list[str] = field(default_factory=list)
    origin: list[str] = field(default_factory=list)
    tools: set[int] = field(default_factory=set)

    def add(self, line: str, origin: str) -> None:
        self.lines.append(line)
        self.origin.append(origin)

    @property
    def text(self) -> str:
        return "\n".join(self.lines) + "\n"


def _f(v: float) -> str:
    text = f"{v:.6f}".rstrip("0").rstrip(".")
    return "0" if text in ("-0", "") else text


def commands_to_gcode(objects: list[dict], arc_tol_mm: float, start=None, initial_tool: int | None = None) -> GcodeText:
    """FreeCAD path commands of the job's objects -> G-code text (one FreeCAD command -> one or more lines)."""
    if arc_tol_mm <= 0:
        raise InputError("--arc-tol must be > 0")
    out = GcodeText()
    out.add("G21 G90 G17 (postproc: FreeCAD job, mm)", "the post's preamble")
    pos = np.full(3, np.nan)
    if initial_tool is not None:
        out.add(f"G43 H{initial_tool} (tool in the spindle at the start: --initial-tool)", "--initial-tool")
        out.tools.add(initial_tool)
    if start is not None:
        pos = _numbers(start, (3,), "--start")
        out.add(f"G0 X{_f(pos[0])} Y{_f(pos[1])} Z{_f(pos[2])} (start position: --start)", "--start")
    state = {"pos": pos, "plane": 17, "feed": None}
    for obj in objects:
        label = str(obj.get("label", "?"))
        for k, (name, params) in enumerate(obj.get("commands", [])):
            _command(out, state, str(name).strip(), {str(a).upper(): float(v) for a, v in params.items()}, f"{label}, command {k + 1}", arc_tol_mm)
    return out


def _command(out: GcodeText, state: dict, name: str, params: dict, where: str, arc_tol_mm: float) -> None:
    upper = name.upper()
    if upper.startswith("("):
        out.add("(" + re.sub(r"[()\r\n]", " ", name.strip("()")).strip() + ")", where)
        return
    code = re.sub(r"^([GM])0+(\d)", r"\1\2", upper)
    words = ""
    if "F" in params:
        state["feed"] = params["F"] * FREECAD_FEED_TO_MM_MIN
    if code in ("G0", "G1"):
        axes = [a for a in "XYZABC" if a in params]
        if not axes:
            return out.add(f"({name}: no axis word)", where)
        for i, a in enumerate("XYZ"):
            if a in params:
                state["pos"][i] = params[a]
        words = " ".join(f"{a}{_f(params[a])}" for a in axes)
        feed = f" F{_f(state['feed'])}" if code == "G1" and state["feed"] is not None else ""
        return out.add(f"{code} {words}{feed}", where)
    if code in ("G2", "G3"):
        return _arc(out, state, code, params, where, arc_tol_mm)
    if code in ("G17", "G18", "G19"):
        state["plane"] = int(code[1:])
    if code in _PASS or _WCS.match(code):
        extra = "".join(f" {a}{_f(v)}" for a, v in params.items() if a == "S")
        return out.add(code + extra, where)
    if code == "M6":
        if "T" not in params:
            raise InputError(f"{where}: M6 without a tool number")
        tool = int(params["T"])
        out.tools.add(tool)
        out.add(f"M6 T{tool}", where)
        return out.add(f"G43 H{tool} (the robot's TCP of tool {tool}: --tool {tool}=...)", where)
    if code == "G43" and "H" in params:
        out.tools.add(int(params["H"]))
        return out.add(f"G43 H{int(params['H'])}", where)
    if code in _CYCLES:
        raise InputError(f"{where}: drilling cycle {name}: a robot needs its moves; translate drill cycles to G0/G1 in the job first")
    if code in ("G91", "G20"):
        raise InputError(f"{where}: {name}: FreeCAD paths are absolute millimetres; the post does not take {name}")
    raise InputError(f"{where}: {name} is not a command the postproc post understands")


def _arc(out: GcodeText, state: dict, code: str, params: dict, where: str, arc_tol_mm: float) -> None:
    start = state["pos"].copy()
    if np.isnan(start).any():
        raise InputError(f"{where}: an arc before the position is known (give --start X,Y,Z)")
    if "R" in params:
        raise InputError(f"{where}: R-format arc: the post needs I, J, K centre offsets")
    end = np.array([params.get(a, start[i]) for i, a in enumerate("XYZ")])
    centre = start + np.array([params.get("I", 0.0), params.get("J", 0.0), params.get("K", 0.0)])
    points = linearise_arc(start, end, centre, code == "G2", arc_tol_mm, state["plane"], where)
    feed = f" F{_f(state['feed'])}" if state["feed"] is not None else ""
    for p in points:
        out.add(f"G1 X{_f(p[0])} Y{_f(p[1])} Z{_f(p[2])}{feed}", where + f" ({code} arc, {len(points)} segments)")
    state["pos"] = end


def annotate(message: str, origin: list[str]) -> str:
    """'lines 2, 3' of the generated G-code (which the user never sees) -> 'at G54, command 2; ...'."""

    def where(match):
        places = [origin[int(n) - 1] if 1 <= int(n) <= len(origin) else f"G-code line {n}" for n in re.findall(r"\d+", match.group(0))]
        return "at " + "; ".join(dict.fromkeys(places)) + " "

    return re.sub(r"\b(?:on )?lines? [\d, ]+", where, message)


def _prepare(request: dict):
    """The post's options and the job as G-code, checked: (args, GcodeText, frames, tools)."""
    args = argument_parser().parse_args(shlex.split(request.get("argstring") or ""))
    if dialects.get(args.to, "--to").machine_program:
        raise InputError(f"--to {args.to}: the FreeCAD post writes robot programs (--to krl or rapid); "
                         "for a five-axis machine (RTCP) post to G-code and run 'postproc convert --to gcode --machine M --rtcp MODE'")
    if args.model is None:
        raise InputError("post arguments: --model MODEL.json is required (a model from 'postproc fit')")
    gcode = commands_to_gcode(request.get("objects", []), args.arc_tol, args.start, args.initial_tool)
    tools = _transforms(args.tool, "--tool", lambda n: f"H{int(n.lstrip('Tt'))}" if n.lstrip("Tt").isdigit() else n)
    missing = sorted(t for t in gcode.tools if f"H{t}" not in tools)
    if missing:
        raise InputError(f"the job uses tool(s) {', '.join(map(str, missing))}: give each as the robot's TCP, --tool N=X,Y,Z[,A,B,C]")
    return args, gcode, _transforms(args.frame, "--frame"), tools


def planned_targets(request: dict):
    """The job's targets as the post reads them, placed in the robot base frame, before compensation
    (3-axis moves get the writer's tool-down orientation): what the compensated program must cut."""

    _, gcode, frames, tools = _prepare(request)
    tp = parse_program("-", "gcode", gcode.text.encode("latin-1"))
    missing = np.isnan(tp.orientation).any(axis=1)
    orientation = np.where(missing[:, None], TOOL_DOWN, tp.orientation)
    return tp.with_orientations(orientation).with_frames(frames, tools)


def run(request: dict) -> dict:
    """One post request (see the module docstring) -> its answer; raises PostprocError."""
    # Deferred, as postproc.post: the fitting and compensation stack (scipy.optimize) loads only when a job is posted.
    from postproc.model.model_io import load_model

    from .post import post, write_programs

    args, gcode, frames, tools = _prepare(request)
    filename = request.get("filename") or "-"
    suffix = dialects.get(args.to, "--to").extensions[0]
    output = (request.get("name") or "postproc") + suffix if filename == "-" else filename
    force = None if args.force is None else _numbers(args.force, (3,), "--force")
    try:
        files = post(gcode.text, args.model, args.to, output=output, dialect="gcode", frames=frames, tools=tools,
                     robot=args.robot, tol_mm=args.tol, max_iter=args.max_iter, scheme=args.scheme, temp_c=args.temp, force_n=force,
                     allow_model_mismatch=args.allow_model_mismatch, allow_extrapolation=args.allow_extrapolation)
    except PostprocError as exc:
        raise _annotated(exc, gcode.origin) from None
    if filename != "-":
        write_programs(files)
    main_text = next(iter(files.values()))
    messages = [f"postproc: {len(gcode.lines)} G-code lines from FreeCAD, program {', '.join(files)}",
                f"postproc: {describe_model(model_summary(load_model(args.model)[0])['model'])}"]
    if filename != "-" and not filename.lower().endswith(suffix):
        messages.append(f"postproc: note: a {args.to.upper()} program's file name usually ends in {suffix}")
    return {"ok": True, "files": list(files) if filename != "-" else [], "text": main_text, "cam_gcode": gcode.text, "messages": messages}


def _annotated(exc: PostprocError, origin: list[str]) -> PostprocError:
    """The same error, its lines pointed at the FreeCAD operation and command they came from."""
    text = annotate(str(exc), origin)
    report = getattr(exc, "report", None)
    if report is not None:
        # One line per FreeCAD command and reason (an arc's segments share theirs).
        failures = list(dict.fromkeys((origin[line - 1] if 0 < line <= len(origin) else f"G-code line {line}", why) for line, why in report.failures()))
        text += "".join(f"\n  {place}: {why}" for place, why in failures[:20])
        if len(failures) > 20:
            text += f"\n  ... and {len(failures) - 20} more"
    return (JobError if isinstance(exc, JobError) else InputError)(text)


def main(argv: list[str] | None = None) -> int:
    """``python -m postproc.cam.freecad``: a request on stdin, the answer on stdout."""
    try:
        request = json.load(sys.stdin)
        answer, status = run(request), 0
    except _HelpRequested as help_:
        answer, status = {"ok": True, "files": [], "text": None, "help": str(help_), "messages": [str(help_)]}, 0
    except PostprocError as exc:
        answer, status = {"ok": False, "error": str(exc)}, 1 if isinstance(exc, JobError) else 2
    except json.JSONDecodeError as exc:
        answer, status = {"ok": False, "error": f"postproc post: the request is not JSON ({exc})"}, 2
    json.dump(answer, sys.stdout)
    sys.stdout.write("\n")
    return status


if __name__ == "__main__":
    sys.exit(main())
