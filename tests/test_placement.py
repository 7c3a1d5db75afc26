"""Force-induced error and workpiece placement (seed 002): compliance, search, CLI."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from postproc.cli import app
from postproc.process import compliance as comp
from postproc.process import placement as pl
from postproc.process import placement_branch as pb
from postproc.process.place_program import current_frame, problem_from_program
from postproc.programs import parse_program
from postproc.robot import kinematics as kin
from postproc.robot.posture import singularity_margins
from postproc.robot.robots import load_robot

REPO = Path(__file__).resolve().parents[1]
BLOCK_PASS = REPO / "examples" / "data" / "block_pass.src"
BLOCK_FACE = REPO / "examples" / "data" / "block_face.src"
ROBOT = "irb6660_205_190"
FORCE = (200.0, 100.0, 300.0)  # N, tool frame


@pytest.fixture(scope="module")
def robot():
    return load_robot(ROBOT)


def test_compliance_is_the_small_force_deflection(robot):
    """C_tt F equals the TCP displacement of the joints deflected by Kq^-1 J^T F (finite difference)."""
    rng = np.random.default_rng(3)
    q = rng.uniform([-60, 0, 10, -90, 30, -90], [60, 50, 60, 90, 100, 90], size=(20, 6))
    tool = np.array([30.0, -20.0, 250.0])
    tcp = kin.fk(robot, q, tool=tool)
    flange = kin.fk(robot, q)
    jv = comp.tcp_linear_jacobian(robot, q, tcp[:, :3, 3] - flange[:, :3, 3])
    c = comp.joint_compliance(robot)
    c_tt = comp.translational_compliance(jv, c)
    force = rng.normal(size=(20, 3)) * 10.0  # N (small: the deflection must stay linear)
    jac = kin.jacobian(robot, q, tool=tool)
    dq = np.einsum("k,nik,ni->nk", c * 1e-3, jac[:, :3, :], force)  # rad: c [rad/(N mm)] x torque [N mm]
    moved = kin.fk(robot, q + np.degrees(dq), tool=tool)[:, :3, 3] - tcp[:, :3, 3]
    np.testing.assert_allclose(np.einsum("nij,nj->ni", c_tt, force), moved, rtol=1e-3, atol=1e-6)
    assert np.allclose(c_tt, np.swapaxes(c_tt, 1, 2))
    assert np.all(np.linalg.eigvalsh(c_tt) > -1e-15)
    # a robot arm is soft: 0.05 to 5 mm/kN at the tool along any axis
    assert 5e-5 < np.median(np.linalg.eigvalsh(c_tt)[:, -1]) < 5e-3


def test_weights_and_normal_error():
    pos = np.array([[0, 0, 50], [0, 0, 0], [10, 0, 0], [30, 0, 0], [30, 0, 50]], dtype=float)  # approach, cut, retract
    cutting = np.array([False, True, True, True, False])
    w = comp.step_weights(pos, cutting)
    np.testing.assert_allclose(w, [0, 5, 15, 10, 0])
    np.testing.assert_allclose(comp.weighted_mean(np.array([9, 1, 2, -4, 100.0]), w), (5 * 1 + 15 * 2 + 10 * 4) / 30)
    c = np.diag([1e-4, 2e-4, 3e-4])[None]
    assert np.isclose(comp.normal_error(c, np.array([[0, 0, 100.0]]), np.array([[0, 0, 1.0]]))[0], 0.03)
    assert np.isclose(comp.normal_compliance(c, np.array([[0, 0, 1.0]]))[0], 3e-4)
    # the factored form used by the search equals n . C_tt F with C_tt formed
    rng = np.random.default_rng(0)
    jv, cj = rng.normal(size=(5, 3, 6)) * 500, rng.uniform(1e-7, 1e-6, 6)
    force, normal = rng.normal(size=(5, 3)) * 100, rng.normal(size=(5, 3))
    c_tt = comp.translational_compliance(jv, cj)
    e, cn = comp.normal_error_and_compliance(jv, cj, force, normal)
    np.testing.assert_allclose(e, comp.normal_error(c_tt, force, normal), rtol=1e-12)
    np.testing.assert_allclose(cn, comp.normal_compliance(c_tt, normal), rtol=1e-12)


def test_identified_compliance_is_used(robot):
    from postproc.model.effects import parse_effects
    from postproc.model.errormodel import ErrorModel

    for spec in ("joint_compliance", "geometric,external_load"):
        base = ErrorModel.create(robot, [0, 0, 200], parse_effects(spec))
        names = [p.name for p in base.params if p.name.endswith(tuple(f".c{i}" for i in range(1, 7)))]
        fitted = base.with_values({n: 1e-6 * (i + 1) for i, n in enumerate(names)})
        np.testing.assert_allclose(comp.joint_compliance(robot, fitted), 1e-6 * np.arange(1, 7))
    assert comp.identified_compliance(ErrorModel.create(robot, [0, 0, 200], parse_effects("geometric"))) is None
    np.testing.assert_allclose(comp.joint_compliance(robot), 1 / robot.stiffness_nm_per_rad)


@pytest.fixture(scope="module")
def block_pass(robot):
    tp = parse_program(BLOCK_PASS)
    return tp, problem_from_program(tp, robot, force_tool=FORCE)


def test_search_equals_brute_force_and_halves_the_error(block_pass):
    tp, problem = block_pass
    xs, ys, ts = np.arange(300, 1801, 150.0), np.arange(-800, 801, 200.0), np.arange(0, 91, 15.0)
    res = pl.search(problem, xs, ys, ts, 1170.0, refine=True)
    # brute force: every grid candidate on its own, one at a time
    best, where = np.inf, None
    for x in xs:
        for y in ys:
            for t in ts:
                err, _, ok = pl.path_errors(problem, pl.placement_frames([[x, y, t]], 1170.0)[0])
                if ok:
                    value = comp.weighted_mean(err, problem.weights)
                    if value < best:
                        best, where = value, (x, y, t)
    assert np.isclose(res.grid_best_mm, best, rtol=1e-12)
    np.testing.assert_allclose(res.grid_best, where)
    assert res.best_mm <= res.grid_best_mm  # refinement never loses
    assert np.all(np.abs(res.best - res.grid_best) <= [150, 200, 15] + np.array([1e-9] * 3))
    # the program's own placement (seed Table 3 pattern, group 1: x 1400, y 200, theta 90)
    current = pl.evaluate(problem, current_frame(tp)[None]).mean_mm[0]
    assert np.isfinite(current)
    assert res.best_mm <= 0.5 * current, f"reduction only {100 * (1 - res.best_mm / current):.1f} %"


def test_chunking_does_not_change_results(block_pass):
    _, problem = block_pass
    cand = np.stack(np.meshgrid([800.0, 1000, 1400], [-400.0, 0, 300], [0.0, 45, 90], indexing="ij"), -1).reshape(-1, 3)
    frames = pl.placement_frames(cand, 1170.0)
    a = pl.evaluate(problem, frames, chunk_poses=7)
    b = pl.evaluate(problem, frames)
    np.testing.assert_array_equal(a.feasible, b.feasible)
    np.testing.assert_allclose(a.mean_mm, b.mean_mm, rtol=1e-12)
    assert a.feasible.any() and not a.feasible.all()


def test_infeasible_far_away_and_near_singularity(block_pass, robot):
    _, problem = block_pass
    far = pl.evaluate(problem, pl.placement_frames([[3000.0, 0.0, 0.0]], 1170.0))
    assert not far.feasible[0] and np.isnan(far.mean_mm[0]) and far.reason[0] == pb.REACH
    q = np.array([[0.0, 30.0, 20.0, 0.0, 0.5, 0.0]])
    wrist, elbow, shoulder = singularity_margins(robot, q)
    assert wrist[0] < 1.0 and elbow[0] > 5.0 and shoulder[0] > 50.0


def test_rapid_confdata_rules_the_branch(robot, tmp_path):
    """A RAPID program keeps its confdata: candidates where it cannot hold are infeasible."""
    frame = pl.placement_frames([[1200.0, 0.0, 0.0]], 1170.0)[0]
    local = np.array([[x, 50.0, 100.0] for x in range(0, 41, 10)])
    rot = np.diag([1.0, -1.0, -1.0])
    tool = np.eye(4)
    tool[2, 3] = 250.0
    poses = np.repeat(np.eye(4)[None], len(local), axis=0)
    poses[:, :3, :3], poses[:, :3, 3] = rot, local
    flange = frame @ poses @ np.linalg.inv(tool)
    q, _ = kin.select_nearest(robot, kin.ik(robot, flange), np.zeros(6))
    conf = kin.abb_confdata(robot, q)
    lines = ["MODULE Block", "  PERS tooldata spindle := [TRUE,[[0,0,250],[1,0,0,0]],[20,[0,0,100],[1,0,0,0],0,0,0]];",
             '  TASK PERS wobjdata block := [FALSE,TRUE,"",[[1200,0,1170],[1,0,0,0]],[[0,0,0],[1,0,0,0]]];', "  PROC main()"]
    for p, c in zip(local, conf):
        lines.append(f"    MoveL [[{p[0]:g},{p[1]:g},{p[2]:g}],[0,1,0,0],[{c[0]},{c[1]},{c[2]},{c[3]}],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, spindle\\WObj:=block;")
    lines += ["  ENDPROC", "ENDMODULE", ""]
    program = tmp_path / "block.mod"
    program.write_text("\n".join(lines))
    tp = parse_program(program)
    frames = pl.placement_frames([[1200.0, 0.0, 0.0], [1200.0, 0.0, 180.0], [1200, 0, 100.0]], 1170.0)
    kept = pl.evaluate(problem_from_program(tp, robot, force_tool=FORCE, conf_mode="keep"), frames)
    assert kept.feasible[0]
    assert not kept.feasible[2] and kept.reason[2] == pb.CONF  # axes 1 and 6 would leave the programmed quadrants
    rederived = pl.evaluate(problem_from_program(tp, robot, force_tool=FORCE), frames)
    assert rederived.feasible[0] and rederived.feasible[2]  # a re-post writes the quadrants the joints are in
    out = tmp_path / "placed.mod"
    proc = _cli(program, "--search", "1100:1300:100,-100:100:100,0:0:0", "-o", out, "--keep-conf", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    doc = json.loads(proc.stdout)
    best = doc["best"]
    placed = parse_program(out)
    np.testing.assert_allclose(current_frame(placed)[:3, 3], [best["x"], best["y"], 1170.0], atol=1e-3)
    assert out.read_text().count("\n") == program.read_text().count("\n")
    changed = [a for a, b in zip(out.read_text().splitlines(), program.read_text().splitlines()) if a != b]
    assert len(changed) == 1 and "wobjdata block" in changed[0]


runner = CliRunner()


def _cli(program, *args, cwd=None):
    cmd = ["place", str(program), "--robot", ROBOT, "--force", ",".join(map(str, FORCE)), "--z", "1170", "--json", *map(str, args)]
    result = runner.invoke(app, cmd)
    result.returncode = result.exit_code
    return result


def test_cli_place_block(tmp_path):
    out, plot = tmp_path / "placed.src", tmp_path / "map.png"
    proc = _cli(BLOCK_PASS, "--search", "300:1800:150,-800:800:200,0:90:15", "-o", out, "--plot", plot)
    assert proc.returncode == 0, proc.stderr
    doc = json.loads(proc.stdout)
    assert set(doc["best"]) >= {"x", "y", "theta", "mean_normal_error_mm"} and isinstance(doc["evaluated"], int)
    assert doc["evaluated"] >= 11 * 9 * 7
    assert doc["reduction_percent"] >= 50.0
    assert doc["best"]["mean_normal_error_mm"] <= doc["grid_best"]["mean_normal_error_mm"]
    placed = parse_program(out)
    b = doc["best"]
    frame = current_frame(placed)
    np.testing.assert_allclose(frame[:3, 3], [b["x"], b["y"], 1170.0], atol=1e-3)
    np.testing.assert_allclose(np.degrees(np.arctan2(frame[1, 0], frame[0, 0])), b["theta"], atol=1e-3)
    assert plot.stat().st_size > 20_000 and (tmp_path / "map_path.png").stat().st_size > 10_000


def test_cli_bad_input_and_no_feasible_placement(tmp_path):
    out = tmp_path / "never.src"
    bad = _cli(BLOCK_PASS, "--search", "0:100,0:1:1,0:0:0")
    assert bad.returncode == 2 and "--search" in bad.stderr
    broken = tmp_path / "broken.src"
    broken.write_text(BLOCK_PASS.read_text().replace("LIN {X 20, Y 50", "LIN {X 20,, Y 50"))
    proc = _cli(broken, "--search", "1000:1100:100,0:0:0,0:0:0", "-o", out)
    assert proc.returncode == 2 and "broken.src" in proc.stderr and ":10" in proc.stderr
    far = _cli(BLOCK_PASS, "--search", "3000:3100:100,0:0:0,0:0:0", "-o", out)
    assert far.returncode == 1 and "no feasible placement" in far.stderr
    assert not out.exists()
    both = runner.invoke(app, ["place", str(BLOCK_PASS), "--robot", ROBOT, "--search", "0:0:0,0:0:0,0:0:0", "--z", "0"])
    assert both.exit_code == 2 and "--force" in both.stderr


def test_cli_place_with_cut_model_and_stock(tmp_path):
    from postproc.process.engagement import block_stock

    stl = tmp_path / "block.stl"
    block_stock().export(stl)
    program = tmp_path / "pass97.src"
    program.write_text(BLOCK_PASS.read_text().replace("Z 100,", "Z 97,"))
    cut = REPO / "examples" / "cut_aluminium.toml"
    base = ["place", str(program), "--robot", ROBOT, "--z", "1170", "--json", "--search", "1000:1400:200,0:400:200,0:90:45"]
    with_stock = runner.invoke(app, base + ["--cut", str(cut), "--stock", str(stl)])
    stated = runner.invoke(app, base + ["--cut", str(cut)])
    assert with_stock.exit_code == 0 and stated.exit_code == 0, with_stock.stderr + stated.stderr
    a, b = json.loads(with_stock.stdout), json.loads(stated.stdout)
    assert "engagement from" in a["force"] and a["best"]["mean_normal_error_mm"] > 0
    # the stock gives a 3 mm slot (full immersion), the file a 3 mm x 12 mm cut: different forces
    assert a["best"]["mean_normal_error_mm"] != pytest.approx(b["best"]["mean_normal_error_mm"], rel=1e-3)
    no_cut = runner.invoke(app, base + ["--force", "1,2,3", "--stock", str(stl)])
    assert no_cut.exit_code == 2 and "--stock needs --cut" in no_cut.stderr


def test_path_errors_equal_a_hand_computation(block_pass, robot):
    """One turned candidate, computed point by point with the robot's own Jacobian at the TCP."""
    tp, problem = block_pass
    frame = pl.placement_frames([[1000.0, 100.0, 30.0]], 1170.0)[0]
    err, cn, ok = pl.path_errors(problem, frame)
    assert ok
    tool = tp.tools[tp.tool[1]]
    for j in range(len(problem.local_tcp)):
        tcp = frame @ problem.local_tcp[j]
        q, _ = kin.select_nearest(robot, kin.ik(robot, (tcp @ np.linalg.inv(tool))[None]), np.zeros(6))
        jv = kin.jacobian(robot, q, tool=tool[:3, 3])[0, :3]
        c_tt = jv @ np.diag(1e-3 / robot.stiffness_nm_per_rad) @ jv.T
        force = tcp[:3, :3] @ np.array(FORCE) * (j > 0)  # the PTP approach (row 0) does not cut
        normal = -tcp[:3, 2]
        assert err[j] == pytest.approx(normal @ c_tt @ force, rel=1e-9, abs=1e-15)
        assert cn[j] == pytest.approx(normal @ c_tt @ normal, rel=1e-9)


@pytest.mark.parametrize("robot_name", [ROBOT, "kr160_r1570"])
def test_configuration_selection_finds_every_posture_of_the_data(robot_name):
    """Selecting by the confdata / Status-Turn of joints q finds, for every q inside the
    limits, a solution with exactly those data (the earlier turn search missed about a
    quarter of the KR160's, whose A1, A4 and A6 all span more than a turn); data no
    solution has give none."""
    robot = load_robot(robot_name)
    rng = np.random.default_rng(7)
    q = rng.uniform(robot.lower_deg, robot.upper_deg, size=(600, 6))
    q = q[kin.within_limits(robot, q)][:400]  # (the IRB6660's coupled J2/J3 limit too)
    sols = kin.ik(robot, kin.fk(robot, q))
    conf = kin.abb_confdata(robot, q)
    chosen, idx = kin.select_by_abb_conf(robot, sols, conf)
    assert (idx >= 0).all()
    assert (kin.abb_confdata(robot, chosen) == conf).all() and kin.within_limits(robot, chosen).all()
    status, turn = kin.kuka_status_turn(robot, q)
    chosen, idx = kin.select_by_kuka_status(robot, sols, status, turn)
    assert (idx >= 0).all()
    st, tu = kin.kuka_status_turn(robot, chosen)
    assert (st == status).all() and (tu == turn).all()
    impossible = conf.copy()
    impossible[:, 0] = 7  # axis 1 in the quadrant 630..720 deg: beyond every robot's range
    assert (kin.select_by_abb_conf(robot, sols, impossible)[1] == -1).all()


def test_program_with_two_frames_or_a_dat_file(tmp_path):
    two = tmp_path / "two.src"
    text = BLOCK_PASS.read_text()
    two.write_text(text.replace("LIN {X 30,", "$BASE = {X 0, Y 0, Z 0, A 0, B 0, C 0}\r\nLIN {X 30,"))
    proc = _cli(two, "--search", "1000:1100:100,0:0:0,0:0:0")
    assert proc.returncode == 2 and "several frames" in proc.stderr and "line 12" in proc.stderr
    src = tmp_path / "pass.src"
    src.write_text(text.replace("DEF block_pass( )", "DEF pass( )"))
    (tmp_path / "pass.dat").write_text("DEFDAT pass\r\nENDDAT\r\n")
    out = tmp_path / "out.src"
    proc = _cli(src, "--search", "600:1000:200,-400:0:200,0:90:45", "-o", out)
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "out.dat").read_text() == (tmp_path / "pass.dat").read_text()
    changed = [a for a, b in zip(out.read_text().splitlines(), src.read_text().splitlines()) if a != b]
    assert len(changed) == 1 and changed[0].startswith("$BASE")
