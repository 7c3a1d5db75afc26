"""compensate: a program rewritten so the robot or machine reaches the intended targets
(whole, streamed in chunks, or a batch of programs). The command builds the request; the
job is the library's (``postproc.jobs.compensate_files``), which asks the machine how."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from postproc.compensation.request import CompensationRequest
from postproc.jobs.compensate_files import JobLog, compensate_files
from postproc.model.measurements import write_text_atomic
from postproc.programs.dialects.heidenhain.tool_table import parse_tool_radii
from postproc.progress import ProgressLine

from .app import app, err, handles_errors, out
from .common import (
    DIALECT_HELP,
    TOOL_RADIUS_OPTION,
    check_output_folder,
    floats,
    named_frames,
)
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
    tool_radius: Optional[list[str]] = TOOL_RADIUS_OPTION,
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
        frames=named_frames(frame, "--frame") or {}, tools=named_frames(tool, "--tool") or {}, tool_radii=parse_tool_radii(tool_radius),
        start_joints=None if start_joints is None else tuple(floats(start_joints, 6, "--start-joints")),
        max_deviation_mm=max_deviation, subdivide=subdivide, stream=stream, report=report, robot=robot,
        allow_mismatch=allow_mismatch, allow_extrapolation=allow_extrapolation, grid=grid, input_axes=input_axes)
    check_output_folder(report, "--report")
    status = compensate_files(request, JobLog(out, err, write_page=_write_page))
    if status:
        raise typer.Exit(status)


def _write_page(report: Path, rep, summary: dict, model, program: str, model_path: Path) -> None:
    """--report PAGE.html (its figures take a few seconds: a spinner meanwhile)."""

    # Deferred import: it loads matplotlib (slow to import); `postproc --version` must stay fast.
    from postproc.report.compensation import compensation_report

    with ProgressLine("report", console=err) as progress:
        progress(f"writing the report page {report}")
        write_text_atomic(report, compensation_report(rep, summary, model, program, str(model_path)))
