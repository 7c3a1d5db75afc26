"""Programs compensated in chunks (postproc.jobs.stream): byte-identical to the whole-program path
on programs both can take, posture and modal state carried across cuts, all or nothing."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import FRAME_AND_COMPLIANCE, G54, H1, TOOL
from typer.testing import CliRunner

import postproc
from postproc.cli import app
from postproc.jobs.compensate import CompensationError, compensate
from postproc.jobs.stream import StreamFallback, compensate_streamed
from postproc.model.effects import parse_effects
from postproc.model.model_io import save_model
from postproc.model.sim import random_truth
from postproc.programs import emit_texts, parse_program

runner = CliRunner()


@pytest.fixture(scope="module")
def model():
    robot = postproc.load_robot("kr160_r1570")
    return random_truth(robot, TOOL, parse_effects(FRAME_AND_COMPLIANCE), np.random.default_rng(3))


def _krl(path, n=700, extra=()):
    """Inline targets, partial aggregates (Z and A B C carried from earlier lines), comments."""
    lines = ["DEF raster( )", ";FOLD header", "$BASE = {X 0, Y 0, Z 0, A 0, B 0, C 0}", "$TOOL = {X 0, Y 0, Z 200, A 0, B 0, C 0}", ";ENDFOLD",
             "$APO.CDIS = 0.2", "LIN {X 900, Y -200, Z 450, A 0, B 180, C 0} C_DIS"]
    for i in range(n):
        x, y = 900.0 + 200.0 * (i // 40) / 20, -200.0 + 400.0 * (i % 40) / 40
        lines.append(f"LIN {{X {x:.3f}, Y {y:.3f}}} C_DIS" if i % 3 else f"LIN {{X {x:.3f}, Y {y:.3f}, Z {450 + 5 * np.sin(i / 9):.3f}, A 0, B 180, C 0}} C_DIS")
        if i % 97 == 5:
            lines.append("; a comment between moves")
    path.write_text("\r\n".join(lines + list(extra) + ["END"]) + "\r\n", encoding="latin-1")
    return path


def _gcode(path, n=700):
    """A CAM-style five-axis program (G43.5 tool axis vectors): modal axes and motion mode,
    feed, M codes, comments."""
    lines = ["%", "(raster)", "G21 G90 G17", "G54", "G43.5 H1", "G0 X0 Y-200 Z10 I0 J0 K1", "G1 Z0 I0 J0 K1 F600"]
    for i in range(n):
        x, y = 200.0 * (i // 40) / 20, -200.0 + 400.0 * (i % 40) / 40
        tilt = np.radians(10.0 * np.sin(i / 7.0))
        axis = f"I{np.sin(tilt):.6f} J0 K{np.cos(tilt):.6f}"
        lines.append(f"X{x:.3f} Y{y:.3f} {axis}" if i % 4 else f"G1 X{x:.3f} Y{y:.3f} Z{5 * np.sin(i / 9):.3f} {axis}")
        if i % 101 == 7:
            lines.append("M8 (coolant)")
    path.write_text("\n".join(lines + ["G0 Z50 I0 J0 K1", "G49", "M30", "%"]) + "\n", encoding="latin-1")
    return path


GCODE_SETUP = {"frames": {"G54": G54}, "tools": {"H1": H1}}


def _whole(program, model, out, **options):
    tp = parse_program(program)
    new, rep = compensate(tp, model, **options)
    assert not rep.failures()
    out.write_text(emit_texts(tp, new)[0], encoding="latin-1")
    return rep


@pytest.mark.parametrize("workers", [0, 2])
@pytest.mark.parametrize("make,options", [(_krl, {}), (_gcode, GCODE_SETUP)])
def test_streamed_output_is_byte_identical_to_the_whole_program(tmp_path, model, make, options, workers):
    """In one process and in the pipeline of worker processes alike."""
    program = make(tmp_path / ("p.src" if make is _krl else "p.ngc"))
    whole = tmp_path / "whole.src"
    rep = _whole(program, model, whole, **options)
    chunks = {}
    for chunk in (97, 10_000):
        out = tmp_path / f"stream{chunk}.src"
        result = compensate_streamed(program, model, out, chunk_lines=chunk, workers=workers, **options)
        chunks[chunk] = result.summary["chunks"]
        assert out.read_bytes() == whole.read_bytes(), chunk
        assert result.summary["targets"] == rep.summary()["targets"]
        want = rep.summary()
        for key in ("targets", "compensated", "iterations_max", "iterations_median", "failed"):
            assert result.summary[key] == want[key], key
        for key in ("predicted_before", "predicted_after"):
            assert result.summary[key] == pytest.approx(want[key], rel=1e-9)
        assert result.summary["path"] == pytest.approx(want["path"], rel=1e-9)
    assert chunks[10_000] == 1 and chunks[97] > 5


def test_posture_is_carried_across_cuts(tmp_path, model):
    """A start posture with the wrist flipped: every chunk keeps it (as the whole program does)."""
    from postproc.robot import kinematics as kin

    program = _krl(tmp_path / "p.src", n=400)
    tp = parse_program(program)
    flange = tp.base_poses()[:1] @ np.linalg.inv(tp.tools[tp.tool[0]])
    sols = kin.ik(model.robot, flange)[0]
    ok = ~np.isnan(sols).any(axis=1) & kin.within_limits(model.robot, np.nan_to_num(sols))
    default = _whole(program, model, tmp_path / "default.src")
    flipped = [q for q in sols[ok] if np.sign(q[4]) != np.sign(sols[ok][np.argmin(np.abs(sols[ok]).sum(axis=1))][4])]
    assert flipped, "no flipped-wrist solution to start from"
    start = {"start_joints": flipped[0]}
    _whole(program, model, tmp_path / "whole.src", **start)
    assert (tmp_path / "whole.src").read_bytes() != (tmp_path / "default.src").read_bytes()  # the posture matters here
    compensate_streamed(program, model, tmp_path / "stream.src", chunk_lines=60, **start)
    assert (tmp_path / "stream.src").read_bytes() == (tmp_path / "whole.src").read_bytes()
    assert default.summary()["failed"] == 0


def test_state_changes_after_the_moves_are_read_in_context(tmp_path, model):
    """Lines that are not plain moves end the chunked part; the rest is one chunk read after
    the restated state (a $BASE change then more moves)."""
    extra = ["$BASE = {X 10, Y 0, Z 0, A 0, B 0, C 0}", "LIN {X 950, Y 0, Z 440, A 0, B 180, C 0}", "LIN {X 960}"]
    program = _krl(tmp_path / "p.src", n=300, extra=extra)
    _whole(program, model, tmp_path / "whole.src")
    result = compensate_streamed(program, model, tmp_path / "stream.src", chunk_lines=50)
    assert (tmp_path / "stream.src").read_bytes() == (tmp_path / "whole.src").read_bytes()
    assert result.summary["chunks"] > 3


def test_path_dependent_models_and_other_languages_are_read_whole(tmp_path, model):
    robot = postproc.load_robot("kr160_r1570")
    backlash = random_truth(robot, TOOL, parse_effects(FRAME_AND_COMPLIANCE + ",backlash"), np.random.default_rng(3))
    with pytest.raises(StreamFallback, match="backlash"):
        compensate_streamed(_krl(tmp_path / "p.src", n=50), backlash, tmp_path / "o.src")
    rapid = tmp_path / "p.mod"
    rapid.write_text("MODULE M\n  PROC main()\n    MoveL [[1,2,3],[1,0,0,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, z1, tool0;\n  ENDPROC\nENDMODULE\n")
    with pytest.raises(StreamFallback, match="rapid"):
        compensate_streamed(rapid, model, tmp_path / "o.mod")
    assert not (tmp_path / "o.src").exists() and not (tmp_path / "o.mod").exists()


def test_a_failure_in_a_late_chunk_writes_nothing_and_names_the_program_line(tmp_path, model):
    program = _krl(tmp_path / "p.src", n=300)
    lines = program.read_bytes().decode("latin-1").split("\r\n")
    bad = 250  # 1-based line of a target far out of reach, in a late chunk
    lines[bad - 1] = "LIN {X 5000, Y 0, Z 450, A 0, B 180, C 0} C_DIS"
    program.write_text("\r\n".join(lines), encoding="latin-1")
    out = tmp_path / "out" / "p.src"
    out.parent.mkdir()
    with pytest.raises(CompensationError) as caught:
        compensate_streamed(program, model, out, chunk_lines=40)
    assert bad in [line for line, _ in caught.value.failures]
    assert list(out.parent.iterdir()) == []  # no output, no temporary file


def test_cli_streams_and_falls_back(tmp_path, model):
    program = _krl(tmp_path / "p.src", n=200)
    save_model(tmp_path / "m.json", model)
    outs = {}
    for mode in ("always", "never"):
        outs[mode] = tmp_path / f"{mode}.src"
        res = runner.invoke(app, ["compensate", str(program), "--model", str(tmp_path / "m.json"), "-o", str(outs[mode]), "--stream", mode])
        assert res.exit_code == 0, res.output
        assert ("chunks" in res.output) == (mode == "always")
    assert outs["always"].read_bytes() == outs["never"].read_bytes()
    bad = runner.invoke(app, ["compensate", str(program), "--model", str(tmp_path / "m.json"), "-o", str(tmp_path / "x.src"), "--stream", "sometimes"])
    assert bad.exit_code == 2 and "--stream" in bad.output


def test_a_chunk_sent_to_a_worker_is_restored_bit_for_bit(tmp_path, model):
    """The pipe carries only the varying columns of the IR's wide arrays; -0.0, NaN and
    every other value come back as they were."""
    import dataclasses

    from postproc.jobs.compensate import reference_postures
    from postproc.jobs.stream import _Task

    tp = parse_program(_krl(tmp_path / "p.src", n=60))
    values = tp.values.copy()
    values[:, -1] = 0.0
    values[5, -1], values[7, 1] = -0.0, np.nan  # -0.0 in a column of 0.0: equal as a value, not as bits
    tp = dataclasses.replace(tp, values=values)
    task = _Task(tp, None, reference_postures(tp, model), -1, "")
    piped = task.for_pipe()
    assert piped.tp.values is None and piped.packed["values"][4].size < values.size
    back = piped.toolpath()
    for f in dataclasses.fields(tp):
        a, b = getattr(tp, f.name), getattr(back, f.name)
        if isinstance(a, np.ndarray):
            assert a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes(), f.name


_TORCH_AFTER_FORK = """
import torch
from postproc.jobs import stream
a = torch.randn(600, 600); (a @ a).sum()  # the parent's thread pool runs (as a learned predictor's would)
def work(_):
    b = torch.randn(600, 600)
    return float((torch.tanh(b) @ b).sum() * 0)
with stream._pool(2) as (pool, _slots):
    print(sum(pool.map(work, range(4))))
"""


def test_workers_forked_after_torch_ran_do_not_hang():
    """A forked worker whose parent already used torch's thread pool hung in its first
    parallel torch operation (a model with a pso-bp predictor, streamed): the pool's workers
    run torch on one thread."""
    import subprocess
    import sys

    done = subprocess.run([sys.executable, "-c", _TORCH_AFTER_FORK], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "0.0"
