"""Stäubli VAL3: reading an application (program, data, called programs), writing it back
byte for byte, the controller's configuration rules, compensation on a simulated true
TX2-90, and new programs from other languages.

No open VAL3 interpreter exists to judge the reading: the expected positions below were
worked out by hand from the VAL3 reference manual's rules ("trsf": Rx, Ry, Rz about the
moving axes x, y', z''; "frame" / "tool": each relative to the one its fatherId names, up to
world / flange; "appro": the trsf is in the point's own axes), as the comments show.
"""

from __future__ import annotations

import re
import shutil
from dataclasses import fields, replace
from pathlib import Path

import numpy as np
import pytest
from helpers import FRAME_AND_COMPLIANCE, truth_and_fit
from typer.testing import CliRunner

import postproc
from postproc.cli import app
from postproc.errors import InputError, ParseError, SharedNumberError
from postproc.jobs.compensate import compensate
from postproc.model.model_io import save_model
from postproc.model.sim import Cylinder
from postproc.programs import emit_texts, parse_program
from postproc.programs.dialects import sniff
from postproc.programs.dialects.val3 import VAL3
from postproc.programs.dialects.val3 import code as val3_code
from postproc.programs.dialects.val3 import data as val3_data
from postproc.programs.dialects.val3 import parse as val3_parse
from postproc.programs.dialects.val3.controller import config_of_joints
from postproc.programs.dialects.val3.rotation import matrix_to_rxyz, rxyz_to_matrix, rxyz_to_quat_wxyz
from postproc.programs.ir import Kind
from postproc.robot import kinematics as kin
from postproc.robot.frames import quat_wxyz_to_matrix

DEMO = Path(__file__).parent / "data" / "val3_demo"
runner = CliRunner()


def test_demo_positions_written_by_hand():
    tp = parse_program(DEMO / "start.pgx")
    assert tp.dialect == "val3" and [Path(s.path).name for s in tp.sources] == ["start.pgx", "demo.dtx", "cut.pgx", "demo.pjx"]
    assert tp.kind.tolist() == [Kind.ABSJ, Kind.JOINT, Kind.LINEAR, Kind.LINEAR, Kind.CIRC_VIA, Kind.CIRC_END]
    assert tp.line.tolist() == [6, 7, 8, 9, 5, 5] and tp.file.tolist() == [0, 0, 0, 0, 2, 2]  # cut.pgx is called on line 10
    # jHome: j2=-30 j3=120 j5=60, the attributes left out are 0
    np.testing.assert_array_equal(tp.joints[0], [0, -30, 120, 0, 60, 0])
    # pA[0] = (100, 0, 50) in fPart; fPart = (10, 20, 30) in fTable -> (110, 20, 80) in fTable;
    # fTable turns 90 degrees about z: (110, 20, 80) -> (-20, 110, 80), plus (500, 100, -200).
    # appro(pA[0], {0,0,-50,...}): -50 along pA[0]'s own z, which Rx(180) points down: z + 50.
    # pA[1] = (200, 0, 50) -> (480, 310, -120); pA[2] = (150, 50, 50) -> (-70, 160, 80) + ... = (430, 260, -120).
    expected = [[400, 0, 300], [480, 210, -120], [480, 210, -70], [480, 310, -120], [430, 260, -120]]
    np.testing.assert_allclose(tp.base_poses()[1:, :3, 3], expected, atol=1e-9)
    # tTip is 50 mm along tGrip's z, tGrip 150 mm along the flange's: 200 mm.
    np.testing.assert_allclose(tp.tools[tp.tool[2]][:3, 3], [0, 0, 200], atol=1e-12)
    # pB: Rx(30) Ry(20) Rz(10) by hand: R[0,2] = sin 20, R[1,2] = -sin 30 cos 20, R[0,1] = -cos 20 sin 10.
    r = tp.base_poses()[1, :3, :3]
    s, c = np.sin, np.cos
    d = np.deg2rad
    assert r[0, 2] == pytest.approx(s(d(20))) and r[1, 2] == pytest.approx(-s(d(30)) * c(d(20))) and r[0, 1] == pytest.approx(-c(d(20)) * s(d(10)))
    assert tp.speed.tolist() == [500, 500, 500, 500, 200, 200] and tp.zone.tolist() == [0, 0, 0, 0, 5, 5]
    assert tp.conf[1, :3].tolist() == [-1, 1, 1]  # lefty, epositive, wpositive
    assert tp.resolved.all()


def test_unchanged_emit_is_byte_identical():
    tp = parse_program(DEMO / "start.pgx")
    assert emit_texts(tp, tp) == [s.text for s in tp.sources]
    result = runner.invoke(app, ["roundtrip", str(DEMO / "start.pgx")])
    assert result.exit_code == 0 and "IDENTICAL" in result.output


def test_rotation_is_rx_ry_rz_about_moving_axes():
    rng = np.random.default_rng(3)
    angles = rng.uniform(-170, 170, (50, 3))
    angles[:, 1] = rng.uniform(-85, 85, 50)
    rot = rxyz_to_matrix(angles)
    a, b, c = np.deg2rad(angles).T
    one, zero = np.ones_like(a), np.zeros_like(a)
    rx = np.stack([np.stack([one, zero, zero], -1), np.stack([zero, np.cos(a), -np.sin(a)], -1), np.stack([zero, np.sin(a), np.cos(a)], -1)], -2)
    ry = np.stack([np.stack([np.cos(b), zero, np.sin(b)], -1), np.stack([zero, one, zero], -1), np.stack([-np.sin(b), zero, np.cos(b)], -1)], -2)
    rz = np.stack([np.stack([np.cos(c), -np.sin(c), zero], -1), np.stack([np.sin(c), np.cos(c), zero], -1), np.stack([zero, zero, one], -1)], -2)
    np.testing.assert_allclose(rot, rx @ ry @ rz, atol=1e-12)
    np.testing.assert_allclose(matrix_to_rxyz(rot), angles, atol=1e-9)
    # RoboDK's Pose_2_TxyzRxyz (its VAL3 post): ry = asin(R02), rx = atan2(-R12, R22), rz = atan2(-R01, R00)
    np.testing.assert_allclose(np.rad2deg(np.arcsin(rot[:, 0, 2])), angles[:, 1], atol=1e-9)
    np.testing.assert_allclose(np.rad2deg(np.arctan2(-rot[:, 1, 2], rot[:, 2, 2])), angles[:, 0], atol=1e-9)
    np.testing.assert_allclose(quat_wxyz_to_matrix(rxyz_to_quat_wxyz(angles)), rot, atol=1e-12)


def test_sniffing_by_content_and_extension(tmp_path):
    (tmp_path / "prog.txt").write_text((DEMO / "start.pgx").read_text())
    assert sniff(tmp_path / "prog.txt").name == "val3"
    assert sniff(DEMO / "start.pgx").name == "val3" and sniff(DEMO / "demo.pjx").name == "val3"
    assert sniff(tmp_path / "x.src", b"DEF x()\nPTP HOME\nEND\n").name == "krl"


def test_project_reads_its_start_program():
    tp = parse_program(DEMO / "demo.pjx")
    assert len(tp) == 6 and Path(tp.sources[0].path).name == "start.pgx"


def _app(tmp_path, code: str, points: str = "", extra: str = "") -> Path:
    """A one-program application in tmp_path with the demo's data plus ``points``."""
    shutil.copy(DEMO / "demo.dtx", tmp_path / "demo.dtx")
    data = (tmp_path / "demo.dtx").read_text().replace("  </Datas>", points + "  </Datas>")
    (tmp_path / "demo.dtx").write_text(data)
    head = '<?xml version="1.0" encoding="utf-8"?>\n<Programs xmlns="http://www.staubli.com/robotics/VAL3/Program/2">\n  <Program name="start">\n    <Code><![CDATA[begin\n'
    (tmp_path / "start.pgx").write_text(head + code + "end\n]]></Code>\n  </Program>\n</Programs>\n" + extra)
    return tmp_path / "start.pgx"


@pytest.mark.parametrize("code, line, column, words", [
    ("  for i = 0 to 2\n    movel(pA[0], tTip, mFast)\n  endFor\n", 6, 5, "inside 'for' (line 5)"),
    ("  pA[0].trsf.x = 3\n  movel(pA[0], tTip, mFast)\n", 5, 3, "assigned at run time"),
    ("  movel(pA[7], tTip, mFast)\n", 5, 9, "no such element"),
    ("  movel(pZ, tTip, mFast)\n", 5, 9, "no such variable"),
    ("  movel(pA[i], tTip, mFast)\n", 5, 9, "computed at run time"),
    ("  movel(appro(pA[0], trApp), tTip, mFast)\n", 5, 22, "appro's trsf is computed"),
    ("  call other()\n", 5, 8, "not in the application's folder"),
    ("  link(pA, fTable)\n", 5, 3, "link() is not modelled"),
    ("  movel(jHome, tTip, mFast)\n", 5, 9, "is a jointRx, not a pointRx"),
])
def test_what_the_text_does_not_determine_is_refused_with_its_place(tmp_path, code, line, column, words):
    path = _app(tmp_path, code)
    with pytest.raises(ParseError) as err:
        parse_program(path)
    assert (err.value.line, err.value.column) == (line, column) and words in str(err.value), str(err.value)
    assert err.value.path.endswith("start.pgx")


def test_movej_without_a_definite_config_is_unresolved_and_compensate_refuses(tmp_path, tx2_truth):
    point = '    <Data name="pFree" type="pointRx" size="1">\n      <Value key="0" x="500" z="100" rx="180" shoulder="sfree" elbow="epositive" wrist="wpositive" fatherId="world[0]" />\n    </Data>\n'
    path = _app(tmp_path, "  movej(pFree, tTip, mFast)\n  movel(pA[0], tTip, mFast)\n", point)
    tp = parse_program(path)
    assert tp.resolved.tolist() == [False, True] and "sfree" in tp.notes[0] and tp.notes[0].startswith(f"{path}:5:3: movej to pFree[0]")
    result = runner.invoke(app, ["inspect", str(path), "--json"])
    assert result.exit_code == 0 and '"resolved": false' in result.output
    with pytest.raises(InputError, match=r"start\.pgx:5:3: movej to pFree\[0\] with config \{sfree, epositive, wpositive\}"):
        compensate(tp, tx2_truth[2])


def test_config_words_from_joints_and_branch_selection():
    robot = postproc.load_robot("tx2_90")
    q = np.array([[0, 20, 100, 0, 60, 0], [0, 60, -30, 0, 60, 0], [0, 20, 100, 0, -60, 0], [170, -20, -100, 0, 60, 0]], float)
    words = config_of_joints(robot, q)
    # front, j3 > 0, j5 > 0: lefty epositive wpositive; then enegative; then wnegative; the last is behind axis 1: righty
    assert words.tolist() == [[-1, 1, 1], [-1, -1, 1], [-1, 1, -1], [1, -1, 1]]
    sols = kin.ik(robot, kin.fk(robot, q))
    conf = np.column_stack([words, np.full(4, np.nan)])
    got, branch = VAL3.controller.branch_from_conf(robot, sols, conf)
    assert (branch >= 0).all()
    np.testing.assert_allclose(got, q, atol=1e-6)


def _cell_program(tmp_path, robot) -> Path:
    """A pocket of 48 movel targets in a work frame, entered by a movej whose config the
    controller takes; tool 200 mm along the flange, blend off."""
    frame = '      <Value key="0" x="0" y="0" z="-250" rz="15" fatherId="world[0]" />\n'
    xs, ys = np.linspace(420, 640, 8), np.linspace(-150, 150, 6)
    pts = [(x, y, 0.2 * k) for k, (x, y) in enumerate((x, y) for x in xs for y in ys)]
    q_first = kin.select_nearest(robot, kin.ik(robot, _frame_pose() @ _target(pts[0]) @ np.linalg.inv(_tool())), [0, 20, 100, 0, 60, 0])[0]
    s, e, w = (["righty", "lefty"][int(v < 0)] if i == 0 else [["epositive", "enegative"], ["wpositive", "wnegative"]][i - 1][int(v < 0)] for i, v in enumerate(config_of_joints(robot, q_first)[0]))
    values = "".join(f'      <Value key="{i}" x="{x:.3f}" y="{y:.3f}" z="{z:.3f}" rx="180" ry="0" rz="180" shoulder="{s}" elbow="{e}" wrist="{w}" fatherId="fWork[0]" />\n' for i, (x, y, z) in enumerate(pts))
    dtx = ('<?xml version="1.0" encoding="utf-8"?>\n<Database xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance" xmlns="http://www.staubli.com/robotics/VAL3/Data/2">\n  <Datas>\n'
           f'    <Data name="fWork" access="public" xsi:type="array" type="frame" size="1">\n{frame}    </Data>\n'
           '    <Data name="tSpindle" access="public" xsi:type="array" type="tool" size="1">\n      <Value key="0" z="200" fatherId="flange[0]" />\n    </Data>\n'
           '    <Data name="mCut" access="public" xsi:type="array" type="mdesc" size="1">\n      <Value key="0" tmax="100" blend="off" />\n    </Data>\n'
           f'    <Data name="pCut" access="public" xsi:type="array" type="pointRx" size="{len(pts)}">\n{values}    </Data>\n  </Datas>\n</Database>\n')
    code = ["begin", "  movej(pCut[0], tSpindle, mCut)"] + [f"  movel(pCut[{i}], tSpindle, mCut)" for i in range(1, len(pts))] + ["  waitEndMove()", "end"]
    pgx = ('<?xml version="1.0" encoding="utf-8"?>\n<Programs xmlns="http://www.staubli.com/robotics/VAL3/Program/2">\n  <Program name="start" access="public">\n'
           "    <Code><![CDATA[" + "\r\n".join(code) + "\r\n]]></Code>\n  </Program>\n</Programs>\n")
    (tmp_path / "cell.dtx").write_text(dtx)
    (tmp_path / "start.pgx").write_bytes(pgx.encode())
    return tmp_path / "start.pgx"


def _frame_pose():
    t = np.eye(4)
    t[:3, :3] = rxyz_to_matrix(np.array([[0.0, 0.0, 15.0]]))[0]
    t[:3, 3] = [0, 0, -250]
    return t


def _tool():
    t = np.eye(4)
    t[2, 3] = 200
    return t


def _target(p):
    t = np.eye(4)
    t[:3, :3] = rxyz_to_matrix(np.array([[180.0, 0.0, 180.0]]))[0]
    t[:3, 3] = p
    return t


@pytest.fixture(scope="module")
def tx2_truth():
    robot = postproc.load_robot("tx2_90")
    region = Cylinder(theta1_deg=(-40.0, 40.0), radius_mm=(380.0, 760.0), z_mm=(-300.0, 100.0))
    return robot, *truth_and_fit(robot, FRAME_AND_COMPLIANCE, seed=21, region=region, cv_folds=0)


def _run_on(truth, tp, q_ref):
    """Where the true robot's TCP goes (controller: nominal IK, the branch of q_ref)."""
    flange = tp.base_poses() @ np.linalg.inv(tp.tools[tp.tool])
    q, _ = kin.select_nearest(truth.robot, kin.ik(truth.robot, flange), q_ref)
    m = replace(truth, tool_mm=tp.tools[tp.tool[0]][:3, 3])
    return m.predict_prepared(m.prepare(q_deg=q))


def test_compensated_cell_lands_on_the_simulated_true_robot(tmp_path, tx2_truth):
    robot, truth, model = tx2_truth
    path = _cell_program(tmp_path, robot)
    tp = parse_program(path)
    assert VAL3.controller.conf_applies(tp).tolist() == [True] + [False] * (len(tp) - 1)
    new, report = compensate(tp, model)
    assert not report.failed.any(), report.failures()
    goal = tp.base_positions()
    q_ref = np.array([0, 20, 100, 0, 60, 0.0])
    before = np.linalg.norm(_run_on(truth, tp, q_ref) - goal, axis=1)
    after = np.linalg.norm(_run_on(truth, new, q_ref) - goal, axis=1)
    assert np.sqrt(np.mean(before**2)) > 0.5  # millimetres as written
    assert after.max() <= 0.05, after.max()  # the model's accuracy after
    texts = emit_texts(tp, new)
    assert texts[0] == tp.sources[0].text  # only the data file's numbers change
    number = re.compile(r"[+-]?(\d+\.?\d*|\.\d+)")
    assert number.sub("#", texts[1]) == number.sub("#", tp.sources[1].text)
    out = tmp_path / "out"
    out.mkdir()
    for text, doc in zip(texts, tp.sources):
        (out / Path(doc.path).name).write_bytes(text.encode("latin-1"))
    back = parse_program(out / "start.pgx")
    np.testing.assert_allclose(back.position, new.position, atol=6e-4)


def test_cli_compensate_writes_program_and_data_together(tmp_path, tx2_truth):
    robot, _, model = tx2_truth
    path = _cell_program(tmp_path, robot)
    save_model(tmp_path / "model.json", model)
    out = tmp_path / "out"
    out.mkdir()
    result = runner.invoke(app, ["compensate", str(path), "--model", str(tmp_path / "model.json"), "-o", str(out / "start.pgx")])
    assert result.exit_code == 0, result.output
    assert sorted(p.name for p in out.iterdir()) == ["cell.dtx", "start.pgx"]
    assert (out / "start.pgx").read_bytes() == path.read_bytes() and (out / "cell.dtx").read_text() != (tmp_path / "cell.dtx").read_text()


def test_convert_krl_to_val3_and_back_gives_the_same_poses(tmp_path):
    src = tmp_path / "part.src"
    src.write_text("DEF part( )\r\n$BASE = {X 800, Y -100, Z 300, A 30, B 0, C 0}\r\n$TOOL = {X 0, Y 0, Z 180, A 0, B 0, C 0}\r\n$VEL.CP = 0.2\r\n"
                   "PTP {X 10, Y 20, Z 30, A 0, B 180, C 0}\r\nLIN {X 110, Y 20, Z 30, A 10, B 170, C 5} C_DIS\r\n"
                   "CIRC {X 160, Y 70, Z 30, A 0, B 180, C 0}, {X 110, Y 120, Z 30, A 0, B 180, C 0}\r\nPTP {A1 0, A2 -90, A3 90, A4 0, A5 45, A6 0}\r\nEND\r\n")
    (tmp_path / "part.dat").write_text("DEFDAT part\r\nENDDAT\r\n")
    original = parse_program(src)
    out = tmp_path / "app" / "part.pgx"
    out.parent.mkdir()
    result = runner.invoke(app, ["convert", str(src), "--to", "val3", "-o", str(out)])
    assert result.exit_code == 0, result.output
    assert sorted(p.name for p in out.parent.iterdir()) == ["part.dtx", "part.pgx", "part.pjx"]
    back = parse_program(out)
    assert back.kind.tolist() == original.kind.tolist() and back.resolved.all()  # ssame esame wsame: the posture it is in
    assert not VAL3.controller.conf_applies(back).any()
    cart = original.kind != Kind.ABSJ
    np.testing.assert_allclose(back.base_poses()[cart], original.base_poses()[cart], atol=1e-5)
    np.testing.assert_allclose(back.tools[back.tool[cart]], original.tools[original.tool[cart]], atol=1e-6)
    np.testing.assert_allclose(back.joints[~cart], original.joints[~cart], atol=1e-9)
    assert back.speed[cart].tolist() == pytest.approx([200.0] * int(cart.sum()))
    assert emit_texts(back, back) == [s.text for s in back.sources]


def test_a_data_file_must_be_found(tmp_path):
    (tmp_path / "start.pgx").write_text((DEMO / "start.pgx").read_text())
    with pytest.raises(InputError, match="data file"):
        parse_program(tmp_path / "start.pgx")


def test_a_field_the_data_leaves_out_is_written_when_it_changes(tmp_path):
    """pNoZ writes no y and no z (they are 0): moved, it gets the attributes it lacked."""
    point = '    <Data name="pNoZ" type="pointRx" size="1">\n      <Value key="0" x="500" rx="180" fatherId="world[0]" />\n    </Data>\n'
    path = _app(tmp_path, "  movel(pNoZ, tTip, mFast)\n", point)
    tp = parse_program(path)
    assert tp.position[0].tolist() == [500, 0, 0] and np.isnan(tp.values[0, 1:3]).all()
    moved = tp.with_positions(tp.position + [[0.25, -1.5, 2.0]])
    texts = emit_texts(tp, moved)
    assert '<Value y="-1.500" z="2.000" key="0" x="500.25" rx="180" fatherId="world[0]" />' in texts[1]
    (tmp_path / "demo.dtx").write_text(texts[1])
    np.testing.assert_allclose(parse_program(path).position, moved.position, atol=1e-9)


def test_a_point_shared_by_two_motions_that_would_need_two_values_is_refused(tmp_path):
    tp = parse_program(DEMO / "start.pgx")  # pA[0]: movel to it, then movel to appro(pA[0], ...)
    position = tp.position.copy()
    position[2, 0] += 0.5  # the first use moves, the second does not
    with pytest.raises(SharedNumberError, match="demo.dtx"):
        emit_texts(tp, tp.with_positions(position))


def _mixed_program(tmp_path, n: int = 1500) -> Path:
    """A long application whose plain motion lines (the bulk reading) are mixed with lines the
    statement-by-statement reading takes: comments, appro(), movec, a call, a point declared
    without a <Value>, movej to points whose config leaves the posture free (notes)."""
    words = ['shoulder="lefty" elbow="epositive" wrist="wpositive"', 'shoulder="sfree" elbow="epositive" wrist="wpositive"', "", 'shoulder="ssame" elbow="esame" wrist="wsame"']
    values = "".join(f'      <Value key="{i}" x="{100 + i * 0.5:.3f}" y="{(i % 17) - 8}" z="{50 + i % 5}" rx="180" ry="{i % 3}" rz="{i % 11}" {words[i % 4]} fatherId="{("world[0]", "fPart[0]", "fTable[0]")[i % 3]}" />\n' for i in range(n))
    points = f'    <Data name="pRun" access="public" xsi:type="array" type="pointRx" size="{n + 3}">\n{values}    </Data>\n'
    shapes = ["  movel(pRun[{i}], tTip, mFast)\n", "  movej(pRun[{i}], tGrip, mBlend)\n", "  movel( pRun[ {i} ] ,tTip,mBlend )  \n", "  movel(pRun[{i}], tTip, mFast) // a comment\n",
              "  movel(appro(pRun[{i}], {{0, 0, -10, 0, 0, 0}}), tTip, mFast)\n", "  movec(pRun[{i}], pRun[{j}], tTip, mBlend)\n", "  movej(jHome, flange, mFast)\n", "\n  // {i}\n",
              "  waitEndMove()\n", "  movel(pRun[{n}], tTip, mFast)\n", "  call cut()\n", "  movej(pB, tGrip, mFast)\r\n"]
    rng = np.random.default_rng(29)
    pick = rng.choice(len(shapes), 2 * n, p=np.array([40, 20, 5, 2, 2, 2, 2, 2, 2, 1, 1, 1]) / 80)
    code = "".join(shapes[k].format(i=int(i), j=int(i + 1) % n, n=n + int(i) % 3) for k, i in zip(pick, rng.integers(0, n, 2 * n)))
    shutil.copy(DEMO / "cut.pgx", tmp_path / "cut.pgx")
    return _app(tmp_path, code, points)


def test_the_bulk_reading_of_plain_lines_equals_the_statement_by_statement_reading(tmp_path, monkeypatch):
    path = _mixed_program(tmp_path)
    bulk_rows = []
    monkeypatch.setattr(val3_parse._Assembler, "_fast_rows", _spy(val3_parse._Assembler._fast_rows, bulk_rows))
    fast = parse_program(path)
    assert sum(len(call[5]) for call in bulk_rows) > 0.8 * len(fast)  # the bulk path read most rows
    monkeypatch.setattr(val3_code.CodeReader, "bulk", False)
    monkeypatch.setattr(val3_data, "_read_tags_fast", lambda *args: None)
    slow = parse_program(path)
    assert len(fast) == len(slow) > 2500 and fast.notes == slow.notes and len(fast.notes) > 100
    for f in fields(fast):
        a, b = getattr(fast, f.name), getattr(slow, f.name)
        if isinstance(a, np.ndarray):
            np.testing.assert_array_equal(a, b, err_msg=f.name)  # NaN == NaN here; spans included
        else:
            assert a == b, f.name
    assert emit_texts(fast, fast) == [s.text for s in fast.sources]


def _spy(method, calls: list):
    def spied(self, *args):
        calls.append(args)
        return method(self, *args)
    return spied
