"""validate: evaluation protocols (random, grid points, sessions, another series)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Optional

import typer

from postproc.errors import InputError
from postproc.model.effects import parse_effects
from postproc.model.noise_model import checked as noise_model_checked
from postproc.progress import ProgressLine
from postproc.robot.robots import load_robot

from .app import app, err, handles_errors, out
from .common import (
    DROP_INVALID_HELP,
    GP_FEATURES_HELP,
    GP_GLOBAL_SIZE_HELP,
    GP_SHARED_EXPERTS_HELP,
    NOISE_MODEL_HELP,
    SESSION_OFFSETS_HELP,
    floats,
    gp_options_checked,
    gp_options_given,
    load_measurements,
    refuse_unused,
)
from .plugin_option import with_plugins


@app.command("validate")
@handles_errors
@with_plugins
def validate_cmd(
    meas: Path = typer.Argument(..., help="Measurement CSV to fit on (and, except for --protocol series, to hold poses out of)."),
    protocol: str = typer.Option(..., "--protocol", help="random, points (whole commanded positions), sessions (each session in turn) or series (another series, re-registered on half)."),
    robot: str = typer.Option(..., "--robot", help="Robot name or file."),
    tool: str = typer.Option(..., "--tool", help="X,Y,Z of the measured point in the flange frame, mm."),
    effects: str = typer.Option(..., "--effects", help="Effects each fold fits (as fit --effects)."),
    predictor: Optional[str] = typer.Option(None, "--predictor", help="A predictor on the physics residual in each fold (hybrid), e.g. gpr."),
    other: Optional[Path] = typer.Option(None, "--other", help="series: the other series' measurement CSV."),
    fraction: float = typer.Option(0.2, "--fraction", help="random: share of the poses held out."),
    every: int = typer.Option(5, "--every", help="points: hold out every k-th commanded position ('point' column)."),
    gp_features: str = typer.Option("pose", "--gp-features", help=GP_FEATURES_HELP),
    gp_leaf_size: int = typer.Option(500, "--gp-leaf-size", help="gpr local: most poses per workspace region."),
    gp_global_size: int = typer.Option(600, "--gp-global-size", help=GP_GLOBAL_SIZE_HELP),
    gp_shared_experts: int = typer.Option(4, "--gp-shared-experts", help=GP_SHARED_EXPERTS_HELP),
    noise_model: str = typer.Option("none", "--noise-model", help=NOISE_MODEL_HELP),
    session_offsets: bool = typer.Option(False, "--session-offsets", help=SESSION_OFFSETS_HELP),
    seed: int = typer.Option(0, "--seed"),
    json_out: bool = typer.Option(False, "--json", help="Print the figures as JSON."),
    drop_invalid: bool = typer.Option(False, "--drop-invalid", help=DROP_INVALID_HELP),
):
    """Error on held-out poses under a named protocol, with each test pose's distance to the training poses."""
    # Deferred import: it loads scipy (slow to import); `postproc --version` must stay fast.
    from postproc.model import validate as protocols

    if protocol not in protocols.PROTOCOLS:
        raise InputError(f"--protocol: '{protocol}' is not one of {', '.join(protocols.PROTOCOLS)}")
    if predictor is not None and predictor not in ("gpr", "pso-bp", "grid"):
        raise InputError(f"--predictor: '{predictor}' is not one of gpr, pso-bp, grid")
    shared = (gp_features, gp_leaf_size, gp_global_size, gp_shared_experts)
    refuse_unused(f"with --protocol {protocol}", {"--other": other is not None and protocol != "series",
                                                   "--fraction": fraction != 0.2 and protocol != "random",
                                                   "--every": every != 5 and protocol != "points",
                                                   **(gp_options_given(*shared) if predictor != "gpr" else {})})
    if protocol == "series" and other is None:
        raise InputError("--protocol series needs --other OTHER.csv (the series to re-register and score)")
    robot_model = load_robot(robot)
    chosen = parse_effects(effects)
    gp_options = gp_options_checked(*shared) if predictor == "gpr" else None
    spec = protocols.FitSpec(robot_model, floats(tool, 3, "--tool"), chosen, predictor, gp_options, seed=seed, noise=noise_model_checked(noise_model),
                                session_offsets=session_offsets)
    data = load_measurements(meas, robot_model, drop_invalid)
    other_data = load_measurements(other, robot_model, drop_invalid) if other is not None else None
    with ProgressLine("validate", console=err, disable=json_out) as say:
        if protocol == "random":
            result = protocols.run_random(spec, data, fraction, seed, say)
        elif protocol == "points":
            result = protocols.run_points(spec, data, every, say)
        elif protocol == "sessions":
            result = protocols.run_sessions(spec, data, say)
        else:
            result = protocols.run_series(spec, data, other_data, say)
    if json_out:
        print(json.dumps(result.as_dict()))
        return
    for line in protocols.result_lines(result):
        out.print(line, highlight=False)
