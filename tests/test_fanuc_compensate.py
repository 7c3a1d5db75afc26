"""A Fanuc TP program compensated end to end on the M-20iA: a true robot, a model fitted
to its simulated measurements, the program compensated, then run on the true robot (the
controller's joints: the CONFIG of each J target, the posture carried along L targets)."""

from __future__ import annotations

import re

import numpy as np
import pytest
from helpers import FRAME_AND_COMPLIANCE, true_tcp, truth_and_fit

import postproc
from postproc.jobs.compensate import compensate
from postproc.model.sim import Cylinder
from postproc.programs import emit_texts, parse_program
from postproc.robot import kinematics as kin

UFRAME1 = np.eye(4)
UFRAME1[:3, 3] = [0.0, 0.0, -100.0]  # the table 100 mm below the J2 height
UTOOL1 = np.eye(4)
UTOOL1[:3, 3] = [0.0, 0.0, 200.0]  # helpers.TOOL: the tool the model was fitted with


def fanuc_program(path, n: int = 60):
    """A weld-like pass of L moves in user frame 1 with tool 1, a J move first."""
    mn = ["/PROG  PART", "/ATTR", "OWNER\t\t= MNEDITOR;", "COMMENT\t\t= \"\";", "DEFAULT_GROUP\t= 1,*,*,*,*;", "/MN",
          "   1:  UFRAME_NUM=1 ;", "   2:  UTOOL_NUM=1 ;"]
    pos = ["/POS"]
    for i in range(n):
        x, y, z = 850.0 + 10.0 * (i % 30), -250.0 + 500.0 * (i // 30), 350.0 + 0.1 * i
        motion = "J" if i == 0 else "L"
        speed = "50%" if i == 0 else "200mm/sec"
        mn.append(f"{i + 3:4d}:{motion} P[{i + 1}] {speed} {'FINE' if i == 0 else 'CNT50'}    ;")
        pos += [f"P[{i + 1}]{{", "   GP1:", "\tUF : 1, UT : 1,\t\tCONFIG : 'N U T, 0, 0, 0',",
                f"\tX = {x:9.3f}  mm,\tY = {y:9.3f}  mm,\tZ = {z:9.3f}  mm,",
                "\tW =  -180.000 deg,\tP =     0.000 deg,\tR =     0.000 deg", "};"]
    path.write_text("\r\n".join(mn + pos + ["/END", ""]))
    return path


@pytest.fixture(scope="module")
def m20ia():
    return postproc.load_robot("fanuc_m20ia")


@pytest.fixture(scope="module")
def truth_and_model(m20ia):
    return truth_and_fit(m20ia, FRAME_AND_COMPLIANCE, seed=29, region=Cylinder(z_mm=(100.0, 500.0)), cv_folds=0)


def run_on(truth, tp):
    """Where the true robot's TCP goes when the controller runs the program: each target's
    joints by the nominal IK, the CONFIG's solution ('N U T, 0, 0, 0')."""
    from postproc.programs.dialects.fanuc.controller import R30IB

    flange = tp.base_poses() @ np.linalg.inv(tp.tools[tp.tool])
    q, branch = R30IB.branch_from_conf(truth.robot, kin.ik(truth.robot, flange), tp.conf)
    assert (branch >= 0).all()
    return true_tcp(truth, tp, q)


def test_compensated_fanuc_program_lands_within_0_05_mm(tmp_path, truth_and_model):
    truth, model = truth_and_model
    path = fanuc_program(tmp_path / "part.ls")
    tp = parse_program(path)
    given = {"frames": {"UFRAME[1]": UFRAME1}, "tools": {"UTOOL[1]": UTOOL1}}
    new, report = compensate(tp, model, **given)
    assert not report.failed.any(), report.failures()
    old_placed = tp.with_frames(given["frames"], given["tools"])
    new_placed = new.with_frames(given["frames"], given["tools"])
    goal = old_placed.base_positions()
    before = np.linalg.norm(run_on(truth, old_placed) - goal, axis=1)
    after = np.linalg.norm(run_on(truth, new_placed) - goal, axis=1)
    print(f"true error rms before {np.sqrt(np.mean(before**2)):.3f} mm, after {np.sqrt(np.mean(after**2)):.4f} mm, max after {after.max():.4f} mm")
    assert np.sqrt(np.mean(before**2)) > 1.0
    assert np.sqrt(np.mean(after**2)) <= 0.05
    # Only numbers change, in the file's own notation; the new text reads back as compensated.
    text = emit_texts(tp, new)[0]
    number = re.compile(r"[+-]?(\d+\.?\d*|\.\d+)")
    assert number.sub("#", text) == number.sub("#", tp.sources[0].text)
    back = parse_program(path, "fanuc", text.encode("latin-1"))
    np.testing.assert_allclose(back.position, new.position, atol=6e-4)
