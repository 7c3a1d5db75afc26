"""place: a workpiece placement search."""

from __future__ import annotations

import io
import json
from pathlib import Path
from typing import Optional

import numpy as np
import typer

from postproc.errors import InputError, JobError
from postproc.files import write_all
from postproc.process import place_report as report
from postproc.process import placement as pl
from postproc.process.compliance import identified_compliance
from postproc.process.forces import load_cut_params
from postproc.process.place_program import check_placed, placed_conf, placed_texts, problem_from_program
from postproc.programs.dialects import of as dialect_of
from postproc.programs.program_io import parse_program
from postproc.progress import ProgressLine
from postproc.robot.robots import load_robot

from .app import app, err, handles_errors, out
from .common import DIALECT_HELP, floats
from .plugin_option import with_plugins


def _search_spec(text: str) -> list[tuple[float, float, float]]:
    """'X0:X1:DX,Y0:Y1:DY,T0:T1:DT' -> three (start, stop, step)."""
    parts = text.split(",")
    if len(parts) != 3 or any(len(p.split(":")) != 3 for p in parts):
        raise InputError(f"--search: expected X0:X1:DX,Y0:Y1:DY,T0:T1:DT (mm, mm, deg), got '{text}'")
    try:
        return [tuple(float(v) for v in p.split(":")) for p in parts]
    except ValueError:
        raise InputError(f"--search: expected numbers in X0:X1:DX,Y0:Y1:DY,T0:T1:DT, got '{text}'") from None


@app.command("place")
@handles_errors
@with_plugins
def place_cmd(
    program: Path = typer.Argument(..., help="Program whose Cartesian targets are in one workpiece frame (RAPID work object, KRL $BASE)."),
    robot: str = typer.Option(..., "--robot", help="Robot name from robots/ or a robot file."),
    search_spec: str = typer.Option(..., "--search", help="X0:X1:DX,Y0:Y1:DY,T0:T1:DT: the grid of workpiece frames (mm, mm, deg about base z)."),
    z: float = typer.Option(..., "--z", help="Height of the workpiece frame in the base frame, mm."),
    force: Optional[str] = typer.Option(None, "--force", help="Constant cutting force fx,fy,fz on the tool, N, tool frame."),
    cut: Optional[Path] = typer.Option(None, "--cut", help="Cutting-parameter TOML (tool, material, cut) for the mechanistic force model, instead of --force."),
    stock: Optional[Path] = typer.Option(None, "--stock", help="Stock mesh (STL, OBJ, ...) in the workpiece frame: engagement per target from stock minus swept tool (with --cut; 3-axis Z-map)."),
    model: Optional[Path] = typer.Option(None, "--model", help="Fitted model JSON: its identified joint compliance replaces the robot file's stiffness."),
    json_out: bool = typer.Option(False, "--json", help="Machine-readable output (spec/cli.md)."),
    output: Optional[Path] = typer.Option(None, "-o", "--output", help="Write the program with the best workpiece frame here."),
    plot: Optional[Path] = typer.Option(None, "--plot", help="Heat map PNG of the mean normal error per theta; the error along the path goes beside it (*_path.png)."),
    refine: bool = typer.Option(True, "--refine/--no-refine", help="Bounded local refinement after the grid."),
    singular_margin: float = typer.Option(5.0, "--singular-margin", help="Minimum distance from wrist and elbow singularities, deg."),
    keep_conf: bool = typer.Option(False, "--keep-conf", help="Keep the program's configuration data (turn data included) at every placement; by default they are re-derived for the moved workpiece as a re-post would, keeping its arm configuration."),
    dialect: Optional[str] = typer.Option(None, "--dialect", help=DIALECT_HELP),
):
    """Find the workpiece placement that minimises the force-induced normal error (seed 002)."""
    if (force is None) == (cut is None):
        raise InputError("give the cutting force as either --force FX,FY,FZ or --cut CUT.toml")
    axes = [pl.grid_axis(spec, name) for spec, name in zip(_search_spec(search_spec), ("x", "y", "theta"))]
    tp = parse_program(program, dialect)
    problem, sources = _place_problem(tp, load_robot(robot), force, cut, stock, model, singular_margin, "keep" if keep_conf else "rederive")
    with ProgressLine("place", console=err) as progress:
        result = pl.search(problem, *axes, z, refine=refine, progress=report.counted(progress))
    frame0, cur = report.current_placement(tp, problem, result, z)
    doc = {"best": None, **report.summary(result, problem), "current": cur, "reduction_percent": None, **sources}
    if not np.isfinite(result.best_mm):
        if json_out:
            print(json.dumps(doc))
        else:
            out.print("\n".join(report.lines(doc, z)))
        raise JobError(f"no feasible placement in the search grid ({result.grid_mean_mm.size} candidates): "
                       + ", ".join(f"{name} {n}" for name, n in doc["infeasible"].items()))
    doc["best"] = {"x": float(result.best[0]), "y": float(result.best[1]), "theta": float(result.best[2]), "z": z, "mean_normal_error_mm": result.best_mm}
    doc["grid_best"] = {"x": float(result.grid_best[0]), "y": float(result.grid_best[1]), "theta": float(result.grid_best[2]), "mean_normal_error_mm": result.grid_best_mm}
    if cur is not None and cur["mean_normal_error_mm"]:
        doc["reduction_percent"] = 100.0 * (1.0 - result.best_mm / cur["mean_normal_error_mm"])
    best_frame = pl.placement_frames(result.best, z)[0]
    files: dict[Path, bytes] = {}  # the program's files and the figures: written together or not at all
    if output is not None:
        new_conf = placed_conf(problem, best_frame) if not keep_conf else None
        texts = placed_texts(tp, best_frame, new_conf)
        check_placed(tp, texts, best_frame, new_conf)

        files.update({Path(p): text.encode("latin-1") for p, text in dialect_of(tp).files(tp, texts, output).items()})
        doc["written"] = str(output)
        doc["conf_written"] = 0 if new_conf is None else int(np.isfinite(new_conf).any(axis=1).sum())
    if plot is not None:
        figures = _place_figures(plot, result, problem, best_frame, frame0, cur)
        files.update(figures)
        doc["figures"] = [str(p) for p in figures]
    write_all(files)
    if json_out:
        print(json.dumps(doc))
        return
    out.print("\n".join(report.lines(doc, z)))


def _place_problem(tp, robot_model, force, cut, stock, model, singular_margin, conf_mode):
    """The placement problem of the place command's inputs, and where its force and compliance come from."""
    fitted = None
    if model is not None:
        # Deferred import: it loads scipy (slow to import); `postproc --version` must stay fast.
        from postproc.model.model_io import load_model

        fitted, _ = load_model(model)
    params = None if cut is None else load_cut_params(cut)
    force_tool = None if force is None else floats(force, 3, "--force")
    engagement = None
    if stock is not None:
        if params is None:
            raise InputError("--stock needs --cut (the engagement feeds the mechanistic force model)")
        # Deferred import: it loads trimesh (slow to import); `postproc --version` must stay fast.
        from postproc.process.engagement import load_stock, program_engagement

        engagement = program_engagement(tp, params.diameter, load_stock(stock))
    problem = problem_from_program(tp, robot_model, force_tool=force_tool, params=params, engagement=engagement, model=fitted, singular_deg=singular_margin, conf_mode=conf_mode)
    sources = {"force": "constant tool-frame force" if force is not None else f"mechanistic model ({cut})" + (f", engagement from {stock}" if stock else ""),
               "stiffness": "identified by the model" if fitted is not None and identified_compliance(fitted) is not None else f"joint stiffness of {robot_model.name}"}
    return problem, sources


def _place_figures(plot: Path, result, problem, best_frame, frame0, cur) -> dict[Path, bytes]:
    """The heat map (PLOT) and the error along the path (PLOT_path), as PNG bytes by path."""
    # Deferred import: it loads matplotlib (slow to import); `postproc --version` must stay fast.
    from postproc.report.placement_figures import error_maps, path_errors

    steps = np.linalg.norm(np.diff(problem.local_tcp[:, :3, 3], axis=0), axis=1) * ((problem.weights[1:] > 0) & (problem.weights[:-1] > 0))
    dist = np.concatenate([[0.0], np.cumsum(steps)])  # length along the cut
    err_best, _, _ = pl.path_errors(problem, best_frame)
    err_cur = None
    if frame0 is not None and cur["mean_normal_error_mm"] is not None:
        err_cur, _, _ = pl.path_errors(problem, frame0)
    current_xyt = None if cur is None else (cur["x"], cur["y"], cur["theta"])
    paths = [plot, plot.with_name(plot.stem + "_path" + plot.suffix)]
    cutting = problem.weights > 0
    figs = [error_maps(result, current_xyt),
            path_errors(dist[cutting], err_best[cutting], None if err_cur is None else err_cur[cutting])]
    pngs = {}
    for fig, path in zip(figs, paths):
        buffer = io.BytesIO()
        fig.savefig(buffer, dpi=110, format="png")
        pngs[path] = buffer.getvalue()
    return pngs
