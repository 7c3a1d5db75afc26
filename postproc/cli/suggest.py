"""suggest-poses: where to measure next."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Optional

import numpy as np
import typer

from postproc.errors import InputError
from postproc.model.effects import parse_effects
from postproc.model.sim import parse_region
from postproc.progress import ProgressLine
from postproc.robot.robots import load_robot

from .app import app, err, handles_errors, out
from .common import check_output_folder, floats, load_measurements, refuse_unused
from .plugin_option import with_plugins


@app.command("suggest-poses")
@handles_errors
@with_plugins
def suggest_poses_cmd(
    output: Path = typer.Option(..., "-o", "--output", help="CSV of the chosen poses (id, q1..q6 and the candidates' other columns), in measuring order."),
    n: int = typer.Option(..., "-n", "--n", help="Number of poses to choose."),
    robot: Optional[str] = typer.Option(None, "--robot", help="Robot name or file (default: the --model's)."),
    tool: Optional[str] = typer.Option(None, "--tool", help="X,Y,Z of the measured point in the flange frame, mm (default: the --model's, else the flange's centre 0,0,0)."),
    effects: Optional[str] = typer.Option(None, "--effects", help="Effects the measurements are to identify (default: the --model's)."),
    model: Optional[Path] = typer.Option(None, "--model", help="A fitted model: the Jacobian is taken at its values."),
    candidates: Optional[Path] = typer.Option(None, "--candidates", help="CSV of poses the robot can reach (q1..q6 degrees; id and other columns optional)."),
    workspace: str = typer.Option("cylinder", "--workspace", help="Without --candidates: where to generate them: cylinder, box or joints (as simulate)."),
    region: Optional[str] = typer.Option(None, "--region", help="Workspace extents, as simulate's --region."),
    box: Optional[str] = typer.Option(None, "--box", help="Generate candidates in a box: the same as --workspace box --region TEXT ('' for the default box)."),
    cylinder: Optional[str] = typer.Option(None, "--cylinder", help="Generate candidates in a cylinder sector: --workspace cylinder --region TEXT."),
    n_candidates: Optional[int] = typer.Option(None, "--n-candidates", help="Without --candidates: how many to generate (default: 60 per chosen pose, at least 2,000, at most 12,000: the more candidates, the better the design can do, while random poses from the same workspace do not change)."),
    tracker: Optional[str] = typer.Option(None, "--tracker", help="X,Y,Z of the laser tracker in the robot base frame, mm: generated candidates must be in its range and line of sight."),
    tracker_range: Optional[str] = typer.Option(None, "--tracker-range", help="MIN:MAX distance the tracker measures, mm (default 1000:15000)."),
    tracker_cone: Optional[float] = typer.Option(None, "--tracker-cone", help="Reflector acceptance half-angle about the tool z axis, deg (default: not checked)."),
    criterion: str = typer.Option("D", "--criterion", help="D (default), E or A-optimal design of the parameters, or I: the least mean predicted error over the candidates (with --program: at its targets)."),
    program: Optional[Path] = typer.Option(None, "--program", help="Region-targeted: minimise the predicted error at this program's targets."),
    dialect: Optional[str] = typer.Option(None, "--dialect", help="Dialect of --program (default: from the extension or content)."),
    measured: Optional[Path] = typer.Option(None, "--measured", help="Poses measured already (measurement CSV): suggest the next batch."),
    random_share: Optional[float] = typer.Option(None, "--random-share", help="Fraction drawn at random (with --program near its targets) of the poses beyond the fewest fit accepts; those first poses are all chosen by the design. Default: 0.2 of them, at most 4 poses (e.g. 39 parameters need 13: -n 20 draws 1, -n 32 draws 4, -n 100 draws 4): on a simulated machining pass with an effect the model lacks, random shares 0, 0.1 and 0.2 gave the same true error at -n 32 to 100, so a few random poses serve as a check where the program runs and the rest are chosen. A value given is used as it is, without the cap."),
    load_states: Optional[str] = typer.Option(None, "--load-states", help="FX,FY,FZ[;FX,FY,FZ...]: every candidate under each of these TCP forces (N, base frame; 0,0,0 for none), written as fx,fy,fz: separates compliance from geometry (effects joint_compliance + external_load)."),
    noise: float = typer.Option(0.02, "--noise", help="Measurement noise per axis, mm."),
    seed: int = typer.Option(0, "--seed"),
    json_out: bool = typer.Option(False, "--json", help="Print {chosen, criterion, expected_rms_mm, ...} as JSON."),
    plot: Optional[Path] = typer.Option(None, "--plot", help="PNG of the predicted error against N, suggested and random."),
    program_out: Optional[Path] = typer.Option(None, "--program-out", help="Also write a robot program that visits the chosen poses (RAPID .mod, KRL .src)."),
    program_language: Optional[str] = typer.Option(None, "--program-language", help="Language of --program-out (default: from its extension)."),
):
    """Choose the poses to measure that identify the model best (optimal experiment design)."""

    # Deferred import: it loads scipy / matplotlib (slow to import); `postproc --version` must stay fast.
    from postproc.model.model_io import load_model
    from postproc.suggest import program_targets, suggest_poses
    from postproc.suggest.candidates import default_count, generate, read_candidates, with_load_states
    from postproc.suggest.inputs import design_model, tracker_from
    from postproc.suggest.job import report_lines, write_outputs
    from postproc.suggest.program import language_of

    if box is not None or cylinder is not None:  # spec/cli.md's --box/--cylinder: a workspace and its region in one option
        refuse_unused("with --box or --cylinder (they give the workspace)", {"--workspace": workspace != "cylinder", "--region": region is not None,
                                                                                "--box and --cylinder together": box is not None and cylinder is not None})
        workspace, region = ("box", box) if box is not None else ("cylinder", cylinder)
    refuse_unused("with --candidates (they are not generated)", {"--box/--cylinder/--region": candidates is not None and region is not None,
                                                                  "--tracker": candidates is not None and tracker is not None,
                                                                  "--n-candidates": candidates is not None and n_candidates is not None})
    refuse_unused("with --program (the design is region-targeted)", {"--criterion": program is not None and criterion not in ("D", "I")})
    fitted = load_model(model)[0] if model is not None else None
    if fitted is None and robot is None:
        raise InputError("suggest-poses needs --robot (or --model MODEL.json)")
    robot_model = load_robot(robot) if robot is not None else fitted.robot
    if tool is not None:
        tool_mm = floats(tool, 3, "--tool")
    elif fitted is not None:
        tool_mm = fitted.tool_mm
    else:  # spec/cli.md's call names no tool: design for the flange, and say so
        tool_mm = np.zeros(3)
        err.print("note: no --tool: the poses are chosen for a point at the flange's centre (0,0,0); "
                  "give --tool X,Y,Z of the measured point (mm, flange frame) to design for it", highlight=False)
    design_for = design_model(robot_model, tool_mm, parse_effects(effects) if effects is not None else None, fitted)
    for path, option in ((output, "-o"), (plot, "--plot"), (program_out, "--program-out")):
        check_output_folder(path, option)
    if program_out is not None:
        language_of(program_out, program_language)  # an unknown language fails before the search, not after
    rng = np.random.default_rng(seed)
    if candidates is not None:
        cands = read_candidates(candidates, robot_model)
    else:
        track = tracker_from(None if tracker is None else floats(tracker, 3, "--tracker"),
                             None if tracker_range is None else tuple(floats(tracker_range.replace(":", ","), 2, "--tracker-range")), tracker_cone)
        # ids name the seed: a batch generated with another seed has other poses under other ids
        count = default_count(n) if n_candidates is None else n_candidates
        cands = generate(robot_model, tool_mm, count, parse_region(workspace, region), rng, track, id_prefix=f"s{seed}-")
    if load_states is not None:
        items = [t for t in load_states.split(";") if t.strip()]
        if not items:
            raise InputError("--load-states: expected FX,FY,FZ[;FX,FY,FZ...] (N, base frame)")
        cands = with_load_states(cands, np.array([floats(t, 3, "--load-states") for t in items]))
    done = load_measurements(measured, robot_model) if measured is not None else None
    targets = program_targets(program, design_for, dialect) if program is not None else None
    with ProgressLine("suggest-poses", console=err, disable=json_out) as progress:
        result = suggest_poses(design_for, cands, n, criterion=criterion, targets_q=targets, measured=done, random_share=random_share,
                               noise_mm=noise, seed=seed, progress=progress)
    title = f"{robot_model.name}, {design_for.effects.spec()}: {n} poses from {len(cands)} candidates"
    written = write_outputs(result, cands, output, program_out, program_language, plot, title)
    if json_out:
        out.print(json.dumps(result.as_json()))
        return
    for line in report_lines(result):
        out.print(line)
    out.print(f"written: {', '.join(map(str, written))}")
