"""rtcp-calibrate: the rotary axes of a five-axis machine from probe points."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Optional

import typer

from postproc.errors import InputError
from postproc.jobs.five_axis.commands import calibration_summary, rtcp_calibrate

from .app import app, handles_errors, out


@app.command("rtcp-calibrate")
@handles_errors
def rtcp_calibrate_cmd(
    probes: Path = typer.Argument(..., help="Probing CSV (spec/probing.md): sphere centres or touches."),
    machine: str = typer.Option(..., "--machine", help="Machine name from machines/ (e.g. xyzac-trt) or a machine file."),
    json_out: bool = typer.Option(False, "--json", help="Print the calibration as JSON (spec/cli.md)."),
    output: Optional[Path] = typer.Option(None, "-o", "--output", help="Calibrated machine file; controller data are written beside it."),
    axis: Optional[str] = typer.Option(None, "--axis", help="Rotary axis of every row when the file has no axis column."),
    method: str = typer.Option("seed003", "--method", help="seed003 (Gauss-Newton circle) or seed004 (iterative re-centred circle)."),
    sphere_radius: Optional[float] = typer.Option(None, "--sphere-radius", help="Calibration sphere radius, mm (touches; fitted when absent)."),
    tip_radius: float = typer.Option(0.0, "--tip-radius", help="Probe tip radius, mm (touches)."),
    min_outlier: float = typer.Option(0.01, "--min-outlier", help="A deviation below this (mm) is never an outlier (probing repeatability)."),
    seed: int = typer.Option(0, "--seed", help="Seed of the random 3-point planes."),
):
    """Calibrate the rotary axes of a five-axis machine from probed sphere centres (seed 003)."""
    if tip_radius and not _has_touch_column(probes):
        raise InputError(f"{probes}: --tip-radius is for touch probing; these rows are sphere centres (no touch column): leave it out")
    doc, _ = rtcp_calibrate(probes, machine, output, axis, method, seed, sphere_radius, tip_radius, min_outlier)
    if json_out:
        print(json.dumps(doc))
        return
    for line in calibration_summary(doc):
        out.print(line)


def _has_touch_column(probes: Path) -> bool:
    """The probing CSV's header (the first line not a # comment) names a touch column."""
    try:
        with open(probes, encoding="utf-8-sig", errors="replace") as fh:
            header = next((line for line in fh if line.strip() and not line.lstrip().startswith("#")), "")
    except OSError:
        return True  # unreadable: the reader names the error
    return "touch" in [h.strip().lower() for h in header.split(",")]
