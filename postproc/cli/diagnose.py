"""diagnose, ladder, similarity: what a model misses, the effects ladder, region similarity."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Optional

import typer
from rich.table import Table

from postproc.errors import InputError, OutputError
from postproc.model.effects import EffectSum, _split_top_level, parse_effects
from postproc.model.errormodel import ErrorModel
from postproc.model.measurements import write_text_atomic
from postproc.plugins import plugin_arguments
from postproc.progress import ProgressLine
from postproc.robot.robots import load_robot

from .app import app, err, handles_errors, out
from .common import DROP_INVALID_HELP, check_output_folder, floats, load_measurements, refuse_unused, sessions_as_asked
from .plugin_option import with_plugins


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
    drop_invalid: bool = typer.Option(False, "--drop-invalid", help=DROP_INVALID_HELP),
):
    """Where the model fails and which effect is missing."""
    # Deferred import: it loads scipy (slow to import); `postproc --version` must stay fast.
    from postproc.model.diagnose import Files, diagnose
    from postproc.model.model_io import load_model

    if folds < 2:
        raise InputError("--folds must be at least 2")
    check_output_folder(report, "--report")
    error_model, _ = load_model(model)
    data = sessions_as_asked(load_measurements(meas, error_model.robot, drop_invalid), error_model, False, meas)
    with ProgressLine("diagnose", console=err, disable=json_out) as progress:
        result = diagnose(error_model, data, folds=folds, seed=seed, noise_mm=noise, progress=progress, files=Files(str(model), str(meas), plugin_arguments()))
    if report is not None:
        # Deferred import: it loads matplotlib (slow to import); `postproc --version` must stay fast.
        from postproc.report.html import diagnosis_report

        write_text_atomic(report, diagnosis_report(error_model, data, result, title=f"Diagnosis of {model.name} on {meas.name}"))
    if json_out:
        print(json.dumps(result.as_json()))
        return
    _print_diagnosis(result, error_model)
    if report is not None:
        out.print(f"report written to {report}")


def _print_diagnosis(result, error_model) -> None:
    """The diagnosis on one screen; each suggested command printed once, after its findings."""
    # Deferred import: it loads scipy (slow to import); `postproc --version` must stay fast.
    from postproc.model.candidates import MIN_PROGRESS, MIN_STABILITY
    from postproc.model.diagnose import grouped_findings

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
    drop_invalid: bool = typer.Option(False, "--drop-invalid", help=DROP_INVALID_HELP),
):
    """Fit a sequence of models, each adding the next effect, and report the error per step."""
    # Deferred import: it loads scipy (slow to import); `postproc --version` must stay fast.
    from postproc.model.diagnose import ladder

    robot_model, tool_mm = load_robot(robot), floats(tool, 3, "--tool")
    check_output_folder(plot, "--plot")
    check_output_folder(report, "--report")
    data = load_measurements(meas, robot_model, drop_invalid)
    val = load_measurements(validation, robot_model, drop_invalid) if validation is not None else None
    steps = None
    if effects is not None:
        steps = _split_top_level(effects)
        parse_effects(effects)  # validate names and options before any work
    with ProgressLine("ladder", console=err, disable=json_out) as progress:
        rows = ladder(robot_model, tool_mm, data, steps, seed=seed, noise_mm=noise, validation=val, progress=progress)
    floor = rows[-1]["noise_floor_mm"]
    if plot is not None:
        # Deferred import: it loads matplotlib (slow to import); `postproc --version` must stay fast.
        from postproc.report.figures import ladder_chart

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
        # Deferred import: it loads matplotlib (slow to import); `postproc --version` must stay fast.
        from postproc.report.html import ladder_report

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
    # Deferred import: it loads torch and scikit-learn / scipy (slow to import); `postproc --version` must stay fast.
    from postproc.model.learn import region_similarity
    from postproc.model.model_io import load_model

    if model is not None:
        refuse_unused("with --model (the model gives the robot and tool)", {"--robot": robot is not None, "--tool": tool is not None})
        error_model, _ = load_model(model)
    elif robot is not None and tool is not None:
        error_model = ErrorModel.create(load_robot(robot), floats(tool, 3, "--tool"), EffectSum())
    else:
        raise InputError("similarity needs --model MODEL.json, or --robot and --tool")
    a, b = (sessions_as_asked(load_measurements(path), error_model, False, path) for path in (region_a, region_b))
    ea = a.measured_mm - error_model.predict(a)
    eb = b.measured_mm - error_model.predict(b)
    sim = region_similarity(ea, eb)
    advisable = sim >= 0.94  # seed 001 Table 4: transferable cylinder regions scored 0.94 and above
    if json_out:
        print(json.dumps({"similarity": sim, "pairs": int(min(len(a), len(b))), "transfer_advisable": bool(advisable)}))
        return
    out.print(f"cosine similarity of the normalised errors over {min(len(a), len(b))} pose pairs: {sim:.4f}")
    out.print("transfer learning is advisable (>= 0.94, seed 001 Table 4)" if advisable else "the regions' errors differ: measure the target region rather than transfer (< 0.94, seed 001 Table 4)")
