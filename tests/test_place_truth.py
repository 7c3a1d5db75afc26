"""Placement that tells the truth (issue 28): feasibility equal to a brute-force reference,
configuration data re-derived for a moved workpiece (or kept, on request), every infeasible
cell with its reason, the current placement evaluated as a grid cell, ``place -o`` writing
work object and configuration data that ``compensate`` reads back."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from placement_reference import reference_cell
from typer.testing import CliRunner

from postproc.cli import app
from postproc.process import placement as pl
from postproc.process import placement_branch as pb
from postproc.process.place_program import problem_from_program
from postproc.programs import dialects, parse_program
from postproc.robot.robots import load_robot

REPO = Path(__file__).resolve().parents[1]
FACE_MOD = REPO / "examples" / "data" / "block_face.mod"  # RAPID, confdata on every target, written at x 1300, y -500, theta 90
FACE_SRC = REPO / "examples" / "data" / "block_face.src"  # KRL, no Status/Turn
ROBOT = "irb6660_205_190"
FORCE = (200.0, 100.0, 300.0)
runner = CliRunner()


@pytest.fixture(scope="module")
def robot():
    return load_robot(ROBOT)


def _grid(xs, ys, ts):
    return np.stack(np.meshgrid(xs, ys, ts, indexing="ij"), -1).reshape(-1, 3)


@pytest.mark.parametrize("program, mode, grid", [
    (FACE_MOD, "rederive", (np.arange(500, 1301, 200.0), np.arange(-600, 601, 300.0), np.arange(0, 91, 30.0))),
    (FACE_SRC, "rederive", (np.arange(500, 1301, 200.0), np.arange(-600, 601, 300.0), np.arange(0, 91, 30.0))),
    (FACE_MOD, "keep", (np.array([700.0, 1000, 1300]), np.array([-500.0, 0, 300]), np.array([30.0, 90]))),
])
def test_feasibility_equals_the_brute_force_reference(robot, program, mode, grid):
    """Every cell's reason (0: feasible) and, where feasible, every joint equal the reference's."""
    problem = problem_from_program(parse_program(program), robot, force_tool=FORCE, conf_mode=mode)
    cand = _grid(*grid)
    frames = pl.placement_frames(cand, 1170.0)
    ev = pl.evaluate(problem, frames)
    reference = [reference_cell(problem, f) for f in frames]
    np.testing.assert_array_equal(ev.reason, [r for r, _ in reference])
    assert ev.feasible.any() and not ev.feasible.all()
    for k in np.nonzero(ev.feasible)[0][:10]:
        q, why = pl.placement_joints(problem, frames[k])
        assert (why == 0).all()
        np.testing.assert_allclose(q, reference[k][1], atol=1e-9)


def test_rederived_configuration_data_keep_most_of_the_workspace(robot):
    """The RAPID face pass: its confdata, written for x 1300, y -500, theta 90, hold at few
    other placements (axis 1 and 6 change quadrant as the workpiece moves); re-derived as a
    re-post would, the placements are those of the same pass without any configuration data."""
    grid = (np.arange(300, 1501, 100.0), np.arange(-600, 601, 100.0), np.arange(0, 91, 30.0))
    kept = pl.search(problem_from_program(parse_program(FACE_MOD), robot, force_tool=FORCE, conf_mode="keep"), *grid, 1170.0, refine=False)
    rederived = pl.search(problem_from_program(parse_program(FACE_MOD), robot, force_tool=FORCE), *grid, 1170.0, refine=False)
    free = pl.search(problem_from_program(parse_program(FACE_SRC), robot, force_tool=FORCE), *grid, 1170.0, refine=False)
    n_kept, n_rederived = int((kept.grid_reason == 0).sum()), int((rederived.grid_reason == 0).sum())
    assert 0 < n_kept < n_rederived / 5, (n_kept, n_rederived)
    assert n_rederived == int((free.grid_reason == 0).sum())
    assert set(pb.reason_counts(kept.grid_reason)) >= {"out of reach", "configuration data"}
    assert "configuration data" not in pb.reason_counts(rederived.grid_reason)
    assert {"joint 2 limit", "joint 3 limit"} <= set(pb.reason_counts(rederived.grid_reason))


def test_reasons_name_the_joint_the_coupling_and_the_singularity(robot):
    """A candidate infeasible for one cause only gets that cause."""
    problem = problem_from_program(parse_program(FACE_SRC), robot, force_tool=FORCE)
    flat = pl.placement_frames([[3000.0, 0.0, 0.0]], 1170.0)
    assert pl.evaluate(problem, flat).reason[0] == pb.REACH
    sols = np.zeros((1, 2, 8, 6))
    sols[0, :, :] = [0.0, 10.0, 10.0, 0.0, 60.0, 0.0]
    cases = {pb.LIMIT + 1: [0.0, 90.0, 10.0, 0.0, 60.0, 0.0], pb.COUPLING: [0.0, -30.0, -15.0, 0.0, 60.0, 0.0],
             pb.WRIST: [0.0, 10.0, 10.0, 0.0, 1.0, 0.0], pb.FLIP: [0.0, 10.0, 10.0, 60.0, 60.0, 0.0], pb.REACH: [np.nan] * 6}
    one, two = problem, slice(0, 2)
    small = replace(one, local_tcp=one.local_tcp[two], flange_T_tcp=one.flange_T_tcp[two], force_local=one.force_local[two],
                    normal_local=one.normal_local[two], weights=one.weights[two], conf=one.conf[two],
                    conf_applies=np.zeros(2, dtype=bool), line=one.line[two], arm=one.arm[two])
    for code, q in cases.items():
        s = sols.copy()
        s[0, 1, :] = q
        _, reason = pb.program_postures(small, s)
        assert reason[0, 1] == code, (code, reason)
    # joints move continuously: axis 6 (+-360 deg) through 180 deg is fine, axis 1 (+-180 deg) cannot pass it
    s = sols.copy()
    s[0, 0, :] = [170.0, 10.0, 10.0, 0.0, 60.0, 170.0]
    s[0, 1, :] = [170.0, 10.0, 10.0, 0.0, 60.0, -175.0]
    q, reason = pb.program_postures(small, s)
    assert reason[0, 1] == 0 and q[0, 1, 5] == pytest.approx(185.0)
    s[0, 1, :] = [-175.0, 10.0, 10.0, 0.0, 60.0, 170.0]
    q, reason = pb.program_postures(small, s)
    assert reason[0, 1] == pb.LIMIT and q[0, 1, 0] == pytest.approx(185.0)


def _place(program, *args):
    cmd = ["place", str(program), "--robot", ROBOT, "--force", ",".join(map(str, FORCE)), "--z", "1170", "--json", *map(str, args)]
    return runner.invoke(app, cmd)


def test_current_placement_is_the_grid_cell(tmp_path):
    """The program's own placement and the grid cell at its x, y, theta give the same number
    (before: 'infeasible' against the cell's value: the work object's rounded quaternion put
    axis 1 a hair under 0 deg at the target on the base's x axis, another quadrant)."""
    for extra in ([], ["--keep-conf"]):
        res = _place(FACE_MOD, "--search", "1200:1400:100,-600:-400:100,80:100:10", "--no-refine", *extra)
        assert res.exit_code == 0, res.stderr
        doc = json.loads(res.stdout)
        cur = doc["current"]
        assert cur["grid_cell"] and cur["feasible"], cur
        grid = _place(FACE_MOD, "--search", "1300:1300:0,-500:-500:0,90:90:0", "--no-refine", *extra)
        cell = json.loads(grid.stdout)["best"]
        assert cur["mean_normal_error_mm"] == cell["mean_normal_error_mm"]
        assert doc["configuration_data"] == ("kept" if extra else "rederived")


def test_place_prints_the_reasons(tmp_path):
    res = runner.invoke(app, ["place", str(FACE_MOD), "--robot", ROBOT, "--force", "200,100,300", "--z", "1170",
                              "--search", "700:1300:300,-500:500:250,0:90:45", "--no-refine", "--keep-conf"])
    assert res.exit_code == 0, res.stderr
    assert "infeasible grid cells by reason: out of reach" in res.stdout and "configuration data" in res.stdout
    assert "kept as the program writes them" in res.stdout
    doc = json.loads(_place(FACE_MOD, "--search", "700:1300:300,-500:500:250,0:90:45", "--no-refine", "--keep-conf").stdout)
    assert sum(doc["infeasible"].values()) + doc["feasible"] == doc["grid"] == 3 * 5 * 3
    far = _place(FACE_MOD, "--search", "3000:3100:100,0:0:0,0:0:0")
    assert far.exit_code == 1 and "out of reach 2" in far.stderr


def test_written_program_reads_back_at_the_placed_poses(tmp_path):
    """place -o: work object and re-derived confdata; parsed again, every target sits at the
    placed pose and its confdata are those of the joints the robot takes there; compensate
    reads the written program (exit 0) and predicts at those poses."""
    out, plot = tmp_path / "placed.mod", tmp_path / "map.png"
    res = _place(FACE_MOD, "--search", "500:900:100,-600:-300:100,60:90:15", "-o", out, "--plot", plot)
    assert res.exit_code == 0, res.stderr
    doc = json.loads(res.stdout)
    b = doc["best"]
    frame = pl.placement_frames([[b["x"], b["y"], b["theta"]]], 1170.0)[0]
    original, placed = parse_program(FACE_MOD), parse_program(out)
    np.testing.assert_allclose(placed.base_poses(), frame @ original.target_poses(), atol=1e-3)
    robot = load_robot(ROBOT)
    problem = problem_from_program(placed, robot, force_tool=FORCE, conf_mode="keep")  # the written data, as written
    q, why = pl.placement_joints(problem, pl.placement_frames([[b["x"], b["y"], b["theta"]]], 1170.0)[0])
    assert (why == 0).all()
    assert doc["conf_written"] == len(original) and not np.array_equal(placed.conf, original.conf)
    np.testing.assert_array_equal(placed.conf, robot_conf := np.asarray(dialects.get("rapid").conf_of_joints(robot, q)))
    assert robot_conf.shape == (len(original), 4) and plot.stat().st_size > 20_000


def test_compensate_reads_the_placed_program(tmp_path):
    """The placed program (new work object, re-derived confdata) compensates with exit 0:
    every target reached on its written configuration, none changes branch."""
    from postproc.model.effects import parse_effects
    from postproc.model.errormodel import ErrorModel
    from postproc.model.model_io import save_model

    out = tmp_path / "placed.mod"
    # (off round numbers: a target with axis 1 at exactly 0 deg sits on a quadrant boundary,
    # and compensate refuses a correction that crosses it)
    assert _place(FACE_MOD, "--search", "510:910:200,-590:-390:200,60:90:30", "--no-refine", "-o", out).exit_code == 0
    base = ErrorModel.create(load_robot(ROBOT), [0, 0, 250], parse_effects("joint_compliance[payload=20]"))
    model = base.with_values({p.name: 2e-7 for p in base.params})
    save_model(tmp_path / "model.json", model)
    report = tmp_path / "r.json"
    res = runner.invoke(app, ["compensate", str(out), "--model", str(tmp_path / "model.json"), "-o", str(tmp_path / "comp.mod"), "--report", str(report)])
    assert res.exit_code == 0, res.stderr
    points = json.loads(report.read_text())["points"]
    assert len(points) == len(parse_program(FACE_MOD)) and all(p["compensated"] and not p["branch_changed"] for p in points)
    assert max(p["before_mm"] for p in points) > 0.01  # the model predicts an error there: the poses were read


def test_progress_lines_off_a_terminal(capsys):
    """Off a terminal the search says how far it is on stderr (a plain line every few seconds)."""
    from postproc.process import place_report
    from postproc.progress import ProgressLine

    problem = problem_from_program(parse_program(FACE_SRC), load_robot(ROBOT), force_tool=FORCE)
    with ProgressLine("place", terminal=False, every_s=0.0) as progress:
        pl.search(problem, [900.0, 1000], [-500.0], [90.0], 1170.0, refine=False, chunk_poses=len(problem.local_tcp),
                  progress=place_report.counted(progress))
    assert capsys.readouterr().err.splitlines()[-1].startswith("place: placements evaluated [2/2]")


@pytest.fixture(scope="module")
def face_st(tmp_path_factory):
    """block_face.src with Status and Turn on its first PTP (those of its joints as written)."""
    path = tmp_path_factory.mktemp("krl") / "face_st.src"
    path.write_text(FACE_SRC.read_text().replace("PTP {X 0, Y 50, Z 150, A 0, B 180, C 0}", "PTP {X 0, Y 50, Z 150, A 0, B 180, C 0, S 2, T 37}"))
    return path


@pytest.mark.parametrize("mode", ["rederive", "keep"])
def test_krl_status_turn_equal_the_reference(robot, face_st, mode):
    problem = problem_from_program(parse_program(face_st), robot, force_tool=FORCE, conf_mode=mode)
    assert problem.conf_applies[0] and not problem.conf_applies[1:].any() and problem.arm[0] == 2
    frames = pl.placement_frames(_grid([700.0, 1000, 1300], [-500.0, 0, 300], [0.0, 90]), 1170.0)
    ev = pl.evaluate(problem, frames)
    np.testing.assert_array_equal(ev.reason, [reference_cell(problem, f)[0] for f in frames])
    assert ev.feasible.any() and not ev.feasible.all()


def test_krl_placed_program_gets_the_new_status_and_turn(robot, face_st, tmp_path):
    """Moved to where axes 2 and 3 change sign, the PTP's Turn changes; the .src reads back with it."""
    out = tmp_path / "placed.src"
    res = _place(face_st, "--search", "1200:1200:0,-300:-300:0,90:90:0", "-o", out, "--no-refine")
    assert res.exit_code == 0, res.stderr
    placed = parse_program(out)
    frame = pl.placement_frames([[1200.0, -300.0, 90.0]], 1170.0)[0]
    q, why = pl.placement_joints(problem_from_program(placed, robot, force_tool=FORCE, conf_mode="keep"), frame)
    assert (why == 0).all()
    status, turn = dialects.get("krl").conf_of_joints(robot, q[:1])[0, :2]
    assert (status, turn) == (2, 35) and tuple(placed.conf[0, :2]) == (status, turn)  # A2 < 0 now, A3 >= 0: T 37 -> 35
    changed = [a for a, b in zip(out.read_text().splitlines(), face_st.read_text().splitlines()) if a != b]
    assert len(changed) == 2 and changed[0].startswith("$BASE") and changed[1].endswith("S 2, T 35}")
