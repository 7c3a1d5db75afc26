"""Robot commands: robots (the bundled robots), fk, ik."""

from __future__ import annotations

import json
from typing import Optional

import numpy as np
import typer
from rich.table import Table

from postproc.errors import JobError
from postproc.robot.frames import abc_to_matrix, make_transform, matrix_to_abc
from postproc.robot.kinematics import fk as _fk
from postproc.robot.kinematics import ik as _ik
from postproc.robot.kinematics import within_limits
from postproc.robot.robots import available_robots, load_robot

from .app import app, handles_errors, out
from .common import floats


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
    joints = floats(q, 6, "--q")
    pose = _fk(model, joints[None], tool=None if tool is None else floats(tool, 3, "--tool"))[0]
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
    pose = make_transform(abc_to_matrix(floats(abc, 3, "--abc")[None]), floats(xyz, 3, "--xyz")[None])
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
