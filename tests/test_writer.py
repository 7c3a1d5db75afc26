"""New RAPID / KRL programs from another program's Toolpath (the event-protocol writer)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from postproc.cli import app
from postproc.errors import EmitError
from postproc.programs import parse_program, write_program
from postproc.programs.dialects.rapid.writer import RapidWriter
from postproc.programs.ir import Kind

CORPUS = Path(__file__).parent / "corpus"
runner = CliRunner()
G54 = np.array([[0.0, -1, 0, 800], [1, 0, 0, 100], [0, 0, 1, 300], [0, 0, 0, 1]])  # --frame G54=800,100,300,90,0,0
SOURCES = ["krl/circ_arcs.src", "krl/inline_milling.src", "rapid/milling_wobj.mod", "rapid/circles.mod", "rapid/absj_home.mod", "gcode/arcs_plane.ngc", "gcode/work_offsets.ngc"]


@pytest.mark.parametrize("source", SOURCES)
@pytest.mark.parametrize("dialect", ["rapid", "krl"])
def test_written_program_reaches_the_same_targets(source, dialect, tmp_path):
    tp = parse_program(CORPUS / source)
    if "G54" in tp.frame_names and not tp.frame_known[tp.frame_names.index("G54")]:
        tp = tp.with_frames({"G54": G54})  # a work offset the program leaves to the controller (convert refuses it otherwise)
    texts = write_program(tp, dialect, "conv")
    suffixes = [".mod"] if dialect == "rapid" else [".src", ".dat"]
    for text, suffix in zip(texts, suffixes):
        (tmp_path / f"conv{suffix}").write_bytes(text.encode("latin-1"))
    back = parse_program(tmp_path / f"conv{suffixes[0]}")
    # A G2/G3 becomes a circular move (auxiliary point + end, tests/test_convert_arcs.py): compare the ends.
    back = back.take(np.nonzero(back.kind != Kind.CIRC_VIA)[0]) if tp.dialect == "gcode" else back
    assert len(back) == len(tp)
    cart = ~np.isnan(tp.position).any(axis=1)
    np.testing.assert_allclose(back.base_positions()[cart], tp.base_positions()[cart], atol=1e-3)
    with_ori = cart & ~np.isnan(tp.orientation).any(axis=1)
    np.testing.assert_allclose(back.base_poses()[with_ori, :3, :3], tp.base_poses()[with_ori, :3, :3], atol=1e-6)
    joints = ~np.isnan(tp.joints).any(axis=1)
    np.testing.assert_allclose(back.joints[joints], tp.joints[joints], atol=1e-6)
    assert (back.kind[cart] == tp.kind[cart]).all() or tp.dialect == "gcode"


def test_event_protocol_directly():
    w = RapidWriter("demo")
    w.start("main")
    w.tool("spindle", np.array([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 200.0], [0, 0, 0, 1]]))
    w.speed(50.0)
    w.zone(0.5)
    pose = np.eye(4)
    pose[:3, 3] = [800, 0, 400]
    w.move_linear(pose)
    w.raw("done")
    text = w.end()[0]
    assert "MoveL [[800,0,400],[1,0,0,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v1000\\V:=50, z10\\Z:=0.5, spindle;" in text
    assert "PERS tooldata spindle := [TRUE,[[0,0,200]" in text and "! done" in text


def test_unknown_positions_are_refused_and_cli_writes_nothing(tmp_path):
    (tmp_path / "loop.src").write_text("DEF loop( )\nFOR I = 1 TO N\n  LIN PATH[I]\nENDFOR\nEND\n")
    with pytest.raises(EmitError, match="unknown"):
        write_program(parse_program(tmp_path / "loop.src"), "rapid")  # LIN PATH[I]: I counts to N, not known at post time
    tp = parse_program(CORPUS / "gcode" / "face_mill.nc")  # Z is unknown before the first Z word
    with pytest.raises(EmitError, match="unknown"):
        write_program(tp, "rapid")
    out = tmp_path / "x.mod"
    result = runner.invoke(app, ["convert", str(CORPUS / "gcode" / "face_mill.nc"), "--to", "rapid", "-o", str(out)])
    assert result.exit_code == 2 and not out.exists()
    result = runner.invoke(app, ["convert", str(CORPUS / "gcode" / "arcs_plane.ngc"), "--to", "krl", "-o", str(tmp_path / "a.src"), "--frame", "G54=0,0,0,0,0,0"])
    assert result.exit_code == 0 and (tmp_path / "a.dat").exists()


def test_output_folder_that_does_not_exist_is_bad_usage(tmp_path):
    out = tmp_path / "no_such_folder" / "a.src"
    result = runner.invoke(app, ["convert", str(CORPUS / "gcode" / "arcs_plane.ngc"), "--to", "krl", "-o", str(out), "--frame", "G54=0,0,0,0,0,0"])
    assert result.exit_code == 2 and "no_such_folder" in result.stderr and "cannot write" in result.stderr
    assert not out.parent.exists()
