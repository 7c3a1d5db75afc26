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

from ..arcs import summary as arc_summary
from ..compensate import CompensationError, compensate
from ..coverage_text import describe_model, model_summary
from ..errors import InputError
from ..fivex.commands import compensate_five_program
from ..force_file import base_frame_forces, read_force_file
from ..forces import load_cut_params, program_forces
from ..measurements import write_text_atomic
from ..plugin_option import with_plugins
from ..program_check import check_model_fits
from ..program_content import require_program
from ..programs import check_texts, emit_texts, files_for, parse_program, refuse_overwrite, refuse_stdout, write_set
from ..progress import ProgressLine
from ..stream import StreamFallback, compensate_streamed, wants_stream
from ..subdivide import DEFAULT_TOLERANCE_MM, compensate_subdivided
from .app import app, err, handles_errors, out
from .common import check_output_folder, floats, named_frames, refuse_unused


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
    dialect: Optional[str] = typer.Option(None, "--dialect", help="rapid, krl or gcode (default: from the extension or content)."),
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
    if model.suffix == ".toml":
        refuse_unused("by five-axis compensation (--model MACHINE.toml)", {
            "--out-dir": out_dir is not None, "--jobs": jobs is not None, "--scheduler": scheduler is not None, "--in-place": in_place,
            "--tol": tol != 0.01, "--max-iter": max_iter != 25, "--scheme": scheme != "broyden", "--temp": temp is not None,
            "--force": force is not None, "--report": report is not None,
            "--start-joints": start_joints is not None, "--cut": cut is not None, "--max-deviation": max_deviation is not None,
            "--force-file": force_file is not None, "--subdivide": subdivide, "--robot": robot is not None, "--allow-model-mismatch": allow_mismatch,
            "--allow-extrapolation (a machine's error grid is never extrapolated)": allow_extrapolation})

        if len(programs) != 1 or output is None:
            raise InputError("five-axis compensation takes one program and -o OUT")
        for line in compensate_five_program(Path(programs[0]), model, Path(output), grid, input_axes, dialect=dialect,
                                            frames=named_frames(frame, "--frame"), tools=named_frames(tool, "--tool")):
            out.print(line)
        return
    # Deferred import: it loads scipy (slow to import); `postproc --version` must stay fast.
    from ..model_io import load_model

    refuse_unused("with a robot model (five-axis only: --model MACHINE.toml)", {"--grid": grid is not None, "--input-axes": input_axes is not None})
    if tol <= 0 or max_iter < 1:
        raise InputError("--tol must be > 0 and --max-iter >= 1")
    if max_deviation is not None and not max_deviation > 0:
        raise InputError(f"--max-deviation must be > 0 mm, got {max_deviation}")
    check_output_folder(report, "--report")
    error_model, _ = load_model(model)
    forces = None if force is None else floats(force, 3, "--force")
    common = {"tol_mm": tol, "max_iter": max_iter, "scheme": scheme, "temp_c": temp, "force_n": forces,
              "frames": named_frames(frame, "--frame"), "tools": named_frames(tool, "--tool"),
              "start_joints": None if start_joints is None else floats(start_joints, 6, "--start-joints"),
              "allow_extrapolation": allow_extrapolation}
    if out_dir is not None or jobs is not None or scheduler is not None or len(programs) > 1:
        if cut is not None or in_place or subdivide or force_file is not None or data:
            raise InputError("--cut, --force-file, --in-place, --subdivide and --data work on one program at a time (not with --out-dir)")
        options = {**common, "max_deviation_mm": max_deviation, "model_check": (str(model), robot, allow_mismatch)}
        out.print(describe_model(model_summary(error_model)["model"]))
        raise typer.Exit(_compensate_batch(programs, model, output, out_dir, jobs, scheduler, dialect, options, report))
    program = programs[0]
    if output is None:
        raise InputError("compensate needs -o OUT (or --out-dir DIR for many programs)")
    stream_options = {**common, "max_deviation_mm": max_deviation, "model_check": (str(model), robot, allow_mismatch)}
    if cut is None and report is None and output != "-" and not data and _compensate_streamed(program, error_model, output, dialect, stream, in_place, stream_options):
        return
    tp = _read_program(program, dialect, data)
    require_program(tp)  # an empty file, no DEF / MODULE, no motion: nothing is written
    to_stdout = output == "-"
    _refuse_unsafe_output(tp, output, in_place)
    log = err if to_stdout else out

    for note in check_model_fits(tp, error_model, str(model), robot, allow_mismatch):
        log.print(f"note: {note} (--allow-model-mismatch)")

    with ProgressLine("compensating", console=err) as progress:
        options = dict(common, force_per_target=_block_forces(cut, force_file, forces, tp, frame, tool, log), progress=progress,
                       detail=_is_page(report))
        written, added = tp, ()
        if subdivide:
            sub = compensate_subdivided(tp, error_model, max_deviation or DEFAULT_TOLERANCE_MM, **options)
            written, new, rep, added = sub.program, sub.compensated, sub.report, sub.added
        else:
            new, rep = compensate(tp, error_model, max_deviation_mm=max_deviation, **options)
    summary = {**rep.summary(), **model_summary(error_model)}

    summary["arcs"] = arc_summary(written, rep.path_mm)  # the subdivided program when --subdivide added targets
    if _is_page(report):  # written also when targets fail: the page shows where
        _write_page(report, rep, summary, error_model, program, model)
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
    _write_compensated(written, new, np.nonzero(rep.compensated)[0], output, in_place, original=tp)
    if added:
        log.print(f"{len(added)} new target(s) subdivide straight segments and arcs (lines {', '.join(str(line) for line, _ in added[:20])}{' ...' if len(added) > 20 else ''})")
    _print_compensation(summary, scheme, new.notes, log)


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


def _cut_forces(cut: Optional[Path], tp, frame, tool):
    """--cut: the mechanistic force (N, 3) of every target in the base frame, None without it."""
    if cut is None:
        return None

    placed = tp.with_frames(named_frames(frame, "--frame"), named_frames(tool, "--tool")) if (frame or tool) else tp
    return program_forces(placed, params=load_cut_params(cut))


def _block_forces(cut, force_file, forces, tp, frame, tool, log):
    """The force of every target in the base frame from --cut or --force-file, None without them."""
    if force_file is None:
        return _cut_forces(cut, tp, frame, tool)

    if cut is not None or forces is not None:
        raise InputError("--force-file gives the force of every motion block: not with --force or --cut")
    tool_frame, unlisted = read_force_file(force_file, tp)
    if unlisted:
        log.print(f"note: {unlisted} Cartesian target(s) have no row in {force_file}: no process force there")
    placed = tp.with_frames(named_frames(frame, "--frame"), named_frames(tool, "--tool")) if (frame or tool) else tp
    return base_frame_forces(placed, tool_frame)


def _is_page(report: Optional[Path]) -> bool:
    """--report PAGE.html: the page (postproc.report.compensation), else the JSON."""
    return report is not None and report.suffix.lower() in (".html", ".htm")


def _write_page(report: Path, rep, summary: dict, model, program: str, model_path: Path) -> None:
    """--report PAGE.html (its figures take a few seconds: a spinner meanwhile)."""

    # Deferred import: it loads matplotlib (slow to import); `postproc --version` must stay fast.
    from ..report.compensation import compensation_report

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

def _compensate_batch(programs, model, output, out_dir, jobs, scheduler, dialect, options, report) -> int:
    """compensate PROGRAM... --out-dir DIR [--jobs N | --scheduler ADDRESS]: postproc.batch on Dask."""

    # Deferred import: it loads dask.distributed (slow to import); `postproc --version` must stay fast.
    from ..batch import run_batch

    if out_dir is None or output is not None:
        raise InputError("several programs take --out-dir DIR (not -o)")
    if jobs is not None and scheduler is not None:
        raise InputError("give --jobs N or --scheduler ADDRESS, not both")
    if jobs is not None and jobs < 1:
        raise InputError("--jobs must be at least 1")
    if "-" in programs:
        raise InputError("standard input (-) is for a single program with -o")
    finished = []
    with ProgressLine("compensating", console=err) as progress:
        progress("programs", 0, len(programs))

        def one_done(result) -> None:
            finished.append(result)
            progress("programs", len(finished), len(programs))

        results = run_batch([Path(p) for p in programs], model, out_dir, options, jobs=jobs, scheduler=scheduler, dialect=dialect,
                            on_done=one_done)
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


def _compensate_streamed(program: str, model, output: str, dialect, mode: str, in_place: bool, options: dict) -> bool:
    """compensate --stream: a long program in chunks (postproc.stream); False where the
    whole-program path must take it (too short, or a program the chunks cannot carry: said why)."""
    if not wants_stream(program, mode):
        return False
    try:
        with ProgressLine("compensating in chunks", console=err) as progress:
            result = compensate_streamed(program, model, output, dialect=dialect, in_place=in_place, tune_malloc=True,
                                         progress=progress, **options)
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
        out.print(f"{s['compensated']} of {s['targets']} targets compensated ({options['scheme']}, {s['chunks']} chunks); predicted error RMS "
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
