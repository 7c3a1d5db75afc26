"""Library entry points of the five-axis CLI commands (postproc.cli only maps errors and prints)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from postproc.errors import InputError, JobError
from postproc.files import write_all as write_bytes
from postproc.fivex.calibrate import Calibration, calibrate_machine
from postproc.fivex.controllers import heidenhain_csv, linuxcnc_trt, siemens_tc_carr
from postproc.fivex.kinematics import fk
from postproc.fivex.machine import load_machine, machine_toml
from postproc.fivex.probes import read_probes
from postproc.programs import dialects
from postproc.programs.dialects.heidenhain.kinematics import tnc_kinematics
from postproc.programs.program_io import emit_texts, parse_program, write_program

from .emit import MODES, emit, solve
from .offsets import to_machine
from .program import ROTARY_FIELD, from_toolpath, to_robot_toolpath


def rtcp_calibrate(probes: Path, machine_name: str, output: Path | None = None, axis: str | None = None, method: str = "seed003",
                   seed: int = 0, sphere_radius: float | None = None, tip_radius: float = 0.0, min_outlier_mm: float = 0.01) -> tuple[dict, Calibration]:
    """Calibrate the rotary axes from a probing CSV; with ``output``, write the calibrated
    machine file and the controller data beside it (all files or none). Returns the JSON
    document (spec/cli.md) and the calibration."""
    machine = load_machine(machine_name)
    centres = read_probes(probes, axis=axis, sphere_radius=sphere_radius, tip_radius=tip_radius)
    cal = calibrate_machine(machine, centres, method=method, seed=seed, min_outlier_mm=min_outlier_mm)
    doc = cal.as_json()
    doc["probes"] = str(probes)
    controllers = {}
    lcnc = linuxcnc_trt(cal.machine, machine)
    sie = siemens_tc_carr(cal.machine)
    if lcnc:
        controllers["linuxcnc"] = {k: v for k, v in lcnc.items() if k != "text"}
    if sie:
        controllers["siemens"] = {k: v for k, v in sie.items() if k != "text"}
    doc["controller_data"] = controllers
    if output is not None:
        output = Path(output)
        header = (f"Calibrated by postproc rtcp-calibrate from {probes} ({method}); nominal machine {machine.source_path}.\n"
                  "Rotary axes: fitted direction and a point on the axis (the fitted circle centre).")
        files = {output: machine_toml(cal.machine, header), output.with_suffix(".heidenhain.csv"): heidenhain_csv(cal.machine)}
        tnc = tnc_kinematics(cal.machine)  # the TNC's kinematics description (dialects/heidenhain/kinematics.py)
        if tnc:
            files[output.with_suffix(".tnc-kinematics.txt")] = tnc
        if lcnc:
            files[output.with_suffix(".linuxcnc.hal")] = lcnc["text"]
        if sie:
            files[output.with_suffix(".siemens.spf")] = sie["text"]
        write_all(files)
        doc["files"] = {str(p): label for p, label in zip(files, ["calibrated machine (postproc TOML)", "Heidenhain-style kinematics table (CSV)",
                                                                   *(["Heidenhain TNC kinematics description (transformation chain)"] if tnc else []),
                                                                   *(["LinuxCNC trt kinematics HAL pins"] if lcnc else []),
                                                                   *(["Siemens 840D $TC_CARR (type P)"] if sie else [])])}
    return doc, cal


def calibration_summary(doc: dict) -> list[str]:
    lines = []
    for name, ax in doc["axes"].items():
        d, p, v = ax["direction"], ax["point"], ax["vs_nominal"]
        lines.append(f"axis {name}: direction [{d[0]:.6f}, {d[1]:.6f}, {d[2]:.6f}] (+-{ax['direction_sigma_rad']:.1e} rad), "
                     f"point [{p[0]:.4f}, {p[1]:.4f}, {p[2]:.4f}] mm (+-{ax['point_sigma_mm']:.4f}), circle RMS {ax['rms_mm']:.4f} mm, "
                     f"{ax['kept']} of {ax['positions']} positions kept")
        lines.append(f"  vs nominal: line distance {v['line_distance_mm']:.4f} mm, angle {v['angle_rad']:.2e} rad, "
                     f"offset at the circle centre {v['offset_at_centre_mm']:.4f} mm")
        for o in ax["removed"]:
            lines.append(f"  removed id {o['id']} (row {o['row']}): {o['why']}")
    for path, label in doc.get("files", {}).items():
        lines.append(f"wrote {path} ({label})")
    return lines


def convert_five(program: Path, to: str, output: Path, machine_name: str, rtcp: str | None, dialect: str | None = None,
                 input_axes: str | None = None, tool: int = 1, max_deviation_mm: float = 0.01, frames: dict | None = None,
                 tools: dict | None = None) -> list[str]:
    """``convert`` with a machine: a five-axis G-code program for ``--rtcp`` mode, or a
    robot program from a five-axis G-code one. Returns the summary lines."""

    machine = load_machine(machine_name)
    if input_axes not in (None, "tip", "machine"):
        raise InputError(f"--input-axes: '{input_axes}' is not tip or machine")
    target = dialects.get(to, "--to")
    modes = target.rtcp_modes or MODES  # a language with one RTCP form (sinumerik: TRAORI) takes it by default
    rtcp = modes[0] if rtcp is None and len(modes) == 1 else rtcp
    if target.machine_program and rtcp not in modes:
        raise InputError(f"--rtcp: {'missing' if rtcp is None else repr(rtcp) + ' is not'} one of {', '.join(modes)} (needed with --to {to})")
    if target.five_axis_modes:  # a language that writes its own five-axis programs (Klartext M128)
        return _convert_own(program, target, output, machine, rtcp, dialect, input_axes, tool, frames, tools)
    tp = parse_program(program, dialect)
    if frames or tools:  # work offsets / tool lengths the program leaves to the controller (offsets.py refuses them undefined)
        tp = tp.with_frames(frames, tools)
    path = from_toolpath(tp, machine, input_axes)
    if target.machine_program:
        if not max_deviation_mm > 0:
            raise InputError(f"--max-deviation must be > 0 mm, got {max_deviation_mm}")
        result = emit(machine, path, rtcp, tool=tool, tool_length=path.tool_length, max_deviation_mm=max_deviation_mm)
        write_all({Path(output): result.text}, encoding="latin-1")
        lines = [f"{len(path.tip)} targets written to {output} ({rtcp} mode, machine {machine.name})"]
        if rtcp == "none":
            lines.append(f"largest tip deviation at the middle of a move (axes interpolated linearly): {result.chord_error_mm:.4f} mm")
        return lines + [f"note: {n}" for n in result.notes]
    if not dialects.of(tp).machine_program:
        raise InputError("--machine with --to rapid/krl converts a five-axis G-code program; this one is a robot program")
    robot = to_robot_toolpath(tp, path)  # in the machine frame: the work offsets are in the positions
    texts = write_program(robot, to, Path(output).stem)
    outputs = target.new_program_paths(Path(output))
    write_all(dict(zip(outputs, texts)), encoding="latin-1")
    return [f"{len(path.tip)} targets written to {', '.join(map(str, outputs))} (tool axis -> TCP z opposite; rotation about it from the base x axis)"]


def _convert_own(program: Path, target, output: Path, machine, rtcp: str | None, dialect: str | None, input_axes: str | None, tool: int,
                 frames: dict | None, tools: dict | None) -> list[str]:
    """``convert --to LANG --rtcp MODE`` for a language with ``rtcp_modes``: the tips and the
    rotary positions the machine's inverse kinematics gives (emit.solve), written by the language."""
    if rtcp not in target.five_axis_modes:
        raise InputError(f"--rtcp: {'missing' if rtcp is None else repr(rtcp) + ' is not'} one of {', '.join(target.five_axis_modes)} (needed with --to {target.name})")
    tp = parse_program(program, dialect)
    if frames or tools:
        tp = tp.with_frames(frames, tools)
    path = from_toolpath(tp, machine, input_axes)
    axes = solve(machine, path, path.tool_length).axes
    header = [f"postproc: {rtcp} (tool tip + rotary axis positions), machine {machine.name}; from {Path(program).name}"]
    text = target.five_axis_text(Path(output).stem, machine.rotary_names, path.tip, axes[:, 3:5], path.rapid, path.feed, path.line, header, tool)
    write_all({Path(output): text}, encoding="latin-1")
    return [f"{len(path.tip)} targets written to {output} ({rtcp} mode, machine {machine.name})"] + [f"note: {n}" for n in path.notes]


def compensate_five_request(request) -> list[str]:
    """``compensate_five_program`` of a ``CompensationRequest`` whose machine is a five-axis
    target (``postproc.jobs.targets.FiveAxisTarget``): one program, ``-o``, ``--grid``, ``--input-axes``."""
    if len(request.programs) != 1 or request.output is None or request.output == "-":
        raise InputError("five-axis compensation takes one program and -o OUT")
    return compensate_five_program(Path(request.programs[0]), Path(request.machine.source), Path(request.output), request.grid,
                                   request.input_axes, dialect=request.dialect, frames=dict(request.frames) or None,
                                   tools=dict(request.tools) or None)


def compensate_five_program(program: Path, machine_file: Path, output: Path, grid_file: Path | None = None, input_axes: str | None = None,
                            controller_name: str | None = None, dialect: str | None = None, frames: dict | None = None,
                            tools: dict | None = None) -> list[str]:
    """``compensate PROGRAM --model CALIBRATED.toml [--grid GRID.csv]``: the program's numbers
    for the real machine; the written text is read back and checked before it is kept."""
    # Deferred import: the error grid loads scipy.interpolate (slow to import); the CLI imports this module at start.
    from postproc.fivex.errormap import load_grid

    from .compensate import actual_tip, commanded, compensate_five



    true = load_machine(machine_file)
    controller = load_machine(controller_name or true.name)
    grid = load_grid(grid_file) if grid_file is not None else None
    tp = parse_program(program, dialect)
    if frames or tools:  # work offsets / tool lengths the program leaves to the controller (offsets.py refuses them undefined)
        tp = tp.with_frames(frames, tools)
    new, report = compensate_five(tp, true, controller, grid, input_axes)
    text = emit_texts(tp, new)[0]
    # What the written numbers (rounded as the text has them) make the real machine do:
    again = parse_program(program, tp.dialect, data=text.encode("latin-1"))
    at, length = report.placement, report.tool_length
    cmd = commanded(controller, again, at, input_axes, length)
    intended, _ = fk(controller, commanded(controller, tp, at, input_axes, length), length)
    written = np.linalg.norm(actual_tip(true, grid, cmd, length) - intended, axis=1)
    if not np.isfinite(written).all() or written.max() > 0.005:
        i = int(np.nanargmax(np.where(np.isfinite(written), written, np.inf)))
        raise JobError(f"{program}:{int(tp.line[i])}: the compensated numbers, as written, leave {written[i]:.4f} mm; nothing was written")
    write_all({Path(output): text}, encoding="latin-1")
    lines = [f"{len(tp)} targets compensated for {machine_file}{' and grid ' + str(grid_file) if grid is not None else ''}: "
             f"predicted tip error max {report.before_mm.max():.4f} -> {written.max():.4f} mm (RMS {np.sqrt(np.mean(report.before_mm**2)):.4f} -> "
             f"{np.sqrt(np.mean(written**2)):.4f} mm, as written); largest linear-axis correction {report.correction_mm.max():.4f} mm"]
    return lines + [f"note: {n}" for n in report.notes]


def write_all(files: dict, encoding: str = "utf-8") -> None:
    """The texts of one job encoded first, then written together or not at all (postproc.files)."""
    write_bytes({Path(path): text.encode(encoding) for path, text in files.items()})
