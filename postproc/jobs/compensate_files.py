"""``compensate_files(request, log)``: the request's program(s) compensated and written, as its
machine says — the public entry ``postproc compensate`` calls.

The machine is asked first (``Machine.own_job``): a machine with a job of its own (a
calibrated five-axis machine: its grid, rotary solutions and read-back) runs it and its
lines are printed. Every other machine, the robot under its fitted model and a script's own
class alike, takes the shared job here: each program read (``read_program``), compensated
target by target by ``compensate_with`` (the robot core, else the machine's ``inverse`` and
``predict``), its texts (``write_texts``) read back and written, all files or none. What only
a robot's model can do (a batch on Dask, chunks, subdivision, the model's checks and its
report page) asks ``request.robot_model`` or ``request.error_model``, never the machine's class.
"""

from __future__ import annotations

import json
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import BinaryIO

import numpy as np
from rich.console import Console
from rich.table import Table

from postproc.compensation.request import CompensationRequest
from postproc.errors import InputError
from postproc.model.coverage_text import describe_model, model_summary
from postproc.model.measurements import write_text_atomic
from postproc.programs.arcs import summary as arc_summary
from postproc.programs.content import require_program
from postproc.programs.program_io import (
    check_texts,
    files_for,
    language_of,
    refuse_overwrite,
    refuse_stdout,
    write_set,
)
from postproc.progress import ProgressLine

from .compensate import CompensationError, compensate_with, process_forces
from .program_check import check_model_fits
from .stream import StreamFallback, stream_request, wants_stream
from .subdivide import subdivide_request

# As the command line's consoles: messages carry user text ([brackets] too), lines are not wrapped.
_PLAIN = {"markup": False, "highlight": False, "soft_wrap": True}
# The page's figures need matplotlib (postproc.report, a floor above): the caller brings the writer.
PageWriter = Callable[[Path, object, dict, object, str, Path], None]


@dataclass(frozen=True)
class JobLog:
    """Where a job's account goes. ``out``: the account; ``err``: progress, failures, and the
    account when the program itself goes to standard output; ``write_page``: ``--report
    PAGE.html``'s writer (report, per-point report, summary, model, program, model file);
    ``stdout``: where ``-o -`` writes the program (default: the process's standard output)."""

    out: Console
    err: Console
    write_page: PageWriter | None = None
    stdout: BinaryIO | None = None


def compensate_files(request: CompensationRequest, log: JobLog | None = None) -> int:
    """Compensate and write the request's program(s) as its machine says; returns the exit
    status (0, or 1 where a batch had programs that failed). Raises the library's typed errors
    (nothing written) for the caller to map."""
    log = log or JobLog(Console(**_PLAIN), Console(stderr=True, **_PLAIN))
    # own_job is optional: a machine class written before it existed takes the shared job.
    own_job = getattr(request.machine, "own_job", None)
    own = own_job(request) if own_job is not None else None
    if own is not None:
        for line in own:
            log.out.print(line)
        return 0
    if request.is_batch:
        log.out.print(describe_model(model_summary(request.robot_model("--out-dir"))["model"]))
        return _compensate_batch(request, log)
    if can_stream(request) and _compensate_streamed(request, log):
        return 0
    _compensate_whole(request, log)
    return 0


def _compensate_whole(request: CompensationRequest, log: JobLog) -> None:
    """compensate PROGRAM -o OUT: the whole program read, compensated (subdivided with
    --subdivide), checked and written."""
    output, report, error_model = request.output, request.report, request.error_model()
    tp = _read_program(request)
    require_program(tp)  # an empty file, no DEF / MODULE, no motion: nothing is written
    to_stdout = output == "-"
    _refuse_unsafe_output(tp, output, request.in_place)
    say = log.err if to_stdout else log.out

    if error_model is not None:
        for note in check_model_fits(tp, error_model, *request.model_check()):
            say.print(f"note: {note} (--allow-model-mismatch)")
    forces = process_forces(request, tp)
    for note in forces.notes:
        say.print(f"note: {note}")

    with ProgressLine("compensating", console=log.err) as progress:
        run = {"forces": forces, "progress": progress, "detail": is_page(report)}
        written, added = tp, ()
        if request.subdivide:
            sub = subdivide_request(request, tp, language_of(tp), **run)
            written, new, rep, added = sub.program, sub.compensated, sub.report, sub.added
        else:
            new, rep = compensate_with(request, tp, **run)
    summary = {**rep.summary(), **_machine_summary(request)}

    summary["arcs"] = arc_summary(written, rep.path_mm)  # the subdivided program when --subdivide added targets
    if is_page(report):  # written also when targets fail: the page shows where
        _write_page(request, log, rep, summary)
    elif report is not None:
        _write_point_report(report, rep, summary)
    failures = rep.failures_at(written)
    if failures:
        log.err.print(_describe(request, summary), highlight=False)
        for where, reason in failures[:50]:
            log.err.print(f"{where}: {reason}", highlight=False)
        if len(failures) > 50:
            log.err.print(f"... and {len(failures) - 50} more")
        raise CompensationError(f"{len(failures)} target(s) cannot be compensated; nothing was written", rep)
    _write_compensated(request, log, written, new, np.nonzero(rep.compensated)[0], original=tp)
    if added:
        say.print(f"{len(added)} new target(s) subdivide straight segments and arcs (lines {', '.join(str(line) for line, _ in added[:20])}{' ...' if len(added) > 20 else ''})")
    scheme = request.scheme if error_model is not None else "fixed point"  # through_machine's iteration: no scheme to choose
    _print_compensation(summary, _describe(request, summary), scheme, new.notes, say)


def _machine_summary(request: CompensationRequest) -> dict:
    """The summary's ``model`` entry for a robot under its fitted model; any other machine by
    its kind and file."""
    model = request.error_model()
    if model is not None:
        return model_summary(model)
    return {"machine": {"kind": request.machine.kind, "source": request.machine.source}}


def _describe(request: CompensationRequest, summary: dict) -> str:
    """The account's first line: the model (robot) or the machine compensated for."""
    if "model" in summary:
        return describe_model(summary["model"])
    return f"compensated for the {request.machine.kind} ({request.machine.source})"


def _print_compensation(summary: dict, described: str, scheme: str, notes, say: Console) -> None:
    """compensate's account of one program: predicted error before and after, the path between
    targets, the arcs, and the program's notes."""
    b, a = summary["predicted_before"], summary["predicted_after"]
    say.print(described)
    if b["rms_mm"] is not None:
        say.print(
            f"{summary['compensated']} of {summary['targets']} targets compensated ({scheme}); predicted error RMS {b['rms_mm']:.4f} -> {a['rms_mm']:.4f} mm, "
            f"max {b['max_mm']:.4f} -> {a['max_mm']:.4f} mm; iterations median {summary['iterations_median']:.0f}, max {summary['iterations_max']}"
        )
    else:
        say.print("no Cartesian target to compensate (joint targets are kept as written)")
    if summary["path"] is not None:
        pth = summary["path"]
        say.print(f"between targets ({pth['segments']} straight or circular segments, controller interpolation, model prediction): "
                  f"largest distance from the intended path {pth['max_mm']:.4f} mm, on the segment into line {pth['line']}; "
                  f"{pth['over_tolerance']} segment(s) over {pth['tolerance_mm']:g} mm (--max-deviation to refuse them)")
    _print_arc_deviation(summary["arcs"], say)
    for note in notes:
        say.print(f"note: {note}")


def _print_arc_deviation(arcs: dict | None, say: Console) -> None:
    """The circular motions' largest predicted distance from the intended arc (issue 13: the mid-arc deviation)."""
    if arcs is not None:
        say.print(f"circular motions ({arcs['arcs']}, CIRC / MoveC / G2 / G3): largest predicted distance from the intended arc "
                  f"{arcs['max_mm']:.4f} mm, on the arc into line {arcs['line']}")


def is_page(report: Path | None) -> bool:
    """--report PAGE.html: the page (postproc.report.compensation), else the JSON."""
    return report is not None and report.suffix.lower() in (".html", ".htm")


def _write_page(request: CompensationRequest, log: JobLog, rep, summary: dict) -> None:
    """--report PAGE.html, by the caller's writer (the page shows the robot model's region)."""
    model = request.robot_model("--report PAGE.html")
    if log.write_page is None:
        raise InputError(f"--report {request.report}: this caller writes no report page (give a .json name)")
    log.write_page(request.report, rep, summary, model, request.programs[0], Path(request.machine.source))


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


def _read_program(request: CompensationRequest):
    """The request's program, or - for standard input (then ``dialect`` is needed), read by
    the machine; ``data``: other modules' files it uses (--data, KRL)."""
    program, dialect = request.programs[0], request.dialect
    if program != "-":
        if request.data:  # only a machine that takes --data reads other modules
            return request.machine.read_program(Path(program), dialect, modules=request.data)
        return request.machine.read_program(Path(program), dialect)
    if dialect is None:
        raise InputError("reading a program from standard input needs --dialect")
    return request.machine.read_program("-", dialect, sys.stdin.buffer.read())


def _refuse_unsafe_output(tp, output: str, in_place: bool) -> None:
    """Before the work: standard output only for one-file programs; no input overwritten
    without --in-place (a changed $config.dat is checked again when the texts are known)."""
    if output == "-":
        refuse_stdout(tp)
    else:
        refuse_overwrite(tp, files_for(tp, [doc.text for doc in tp.sources], output), in_place)


def _write_compensated(request: CompensationRequest, log: JobLog, tp, new, rows, original=None) -> None:
    """Emit (the machine's ``write_texts``), re-parse (the targets ``rows`` must read back as
    compensated), then write the whole set of changed files at once, or the program to
    standard output. ``original``: the program as read when ``tp`` has new targets (files
    differing from it are written)."""
    original = tp if original is None else original
    output, in_place = request.output, request.in_place

    texts = request.machine.write_texts(tp, new)
    check_texts(tp, new, texts, rows)
    if output == "-":
        stdout = log.stdout or sys.stdout.buffer
        stdout.write(texts[0].encode("latin-1"))
        stdout.flush()
        return
    files = files_for(original, texts, output)
    refuse_overwrite(original, files, in_place)
    write_set(files, backup=in_place)


def _compensate_batch(request: CompensationRequest, log: JobLog) -> int:
    """compensate PROGRAM... --out-dir DIR [--jobs N | --scheduler ADDRESS]: postproc.jobs.batch on Dask."""

    # Deferred import: it loads dask.distributed (slow to import); `postproc --version` must stay fast.
    from .batch import run_batch_request

    programs, out_dir, report = request.programs, request.out_dir, request.report
    finished = []
    with ProgressLine("compensating", console=log.err) as progress:
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
        fmt = lambda v: "-" if v is None else f"{v:.4f}"
        table.add_row(r.program, "written" if r.ok else "FAILED", str(r.summary.get("targets", "-")), fmt(b.get("rms_mm")), fmt(a.get("rms_mm")), r.error or "")
        if not r.ok:
            log.err.print(f"error: {r.program}: {r.error}")
    log.out.print(table)
    if report is not None:
        rows = [{"program": r.program, "ok": r.ok, "outputs": list(r.outputs), "error": r.error, "summary": r.summary} for r in results]
        write_text_atomic(report, json.dumps({"programs": rows}, indent=1) + "\n")
    failed = sum(not r.ok for r in results)
    log.out.print(f"{len(results) - failed} of {len(results)} programs written; {failed} failed")
    return 1 if failed else 0


def can_stream(request: CompensationRequest) -> bool:
    """Whether the chunks can carry this request: a robot's model (or ``--stream always``, which
    then names what is missing), no per-target forces, report, subdivision, other modules'
    data, nor standard output (those need the whole program)."""
    return ((request.error_model() is not None or request.stream == "always")
            and request.cut is None and request.force_file is None and request.report is None and not request.subdivide
            and request.output != "-" and not request.data)


def _compensate_streamed(request: CompensationRequest, log: JobLog) -> bool:
    """compensate --stream: a long program in chunks (postproc.jobs.stream); False where the
    whole-program path must take it (too short, or a program the chunks cannot carry: said why)."""
    program = request.programs[0]
    if not wants_stream(program, request.stream):
        return False
    model = request.robot_model("--stream")
    try:
        with ProgressLine("compensating in chunks", console=log.err) as progress:
            result = stream_request(request, tune_malloc=True, progress=progress)
    except StreamFallback as exc:
        log.err.print(f"note: the program is read whole, not in chunks: {exc}")
        return False
    except CompensationError as exc:
        failures = getattr(exc, "failures", [])
        log.err.print(describe_model(model_summary(model)["model"]), highlight=False)
        columns = getattr(exc, "columns", {})
        for line, reason in failures[:50]:
            log.err.print(f"{program}:{line}:{columns[line]}: {reason}" if line in columns else f"{program}:{line}: {reason}", highlight=False)
        raise
    s = result.summary
    b, a = s["predicted_before"], s["predicted_after"]
    log.out.print(describe_model(model_summary(model)["model"]))
    if b["rms_mm"] is not None:
        log.out.print(f"{s['compensated']} of {s['targets']} targets compensated ({request.scheme}, {s['chunks']} chunks); predicted error RMS "
                      f"{b['rms_mm']:.4f} -> {a['rms_mm']:.4f} mm, max {b['max_mm']:.4f} -> {a['max_mm']:.4f} mm; "
                      f"iterations median {s['iterations_median']:.0f}, max {s['iterations_max']}")
    if s["path"] is not None:
        pth = s["path"]
        log.out.print(f"between targets ({pth['segments']} straight or circular segments, controller interpolation, model prediction): "
                      f"largest distance from the intended path {pth['max_mm']:.4f} mm, on the segment into line {pth['line']}; "
                      f"{pth['over_tolerance']} segment(s) over {pth['tolerance_mm']:g} mm (--max-deviation to refuse them)")
    for note in result.notes:
        log.out.print(f"note: {note}")
    return True
