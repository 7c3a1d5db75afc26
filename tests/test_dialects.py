"""Each dialect object: recognising its files, the files a program spans, its configuration rules."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from postproc.errors import InputError
from postproc.programs import dialects
from postproc.robot import kinematics as kin
from postproc.robot.robots import load_robot

CORPUS = Path(__file__).parent / "corpus"


def test_a_krl_data_list_on_its_own_is_sniffed_by_defdat(tmp_path):
    dat = tmp_path / "points.dat"  # .dat says nothing by itself: the content does
    dat.write_bytes((CORPUS / "krl" / "ptp_lin_basic.dat").read_bytes())
    assert dialects.sniff(dat).name == "krl"
    tp = dialects.sniff(dat).parse(dat)
    assert len(tp) == 0 and [d.role for d in tp.sources] == ["dat"]
    other = tmp_path / "notes.dat"
    other.write_bytes(b"just some numbers 1 2 3\n")
    with pytest.raises(InputError, match="cannot tell the dialect"):
        dialects.sniff(other)


def test_a_krl_program_spans_its_dat_and_the_robots_config_dat(tmp_path):
    for name in ("ptp_lin_basic.src", "ptp_lin_basic.dat"):
        (tmp_path / name).write_bytes((CORPUS / "krl" / name).read_bytes())
    (tmp_path / "$config.dat").write_bytes(b"DEFDAT $CONFIG\nDECL INT COUNT=3\nENDDAT\n")
    docs = dialects.get("krl").read_sources(tmp_path / "ptp_lin_basic.src")
    assert [(Path(d.path).name, d.role) for d in docs] == [("ptp_lin_basic.src", "src"), ("ptp_lin_basic.dat", "dat"), ("$config.dat", "config")]
    # Standard input has no folder: the program alone.
    assert [d.role for d in dialects.get("krl").read_sources("-", b"DEF p( )\nEND\n")] == ["src"]
    out = tmp_path / "o" / "new.src"
    tp = dialects.get("krl").parse(tmp_path / "ptp_lin_basic.src")
    assert dialects.of(tp).output_paths(tp, out) == [out, out.with_suffix(".dat"), out.parent / "$config.dat"]


def test_unknown_dialect_names_list_the_known_ones():
    with pytest.raises(InputError, match="--to: 'no-such' is not one of rapid, val3, urscript, krl, .*gcode"):  # every registered name, in sniffing order
        dialects.get("no-such", "--to")


@pytest.fixture(scope="module")
def kr160_solutions():
    robot = load_robot("kr160_r1570")
    q = np.array([[10.0, -80.0, 100.0, 30.0, 45.0, -20.0], [-25.0, -60.0, 80.0, -100.0, -30.0, 60.0]])
    from postproc.robot.kinematics import fk

    return robot, q, kin.ik(robot, fk(robot, q))


def _conf_as_written(name, robot, q):
    """The configuration data a program of this dialect would hold for joints q (IR conf columns)."""
    if name == "krl":
        status, turn = kin.kuka_status_turn(robot, q)
        return np.column_stack([status, turn, np.full(len(q), np.nan), np.full(len(q), np.nan)]).astype(float)
    return kin.abb_confdata(robot, q).astype(float)


@pytest.mark.parametrize("name", ["krl", "rapid"])
def test_configuration_data_pick_the_programs_branch(name, kr160_solutions):
    robot, q, sols = kr160_solutions
    got, branch = dialects.get(name).controller.branch_from_conf(robot, sols, _conf_as_written(name, robot, q))
    np.testing.assert_allclose(got, q, atol=1e-6)
    assert (branch >= 0).all()
    # Another branch's data give another posture: the data decide, not the nearest solution.
    flipped_q = sols[np.arange(2), (branch + 1) % 8]
    usable = ~np.isnan(flipped_q).any(axis=1)
    flipped, _ = dialects.get(name).controller.branch_from_conf(robot, sols[usable], _conf_as_written(name, robot, flipped_q[usable]))
    assert not np.allclose(flipped, q[usable], atol=1e-3)


def test_without_configuration_data_no_branch_is_chosen(kr160_solutions):
    robot, _, sols = kr160_solutions
    for name in dialects.names():
        q, branch = dialects.get(name).controller.branch_from_conf(robot, sols, np.full((2, 4), np.nan))
        assert np.isnan(q).all() and (branch == -1).all(), name


def test_a_rapid_program_file_names_its_missing_or_malformed_parts(tmp_path):
    pgf = tmp_path / "cell.pgf"
    pgf.write_text("<Program>\n  <Module>Main.mod</Module>\n</Program>\n")
    with pytest.raises(InputError, match=r"module Main.mod listed in the program file is not in"):
        dialects.sniff(pgf).parse(pgf)
    pgf.write_text("<Program>\n  <Module>Main.mod</Module>\n")
    with pytest.raises(InputError, match=r"cell.pgf:3:1: not a RAPID program file"):
        dialects.get("rapid").parse(pgf)



def test_each_language_names_the_controller_that_runs_it():
    from postproc.programs.controller import Controller

    makers = {name: dialects.get(name).controller.maker for name in ("rapid", "krl", "gcode")}
    assert makers == {"rapid": "ABB", "krl": "KUKA", "gcode": None}
    assert all(isinstance(dialects.get(name).controller, Controller) for name in dialects.names())
