"""Arcs over the tolerance split into compensated arcs (issue 13, `compensate --subdivide`).

A KRL CIRC / RAPID MoveC whose predicted mid-arc deviation exceeds --max-deviation is, with
--subdivide, written as several arcs of the same circle: copies of its statement before it
(auxiliary point in the middle of each piece, end point at its end; named points declared
the language's way: KRL in the .dat, RAPID as new robtargets) and its own auxiliary point
moved to the middle of the last piece. Every point is compensated; the written program is
run on the true robot by the controller of tests/test_arcs_e2e.py (circle through each
statement's three commanded points) and must follow the intended arcs within the tolerance
(plus the model's own error). Without --subdivide the arc is refused (exit 1), nothing written.
"""

from __future__ import annotations

import re

import numpy as np
import pytest
from test_arcs_e2e import CELLS, _configurations, _distances, _gcode, _krl, _rapid, _run_on_true_robot, _truth_and_model, _work_frame
from typer.testing import CliRunner

from postproc.cli import app
from postproc.jobs.compensate import compensate
from postproc.jobs.subdivide import compensate_subdivided
from postproc.model.model_io import save_model
from postproc.programs import emit_texts, parse_program
from postproc.programs.ir import Kind

TOLERANCE_MM = 0.01
CELL = CELLS["kr160"]
ELBOW_DOWN = 1  # the configuration whose half circle strays most (0.032 mm predicted)
runner = CliRunner()


@pytest.fixture(scope="module")
def truth_and_model():
    return _truth_and_model(CELL)


def _program(tmp_path, dialect, named=False):
    """The e2e path in one dialect, the start posture, and compensate's options for it."""
    q_start = _configurations(CELL)[ELBOW_DOWN]
    if dialect == "gcode":
        path, extra = _gcode(tmp_path, _work_frame(CELL), CELL)
        return path, q_start, {**extra, "start_joints": q_start}
    path, _ = (_krl if dialect == "krl" else _rapid)(tmp_path, _work_frame(CELL), CELL, q_start)
    if named:  # the first MoveC's auxiliary and end points as declared robtargets
        text = path.read_text()
        line = next(x for x in text.splitlines() if "MoveC" in x)
        aux, end = re.findall(r"\[\[[^;]*?\]\]", line)[:2]
        text = text.replace(line, "    MoveC pAux, pEnd, v100, z1, tSpindle;")
        text = text.replace("  PROC main()", f"  CONST robtarget pAux := {aux};\n  CONST robtarget pEnd := {end};\n  PROC main()")
        path.write_text(text)
    return path, q_start, {}


ARCS = (Kind.CIRC_END, Kind.ARC_CW, Kind.ARC_CCW)


def src_line(path, n):
    return path.read_text().splitlines()[n - 1]


def _arcs(tp):
    return int(np.isin(tp.kind, ARCS).sum())


def _written(tp_long, new, folder):
    folder.mkdir()
    for text, doc in zip(emit_texts(tp_long, new), tp_long.sources):
        (folder / doc.path.split("/")[-1]).write_bytes(text.encode("latin-1"))
    return parse_program(folder / tp_long.sources[0].path.split("/")[-1])


@pytest.mark.parametrize("dialect, named", [("krl", False), ("rapid", False), ("rapid", True), ("gcode", False)])
def test_arcs_over_the_tolerance_are_split_and_followed_on_the_true_robot(truth_and_model, tmp_path, dialect, named):
    truth, model = truth_and_model
    path, q_start, options = _program(tmp_path, dialect, named)
    tp = parse_program(path)
    _, plain = compensate(tp, model, max_deviation_mm=TOLERANCE_MM, **options)
    arc_over = np.isin(tp.kind, ARCS) & plain.failed
    assert arc_over.any(), plain.path_mm  # an arc strays over the tolerance: refused as it stands
    sub = compensate_subdivided(tp, model, TOLERANCE_MM, **options)
    assert not sub.report.failed.any(), sub.report.failures()
    assert _arcs(sub.program) > _arcs(tp)  # the arc became several
    assert np.nanmax(sub.report.path_mm) <= TOLERANCE_MM
    back = _written(sub.program, sub.compensated, tmp_path / "out")
    assert _arcs(back) == _arcs(sub.program)
    # On the true robot: every motion, the split arcs included, within the tolerance and the
    # model's own error (about 0.004 mm here); as compensated without splitting, the arc was not.
    frames, tools = options.get("frames"), options.get("tools")
    placed = (lambda t: t.with_frames(frames, tools)) if frames else (lambda t: t)
    plain_back = _written(tp, compensate(tp, model, **options)[0], tmp_path / "plain")
    before, _ = _run_on_true_robot(CELL.robot, truth, placed(plain_back), q_start)
    after, _ = _run_on_true_robot(CELL.robot, truth, placed(back), q_start)
    worst_before = _distances(placed(tp), before).max(axis=1)
    worst_after = _distances(placed(sub.program), after).max(axis=1)
    assert worst_before.max() > 0.02
    assert worst_after.max() <= TOLERANCE_MM + 0.004, worst_after


def test_gcode_pieces_keep_the_block_form_and_a_full_circle_gets_its_end_point(truth_and_model, tmp_path):
    _, model = truth_and_model
    path, _, options = _program(tmp_path, "gcode")
    sub = compensate_subdivided(parse_program(path), model, TOLERANCE_MM, **options)
    blocks = sub.program.sources[0].text.splitlines()
    circle = [b for b in blocks if b.startswith("G2 I")]
    assert len(circle) >= 3  # the full circle G2 I J became pieces, each with its end point
    assert all(re.fullmatch(r"G2 I-?[\d.]+ J-?[\d.]+ X-?[\d.]+ Y-?[\d.]+", b) for b in circle), circle  # Z stays modal
    assert circle[-1].endswith("X85.0000 Y-125.0000")  # the last piece closes the circle where it started


def test_krl_split_arcs_declare_their_end_points_in_the_dat(truth_and_model, tmp_path):
    _, model = truth_and_model
    path, _, _ = _program(tmp_path, "krl")
    save_model(tmp_path / "m.json", model)
    out = tmp_path / "out" / "part.src"
    out.parent.mkdir()
    res = runner.invoke(app, ["compensate", str(path), "--model", str(tmp_path / "m.json"), "-o", str(out), "--subdivide",
                              "--max-deviation", str(TOLERANCE_MM)])
    assert res.exit_code == 0, res.output
    src, dat = out.read_text(), out.with_suffix(".dat").read_text()
    assert "subdivide straight segments and arcs" in res.output
    assert "DECL E6POS XPHALF_S1=" in dat and re.search(r"^CIRC \{X [^}]*\}, XPHALF_S1\r?$", src, re.MULTILINE), src
    assert re.search(r"^CIRC \{X [^}]*\}, XPHALF\r?$", src, re.MULTILINE)  # the original statement ends the last piece
    assert "DECL E6POS XPHALF=" in dat


def test_rapid_named_auxiliary_point_is_declared_anew(truth_and_model, tmp_path):
    _, model = truth_and_model
    path, _, _ = _program(tmp_path, "rapid", named=True)
    sub = compensate_subdivided(parse_program(path), model, TOLERANCE_MM)
    text = sub.program.sources[0].text
    # the copies name new robtargets; the original statement keeps its end and names a moved auxiliary point
    assert "MoveC pAux_S1, pEnd_S1, v100, z1, tSpindle;" in text and "CONST robtarget pEnd_S1 := [[" in text
    assert re.search(r"MoveC pAux_S\d, pEnd, v100, z1, tSpindle;", text)
    assert "CONST robtarget pAux := [[" in text  # the old declaration stays as it was


def test_without_subdivide_an_arc_over_the_tolerance_is_refused(truth_and_model, tmp_path):
    _, model = truth_and_model
    path, _, _ = _program(tmp_path, "krl")
    save_model(tmp_path / "m.json", model)
    out = tmp_path / "o.src"
    res = runner.invoke(app, ["compensate", str(path), "--model", str(tmp_path / "m.json"), "-o", str(out), "--max-deviation", str(TOLERANCE_MM)])
    text = " ".join(res.output.split())
    assert res.exit_code == 1 and "splits CIRC / MoveC arcs" in text, text
    column = src_line(path, 7).index("XPHALF") + 1  # the arc's end point, by its name
    assert f"part.src:7:{column}: on the segment into it the predicted path strays" in text
    assert not out.exists() and not out.with_suffix(".dat").exists()


if __name__ == "__main__":  # the numbers: .venv/bin/python tests/test_arc_subdivide.py
    import tempfile
    from pathlib import Path

    truth, model = _truth_and_model(CELL)
    print(f"KR160 elbow down, tolerance {TOLERANCE_MM} mm: compensated -> compensated with --subdivide; largest distance from the intended path over all motions, predicted on arcs and true (mm)")
    for dialect, named in (("krl", False), ("rapid", False), ("gcode", False)):
        with tempfile.TemporaryDirectory() as folder:
            folder = Path(folder)
            path, q_start, options = _program(folder, dialect, named)
            tp = parse_program(path)
            frames, tools = options.get("frames"), options.get("tools")
            placed = (lambda t: t.with_frames(frames, tools)) if frames else (lambda t: t)
            new, plain = compensate(tp, model, **options)
            before, _ = _run_on_true_robot(CELL.robot, truth, placed(_written(tp, new, folder / "plain")), q_start)
            sub = compensate_subdivided(tp, model, TOLERANCE_MM, **options)
            after, _ = _run_on_true_robot(CELL.robot, truth, placed(_written(sub.program, sub.compensated, folder / "out")), q_start)
            print(f"{dialect:6s} arcs {_arcs(tp)} -> {_arcs(sub.program)}, predicted worst arc {np.nanmax(plain.path_mm[np.isin(tp.kind, ARCS)]):.4f} -> "
                  f"{np.nanmax(sub.report.path_mm[np.isin(sub.program.kind, ARCS)]):.4f}; true worst {_distances(placed(tp), before).max():.4f} -> "
                  f"{_distances(placed(sub.program), after).max():.4f}")
