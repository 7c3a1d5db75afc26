"""compensate: a program rewritten so the robot or machine reaches the intended targets
(whole, streamed in chunks, or a batch of programs)."""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Optional

import numpy as np
import typer
from rich.table import Table

from postproc.compensation.request import CompensationRequest
from postproc.errors import InputError
from postproc.jobs.compensate import CompensationError, compensate_with, process_forces
from postproc.jobs.five_axis.commands import compensate_five_request
from postproc.jobs.program_check import check_model_fits
from postproc.jobs.stream import StreamFallback, stream_request, wants_stream
from postproc.jobs.subdivide import subdivide_request
from postproc.jobs.targets import FiveAxisTarget
from postproc.model.coverage_text import describe_model, model_summary
from postproc.model.measurements import write_text_atomic
from postproc.programs.arcs import summary as arc_summary
from postproc.programs.content import require_program
from postproc.programs.program_io import (
    check_texts,
    emit_texts,
    files_for,
    language_of,
    parse_program,
    refuse_overwrite,
    refuse_stdout,
    write_set,
)
from postproc.progress import ProgressLine

from .app import app, err, handles_errors, out
from .common import DIALECT_HELP, check_output_folder, floats, named_frames
from .plugin_option import with_plugins


@app.command("compensate")
@handles_errors
@with_plugins
def compensate_cmd(
    programs: list[str] = typer.Argument(..., help="Program file, or - for standard input (then give --dialect); several with --out-dir."),
    model: Path = typer.Option(..., "--model", help="Model JSON from 'postproc fit'."),
    output: Optional[str] = typer.Option(None, "-o", "--output", help="Compensated program, or - for standard output (refused when targets live in another file). KRL: its .dat (and a changed $config.dat) is written beside it."),
    out_dir: Optional[Path] = typer.Option(None, "--out-dir", help="Many programs: write each (same file name) into this folder."),
    jobs: Optional[int] = typer.Option(None, "--jobs", help="With --out-dir: local worker processes (Dask LocalCluster)."),
    scheduler: Optional[str] = typer.Option(None, "--scheduler", help="With --out-dir: address of an existing Dask scheduler (tcp://host:port)."),
    dialect: Optional[str] = typer.Option(None, "--dialect", help=DIALECT_HELP),
    in_place: bool = typer.Option(False, "--in-place", help="Allow OUT to be the program's own file(s); each replaced file is kept as NAME.bak."),
    tol: float = typer.Option(0.01, "--tol", help="Stop a point when its correction changes by less than this, mm."),
    max_iter: int = typer.Option(25, "--max-iter"),
    scheme: str = typer.Option("broyden", "--scheme", help="broyden (3-D quasi-Newton) or seed000 (XY direct, secant on depth)."),
    temp: Optional[float] = typer.Option(None, "--temp", help="Cell temperature, degC (needs a model effect that uses it, e.g. thermal)."),
    force: Optional[str] = typer.Option(None, "--force", help="Constant process force fx,fy,fz in N, tool frame (needs a model effect that uses it, e.g. external_load)."),
    report: Optional[Path] = typer.Option(None, "--report", help="Write the per-point report as JSON, or (a name ending in .html) a page to look at: the path in 3-D, the error, reach and singularity margins along it, the model's measured region against the program's."),
    frame: Optional[list[str]] = typer.Option(None, "--frame", help="NAME=X,Y,Z,A,B,C: a frame the program uses but does not define (G54, BASE_DATA[1]), mm and KUKA A,B,C degrees. Repeatable. Five-axis G-code: A is the turn about Z, not a rotary-axis offset (those are the program's own G10/G92 A B C, else zero)."),
    tool: Optional[list[str]] = typer.Option(None, "--tool", help="NAME=X,Y,Z[,A,B,C]: a tool the program uses but does not define (H1, TOOL_DATA[2]). Repeatable."),
    start_joints: Optional[str] = typer.Option(None, "--start-joints", help="Q1,...,Q6 degrees: the robot's posture when the program starts (for targets before the program's first joint target or configuration data)."),
    cut: Optional[Path] = typer.Option(None, "--cut", help="Cut file (tool, material, engagement; see examples/cut_aluminium.toml): the mechanistic milling force of every cutting move, pre-compensated through the model's external_load effect."),
    max_deviation: Optional[float] = typer.Option(None, "--max-deviation", help="mm: refuse (exit 1) when the predicted path between two compensated targets strays further from the intended line or arc (default: report only)."),
    robot: Optional[str] = typer.Option(None, "--robot", help="The robot the program is for (a name from robots/ or a file): must be the model's."),
    allow_mismatch: bool = typer.Option(False, "--allow-model-mismatch", help="Compensate although the program's robot, tool or payload differ from the model's (printed as notes)."),
    force_file: Optional[Path] = typer.Option(None, "--force-file", help="CSV line,fx,fy,fz[,file]: the process force (N, tool frame) of each motion block by its line (needs a model effect that uses it, e.g. external_load)."),
    subdivide: bool = typer.Option(False, "--subdivide", help="Straight segments whose predicted path strays more than --max-deviation (default 0.02 mm) get new compensated targets, declared the language's way (KRL .dat, RAPID robtarget, G1 blocks); such arcs (CIRC, MoveC, G2/G3) are split into compensated arcs of the same circle."),
    grid: Optional[Path] = typer.Option(None, "--grid", help="Five-axis (--model MACHINE.toml): linear-axis error grid CSV x,y,z,dx,dy,dz (seed 004)."),
    input_axes: Optional[str] = typer.Option(None, "--input-axes", help="Five-axis: tip (tool tip + rotary angles, RTCP on) or machine (machine axes)."),
    stream: str = typer.Option("auto", "--stream", help="auto (programs over 16 MB), always or never: compensate a long KRL or G-code program in chunks of lines (memory bounded; the same output), where the program allows it."),
    data: Optional[list[Path]] = typer.Option(None, "--data", help="KRL: another module's data list (.dat: its GLOBAL points of a PUBLIC DEFDAT), module (.src: its functions) or a folder of them, that the program uses. Repeatable."),
    allow_extrapolation: bool = typer.Option(False, "--allow-extrapolation", help="Compensate targets outside the joint ranges and the region the model was measured in (refused by default: the model only extrapolates there)."),
):
    """Rewrite a program so the robot reaches its targets under the fitted error model
    (or a five-axis G-code program for a calibrated machine file given as --model)."""
    # Deferred import: reading a model loads scipy.optimize (slow to import); `postproc --version` must stay fast.
    from postproc.jobs.target_file import load_target

    request = CompensationRequest(
        load_target(model), programs=tuple(programs), output=output, out_dir=out_dir, jobs=jobs, scheduler=scheduler,
        dialect=dialect, data=tuple(data or ()), in_place=in_place, tol_mm=tol, max_iter=max_iter, scheme=scheme, temp_c=temp,
        force_n=None if force is None else tuple(floats(force, 3, "--force")), force_file=force_file, cut=cut,
        frames=named_frames(frame, "--frame") or {}, tools=named_frames(tool, "--tool") or {},
        start_joints=None if start_joints is None else tuple(floats(start_joints, 6, "--start-joints")),
        max_deviation_mm=max_deviation, subdivide=subdivide, stream=stream, report=report, robot=robot,
        allow_mismatch=allow_mismatch, allow_extrapolation=allow_extrapolation, grid=grid, input_axes=input_axes)
    if isinstance(request.machine, FiveAxisTarget):
        for line in compensate_five_request(request):
            out.print(line)
        return
    check_output_folder(report, "--report")
    if request.is_batch:
        out.print(describe_model(model_summary(request.machine.model)["model"]))
        raise typer.Exit(_compensate_batch(request))
    if _can_stream(request) and _compensate_streamed(request):
        return
    _compensate_whole(request)


def _compensate_whole(request: CompensationRequest) -> None:
    """compensate PROGRAM -o OUT: the whole program read, compensated (subdivided with
    --subdivide), checked and written."""
    program, output, report, error_model = request.programs[0], request.output, request.report, request.machine.model
    tp = _read_program(program, request.dialect, request.data)
    require_program(tp)  # an empty file, no DEF / MODULE, no motion: nothing is written
    to_stdout = output == "-"
    _refuse_unsafe_output(tp, output, request.in_place)
    log = err if to_stdout else out

    for note in check_model_fits(tp, error_model, *request.model_check()):
        log.print(f"note: {note} (--allow-model-mismatch)")
    forces = process_forces(request, tp)
    for note in forces.notes:
        log.print(f"note: {note}")

    with ProgressLine("compensating", console=err) as progress:
        run = {"forces": forces, "progress": progress, "detail": _is_page(report)}
        written, added = tp, ()
        if request.subdivide:
            sub = subdivide_request(request, tp, language_of(tp), **run)
            written, new, rep, added = sub.program, sub.compensated, sub.report, sub.added
        else:
            new, rep = compensate_with(request, tp, **run)
    summary = {**rep.summary(), **model_summary(error_model)}

    summary["arcs"] = arc_summary(written, rep.path_mm)  # the subdivided program when --subdivide added targets
    if _is_page(report):  # written also when targets fail: the page shows where
        _write_page(report, rep, summary, error_model, program, Path(request.machine.source))
    elif report is not None:
        _write_point_report(report, rep, summary)
    failures = rep.failures_at(written)
    if failures:
        err.print(describe_model(summary["model"]), highlight=False)
        for where, reason in failures[:50]:
            err.print(f"{where}: {reason}", highlight=False)
        if len(failures) > 50:
            err.print(f"... and {len(failures) - 50} more")
        raise CompensationError(f"{len(failures)} target(s) cannot be compensated; nothing was written", rep)
    _write_compensated(written, new, np.nonzero(rep.compensated)[0], output, request.in_place, original=tp)
    if added:
        log.print(f"{len(added)} new target(s) subdivide straight segments and arcs (lines {', '.join(str(line) for line, _ in added[:20])}{' ...' if len(added) > 20 else ''})")
    _print_compensation(summary, request.scheme, new.notes, log)


def _print_compensation(summary: dict, scheme: str, notes, log) -> None:
    """compensate's account of one program: predicted error before and after, the path between
    targets, the arcs, and the program's notes."""
    b, a = summary["predicted_before"], summary["predicted_after"]
    log.print(describe_model(summary["model"]))
    if b["rms_mm"] is not None:
        log.print(
            f"{summary['compensated']} of {summary['targets']} targets compensated ({scheme}); predicted error RMS {b['rms_mm']:.4f} -> {a['rms_mm']:.4f} mm, "
            f"max {b['max_mm']:.4f} -> {a['max_mm']:.4f} mm; iterations median {summary['iterations_median']:.0f}, max {summary['iterations_max']}"
        )
    else:
        log.print("no Cartesian target to compensate (joint targets are kept as written)")
    if summary["path"] is not None:
        pth = summary["path"]
        log.print(f"between targets ({pth['segments']} straight or circular segments, controller interpolation, model prediction): "
                  f"largest distance from the intended path {pth['max_mm']:.4f} mm, on the segment into line {pth['line']}; "
                  f"{pth['over_tolerance']} segment(s) over {pth['tolerance_mm']:g} mm (--max-deviation to refuse them)")
    _print_arc_deviation(summary["arcs"], log)
    for note in notes:
        log.print(f"note: {note}")


def _print_arc_deviation(arcs: dict | None, log) -> None:
    """The circular motions' largest predicted distance from the intended arc (issue 13: the mid-arc deviation)."""
    if arcs is not None:
        log.print(f"circular motions ({arcs['arcs']}, CIRC / MoveC / G2 / G3): largest predicted distance from the intended arc "
                  f"{arcs['max_mm']:.4f} mm, on the arc into line {arcs['line']}")


def _is_page(report: Optional[Path]) -> bool:
    """--report PAGE.html: the page (postproc.report.compensation), else the JSON."""
    return report is not None and report.suffix.lower() in (".html", ".htm")


def _write_page(report: Path, rep, summary: dict, model, program: str, model_path: Path) -> None:
    """--report PAGE.html (its figures take a few seconds: a spinner meanwhile)."""

    # Deferred import: it loads matplotlib (slow to import); `postproc --version` must stay fast.
    from postproc.report.compensation import compensation_report

    with ProgressLine("report", console=err) as progress:
        progress(f"writing the report page {report}")
        write_text_atomic(report, compensation_report(rep, summary, model, program, str(model_path)))


def _write_point_report(report: Path, rep, summary: dict) -> None:
    """--report: the summary and one entry per target, as JSON."""
    def num(v):
        return None if v is None or np.isnan(v) else float(v)

    doc = {"summary": summary, "points": [
        {"line": int(rep.line[i]), "compensated": bool(rep.compensated[i]), "iterations": int(rep.iterations[i]),
         "before_mm": num(rep.before_mm[i]), "after_mm": num(rep.after_mm[i]),
         "correction_mm": num(rep.correction_mm[i]), "converged": bool(rep.converged[i]),
         "within_limits": bool(rep.within_limits[i]), "singular": bool(rep.singular[i]), "branch_changed": bool(rep.branch_changed[i]),
         "path_mm": None if rep.path_mm is None else num(rep.path_mm[i])}
        for i in range(len(rep.line))]}
    write_text_atomic(report, json.dumps(doc, indent=1) + "\n")


def _read_program(program: str, dialect: str | None, modules=None):
    """The program at ``program``, or - for standard input (then ``dialect`` is needed);
    ``modules``: other modules' files it uses (--data, KRL)."""
    if program != "-":
        return parse_program(Path(program), dialect, modules=modules or ())
    if dialect is None:
        raise InputError("reading a program from standard input needs --dialect")
    return parse_program("-", dialect, sys.stdin.buffer.read())


def _refuse_unsafe_output(tp, output: str, in_place: bool) -> None:
    """Before the work: standard output only for one-file programs; no input overwritten
    without --in-place (a changed $config.dat is checked again when the texts are known)."""
    if output == "-":
        refuse_stdout(tp)
    else:
        refuse_overwrite(tp, files_for(tp, [doc.text for doc in tp.sources], output), in_place)


def _write_compensated(tp, new, rows, output: str, in_place: bool, original=None) -> None:
    """Emit, re-parse (the targets ``rows`` must read back as compensated), then write the
    whole set of changed files at once, or the program to standard output. ``original``:
    the program as read when ``tp`` has new targets (files differing from it are written)."""
    original = tp if original is None else original

    texts = emit_texts(tp, new)
    check_texts(tp, new, texts, rows)
    if output == "-":
        sys.stdout.buffer.write(texts[0].encode("latin-1"))
        sys.stdout.buffer.flush()
        return
    files = files_for(original, texts, output)
    refuse_overwrite(original, files, in_place)
    write_set(files, backup=in_place)

def _compensate_batch(request: CompensationRequest) -> int:
    """compensate PROGRAM... --out-dir DIR [--jobs N | --scheduler ADDRESS]: postproc.jobs.batch on Dask."""

    # Deferred import: it loads dask.distributed (slow to import); `postproc --version` must stay fast.
    from postproc.jobs.batch import run_batch_request

    programs, out_dir, report = request.programs, request.out_dir, request.report
    finished = []
    with ProgressLine("compensating", console=err) as progress:
        progress("programs", 0, len(programs))

        def one_done(result) -> None:
            finished.append(result)
            progress("programs", len(finished), len(programs))

        results = run_batch_request(request, on_done=one_done)
    table = Table(title=f"compensate: {len(programs)} programs -> {out_dir}", show_edge=False)
    for col in ("program", "status", "targets", "RMS before (mm)", "RMS after (mm)", "message"):
        table.add_column(col, justify="right" if "RMS" in col or col == "targets" else "left")
    for r in results:
        b, a = r.summary.get("predicted_before", {}), r.summary.get("predicted_after", {})
        fmt = lambda v: "-" if v is None else f"{v:.4f}"  # noqa: E731
        table.add_row(r.program, "written" if r.ok else "FAILED", str(r.summary.get("targets", "-")), fmt(b.get("rms_mm")), fmt(a.get("rms_mm")), r.error or "")
        if not r.ok:
            err.print(f"error: {r.program}: {r.error}")
    out.print(table)
    if report is not None:
        rows = [{"program": r.program, "ok": r.ok, "outputs": list(r.outputs), "error": r.error, "summary": r.summary} for r in results]
        write_text_atomic(report, json.dumps({"programs": rows}, indent=1) + "\n")
    failed = sum(not r.ok for r in results)
    out.print(f"{len(results) - failed} of {len(results)} programs written; {failed} failed")
    return 1 if failed else 0


def _can_stream(request: CompensationRequest) -> bool:
    """Whether the chunks can carry this request: no per-target forces, report, subdivision,
    other modules' data, nor standard output (those need the whole program)."""
    return (request.cut is None and request.force_file is None and request.report is None and not request.subdivide
            and request.output != "-" and not request.data)


def _compensate_streamed(request: CompensationRequest) -> bool:
    """compensate --stream: a long program in chunks (postproc.jobs.stream); False where the
    whole-program path must take it (too short, or a program the chunks cannot carry: said why)."""
    program, model = request.programs[0], request.machine.model
    if not wants_stream(program, request.stream):
        return False
    try:
        with ProgressLine("compensating in chunks", console=err) as progress:
            result = stream_request(request, tune_malloc=True, progress=progress)
    except StreamFallback as exc:
        err.print(f"note: the program is read whole, not in chunks: {exc}")
        return False
    except CompensationError as exc:
        failures = getattr(exc, "failures", [])
        err.print(describe_model(model_summary(model)["model"]), highlight=False)
        columns = getattr(exc, "columns", {})
        for line, reason in failures[:50]:
            err.print(f"{program}:{line}:{columns[line]}: {reason}" if line in columns else f"{program}:{line}: {reason}", highlight=False)
        raise
    s = result.summary
    b, a = s["predicted_before"], s["predicted_after"]
    out.print(describe_model(model_summary(model)["model"]))
    if b["rms_mm"] is not None:
        out.print(f"{s['compensated']} of {s['targets']} targets compensated ({request.scheme}, {s['chunks']} chunks); predicted error RMS "
                  f"{b['rms_mm']:.4f} -> {a['rms_mm']:.4f} mm, max {b['max_mm']:.4f} -> {a['max_mm']:.4f} mm; "
                  f"iterations median {s['iterations_median']:.0f}, max {s['iterations_max']}")
    if s["path"] is not None:
        pth = s["path"]
        out.print(f"between targets ({pth['segments']} straight or circular segments, controller interpolation, model prediction): "
                  f"largest distance from the intended path {pth['max_mm']:.4f} mm, on the segment into line {pth['line']}; "
                  f"{pth['over_tolerance']} segment(s) over {pth['tolerance_mm']:g} mm (--max-deviation to refuse them)")
    for note in result.notes:
        out.print(f"note: {note}")
    return True
