"""Measurement files: import-ur10 (a public data set), simulate (a synthetic set with its truth)."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import numpy as np
import typer

from postproc.errors import InputError
from postproc.model.effects import parse_effects
from postproc.model.errormodel import require_resolved
from postproc.model.formats.ur10_ipa import read_series
from postproc.model.measurements import write_measurements
from postproc.model.sim import parse_region, random_truth, sample_poses, simulate
from postproc.progress import ProgressLine
from postproc.robot.robots import load_robot

from .app import app, err, handles_errors, out
from .common import floats
from .plugin_option import with_plugins


@app.command("import-ur10")
@handles_errors
def import_ur10_cmd(
    series: Path = typer.Argument(..., help="A series folder of the IPA UR10 data set (e.g. data/ur10_ipa/Series_A)."),
    output: Path = typer.Option(..., "-o", "--output", help="Measurement CSV to write (shared schema)."),
):
    """Convert IPA UR10 laser-tracker data (';', decimal comma, radians) to the shared CSV schema."""
    data, tool_mm = read_series(series)
    write_measurements(output, data)
    tool_text = ",".join(f"{v:.4f}" for v in np.where(np.abs(tool_mm) < 5e-5, 0.0, tool_mm))
    out.print(f"{len(data)} poses written to {output} (positions in the tracker frame: fit a base_frame)")
    out.print(f"measured point (T-Mac probe) in the flange frame: --tool {tool_text}")


@app.command("simulate")
@handles_errors
@with_plugins
def simulate_cmd(
    robot: str = typer.Option(..., "--robot", help="Robot name or file."),
    output: Path = typer.Option(..., "-o", "--output", help="Measurement CSV to write."),
    tool: str = typer.Option("0,0,200", "--tool", help="X,Y,Z of the measured point in the flange frame, mm."),
    effects: str = typer.Option("geometric,base_frame,tool_offset,joint_compliance", "--effects", help="Effects of the true robot."),
    n: int = typer.Option(250, "--n", help="Number of poses."),
    seed: int = typer.Option(0, "--seed"),
    noise: float = typer.Option(0.02, "--noise", help="Measurement noise per axis, mm (tracker + repeatability)."),
    magnitude: float = typer.Option(2.0, "--magnitude", help="Error magnitudes in units of seed 001 Table 3."),
    workspace: str = typer.Option("cylinder", "--workspace", help="cylinder (seed 001), box, or joints."),
    region: Optional[str] = typer.Option(None, "--region", help="Workspace extents, e.g. 'theta1=-40:40;radius=700:1150;z=300:800;tilt=30' (cylinder), 'x=..;y=..;z=..' (box), 'q2=-30:20' (joints)."),
    truth_out: Optional[Path] = typer.Option(None, "--truth", help="Also write the true robot as a model JSON."),
):
    """Generate a measurement set from a simulated robot with chosen error effects."""
    # Deferred import: it loads scipy (slow to import); `postproc --version` must stay fast.
    from postproc.model.model_io import save_model

    space = parse_region(workspace, region)
    if n < 1:
        raise InputError("--n must be at least 1")
    chosen = parse_effects(effects)
    require_resolved(chosen)
    robot_model, tool_mm = load_robot(robot), floats(tool, 3, "--tool")
    rng = np.random.default_rng(seed)
    truth = random_truth(robot_model, tool_mm, chosen, rng, magnitude=magnitude)

    with ProgressLine("simulate", console=err) as progress:
        progress(f"sampling {n:,} poses", 0, 2)
        q = sample_poses(robot_model, tool_mm, n, space, rng)
        progress("measuring them", 1, 2)
        data = simulate(truth, q, rng, noise_mm=noise)
    write_measurements(output, data)
    if truth_out is not None:
        save_model(truth_out, truth)
    # Deferred import: it loads scipy (slow to import); `postproc --version` must stay fast.
    from postproc.model.identify import Stats, nominal_model, residuals

    # The same nominal error as fit, ladder and the report print: the nominal robot registered onto the data.
    st = Stats.of(residuals(nominal_model(robot_model, tool_mm, data, registered=True), data))
    out.print(f"{n} poses written to {output}; nominal error RMS {st.rms_mm:.4f} mm, max {st.max_mm:.4f} mm"
              " (nominal robot registered onto the data, 6-DOF best fit, as fit, ladder and the report give it)", highlight=False)
