"""Subdividing straight segments (issue 13, `compensate --subdivide`): where the predicted
path between compensated targets strays more than the tolerance from the intended line,
new compensated targets are written the language's way, and the re-parsed output holds
every target (old and new) at its compensated value with the path within the tolerance."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import FRAME_AND_COMPLIANCE, TOOL, kr160
from typer.testing import CliRunner

from postproc.cli import app
from postproc.errors import EmitError
from postproc.jobs.compensate import compensate
from postproc.jobs.subdivide import compensate_subdivided, new_points
from postproc.model.effects import parse_effects
from postproc.model.identify import fit
from postproc.model.model_io import save_model
from postproc.model.sim import Cylinder, random_truth, sample_poses, simulate
from postproc.programs import dialects, parse_program
from postproc.programs.emit.insert import NewPoint
from postproc.programs.ir import Kind
from postproc.robot import kinematics as kin

runner = CliRunner()
DOWN = "A 0, B 180, C 0"


@pytest.fixture(scope="module")
def truth_and_model():
    robot = kr160()
    rng = np.random.default_rng(3)
    effects = parse_effects(FRAME_AND_COMPLIANCE + "[payload=1]")  # measured with the 1 kg tool of the RAPID test
    truth = random_truth(robot, TOOL, effects, rng)
    # Measured where its programs lie (out to x 1300 mm): postproc refuses targets outside the measured region.
    data = simulate(truth, sample_poses(robot, TOOL, 300, Cylinder(radius_mm=(700.0, 1400.0)), rng), rng)
    return truth, fit(robot, TOOL, effects, data, cv_folds=0).model


@pytest.fixture(scope="module")
def model(truth_and_model):
    return truth_and_model[1]


def _start_ptp(x, y, z):
    """An axis PTP to the joints of the first target (the wrist as a KR160 usually holds it)."""
    from postproc.robot.frames import abc_to_matrix, make_transform

    pose = make_transform(abc_to_matrix(np.array([[0.0, 180.0, 0.0]]))[0], np.array([x, y, z]))
    flange = pose @ np.linalg.inv(make_transform(np.eye(3), TOOL))
    q, _ = kin.select_nearest(kr160(), kin.ik(kr160(), flange[None]), np.array([[0, -60, 40, 0, 60, 0.0]]))
    return "PTP {" + ", ".join(f"A{i + 1} {v:.6f}" for i, v in enumerate(q[0])) + "}"


def _krl(tmp_path):
    """A .src with named points in its .dat (long LINs) and an inline LIN."""
    src = ["DEF part( )", "$BASE = {X 0, Y 0, Z 0, A 0, B 0, C 0}", f"$TOOL = {{X 0, Y 0, Z {TOOL[2]:g}, A 0, B 0, C 0}}",
           _start_ptp(1000, -300, 500), "LIN XPSTART C_DIS", "LIN XP_LONG_POINT_NAME_2345 C_DIS",
           f"LIN {{X 1300, Y 300, Z 500, {DOWN}}}", "END"]
    dat = ["DEFDAT part", f"DECL E6POS XPSTART={{X 1000,Y -300,Z 500,{DOWN},S 2,T 35,E1 0,E2 0,E3 0,E4 0,E5 0,E6 0}}",
           f"DECL E6POS XP_LONG_POINT_NAME_2345={{X 1000,Y 300,Z 500,{DOWN},S 2,T 35,E1 0,E2 0,E3 0,E4 0,E5 0,E6 0}}", "ENDDAT"]
    (tmp_path / "part.src").write_text("\n".join(src) + "\n")
    (tmp_path / "part.dat").write_text("\n".join(dat) + "\n")
    return tmp_path / "part.src"


def test_long_lines_get_compensated_targets_and_the_path_is_within_tolerance(model, tmp_path):
    tp = parse_program(_krl(tmp_path))
    _, plain = compensate(tp, model)
    assert np.nanmax(plain.path_mm) > 0.05  # 600 mm and 300 mm lines bow by ~0.1 mm
    sub = compensate_subdivided(tp, model, 0.02)
    assert not sub.report.failed.any(), sub.report.failures()
    assert np.nanmax(sub.report.path_mm) <= 0.02
    assert len(sub.program) > len(tp) and len(sub.added) == len(sub.program) - len(tp)
    assert all(len(name) <= 24 for _, name in sub.added)  # KRL names
    assert set(sub.program.kind[[i for i in range(len(sub.program)) if sub.program.line[i] in {l for l, _ in sub.added}]]) == {Kind.LINEAR}


def test_cli_writes_src_and_dat_and_they_read_back_compensated(model, tmp_path):
    prog = _krl(tmp_path)
    save_model(tmp_path / "m.json", model)
    out = tmp_path / "out" / "part.src"
    out.parent.mkdir()
    res = runner.invoke(app, ["compensate", str(prog), "--model", str(tmp_path / "m.json"), "-o", str(out), "--subdivide"])
    assert res.exit_code == 0, res.output
    assert "new target(s) subdivide" in res.output
    dat = (out.with_suffix(".dat")).read_text()
    src = out.read_text()
    assert "DECL E6POS XP_LONG_POINT_NAME_23_S1=" in dat and "LIN XP_LONG_POINT_NAME_23_S1 C_DIS" in src
    assert "LIN {X 1" in src and src.count("LIN {") > 1  # the inline LIN got inline copies
    # The written program, compensated again under the same model, needs (almost) nothing:
    # every target is where the compensation put it, and the path stays within 0.02 mm.
    written = parse_program(out)
    sub = compensate_subdivided(parse_program(prog), model, 0.02)
    np.testing.assert_allclose(written.base_positions(), sub.compensated.base_positions(), atol=1e-3)
    assert np.nanmax(sub.report.path_mm) <= 0.02


def test_without_subdivide_max_deviation_refuses(model, tmp_path):
    prog = _krl(tmp_path)
    save_model(tmp_path / "m.json", model)
    out = tmp_path / "o.src"
    res = runner.invoke(app, ["compensate", str(prog), "--model", str(tmp_path / "m.json"), "-o", str(out), "--max-deviation", "0.02"])
    assert res.exit_code == 1 and "--subdivide adds targets" in res.output
    assert not out.exists() and not out.with_suffix(".dat").exists()


RAPID = """MODULE part
  CONST robtarget p1 := [[1000,-300,500],[0,0,1,0],[-1,0,-1,1],[9E9,9E9,9E9,9E9,9E9,9E9]];
  CONST robtarget p2 := [[1000,300,500],
     [0,0,1,0],[0,0,0,1],[9E9,9E9,9E9,9E9,9E9,9E9]];
  PROC main()
    MoveL p1, v100, z10, tool0;
    MoveL p2, v100, z10, tool0;
    MoveL [[1300,300,500],[0,0,1,0],[0,0,0,1],[9E9,9E9,9E9,9E9,9E9,9E9]], v200, fine, tool0;
  ENDPROC
ENDMODULE
"""


def test_rapid_robtargets_and_moves_are_copied_with_their_confdata(tmp_path):
    (tmp_path / "part.mod").write_text(RAPID)
    tp = parse_program(tmp_path / "part.mod")
    points = new_points(tp, kr160(), np.array([1, 2]), np.array([3, 2]))
    sources, names = dialects.of(tp).insert_points(tp, points)
    text = sources[0].text
    assert names == ["p2_S1", "p2_S2", ""]
    assert "CONST robtarget p2_S1 := [[1000,-100,500]," in text and "MoveL p2_S2, v100, z10, tool0;" in text
    assert "MoveL [[1150,300,500],[0,0,1,0]," in text and text.count("v200, fine") == 2
    back = dialects.of(tp).parse_sources(sources)
    assert len(back) == 6 and (back.kind == Kind.LINEAR).all()
    # confdata of each new point is its own (the line crosses axis 1's quadrant boundary at
    # y = 0: cf1 -1 before it, 0 after), not a copy of the end target's
    np.testing.assert_array_equal(back.conf[1:3], [[-1, 0, -1, 1], [0, 0, 0, 1]])


def test_gcode_blocks_are_copied_without_block_numbers(tmp_path):
    path = tmp_path / "p.ngc"
    path.write_text("G21 G90\nN10 G0 X0 Y0 Z10\nN20 G1 X100 Y0 Z10 F600\nN30 X100 Y50\nM30\n")
    tp = parse_program(path)
    lang = dialects.of(tp)
    end = int(np.nonzero(tp.line == 3)[0][0])
    values = tp.values[end].copy()
    values[:3] = [50, 0, 10]
    sources, _ = lang.insert_points(tp, [NewPoint(end, values, np.full(4, np.nan))])
    assert sources[0].text.splitlines()[2] == "G1 X50 Y0 Z10 F600"
    back = lang.parse_sources(sources)
    assert len(back) == len(tp) + 1 and back.kind[end] == Kind.LINEAR
    np.testing.assert_allclose(back.position[end], [50, 0, 10])


def test_gcode_block_that_also_changes_the_tool_is_not_copied(tmp_path):
    path = tmp_path / "p.ngc"
    path.write_text("G21 G90\nG0 X0 Y0 Z10\nT2 M6 G1 X100 Y0 Z10 F600\nM30\n")
    tp = parse_program(path)
    end = int(np.nonzero(tp.line == 3)[0][0])
    with pytest.raises(EmitError, match="line 3: the block also does T2 M6"):
        dialects.of(tp).insert_points(tp, [NewPoint(end, tp.values[end], np.full(4, np.nan))])


@pytest.mark.parametrize("move, who", [("G1 X100 F600", "a point before it"), ("G2 X20 Y0 I10 J0 F600", "it")])
def test_gcode_incremental_target_is_refused_with_its_line(tmp_path, move, who):
    # A G91 number is relative to the point before: a copy before it would move what it means.
    path = tmp_path / "p.ngc"
    path.write_text(f"G21 G90 G17\nG0 X0 Y0 Z10\nG91\n{move}\nM30\n")
    tp = parse_program(path)
    end = int(np.nonzero(tp.line == 4)[0][0])
    with pytest.raises(EmitError, match=rf"p\.ngc, line 4: the target is written in increments \(G91\): {who} cannot be written as a copy$"):
        dialects.of(tp).insert_points(tp, [NewPoint(end, tp.values[end], np.full(4, np.nan))])


def test_rapid_offs_target_is_refused_with_its_line(tmp_path):
    (tmp_path / "o.mod").write_text(RAPID.replace("    MoveL [[1300", "    MoveL Offs(p2,300,0,0), v100, fine, tool0;\n    MoveL [[1300"))
    tp = parse_program(tmp_path / "o.mod")
    row = int(np.nonzero(tp.target_name == np.array(tp.target_name))[0][2])
    with pytest.raises(EmitError, match="line 8: the target is an expression"):
        dialects.of(tp).insert_points(tp, [NewPoint(row, tp.values[row], np.full(4, np.nan))])


def _true_path(truth, tp, samples=16):
    """The true robot driven by the nominal controller along the program's LIN segments
    (straight commanded lines, joints nearest the previous ones): TCP points (M, 3)."""
    from postproc.robot.posture import interpolate_poses

    robot = truth.robot
    flange = tp.flange_poses()
    q_prev = tp.joints[0]
    points = []
    for i in range(2, len(tp)):
        poses = interpolate_poses(flange[i - 1 : i], flange[i : i + 1], np.linspace(0, 1, samples + 1)[1:])[0]
        for pose in poses:
            q, _ = kin.select_nearest(robot, kin.ik(robot, pose[None]), q_prev[None])
            q_prev = q[0]
            points.append(q_prev)
    return truth.predict_prepared(truth.prepare(q_deg=np.array(points)))


def _distance_to_polyline(points, corners):
    from postproc.compensation.segments import distance_to_segments

    d = [distance_to_segments(points[None], a[None], b[None])[0] for a, b in zip(corners[:-1], corners[1:])]
    return np.min(d, axis=0)


def test_on_the_true_robot_the_subdivided_path_follows_the_line(truth_and_model, tmp_path):
    """Run on the simulated true robot (nominal controller IK, true forward model), the
    subdivided program's path stays near the intended lines; the plain one bows off."""
    truth, model = truth_and_model
    tp = parse_program(_krl(tmp_path))
    corners = tp.base_positions()[1:]
    plain, _ = compensate(tp, model)
    sub = compensate_subdivided(tp, model, 0.02)
    worst_plain = _distance_to_polyline(_true_path(truth, plain), corners).max()
    worst_sub = _distance_to_polyline(_true_path(truth, sub.compensated), corners).max()
    # measured: 0.092 mm plain, 0.011 mm subdivided (pytest -s prints them)
    print(f"true path: plain {worst_plain:.4f} mm, subdivided {worst_sub:.4f} mm")
    assert worst_plain > 0.06 and worst_sub < 0.035 and worst_sub < worst_plain / 2, (worst_plain, worst_sub)


def test_rapid_program_subdivided_through_the_cli(model, tmp_path):
    """ConfL on (the default): the new robtargets carry their own confdata (axis 1 changes
    quadrant along the 600 mm line), and the whole module reads back compensated."""
    text = RAPID.replace("tool0", "tSp").replace("MoveL p1, v100, z10", "MoveJ p1, v100, fine").replace(
        "  CONST robtarget p1", "  PERS tooldata tSp := [TRUE,[[0,0,200],[1,0,0,0]],[1,[0,0,1],[1,0,0,0],0,0,0]];\n  CONST robtarget p1")
    (tmp_path / "part.mod").write_text(text)
    save_model(tmp_path / "m.json", model)
    out = tmp_path / "out.mod"
    res = runner.invoke(app, ["compensate", str(tmp_path / "part.mod"), "--model", str(tmp_path / "m.json"), "-o", str(out), "--subdivide",
                              "--allow-model-mismatch"])  # a RAPID program, a KUKA model
    assert res.exit_code == 0, res.output
    written = out.read_text()
    assert "CONST robtarget p2_S1 := [[" in written and "MoveL p2_S1, v100, z10, tSp;" in written
    back = parse_program(out)
    names = list(back.target_name)
    assert back.conf[names.index("p2_S1")][0] == -1 and back.conf[names.index("p2")][0] == 0


def test_a_force_per_block_follows_the_new_targets(tmp_path):
    """--force-file / --cut forces are per target: a new target gets its motion's force."""
    from postproc.jobs.subdivide import _new_index, _options_for_longer

    (tmp_path / "part.mod").write_text(RAPID)
    tp = parse_program(tmp_path / "part.mod")
    points = new_points(tp, kr160(), np.array([1, 2]), np.array([3, 2]))
    force = np.array([[1.0, 0, 0], [2.0, 0, 0], [3.0, 0, 0]])
    longer = _options_for_longer({"force_per_target": force, "tol_mm": 0.01}, tp, points, _new_index(tp, points))
    np.testing.assert_array_equal(longer["force_per_target"][:, 0], [1, 2, 2, 2, 3, 3])
    assert longer["tol_mm"] == 0.01


@pytest.mark.slow
def test_real_gcode_segments_are_copied_and_read_back(shared):
    """Every straight segment of the real G-code corpus whose end block writes a coordinate
    (others use parameters, #<z_cut>) gets a midpoint block; the text parses back with every
    old target unchanged and every new one on its segment (measured: 6,193 segments, 5
    blocks refused with their lines; pytest -s prints it)."""
    import re

    from postproc.errors import PostprocError
    from postproc.jobs.subdivide import check_inserted

    files = sorted((shared / "corpus" / "real" / "gcode").glob("*"))
    refused = []
    if not files:
        pytest.skip("the real corpus is not placed under shared/corpus/real")
    segments = 0
    for path in files:
        try:
            tp = parse_program(path)
        except PostprocError:
            continue  # refused by the parser (tests/test_real_corpus.py)
        known = ~np.isnan(tp.position).any(axis=1)
        rows = np.nonzero((tp.kind[1:] == Kind.LINEAR) & known[1:] & known[:-1] & (tp.spans[1:, 0:3, 0].max(axis=1) >= 0))[0] + 1
        if not len(rows):
            continue
        while len(rows):
            try:
                points = new_points(tp, kr160(), rows, np.full(len(rows), 2))
                sources, _ = dialects.of(tp).insert_points(tp, points)
                break
            except EmitError as exc:  # a block that cannot be copied is refused with its line: drop it, go on
                line = int(re.search(r", line (\d+):", str(exc)).group(1))
                refused.append(str(exc).split(": ", 1)[1])
                rows = rows[tp.line[rows] != line]
        if not len(rows):
            continue  # every segment of the file refused (e.g. loop bodies that run more than once)
        check_inserted(tp, dialects.of(tp).parse_sources(sources), tp, points, {})
        segments += len(rows)
    print(f"{segments} segments subdivided and read back, {len(refused)} refused")
    assert segments > 6000 and len(refused) < 0.02 * segments, (segments, refused[:5])


def test_krl_copies_get_their_own_status_and_turn():
    from postproc.programs.dialects.krl import KRL

    decl = "DECL E6POS XP1={X 1000,Y -300,Z 500,A 0,B 180,C 0,S 2,T 35,E1 0}"
    assert KRL.set_conf_text(decl, np.array([6, 27, np.nan, np.nan])) == decl.replace("S 2,T 35", "S 6,T 27")
    assert KRL.set_conf_text("LIN {X 1, Y 2, Z 3}", np.array([6, 27, np.nan, np.nan])) == "LIN {X 1, Y 2, Z 3}"
    q = np.array([[10.0, -60, 40, 0, 60, 0], [-10.0, -60, 100, 0, -60, 0]])
    conf = KRL.conf_of_joints(kr160(), q)
    status, turn = kin.kuka_status_turn(kr160(), q)
    np.testing.assert_array_equal(conf[:, :2], np.column_stack([status, turn]))


def test_a_block_in_a_loop_body_is_not_subdivided(tmp_path):
    """An O-word loop runs its body's G1 three times (one IR row per execution, sharing the
    text): a block inserted before it would run three times too, so subdividing is refused
    with the body's line."""
    prog = tmp_path / "loop.ngc"
    prog.write_text("G21 G90\nG0 X0 Y0 Z0\n#1=0\no100 while [#1 lt 3]\nG1 X100 Y0 Z0 F600\nG0 X0\n#1=[#1+1]\no100 endwhile\nM2\n")
    tp = parse_program(prog)
    body = np.nonzero(tp.line == 5)[0]
    assert len(body) == 3
    with pytest.raises(EmitError, match=r"loop\.ngc, line 5: the block runs more than once"):
        new_points(tp, kr160(), body[1:2], np.array([2]))


def test_singarea_wrist_refuses_max_deviation_and_notes_the_path(model, tmp_path):
    """RAPID technical reference, SingArea: under `SingArea \\Wrist` the controller may turn the
    wrist off the programmed orientation between targets, so no path between compensated
    targets can be promised (--max-deviation: exit 2, its line, nothing written); without it
    the reported distances are noted as assuming exact interpolation."""
    text = RAPID.replace("  PROC main()\n", "  PROC main()\n    ! SingArea \\Wrist; (a comment: not in force)\n    SingArea \\Wrist;\n")
    prog = tmp_path / "part.mod"
    prog.write_text(text)
    save_model(tmp_path / "m.json", model)
    out = tmp_path / "o.mod"
    res = runner.invoke(app, ["compensate", str(prog), "--model", str(tmp_path / "m.json"), "-o", str(out), "--max-deviation", "0.02",
                              "--allow-model-mismatch"])  # (the program cuts with tool0)
    assert res.exit_code == 2 and f"{prog}:7: SingArea \\Wrist" in res.output, res.output
    assert not out.exists()
    new, _ = compensate(parse_program(prog), model)
    assert any("SingArea \\Wrist" in n and "assume exact interpolation" in n for n in new.notes)
    prog.write_text(RAPID)
    new, _ = compensate(parse_program(prog), model)
    assert not any("SingArea" in n for n in new.notes)
