"""evaluate: a model's error on measurements, optionally after a rigid registration."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import typer

from postproc.errors import InputError

from .app import app, err, handles_errors, out
from .common import DROP_INVALID_HELP, load_measurements, refuse_unused, sessions_as_asked
from .plugin_option import with_plugins

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
    drop_invalid: bool = typer.Option(False, "--drop-invalid", help=DROP_INVALID_HELP),
    session_offsets: bool = typer.Option(False, "--session-offsets", help="Apply the model's session offsets to this file's 'session' ids: only where they are the fit's sessions (the same set-ups)."),
):
    """Position error of a model on a measurement set, and the poses outside the region it was fitted on."""
    # Deferred import: it loads scipy (slow to import); `postproc --version` must stay fast.
    from postproc.model.coverage import describe_outside, outside_poses
    from postproc.model.identify import Stats, refit_base, residuals
    from postproc.model.model_io import load_model

    refuse_unused("without --json", {"--region": region_json and not json_out})  # usage first, before any work
    error_model, _ = load_model(model)
    data = sessions_as_asked(load_measurements(meas, error_model.robot, drop_invalid), error_model, session_offsets, meas)
    if reregister:
        _check_registrable(meas, data)
        error_model = refit_base(error_model, data)
    stats = Stats.of(residuals(error_model, data))
    outside = outside_poses(error_model, data.q_deg, data.path_history())
    if json_out:
        doc = {"n": stats.n, "rms_mm": stats.rms_mm, "mean_mm": stats.mean_mm, "max_mm": stats.max_mm}
        if region_json:
            doc["outside_region"] = None if outside is None else outside.summary()
        elif outside is not None and outside.mask.any():
            err.print(describe_outside(outside, stats.n), highlight=False)
        print(json.dumps(doc))
        return
    out.print(
        f"{stats.n} poses: RMS {stats.rms_mm:.4f} mm, mean {stats.mean_mm:.4f} mm, max {stats.max_mm:.4f} mm "
        f"(RMS x/y/z {stats.rms_axis_mm[0]:.4f}/{stats.rms_axis_mm[1]:.4f}/{stats.rms_axis_mm[2]:.4f})",
        highlight=False,
    )
    out.print(describe_outside(outside, stats.n))
