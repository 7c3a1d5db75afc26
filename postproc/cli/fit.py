"""fit: identify an error model from measurements."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer
from rich.table import Table

from postproc.errors import InputError
from postproc.model.effects import parse_effects
from postproc.model.noise_model import checked as noise_model_checked
from postproc.model.predictor_plugins import predictor_names
from postproc.model.session_offsets import with_session_offsets
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
    check_output_folder,
    floats,
    gp_options_checked,
    gp_options_given,
    load_measurements,
    refuse_unused,
    session_offsets_line,
)
from .plugin_option import with_plugins


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
    drop_invalid: bool = typer.Option(False, "--drop-invalid", help=DROP_INVALID_HELP),
    gp_method: str = typer.Option("auto", "--gp-method", help="gpr: exact, local (experts over workspace regions, 10^4-10^5 poses) or auto (exact up to 2,000 poses)."),
    gp_leaf_size: int = typer.Option(500, "--gp-leaf-size", help="gpr local: most poses per workspace region."),
    gp_features: str = typer.Option("pose", "--gp-features", help=GP_FEATURES_HELP),
    gp_global_size: int = typer.Option(600, "--gp-global-size", help=GP_GLOBAL_SIZE_HELP),
    gp_shared_experts: int = typer.Option(4, "--gp-shared-experts", help=GP_SHARED_EXPERTS_HELP),
    memory_limit: Optional[float] = typer.Option(None, "--memory-limit", help="GB a predictor fit may use (default: the free memory); a fit needing more is refused."),
    noise_model: str = typer.Option("none", "--noise-model", help=NOISE_MODEL_HELP),
    session_offsets: bool = typer.Option(False, "--session-offsets", help=SESSION_OFFSETS_HELP),
):
    """Identify an error model from measurements and write MODEL.json."""
    if gp_method not in ("auto", "exact", "local"):
        raise InputError(f"--gp-method: '{gp_method}' is not one of auto, exact, local")
    refuse_unused("without --predictor tr-gpr", {"--source": source is not None and predictor != "tr-gpr"})
    shared = (gp_features, gp_leaf_size, gp_global_size, gp_shared_experts)
    refuse_unused("without --predictor gpr", {"--gp-method": gp_method != "auto", **gp_options_given(*shared),
                                               "--memory-limit": memory_limit is not None} if predictor != "gpr" else {})
    try:
        _fit(meas, robot, tool, effects, output, predictor, source, prior, loss, cv, seed,
             {"method": gp_method, "memory_limit_gb": memory_limit, **gp_options_checked(*shared)}, drop_invalid,
             noise_model_checked(noise_model), session_offsets)
    except KeyboardInterrupt:
        err.print("interrupted: no model written", style="bold red")
        raise typer.Exit(130) from None


def _fit(meas, robot, tool, effects, output, predictor, source, prior, loss, cv, seed, gp_options, drop_invalid=False, noise="none", session_offsets=False):
    # Deferred import: it loads scipy (slow to import); `postproc --version` must stay fast.
    from postproc.model.identify import fit as run_fit
    from postproc.model.model_io import load_model, save_model

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
        tool_mm = base_model.tool_mm if tool is None else floats(tool, 3, "--tool")
    else:
        if robot is None or tool is None:
            raise InputError("fit needs --robot and --tool (or --from MODEL.json)")
        robot_model, tool_mm = load_robot(robot), floats(tool, 3, "--tool")
    check_output_folder(output, "-o")
    data = load_measurements(meas, robot_model, drop_invalid)
    with ProgressLine("fit", console=err) as progress:
        result = run_fit(robot_model, tool_mm, chosen, data, loss=loss, cv_folds=cv, prior=base_model, seed=seed, progress=progress, noise=noise)
    final = result.model
    if session_offsets:
        final = with_session_offsets(final, data)
    if predictor is not None:
        # Deferred import: it loads scipy (slow to import); `postproc --version` must stay fast.
        from postproc.model.identify import Stats, fit_predictor, residuals

        with ProgressLine(f"fitting the {predictor} predictor", console=err) as line:
            final = fit_predictor(final, data, predictor, load_measurements(source) if source is not None else None, seed=seed,
                                  gp_options=gp_options, progress=lambda done, total, msg: line(msg, done, total), noise=noise)
    save_model(output, final, result, measurements=str(meas))
    _fit_summary(result, robot_model.name, result.model.effects.spec())
    if final.session_offsets is not None:  # taken out of the residual before any predictor; never applied to a program
        out.print(session_offsets_line(final.session_offsets), highlight=False)
    if predictor is not None:
        hybrid = Stats.of(residuals(final, data))
        out.print(f"with the {predictor} predictor on the residual: training RMS {hybrid.rms_mm:.4f} mm (validate with 'postproc evaluate')")
    out.print(f"model written to {output}", highlight=False)
    if final.coverage is not None:  # compensate refuses targets outside it (docs/model-coverage.md)
        out.print(f"measured region recorded in the model: {final.coverage.describe()}", highlight=False)


# A rigid 6-DOF registration needs three points that span a plane; a handful more makes
