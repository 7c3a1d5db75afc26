"""Command-line interface (typer). Thin wrappers over the library; exit codes are decided here only.

Exit status (spec/cli.md): 0 success, 1 the job ran and found a problem the user must
act on, 2 bad input or usage (message on stderr naming file, line/row and column).
"""

from __future__ import annotations

import functools
import json
import sys
from pathlib import Path
from typing import Optional

import numpy as np
import typer
from rich.console import Console
from rich.table import Table

from . import __version__
from .errors import FeatureUnavailableError, InputError, JobError, PostprocError
from .frames import abc_to_matrix, make_transform, matrix_to_abc
from .kinematics import fk as _fk
from .kinematics import ik as _ik
from .kinematics import within_limits
from .robots import available_robots, load_robot

app = typer.Typer(
    name="postproc",
    help="Rewrite robot and five-axis toolpaths so the machine cuts where the CAM program says.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)
out = Console()
err = Console(stderr=True)


def _exit_code(exc: PostprocError) -> int:
    if isinstance(exc, JobError):
        return 1
    return 2


def handles_errors(func):
    """Map the library's typed exceptions to the spec's exit codes, message on stderr."""

    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        try:
            return func(*args, **kwargs)
        except PostprocError as exc:
            err.print(f"[bold red]error:[/] {exc}", highlight=False, markup=True, soft_wrap=True)
            raise typer.Exit(_exit_code(exc)) from None

    return wrapper


def _version(value: bool):
    if value:
        out.print(f"postproc {__version__}", highlight=False)
        raise typer.Exit(0)


@app.callback()
def _root(
    version: bool = typer.Option(False, "--version", callback=_version, is_eager=True, help="Print the version and exit."),
):
    """postproc command line."""


def _floats(text: str, count: int, what: str) -> np.ndarray:
    parts = [p for p in text.replace(";", ",").split(",") if p.strip()]
    try:
        values = np.array([float(p) for p in parts])
    except ValueError:
        raise InputError(f"{what}: expected {count} comma-separated numbers, got '{text}'") from None
    if values.shape != (count,):
        raise InputError(f"{what}: expected {count} comma-separated numbers, got {len(parts)} in '{text}'")
    return values


# ------------------------------------------------------------------ working commands


@app.command("robots")
@handles_errors
def robots_cmd(json_out: bool = typer.Option(False, "--json", help="Machine-readable output.")):
    """List the bundled robots, validating each file."""
    rows = []
    for name in available_robots():
        robot = load_robot(name)
        rows.append(
            {
                "name": name,
                "description": robot.description,
                "verified": robot.verified,
                "analytic_ik": robot.has_analytic_ik,
                "estimated": sorted(k for k, v in robot.estimates.items() if v),
            }
        )
    if json_out:
        print(json.dumps({"robots": rows}))
        return
    table = Table(title="Bundled robots")
    for col in ("name", "description", "verified", "analytic IK", "estimated sections"):
        table.add_column(col)
    for row in rows:
        table.add_row(row["name"], row["description"], str(row["verified"]), str(row["analytic_ik"]), ", ".join(row["estimated"]) or "-")
    out.print(table)


@app.command("fk")
@handles_errors
def fk_cmd(
    robot: str = typer.Argument(..., help="Robot name from robots/ or path to a robot file."),
    q: str = typer.Option(..., "--q", help="Six joint values in degrees, comma separated."),
    tool: Optional[str] = typer.Option(None, "--tool", help="Tool offset X,Y,Z in mm in the flange frame."),
    json_out: bool = typer.Option(False, "--json"),
):
    """Forward kinematics: joint values -> TCP position (mm) and KUKA A,B,C (deg)."""
    model = load_robot(robot)
    joints = _floats(q, 6, "--q")
    pose = _fk(model, joints[None], tool=None if tool is None else _floats(tool, 3, "--tool"))[0]
    result = {"xyz": pose[:3, 3].tolist(), "abc": matrix_to_abc(pose[None, :3, :3])[0].tolist()}
    if json_out:
        print(json.dumps(result))
    else:
        out.print(f"xyz (mm): {np.round(result['xyz'], 4).tolist()}  abc (deg): {np.round(result['abc'], 4).tolist()}")


@app.command("ik")
@handles_errors
def ik_cmd(
    robot: str = typer.Argument(..., help="Robot name from robots/ or path to a robot file."),
    xyz: str = typer.Option(..., "--xyz", help="Flange position X,Y,Z in mm (base frame)."),
    abc: str = typer.Option("0,0,0", "--abc", help="Flange orientation A,B,C in degrees, R = Rz(A) Ry(B) Rx(C)."),
    json_out: bool = typer.Option(False, "--json"),
):
    """Inverse kinematics: all eight analytic solutions, marked inside/outside the joint limits."""
    model = load_robot(robot)
    pose = make_transform(abc_to_matrix(_floats(abc, 3, "--abc")[None]), _floats(xyz, 3, "--xyz")[None])
    sols = _ik(model, pose)[0]
    inside = within_limits(model, sols)
    rows = [{"branch": b, "q": None if np.isnan(s).any() else s.tolist(), "within_limits": bool(ok)} for b, (s, ok) in enumerate(zip(sols, inside))]
    if json_out:
        print(json.dumps({"solutions": rows}))
        return
    table = Table(title=f"IK solutions, {model.name}")
    table.add_column("branch")
    for j in range(6):
        table.add_column(f"q{j + 1} (deg)", justify="right")
    table.add_column("in limits")
    for row in rows:
        cells = ["unreachable"] * 6 if row["q"] is None else [f"{v:.4f}" for v in row["q"]]
        table.add_row(str(row["branch"]), *cells, "yes" if row["within_limits"] else "no")
    out.print(table)
    if not any(r["within_limits"] for r in rows):
        raise JobError("no solution inside the joint limits")


# --------------------------------------------- scripted interface (spec/cli.md)
# Registered now so that the interface is complete; each is built by its own issue.


def _not_built(command: str, issue: str):
    raise FeatureUnavailableError(f"'postproc {command}' is not built in this version yet ({issue})")


@app.command("fit")
@handles_errors
def fit_cmd(
    meas: Path = typer.Argument(..., help="Measurement CSV (spec/measurements.md)."),
    robot: str = typer.Option(..., "--robot"),
    tool: str = typer.Option(..., "--tool", help="X,Y,Z of the measured point in the flange frame, mm."),
    effects: str = typer.Option(..., "--effects", help="Comma-separated effect names, or 'none'."),
    output: Path = typer.Option(..., "-o", "--output"),
    predictor: Optional[str] = typer.Option(None, "--predictor"),
    source: Optional[Path] = typer.Option(None, "--source"),
):
    """Identify an error model from measurements and write MODEL.json."""
    _not_built("fit", "issue 4")


@app.command("evaluate")
@handles_errors
def evaluate_cmd(model: Path = typer.Argument(...), meas: Path = typer.Argument(...), json_out: bool = typer.Option(False, "--json")):
    """Position error of a model on a measurement set."""
    _not_built("evaluate", "issue 4")


@app.command("diagnose")
@handles_errors
def diagnose_cmd(
    model: Path = typer.Argument(...),
    meas: Path = typer.Argument(...),
    json_out: bool = typer.Option(False, "--json"),
    report: Optional[Path] = typer.Option(None, "--report"),
):
    """Where the model fails and which effect is missing."""
    _not_built("diagnose", "issue 5")


@app.command("ladder")
@handles_errors
def ladder_cmd(meas: Path = typer.Argument(...), robot: str = typer.Option(..., "--robot"), tool: str = typer.Option(..., "--tool")):
    """Fit a sequence of models, each adding the next effect, and report validation RMS per step."""
    _not_built("ladder", "issue 5")


@app.command("simulate")
@handles_errors
def simulate_cmd(robot: str = typer.Option(..., "--robot"), output: Path = typer.Option(..., "-o", "--output")):
    """Generate a measurement set from a simulated robot with chosen error effects."""
    _not_built("simulate", "issue 4")


@app.command("compensate")
@handles_errors
def compensate_cmd(
    program: str = typer.Argument(..., help="Program file, or - for standard input."),
    model: Path = typer.Option(..., "--model"),
    output: Path = typer.Option(..., "-o", "--output"),
    dialect: Optional[str] = typer.Option(None, "--dialect"),
):
    """Rewrite a program so the robot reaches its targets under the fitted error model."""
    _not_built("compensate", "issue 6")


@app.command("inspect")
@handles_errors
def inspect_cmd(program: Path = typer.Argument(...), json_out: bool = typer.Option(False, "--json"), dialect: Optional[str] = typer.Option(None, "--dialect")):
    """Motion targets of a program, resolved to the base frame."""
    _not_built("inspect", "issue 3")


@app.command("roundtrip")
@handles_errors
def roundtrip_cmd(programs: list[Path] = typer.Argument(...), dialect: Optional[str] = typer.Option(None, "--dialect")):
    """Parse and re-emit programs unchanged; exit 0 only if every output is byte-identical."""
    _not_built("roundtrip", "issue 3")


def main() -> None:
    app()


if __name__ == "__main__":
    sys.exit(main())
