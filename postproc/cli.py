"""Command-line interface (typer). Thin wrappers over the library; exit codes are decided here only.

Exit status (spec/cli.md): 0 success, 1 the job ran and found a problem the user must
act on, 2 bad input or usage (message on stderr naming file, line/row and column).
"""

from __future__ import annotations

import functools
import io
import json
import sys
from pathlib import Path
from typing import Optional

import numpy as np
import typer
from rich.console import Console
from rich.table import Table

from . import __version__
from .coverage_text import describe_model, model_summary
from .errors import InputError, JobError, OutputError, PostprocError
from .files import write_all
from .frames import abc_to_matrix, make_transform, matrix_to_abc
from .kinematics import fk as _fk
from .kinematics import ik as _ik
from .kinematics import within_limits
from .plugin_option import with_plugins
from .plugins import plugin_arguments
from .program_content import require_program
from .progress import ProgressLine
from .robots import available_robots, load_robot

app = typer.Typer(
    name="postproc",
    help="Rewrite robot and five-axis toolpaths so the machine cuts where the CAM program says.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)
# Messages carry user text (effect specs use [brackets]): never interpret it as markup.
out = Console(markup=False, highlight=False, soft_wrap=True)
err = Console(stderr=True, markup=False, highlight=False, soft_wrap=True)


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
            err.print(f"error: {exc}", style="bold red")
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


def _refuse_unused(why: str, options: dict[str, bool]) -> None:
    """Options given (True) that this use of the command would not use are an error, not a no-op."""
    unused = [name for name, given in options.items() if given]
    if unused:
        raise InputError(f"{', '.join(unused)}: not used {why}; leave {'it' if len(unused) == 1 else 'them'} out")


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


def _fit_summary(result, robot_name: str, effects_spec: str) -> None:
    """One screen: error before/after per axis, cross-validation, outliers, what was not identified."""
    table = Table(title=f"fit: {robot_name}, effects {effects_spec}", show_edge=False)
    for col in ("", "RMS", "mean", "max", "RMS x", "RMS y", "RMS z"):
        table.add_column(col, justify="right")
    for label, st in (("nominal (mm)", result.before), ("fitted (mm)", result.after)):
        table.add_row(label, *(f"{v:.4f}" for v in (st.rms_mm, st.mean_mm, st.max_mm, *st.rms_axis_mm)))
    out.print(table)
    out.print("nominal: the nominal robot registered onto the data (6-DOF best fit), as simulate, ladder and the report give it", highlight=False)
    if result.cv_rms_mm is not None:
        out.print(f"cross-validated RMS: {result.cv_rms_mm:.4f} mm")
    for note in result.notes:
        out.print(f"note: {note}", highlight=False)
    if result.outliers:
        shown = ", ".join(result.outliers[:20]) + (" ..." if len(result.outliers) > 20 else "")
        out.print(f"outliers flagged ({len(result.outliers)}): ids {shown}", highlight=False)
    if result.fixed:
        out.print(f"not identified from these data ({len(result.fixed)} parameters, fixed):")
        for name, why in result.fixed.items():
            out.print(f"  {name}: {why}", highlight=False)


def _load_measurements(path: Path, robot=None, drop_invalid: bool = False):
    """Read a measurement set; with a robot, rows beyond its joint limits are an error
    (or, with --drop-invalid, dropped and listed on stderr)."""
    from .measurements import ESTIMATED_LIMIT_MARGIN_DEG, check_joint_limits, outside_limits, read_measurements

    data = read_measurements(path)
    if robot is None:
        return data
    # Limits a robot file marks as estimates are not grounds to refuse measured data just
    # beyond them: rows within a margin of them are listed as warnings and kept.
    estimated = robot.estimates.get("limits", False)
    data, dropped = check_joint_limits(data, robot.lower_deg, robot.upper_deg, drop_invalid,
                                       margin_deg=ESTIMATED_LIMIT_MARGIN_DEG if estimated else 0.0)
    warned = outside_limits(data, robot.lower_deg, robot.upper_deg) if estimated else []
    if warned:
        err.print(f"warning: {path}: {len(warned)} row(s) outside {robot.name}'s joint limits, which {robot.source_path} marks as estimates; "
                  f"kept, as within {ESTIMATED_LIMIT_MARGIN_DEG:g} deg of them (first: {warned[0]})")
    for message in dropped:
        err.print(f"dropped: {path}, {message}")
    if dropped and len(data) == 0:
        raise InputError(f"{path}: every row is outside the robot's joint limits; nothing left to use")
    return data


_DROP_INVALID_HELP = "Drop (and list) rows whose joints are outside the robot's limits instead of stopping."


def _check_output_folder(path: Optional[Path], option: str) -> None:
    """Fail before any computation when an output cannot be written where asked."""
    if path is None or str(path) == "-":
        return
    folder = path.parent if str(path.parent) else Path(".")
    if not folder.is_dir():
        raise OutputError(f"{option} {path}: folder {folder} does not exist")
    if path.is_dir():
        raise OutputError(f"{option} {path}: is a folder, expected a file name")


@app.command("fit")
@handles_errors
@with_plugins
def fit_cmd(
    meas: Path = typer.Argument(..., help="Measurement CSV (spec/measurements.md)."),
    robot: Optional[str] = typer.Option(None, "--robot", help="Robot name or file (not needed with --from)."),
    tool: Optional[str] = typer.Option(None, "--tool", help="X,Y,Z of the measured point in the flange frame, mm."),
    effects: str = typer.Option(..., "--effects", help="Comma-separated effect names, 'none', or '+name,...' to extend --from."),
    output: Path = typer.Option(..., "-o", "--output", help="Model JSON to write."),
    predictor: Optional[str] = typer.Option(None, "--predictor", help="Data-driven predictor on the residual."),
    source: Optional[Path] = typer.Option(None, "--source", help="Source-domain measurements for tr-gpr."),
    prior: Optional[Path] = typer.Option(None, "--from", help="Extend this model: start from its values and effects."),
    loss: str = typer.Option("linear", "--loss", help="linear, soft_l1, huber or cauchy (robust to outliers)."),
    cv: int = typer.Option(5, "--cv", help="Folds of cross-validation (0 to skip)."),
    seed: int = typer.Option(0, "--seed"),
    drop_invalid: bool = typer.Option(False, "--drop-invalid", help=_DROP_INVALID_HELP),
    gp_method: str = typer.Option("auto", "--gp-method", help="gpr: exact, local (experts over workspace regions, 10^4-10^5 poses) or auto (exact up to 2,000 poses)."),
    gp_leaf_size: int = typer.Option(500, "--gp-leaf-size", help="gpr local: most poses per workspace region."),
    memory_limit: Optional[float] = typer.Option(None, "--memory-limit", help="GB a predictor fit may use (default: the free memory); a fit needing more is refused."),
):
    """Identify an error model from measurements and write MODEL.json."""
    if gp_method not in ("auto", "exact", "local"):
        raise InputError(f"--gp-method: '{gp_method}' is not one of auto, exact, local")
    _refuse_unused("without --predictor tr-gpr", {"--source": source is not None and predictor != "tr-gpr"})
    _refuse_unused("without --predictor gpr", {"--gp-method": gp_method != "auto", "--gp-leaf-size": gp_leaf_size != 500,
                                               "--memory-limit": memory_limit is not None} if predictor != "gpr" else {})
    try:
        _fit(meas, robot, tool, effects, output, predictor, source, prior, loss, cv, seed, {"method": gp_method, "leaf_size": gp_leaf_size, "memory_limit_gb": memory_limit}, drop_invalid)
    except KeyboardInterrupt:
        err.print("interrupted: no model written", style="bold red")
        raise typer.Exit(130) from None


def _fit(meas, robot, tool, effects, output, predictor, source, prior, loss, cv, seed, gp_options, drop_invalid=False):
    from .effects import parse_effects
    from .identify import fit as run_fit
    from .predictor_plugins import predictor_names
    from .model_io import load_model, save_model

    if predictor is not None and predictor not in predictor_names():
        raise InputError(f"--predictor: '{predictor}' is not one of {', '.join(predictor_names())}")
    if predictor == "tr-gpr" and source is None:
        raise InputError("--predictor tr-gpr needs --source SRC.csv (measurements from another workspace region)")
    if loss not in ("linear", "soft_l1", "huber", "cauchy"):
        raise InputError(f"--loss: '{loss}' is not one of linear, soft_l1, huber, cauchy")
    base_model = None
    if prior is not None:
        base_model, _ = load_model(prior)
    if effects.startswith("+"):
        if base_model is None:
            raise InputError("--effects '+...' extends a model: give it with --from MODEL.json")
        chosen = base_model.effects + parse_effects(effects[1:])
    else:
        chosen = parse_effects(effects)
    if base_model is not None:
        robot_model = base_model.robot if robot is None else load_robot(robot)
        if robot_model.name != base_model.robot.name:
            raise InputError(f"--robot {robot_model.name} does not match the model's robot {base_model.robot.name}")
        tool_mm = base_model.tool_mm if tool is None else _floats(tool, 3, "--tool")
    else:
        if robot is None or tool is None:
            raise InputError("fit needs --robot and --tool (or --from MODEL.json)")
        robot_model, tool_mm = load_robot(robot), _floats(tool, 3, "--tool")
    _check_output_folder(output, "-o")
    data = _load_measurements(meas, robot_model, drop_invalid)
    with ProgressLine("fit", console=err) as progress:
        result = run_fit(robot_model, tool_mm, chosen, data, loss=loss, cv_folds=cv, prior=base_model, seed=seed, progress=progress)
    final = result.model
    if predictor is not None:
        from .identify import Stats, fit_predictor, residuals

        with ProgressLine(f"fitting the {predictor} predictor", console=err) as line:
            final = fit_predictor(result.model, data, predictor, _load_measurements(source) if source is not None else None, seed=seed,
                                  gp_options=gp_options, progress=lambda done, total, msg: line(msg, done, total))
    save_model(output, final, result, measurements=str(meas))
    _fit_summary(result, robot_model.name, result.model.effects.spec())
    if predictor is not None:
        hybrid = Stats.of(residuals(final, data))
        out.print(f"with the {predictor} predictor on the residual: training RMS {hybrid.rms_mm:.4f} mm (validate with 'postproc evaluate')")
    out.print(f"model written to {output}", highlight=False)
    if final.coverage is not None:  # compensate refuses targets outside it (docs/model-coverage.md)
        out.print(f"measured region recorded in the model: {final.coverage.describe()}", highlight=False)


# A rigid 6-DOF registration needs three points that span a plane; a handful more makes
# it an estimate rather than an interpolation of noise.
_MIN_REGISTRATION_ROWS = 6


def _check_registrable(path: Path, data) -> None:
    """--reregister fits 6 degrees of freedom: refuse sets that cannot determine them."""
    if len(data) < _MIN_REGISTRATION_ROWS:
        raise InputError(f"{path}: --reregister fits the 6-DOF tracker frame and needs at least {_MIN_REGISTRATION_ROWS} rows, the set has {len(data)}")
    centred = data.measured_mm - data.measured_mm.mean(axis=0)
    spread = np.linalg.svd(centred, compute_uv=False)
    if spread[1] < 1.0:
        raise InputError(f"{path}: --reregister needs measured points that span a plane; these lie on a line (second singular value {spread[1]:.3g} mm)")


@app.command("evaluate")
@handles_errors
@with_plugins
def evaluate_cmd(
    model: Path = typer.Argument(..., help="Model JSON from 'postproc fit'."),
    meas: Path = typer.Argument(..., help="Measurement CSV."),
    json_out: bool = typer.Option(False, "--json", help="Print {n, rms_mm, mean_mm, max_mm} (spec/cli.md: exactly these keys; poses outside the model's region are said on stderr)."),
    region_json: bool = typer.Option(False, "--region", help="With --json: add outside_region {count, worst_joint_deg, worst_mm, tolerance_deg, tolerance_mm} (null for a model without a recorded region)."),
    reregister: bool = typer.Option(False, "--reregister", help="Re-fit only the base/tracker frame on this set (another tracker placement), all else fixed."),
    drop_invalid: bool = typer.Option(False, "--drop-invalid", help=_DROP_INVALID_HELP),
):
    """Position error of a model on a measurement set, and the poses outside the region it was fitted on."""
    from .coverage import describe_outside, outside_poses
    from .identify import Stats, residuals
    from .model_io import load_model

    error_model, _ = load_model(model)
    data = _load_measurements(meas, error_model.robot, drop_invalid)
    if reregister:
        _check_registrable(meas, data)
        from .identify import refit_base

        error_model = refit_base(error_model, data)
    stats = Stats.of(residuals(error_model, data))
    outside = outside_poses(error_model, data.q_deg)
    _refuse_unused("without --json", {"--region": region_json and not json_out})
    if json_out:
        doc = {"n": stats.n, "rms_mm": stats.rms_mm, "mean_mm": stats.mean_mm, "max_mm": stats.max_mm}
        if region_json:
            doc["outside_region"] = None if outside is None else outside.summary()
        elif outside is not None and outside.summary()["count"]:
            err.print(describe_outside(outside, stats.n), highlight=False)
        print(json.dumps(doc))
        return
    out.print(
        f"{stats.n} poses: RMS {stats.rms_mm:.4f} mm, mean {stats.mean_mm:.4f} mm, max {stats.max_mm:.4f} mm "
        f"(RMS x/y/z {stats.rms_axis_mm[0]:.4f}/{stats.rms_axis_mm[1]:.4f}/{stats.rms_axis_mm[2]:.4f})",
        highlight=False,
    )
    out.print(describe_outside(outside, stats.n))


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
    seed: int = typer.Option(0, "--seed"),
    json_out: bool = typer.Option(False, "--json", help="Print the figures as JSON."),
    drop_invalid: bool = typer.Option(False, "--drop-invalid", help=_DROP_INVALID_HELP),
):
    """Error on held-out poses under a named protocol, with each test pose's distance to the training poses."""
    from . import validate as protocols
    from .effects import parse_effects

    if protocol not in protocols.PROTOCOLS:
        raise InputError(f"--protocol: '{protocol}' is not one of {', '.join(protocols.PROTOCOLS)}")
    if predictor is not None and predictor not in ("gpr", "pso-bp", "grid"):
        raise InputError(f"--predictor: '{predictor}' is not one of gpr, pso-bp, grid")
    _refuse_unused(f"with --protocol {protocol}", {"--other": other is not None and protocol != "series",
                                                   "--fraction": fraction != 0.2 and protocol != "random",
                                                   "--every": every != 5 and protocol != "points"})
    if protocol == "series" and other is None:
        raise InputError("--protocol series needs --other OTHER.csv (the series to re-register and score)")
    robot_model = load_robot(robot)
    chosen = parse_effects(effects)
    spec = protocols.FitSpec(robot_model, _floats(tool, 3, "--tool"), chosen, predictor, seed=seed)
    data = _load_measurements(meas, robot_model, drop_invalid)
    other_data = _load_measurements(other, robot_model, drop_invalid) if other is not None else None
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


@app.command("diagnose")
@handles_errors
@with_plugins
def diagnose_cmd(
    model: Path = typer.Argument(..., help="Model JSON from 'postproc fit'."),
    meas: Path = typer.Argument(..., help="Measurement CSV."),
    json_out: bool = typer.Option(False, "--json", help="Machine-readable output (spec/cli.md)."),
    report: Optional[Path] = typer.Option(None, "--report", help="Write an HTML report with figures."),
    noise: Optional[float] = typer.Option(None, "--noise", help="Measurement noise per axis, mm (sets the noise floor); default: estimated from the data (repeats, else a flexible fit)."),
    folds: int = typer.Option(5, "--folds", help="Cross-validation folds."),
    seed: int = typer.Option(0, "--seed"),
    drop_invalid: bool = typer.Option(False, "--drop-invalid", help=_DROP_INVALID_HELP),
):
    """Where the model fails and which effect is missing."""
    from .diagnose import Files, diagnose
    from .measurements import write_text_atomic
    from .model_io import load_model

    if folds < 2:
        raise InputError("--folds must be at least 2")
    _check_output_folder(report, "--report")
    error_model, _ = load_model(model)
    data = _load_measurements(meas, error_model.robot, drop_invalid)
    with ProgressLine("diagnose", console=err, disable=json_out) as progress:
        result = diagnose(error_model, data, folds=folds, seed=seed, noise_mm=noise, progress=progress, files=Files(str(model), str(meas), plugin_arguments()))
    if report is not None:
        from .report.html import diagnosis_report

        write_text_atomic(report, diagnosis_report(error_model, data, result, title=f"Diagnosis of {model.name} on {meas.name}"))
    if json_out:
        print(json.dumps(result.as_json()))
        return
    _print_diagnosis(result, error_model)
    if report is not None:
        out.print(f"report written to {report}")


def _print_diagnosis(result, error_model) -> None:
    """The diagnosis on one screen; each suggested command printed once, after its findings."""
    from .candidates import MIN_PROGRESS, MIN_STABILITY
    from .diagnose import grouped_findings

    st = result.stats
    out.print(f"model {error_model.effects.spec()} on {st.n} poses: RMS {st.rms_mm:.4f} mm, mean {st.mean_mm:.4f}, max {st.max_mm:.4f} "
              f"(x/y/z {st.rms_axis_mm[0]:.4f}/{st.rms_axis_mm[1]:.4f}/{st.rms_axis_mm[2]:.4f}); cross-validated {result.cv_rms_mm:.4f} mm")
    if result.noise is not None:
        out.print(f"noise floor {result.noise_floor_mm:.4f} mm (3-D RMS of the noise; {result.noise.detail})")
    structured = [s for s in result.structure if s.significant][:6]
    if structured:
        table = Table(title="What the residual follows (smooth function of one variable or a pair; held-out)", show_edge=False)
        for col in ("variable(s)", "explained", "p (Holm)"):
            table.add_column(col, justify="left" if col == "variable(s)" else "right")
        for s in structured:
            table.add_row(s.name, f"{100 * s.explained:.1f}%", f"{s.p_adjusted:.1e}")
        out.print(table)
    rows = list(result.candidates) + ([result.combination] if result.combination is not None else [])
    if rows:
        table = Table(title=f"What is missing (recommended: >= {100 * MIN_PROGRESS:.0f}% of the way to the noise floor in >= {100 * MIN_STABILITY:.0f}% of resamples)", show_edge=False)
        for col in ("candidate", "explained", "CV RMS if added (mm)", "way to floor", "stability", "recommended"):
            table.add_column(col, justify="left" if col == "candidate" else "right", overflow="fold", min_width=22 if col == "candidate" else None)
        for c in rows:
            table.add_row(c.effect, f"{100 * c.explained:.1f}%", f"{c.rms_if_added_mm:.4f}", f"{100 * c.progress:.0f}%", f"{100 * c.stability:.0f}%", "yes" if c.significant else "no")
        out.print(table)
    if result.catalog_exhausted:
        out.print("catalog exhausted" + (f": the residual follows {result.follows.name}" if result.follows is not None else ""), highlight=False)
    for texts, command in grouped_findings(result.findings):
        for text in texts:
            out.print(f"- {text}", highlight=False)
        if command:
            out.print(f"    run: {command}", highlight=False, soft_wrap=True)


@app.command("ladder")
@handles_errors
@with_plugins
def ladder_cmd(
    meas: Path = typer.Argument(..., help="Measurement CSV."),
    robot: str = typer.Option(..., "--robot"),
    tool: str = typer.Option(..., "--tool", help="X,Y,Z of the measured point in the flange frame, mm."),
    effects: Optional[str] = typer.Option(None, "--effects", help="Effects to add in this order; default: diagnose chooses each next one."),
    validation: Optional[Path] = typer.Option(None, "--val", help="A validation set to report as well."),
    report: Optional[Path] = typer.Option(None, "--report", help="Write an HTML page with the ladder chart."),
    plot: Optional[Path] = typer.Option(None, "--plot", help="Write the ladder chart as PNG."),
    noise: Optional[float] = typer.Option(None, "--noise", help="Measurement noise per axis, mm; default: estimated from the data."),
    json_out: bool = typer.Option(False, "--json"),
    seed: int = typer.Option(0, "--seed"),
    drop_invalid: bool = typer.Option(False, "--drop-invalid", help=_DROP_INVALID_HELP),
):
    """Fit a sequence of models, each adding the next effect, and report the error per step."""
    from .diagnose import ladder
    from .effects import _split_top_level, parse_effects

    robot_model, tool_mm = load_robot(robot), _floats(tool, 3, "--tool")
    _check_output_folder(plot, "--plot")
    _check_output_folder(report, "--report")
    data = _load_measurements(meas, robot_model, drop_invalid)
    val = _load_measurements(validation, robot_model, drop_invalid) if validation is not None else None
    steps = None
    if effects is not None:
        steps = _split_top_level(effects)
        parse_effects(effects)  # validate names and options before any work
    with ProgressLine("ladder", console=err, disable=json_out) as progress:
        rows = ladder(robot_model, tool_mm, data, steps, seed=seed, noise_mm=noise, validation=val, progress=progress)
    floor = rows[-1]["noise_floor_mm"]
    if plot is not None:
        from .report.figures import ladder_chart

        fig = ladder_chart(rows, floor)
        tmp = plot.with_name(f".{plot.name}.tmp.png")
        try:
            fig.savefig(tmp, dpi=110)
            tmp.replace(plot)
        except OSError as exc:
            raise OutputError(f"--plot {plot}: cannot write ({exc.strerror})") from None
        finally:
            tmp.unlink(missing_ok=True)
    if report is not None:
        from .measurements import write_text_atomic
        from .report.html import ladder_report

        write_text_atomic(report, ladder_report(rows, floor, f"Ladder on {meas.name}"))
    if json_out:
        print(json.dumps({"noise_floor_mm": floor, "steps": rows}))
        return
    out.print("step 0 is the nominal robot registered onto the data (6-DOF best fit), as simulate, fit and the report give it", highlight=False)
    table = Table(title=f"ladder: {robot_model.name} on {meas.name} (noise floor {floor:.4f} mm)", show_edge=False)
    for col in ("step", "added", "train RMS", "CV RMS") + (("validation RMS",) if val is not None else ()):
        table.add_column(col, justify="left" if col == "added" else "right")
    for r in rows:
        table.add_row(str(r["step"]), r["added"], f"{r['train_rms_mm']:.4f}", f"{r['cv_rms_mm']:.4f}", *((f"{r['val_rms_mm']:.4f}",) if val is not None else ()))
    out.print(table)


@app.command("similarity")
@handles_errors
@with_plugins
def similarity_cmd(
    region_a: Path = typer.Argument(..., help="Measurements of one workspace region (e.g. the source)."),
    region_b: Path = typer.Argument(..., help="Measurements of another region (e.g. a target sub-space)."),
    robot: Optional[str] = typer.Option(None, "--robot", help="Robot (errors against its nominal model); not needed with --model."),
    tool: Optional[str] = typer.Option(None, "--tool", help="X,Y,Z of the measured point in the flange frame, mm."),
    model: Optional[Path] = typer.Option(None, "--model", help="Compare what this model leaves instead of the nominal errors."),
    json_out: bool = typer.Option(False, "--json"),
):
    """How alike two regions' error patterns are (seed 001 eq. 9-10), and whether transfer learning is advisable."""
    from .errormodel import ErrorModel
    from .effects import EffectSum
    from .learn import region_similarity
    from .model_io import load_model

    if model is not None:
        _refuse_unused("with --model (the model gives the robot and tool)", {"--robot": robot is not None, "--tool": tool is not None})
        error_model, _ = load_model(model)
    elif robot is not None and tool is not None:
        error_model = ErrorModel.create(load_robot(robot), _floats(tool, 3, "--tool"), EffectSum())
    else:
        raise InputError("similarity needs --model MODEL.json, or --robot and --tool")
    a, b = _load_measurements(region_a), _load_measurements(region_b)
    ea = a.measured_mm - error_model.predict(a)
    eb = b.measured_mm - error_model.predict(b)
    sim = region_similarity(ea, eb)
    advisable = sim >= 0.94  # seed 001 Table 4: transferable cylinder regions scored 0.94 and above
    if json_out:
        print(json.dumps({"similarity": sim, "pairs": int(min(len(a), len(b))), "transfer_advisable": bool(advisable)}))
        return
    out.print(f"cosine similarity of the normalised errors over {min(len(a), len(b))} pose pairs: {sim:.4f}")
    out.print("transfer learning is advisable (>= 0.94, seed 001 Table 4)" if advisable else "the regions' errors differ: measure the target region rather than transfer (< 0.94, seed 001 Table 4)")


@app.command("import-ur10")
@handles_errors
def import_ur10_cmd(
    series: Path = typer.Argument(..., help="A series folder of the IPA UR10 data set (e.g. data/ur10_ipa/Series_A)."),
    output: Path = typer.Option(..., "-o", "--output", help="Measurement CSV to write (shared schema)."),
):
    """Convert IPA UR10 laser-tracker data (';', decimal comma, radians) to the shared CSV schema."""
    from .formats.ur10_ipa import read_series
    from .measurements import write_measurements

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
    from .effects import parse_effects
    from .errormodel import require_resolved
    from .measurements import write_measurements
    from .model_io import save_model
    from .sim import parse_region, random_truth, sample_poses, simulate

    space = parse_region(workspace, region)
    if n < 1:
        raise InputError("--n must be at least 1")
    chosen = parse_effects(effects)
    require_resolved(chosen)
    robot_model, tool_mm = load_robot(robot), _floats(tool, 3, "--tool")
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
    from .identify import Stats, nominal_model, residuals

    # The same nominal error as fit, ladder and the report print: the nominal robot registered onto the data.
    st = Stats.of(residuals(nominal_model(robot_model, tool_mm, data, registered=True), data))
    out.print(f"{n} poses written to {output}; nominal error RMS {st.rms_mm:.4f} mm, max {st.max_mm:.4f} mm"
              " (nominal robot registered onto the data, 6-DOF best fit, as fit, ladder and the report give it)", highlight=False)



@app.command("suggest-poses")
@handles_errors
@with_plugins
def suggest_poses_cmd(
    output: Path = typer.Option(..., "-o", "--output", help="CSV of the chosen poses (id, q1..q6 and the candidates' other columns), in measuring order."),
    n: int = typer.Option(..., "-n", "--n", help="Number of poses to choose."),
    robot: Optional[str] = typer.Option(None, "--robot", help="Robot name or file (default: the --model's)."),
    tool: Optional[str] = typer.Option(None, "--tool", help="X,Y,Z of the measured point in the flange frame, mm (default: the --model's)."),
    effects: Optional[str] = typer.Option(None, "--effects", help="Effects the measurements are to identify (default: the --model's)."),
    model: Optional[Path] = typer.Option(None, "--model", help="A fitted model: the Jacobian is taken at its values."),
    candidates: Optional[Path] = typer.Option(None, "--candidates", help="CSV of poses the robot can reach (q1..q6 degrees; id and other columns optional)."),
    workspace: str = typer.Option("cylinder", "--workspace", help="Without --candidates: where to generate them: cylinder, box or joints (as simulate)."),
    region: Optional[str] = typer.Option(None, "--region", help="Workspace extents, as simulate's --region."),
    box: Optional[str] = typer.Option(None, "--box", help="Generate candidates in a box: the same as --workspace box --region TEXT ('' for the default box)."),
    cylinder: Optional[str] = typer.Option(None, "--cylinder", help="Generate candidates in a cylinder sector: --workspace cylinder --region TEXT."),
    n_candidates: int = typer.Option(2000, "--n-candidates", help="Without --candidates: how many to generate."),
    tracker: Optional[str] = typer.Option(None, "--tracker", help="X,Y,Z of the laser tracker in the robot base frame, mm: generated candidates must be in its range and line of sight."),
    tracker_range: Optional[str] = typer.Option(None, "--tracker-range", help="MIN:MAX distance the tracker measures, mm (default 1000:15000)."),
    tracker_cone: Optional[float] = typer.Option(None, "--tracker-cone", help="Reflector acceptance half-angle about the tool z axis, deg (default: not checked)."),
    criterion: str = typer.Option("D", "--criterion", help="D (default), E or A-optimal design of the parameters, or I: the least mean predicted error over the candidates (with --program: at its targets)."),
    program: Optional[Path] = typer.Option(None, "--program", help="Region-targeted: minimise the predicted error at this program's targets."),
    dialect: Optional[str] = typer.Option(None, "--dialect", help="Dialect of --program (default: from the extension or content)."),
    measured: Optional[Path] = typer.Option(None, "--measured", help="Poses measured already (measurement CSV): suggest the next batch."),
    random_share: float = typer.Option(0.2, "--random-share", help="Fraction of the poses drawn at random (robustness against effects the model lacks; with --program drawn near its targets)."),
    load_states: Optional[str] = typer.Option(None, "--load-states", help="FX,FY,FZ[;FX,FY,FZ...]: every candidate under each of these TCP forces (N, base frame; 0,0,0 for none), written as fx,fy,fz: separates compliance from geometry (effects joint_compliance + external_load)."),
    noise: float = typer.Option(0.02, "--noise", help="Measurement noise per axis, mm."),
    seed: int = typer.Option(0, "--seed"),
    json_out: bool = typer.Option(False, "--json", help="Print {chosen, criterion, expected_rms_mm, ...} as JSON."),
    plot: Optional[Path] = typer.Option(None, "--plot", help="PNG of the predicted error against N, suggested and random."),
    program_out: Optional[Path] = typer.Option(None, "--program-out", help="Also write a robot program that visits the chosen poses (RAPID .mod, KRL .src)."),
    program_language: Optional[str] = typer.Option(None, "--program-language", help="Language of --program-out (default: from its extension)."),
):
    """Choose the poses to measure that identify the model best (optimal experiment design)."""

    from .effects import parse_effects
    from .model_io import load_model
    from .sim import parse_region
    from .suggest import program_targets, suggest_poses
    from .suggest.candidates import generate, read_candidates, with_load_states
    from .suggest.inputs import design_model, tracker_from
    from .suggest.job import report_lines, write_outputs
    from .suggest.program import language_of

    if box is not None or cylinder is not None:  # spec/cli.md's --box/--cylinder: a workspace and its region in one option
        _refuse_unused("with --box or --cylinder (they give the workspace)", {"--workspace": workspace != "cylinder", "--region": region is not None,
                                                                                "--box and --cylinder together": box is not None and cylinder is not None})
        workspace, region = ("box", box) if box is not None else ("cylinder", cylinder)
    _refuse_unused("with --candidates (they are not generated)", {"--box/--cylinder/--region": candidates is not None and region is not None,
                                                                  "--tracker": candidates is not None and tracker is not None,
                                                                  "--n-candidates": candidates is not None and n_candidates != 2000})
    _refuse_unused("with --program (the design is region-targeted)", {"--criterion": program is not None and criterion not in ("D", "I")})
    fitted = load_model(model)[0] if model is not None else None
    if fitted is None and (robot is None or tool is None):
        raise InputError("suggest-poses needs --robot and --tool (or --model MODEL.json)")
    robot_model = load_robot(robot) if robot is not None else fitted.robot
    tool_mm = _floats(tool, 3, "--tool") if tool is not None else fitted.tool_mm
    design_for = design_model(robot_model, tool_mm, parse_effects(effects) if effects is not None else None, fitted)
    for path, option in ((output, "-o"), (plot, "--plot"), (program_out, "--program-out")):
        _check_output_folder(path, option)
    if program_out is not None:
        language_of(program_out, program_language)  # an unknown language fails before the search, not after
    rng = np.random.default_rng(seed)
    if candidates is not None:
        cands = read_candidates(candidates, robot_model)
    else:
        track = tracker_from(None if tracker is None else _floats(tracker, 3, "--tracker"),
                             None if tracker_range is None else tuple(_floats(tracker_range.replace(":", ","), 2, "--tracker-range")), tracker_cone)
        # ids name the seed: a batch generated with another seed has other poses under other ids
        cands = generate(robot_model, tool_mm, n_candidates, parse_region(workspace, region), rng, track, id_prefix=f"s{seed}-")
    if load_states is not None:
        items = [t for t in load_states.split(";") if t.strip()]
        if not items:
            raise InputError("--load-states: expected FX,FY,FZ[;FX,FY,FZ...] (N, base frame)")
        cands = with_load_states(cands, np.array([_floats(t, 3, "--load-states") for t in items]))
    done = _load_measurements(measured, robot_model) if measured is not None else None
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

def _named_frames(items: list[str] | None, option: str) -> dict:
    """'NAME=X,Y,Z[,A,B,C]' options -> {name: 4x4}."""
    out = {}
    for item in items or []:
        name, eq, values = item.partition("=")
        if not eq or not name.strip():
            raise InputError(f"{option}: expected NAME=X,Y,Z[,A,B,C], got '{item}'")
        parts = [p for p in values.split(",") if p.strip()]
        nums = _floats(values, len(parts) if len(parts) in (3, 6) else 6, option)
        abc = nums[3:6] if len(nums) == 6 else np.zeros(3)
        out[name.strip()] = make_transform(abc_to_matrix(abc[None])[0], nums[:3])
    return out


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
        from .fivex.commands import compensate_five_program

        _refuse_unused("by five-axis compensation (--model MACHINE.toml)", {
            "--out-dir": out_dir is not None, "--jobs": jobs is not None, "--scheduler": scheduler is not None, "--in-place": in_place,
            "--tol": tol != 0.01, "--max-iter": max_iter != 25, "--scheme": scheme != "broyden", "--temp": temp is not None,
            "--force": force is not None, "--report": report is not None,
            "--start-joints": start_joints is not None, "--cut": cut is not None, "--max-deviation": max_deviation is not None,
            "--force-file": force_file is not None, "--subdivide": subdivide, "--robot": robot is not None, "--allow-model-mismatch": allow_mismatch,
            "--allow-extrapolation (a machine's error grid is never extrapolated)": allow_extrapolation})

        if len(programs) != 1 or output is None:
            raise InputError("five-axis compensation takes one program and -o OUT")
        for line in compensate_five_program(Path(programs[0]), model, Path(output), grid, input_axes, dialect=dialect,
                                            frames=_named_frames(frame, "--frame"), tools=_named_frames(tool, "--tool")):
            out.print(line)
        return
    from .compensate import CompensationError, compensate
    from .model_io import load_model

    _refuse_unused("with a robot model (five-axis only: --model MACHINE.toml)", {"--grid": grid is not None, "--input-axes": input_axes is not None})
    if tol <= 0 or max_iter < 1:
        raise InputError("--tol must be > 0 and --max-iter >= 1")
    if max_deviation is not None and not max_deviation > 0:
        raise InputError(f"--max-deviation must be > 0 mm, got {max_deviation}")
    _check_output_folder(report, "--report")
    error_model, _ = load_model(model)
    forces = None if force is None else _floats(force, 3, "--force")
    common = {"tol_mm": tol, "max_iter": max_iter, "scheme": scheme, "temp_c": temp, "force_n": forces,
              "frames": _named_frames(frame, "--frame"), "tools": _named_frames(tool, "--tool"),
              "start_joints": None if start_joints is None else _floats(start_joints, 6, "--start-joints"),
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
    from .program_check import check_model_fits

    for note in check_model_fits(tp, error_model, str(model), robot, allow_mismatch):
        log.print(f"note: {note} (--allow-model-mismatch)")

    with ProgressLine("compensating", console=err) as progress:
        options = dict(common, force_per_target=_block_forces(cut, force_file, forces, tp, frame, tool, log), progress=progress,
                       detail=_is_page(report))
        written, added = tp, ()
        if subdivide:
            from .subdivide import DEFAULT_TOLERANCE_MM, compensate_subdivided

            sub = compensate_subdivided(tp, error_model, max_deviation or DEFAULT_TOLERANCE_MM, **options)
            written, new, rep, added = sub.program, sub.compensated, sub.report, sub.added
        else:
            new, rep = compensate(tp, error_model, max_deviation_mm=max_deviation, **options)
    summary = {**rep.summary(), **model_summary(error_model)}
    from .arcs import summary as arc_summary

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
    from .forces import load_cut_params, program_forces

    placed = tp.with_frames(_named_frames(frame, "--frame"), _named_frames(tool, "--tool")) if (frame or tool) else tp
    return program_forces(placed, params=load_cut_params(cut))


def _block_forces(cut, force_file, forces, tp, frame, tool, log):
    """The force of every target in the base frame from --cut or --force-file, None without them."""
    if force_file is None:
        return _cut_forces(cut, tp, frame, tool)
    from .force_file import base_frame_forces, read_force_file

    if cut is not None or forces is not None:
        raise InputError("--force-file gives the force of every motion block: not with --force or --cut")
    tool_frame, unlisted = read_force_file(force_file, tp)
    if unlisted:
        log.print(f"note: {unlisted} Cartesian target(s) have no row in {force_file}: no process force there")
    placed = tp.with_frames(_named_frames(frame, "--frame"), _named_frames(tool, "--tool")) if (frame or tool) else tp
    return base_frame_forces(placed, tool_frame)


def _is_page(report: Optional[Path]) -> bool:
    """--report PAGE.html: the page (postproc.report.compensation), else the JSON."""
    return report is not None and report.suffix.lower() in (".html", ".htm")


def _write_page(report: Path, rep, summary: dict, model, program: str, model_path: Path) -> None:
    """--report PAGE.html (its figures take a few seconds: a spinner meanwhile)."""

    from .measurements import write_text_atomic
    from .report.compensation import compensation_report

    with ProgressLine("report", console=err) as progress:
        progress(f"writing the report page {report}")
        write_text_atomic(report, compensation_report(rep, summary, model, program, str(model_path)))


def _write_point_report(report: Path, rep, summary: dict) -> None:
    """--report: the summary and one entry per target, as JSON."""
    from .measurements import write_text_atomic

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
    from .programs import parse_program

    if program != "-":
        return parse_program(Path(program), dialect, modules=modules or ())
    if dialect is None:
        raise InputError("reading a program from standard input needs --dialect")
    return parse_program("-", dialect, sys.stdin.buffer.read())


def _refuse_unsafe_output(tp, output: str, in_place: bool) -> None:
    """Before the work: standard output only for one-file programs; no input overwritten
    without --in-place (a changed $config.dat is checked again when the texts are known)."""
    from .programs import files_for, refuse_overwrite, refuse_stdout

    if output == "-":
        refuse_stdout(tp)
    else:
        refuse_overwrite(tp, files_for(tp, [doc.text for doc in tp.sources], output), in_place)


def _write_compensated(tp, new, rows, output: str, in_place: bool, original=None) -> None:
    """Emit, re-parse (the targets ``rows`` must read back as compensated), then write the
    whole set of changed files at once, or the program to standard output. ``original``:
    the program as read when ``tp`` has new targets (files differing from it are written)."""
    from .programs import check_texts, emit_texts, files_for, refuse_overwrite, write_set

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

    from .batch import run_batch
    from .measurements import write_text_atomic

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


_KIND_NAMES = {0: "joint", 1: "linear", 2: "circular_via", 3: "circular_end", 4: "joint_target", 5: "rapid", 6: "arc_cw", 7: "arc_ccw"}


@app.command("inspect")
@handles_errors
@with_plugins
def inspect_cmd(
    program: Path = typer.Argument(..., help="Program file (RAPID .mod/.modx/.prg/.sys, or a .pgf with its modules; KRL .src/.sub with its .dat, or a .dat alone; G-code .nc/.ngc/.gcode/.tap/.cnc/.mpf/.spf/.iso; other names by content)."),
    json_out: bool = typer.Option(False, "--json", help="Machine-readable output (spec/cli.md)."),
    dialect: Optional[str] = typer.Option(None, "--dialect", help="rapid, krl or gcode (default: from the extension or content)."),
    data: Optional[list[Path]] = typer.Option(None, "--data", help="KRL: another module's data list (.dat: its GLOBAL points of a PUBLIC DEFDAT), module (.src: its functions) or a folder of them, that the program uses. Repeatable."),
):
    """Motion targets of a program in the robot base frame (G-code: the machine frame), mm; a target the program text does not determine is listed and flagged."""
    from .frames import matrix_to_quat_wxyz
    from .programs import parse_program

    tp = parse_program(program, dialect, modules=data or ())
    poses = tp.base_poses()
    has_ori = ~np.isnan(tp.orientation).any(axis=1)
    quats = np.full((len(tp), 4), np.nan)
    if has_ori.any():
        quats[has_ori] = matrix_to_quat_wxyz(poses[has_ori, :3, :3])

    def num(v):
        return None if v is None or not np.isfinite(v) else round(float(v), 6)

    placed = tp.placed()
    from .arcs import describe

    arc_of = describe(tp)  # G2/G3: plane, direction, centre, radius
    from .emit.feeds import describe as describe_feeds

    feed_of = describe_feeds(tp)  # G-code: feed mode; G93 / G95: F, its unit and the derived mm/min
    moves = []
    for i in range(len(tp)):
        entry = {
            "line": int(tp.line[i]),
            "kind": _KIND_NAMES[int(tp.kind[i])],
            "xyz": [num(v) for v in poses[i, :3, 3]],
            "file": tp.sources[int(tp.file[i])].path,
            "target": tp.target_name[i] or None,
            "frame": tp.frame_names[int(tp.frame[i])],
            "tool": tp.tool_names[int(tp.tool[i])],
            "resolved": bool(placed[i]),
        }
        if has_ori[i]:
            entry["quaternion"] = [num(v) for v in quats[i]]
        if not np.isnan(tp.joints[i]).all():
            entry["joints"] = [num(v) for v in tp.joints[i]]
        if not np.isnan(tp.ext[i]).all():
            entry["ext"] = [num(v) for v in tp.ext[i]]
        if not np.isnan(tp.conf[i]).all():
            entry["conf"] = [num(v) for v in tp.conf[i]]
        if i in arc_of:
            entry["arc"] = arc_of[i]
        if tp.ccomp is not None and tp.ccomp[i]:  # G41/G42: the offset path (a corner arc: no block words of its own), or not followed
            entry["cutter_comp"] = ("corner" if tp.insert_at is not None and tp.insert_at[i, 1] < 0 else "offset") if tp.ccomp[i] == 1 else "not_followed"
        entry["speed"] = num(tp.speed[i])
        if i in feed_of:
            entry.update(feed_of[i])
            if "f_unit" in entry:
                entry["speed"] = None  # F is not a speed under G93 / G95 (see f, f_unit, speed_derived_mm_per_min)
        entry["zone"] = num(tp.zone[i])
        moves.append(entry)
    if json_out:
        print(json.dumps({"dialect": tp.dialect, "moves": moves, "notes": list(tp.notes)}))
        return
    table = Table(title=f"{program} ({tp.dialect}, {len(tp)} targets)", show_edge=False)
    for col in ("line", "kind", "x", "y", "z", "target", "frame", "tool", "ok"):
        table.add_column(col, justify="right" if col in ("line", "x", "y", "z") else "left")
    for m in moves[:200]:
        table.add_row(str(m["line"]), m["kind"], *(f"{v:.3f}" if v is not None else "-" for v in m["xyz"]), m["target"] or "", m["frame"], m["tool"], "yes" if m["resolved"] else "NO")
    out.print(table)
    if len(moves) > 200:
        out.print(f"... {len(moves) - 200} more (use --json)")
    for note in tp.notes:
        out.print(f"note: {note}")


@app.command("convert")
@handles_errors
@with_plugins
def convert_cmd(
    program: Path = typer.Argument(..., help="Program in any supported dialect."),
    to: str = typer.Option(..., "--to", help="rapid or krl: the language of the new program (gcode: a five-axis G-code program, with --machine and --rtcp)."),
    output: Path = typer.Option(..., "-o", "--output", help="New program (KRL: the .src; its .dat is written beside it)."),
    dialect: Optional[str] = typer.Option(None, "--dialect", help="Dialect of the input: rapid, krl or gcode (default: from the extension or content)."),
    machine: Optional[str] = typer.Option(None, "--machine", help="Five-axis machine (machines/ name or file): --to gcode, or a five-axis G-code input."),
    rtcp: Optional[str] = typer.Option(None, "--rtcp", help="With --to gcode: linuxcnc, fanuc (G43.4), siemens (TRAORI) or none (machine axes)."),
    input_axes: Optional[str] = typer.Option(None, "--input-axes", help="Five-axis G-code input: tip (tool tip + rotary angles) or machine (machine axes)."),
    max_deviation: Optional[float] = typer.Option(None, "--max-deviation", help="--to gcode: split moves until the tip stays this close (mm) to the straight path (default 0.01)."),
    frame: Optional[list[str]] = typer.Option(None, "--frame", help="NAME=X,Y,Z[,A,B,C]: a frame the program uses but does not define (G54, BASE_DATA[1]): the robot base (five-axis: the machine) -> the frame (mm; KUKA A B C, deg), written as the robot's base / work object. Repeatable. Five-axis G-code (--machine): A is its turn about Z (B, C zero), not a rotary-axis offset; the rotary axes' offsets are the program's own (G10 L2/L20, G92/G52 A B C), else zero."),
    tool: Optional[list[str]] = typer.Option(None, "--tool", help="NAME=X,Y,Z[,A,B,C]: a tool the program uses but does not define (H1: a G43 tool length): the flange -> the TCP (mm; KUKA A B C, deg), written as the robot's tool. Repeatable."),
    tool_load: Optional[str] = typer.Option(None, "--tool-load", help="MASS,CX,CY,CZ[,IX,IY,IZ]: the load every tool carries (kg; centre of gravity in the flange frame, mm; inertia about it, kg m^2), written as the tooldata's tload (rapid; tool0: a GripLoad) or $LOAD (krl). Without it the load the input program states is carried where it applies; with it, that load must be this one. Where neither gives one, RAPID tooldata get a 1 kg placeholder marked in a comment and KRL leaves $LOAD as the controller has it."),
    arc_tol: Optional[float] = typer.Option(None, "--arc-tol", help="mm: write helical and spiral arcs (G2/G3 with a move along the plane's normal, or a changing radius), which no circular move holds, as straight moves within this chord error (without it they are refused)."),
):
    """Write a new robot program with every target of another program, or a five-axis G-code program (--to gcode --machine M --rtcp MODE)."""
    from .dialects import get
    from .programs import parse_program, write_program, write_texts

    if machine is not None or rtcp is not None:
        from .fivex.commands import convert_five

        if machine is None:
            raise InputError("--rtcp needs --machine (a name from machines/ or a machine file)")
        _refuse_unused("without --to gcode", {"--max-deviation": max_deviation is not None and rtcp is None})
        _refuse_unused("by a five-axis G-code program", {"--tool-load": tool_load is not None, "--arc-tol": arc_tol is not None})
        for line in convert_five(program, to, output, machine, rtcp, dialect, input_axes, max_deviation_mm=0.01 if max_deviation is None else max_deviation,
                                 frames=_named_frames(frame, "--frame"), tools=_named_frames(tool, "--tool")):
            out.print(line)
        return
    _refuse_unused("without --machine (five-axis only)", {"--input-axes": input_axes is not None, "--max-deviation": max_deviation is not None})
    from .emit.tool_load import parse_tool_load

    load = None if tool_load is None else parse_tool_load(tool_load)
    outputs = get(to, "--to").new_program_paths(output)
    tp = parse_program(program, dialect)
    if frame or tool:  # work offsets and tool lengths the program leaves to the controller (refused when not given)
        tp = tp.with_frames(_named_frames(frame, "--frame"), _named_frames(tool, "--tool"))
    texts = write_program(tp, to, output.stem, tool_load=load, arc_tol_mm=arc_tol)
    write_texts(texts, outputs)
    out.print(f"{len(tp)} targets written to {', '.join(map(str, outputs))}")


@app.command("roundtrip")
def roundtrip_cmd(
    programs: list[Path] = typer.Argument(..., help="Program files."),
    dialect: Optional[str] = typer.Option(None, "--dialect"),
):
    """Parse and re-emit programs unchanged; exit 0 only if every output is byte-identical."""
    from .programs import emit_texts, parse_program

    status = 0
    for program in programs:
        try:
            tp = parse_program(program, dialect)
            texts = emit_texts(tp, tp)
        except PostprocError as exc:
            err.print(f"error: {exc}", style="bold red")
            out.print(f"ERROR      {program}")
            status = max(status, _exit_code(exc) if isinstance(exc, JobError) else 2)
            continue
        same = all(t.encode("latin-1") == doc.encode() and doc.encode() == Path(doc.path).read_bytes() for t, doc in zip(texts, tp.sources))
        files = ", ".join(Path(d.path).name for d in tp.sources)
        out.print(f"{'IDENTICAL' if same else 'DIFFERS'}  {program} ({tp.dialect}, {len(tp)} targets; {files})")
        if not same:
            status = max(status, 1)
    raise typer.Exit(status)


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
    from .fivex.commands import calibration_summary, rtcp_calibrate

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


@app.command("freecad-install-post")
@handles_errors
def freecad_install_post_cmd(
    directory: Optional[Path] = typer.Option(None, "--dir", help="Folder to install into (default: FreeCAD's macro folder, asked of freecadcmd)."),
    python: Optional[str] = typer.Option(None, "--python", help="postproc's Python that the post runs (default: this one)."),
):
    """Install the postproc post-processor (postproc_post.py) where FreeCAD's Path/CAM workbench finds it."""
    from .cam.install import default_macro_dir, install_post

    how = "given with --dir"
    if directory is None:
        directory, how = default_macro_dir()
    target = install_post(directory, python)
    out.print(f"installed {target} ({how}); in FreeCAD choose the post processor 'postproc' and give its arguments (--help lists them)")

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
    dialect: Optional[str] = typer.Option(None, "--dialect"),
):
    """Find the workpiece placement that minimises the force-induced normal error (seed 002)."""
    from . import placement as pl
    from . import place_report as report
    from .place_program import check_placed, placed_conf, placed_texts
    from .programs import parse_program

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
        from .dialects import of as dialect_of

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
    from .compliance import identified_compliance
    from .forces import load_cut_params
    from .place_program import problem_from_program

    fitted = None
    if model is not None:
        from .model_io import load_model

        fitted, _ = load_model(model)
    params = None if cut is None else load_cut_params(cut)
    force_tool = None if force is None else _floats(force, 3, "--force")
    engagement = None
    if stock is not None:
        if params is None:
            raise InputError("--stock needs --cut (the engagement feeds the mechanistic force model)")
        from .engagement import load_stock, program_engagement

        engagement = program_engagement(tp, params.diameter, load_stock(stock))
    problem = problem_from_program(tp, robot_model, force_tool=force_tool, params=params, engagement=engagement, model=fitted, singular_deg=singular_margin, conf_mode=conf_mode)
    sources = {"force": "constant tool-frame force" if force is not None else f"mechanistic model ({cut})" + (f", engagement from {stock}" if stock else ""),
               "stiffness": "identified by the model" if fitted is not None and identified_compliance(fitted) is not None else f"joint stiffness of {robot_model.name}"}
    return problem, sources


def _place_figures(plot: Path, result, problem, best_frame, frame0, cur) -> dict[Path, bytes]:
    """The heat map (PLOT) and the error along the path (PLOT_path), as PNG bytes by path."""
    from . import placement as pl
    from .report.placement_figures import error_maps, path_errors

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


effect_app = typer.Typer(help="Write and check an error effect of your own (docs/own-effect.md).", no_args_is_help=True)
app.add_typer(effect_app, name="effect")


@effect_app.command("new")
@handles_errors
def effect_new_cmd(
    name: str = typer.Argument(..., help="The effect's name (lower case, e.g. wrist_cable)."),
    output: Path = typer.Option(Path("."), "-o", "--output", help="FILE.py to write, or a folder to write NAME.py in (an existing file is never overwritten)."),
):
    """Write a commented template effect file (NAME.py), outside the package."""
    from .effect_template import write_template

    path = write_template(name, output)
    out.print(f"wrote {path}; check it with 'postproc effect check {path}', load it with '--plugins {path}'")


@effect_app.command("check")
@handles_errors
def effect_check_cmd(
    file: Path = typer.Argument(..., help="The effect's .py file."),
    robot: str = typer.Option("kr160_r1570", "--robot", help="Robot the checks run on."),
):
    """Contract checks of the effects in FILE: Jacobian, zero parameters, bounds, texts, round trips."""
    from .effect_check import check_effect
    from .effects import CATALOG
    from .plugins import PluginError, load_plugins

    records = [r for r in load_plugins([file], environ={}, entry_points=False) if r.kind == "effect"]
    if not records:
        raise PluginError(f"{file}: defines no Effect subclass with a name")
    table = Table(title=f"effect check {file}")
    for col in ("effect", "check", "result", "detail"):
        table.add_column(col)
    failures = []
    for record in records:
        for check in check_effect(CATALOG[record.name], robot):
            table.add_row(record.name, check.name, "ok" if check.ok else "FAILED", check.detail)
            if not check.ok:
                failures.append(f"{record.name}: {check.name}: {check.detail}")
    out.print(table)
    if failures:
        raise PluginError(f"{file}: {len(failures)} check(s) failed:\n  " + "\n  ".join(failures))


def main() -> None:
    app()


def _compensate_streamed(program: str, model, output: str, dialect, mode: str, in_place: bool, options: dict) -> bool:
    """compensate --stream: a long program in chunks (postproc.stream); False where the
    whole-program path must take it (too short, or a program the chunks cannot carry: said why)."""
    from .compensate import CompensationError
    from .stream import StreamFallback, compensate_streamed, wants_stream

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


# At the end: every command and helper above is defined before `python -m postproc.cli` runs one.
if __name__ == "__main__":
    sys.exit(main())
