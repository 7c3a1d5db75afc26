"""convert --to fanuc: a KRL and a RAPID program written as a new TP listing, read back:
the same poses (user frames and tools given as the remarks of the new program say)."""

from __future__ import annotations

import numpy as np
from typer.testing import CliRunner

import postproc
from postproc.cli import app
from postproc.jobs.convert_conf import converted_conf
from postproc.programs import dialects, parse_program, write_program
from postproc.programs.ir import Kind

runner = CliRunner()

KRL = """DEF part( )
$BASE = {X 100, Y -20, Z 5, A 30, B 0, C 0}
$TOOL = {X 0, Y 0, Z 200, A 0, B 0, C 0}
PTP {X 900, Y 0, Z 300, A 0, B 180, C 0}
LIN {X 950, Y 100, Z 250, A 90, B 170, C 5} C_DIS
CIRC {X 1000, Y 150, Z 250, A 90, B 180, C 0}, {X 1050, Y 100, Z 250, A 90, B 180, C 0}
PTP {A1 10, A2 -80, A3 90, A4 0, A5 30, A6 0}
END
"""

RAPID = """MODULE Part
  PERS tooldata tSpindle := [TRUE,[[0,0,200],[1,0,0,0]],[10,[0,0,80],[1,0,0,0],0,0,0]];
  TASK PERS wobjdata wTable := [FALSE,TRUE,"",[[900,-100,300],[0.9659258,0,0,0.2588190]],[[0,0,0],[1,0,0,0]]];
  PROC main()
    MoveL [[10,20,150],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, z1, tSpindle\\WObj:=wTable;
    MoveL [[30,20,150],[0,0.7071068,0.7071068,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v250, fine, tSpindle\\WObj:=wTable;
  ENDPROC
ENDMODULE
"""


def _round_trip(tmp_path, name: str, text: str):
    """The program written --to fanuc, its CONFIG computed on the KR 160 from the joints the KRL
    controller takes (convert --robot: a J motion from another language needs it)."""
    src = tmp_path / name
    src.write_text(text)
    tp = parse_program(src)
    out = tmp_path / "out.ls"
    conf, _ = converted_conf(tp, dialects.get("fanuc"), postproc.load_robot("kr160_r1570"))
    out.write_text(write_program(tp, "fanuc", "out", conf=conf)[0])
    back = parse_program(out)
    given_frames = {f"UFRAME[{k + 1}]": tp.frames[i] for k, i in enumerate(sorted(set(tp.frame.tolist()) - {0}))}
    given_tools = {f"UTOOL[{k + 1}]": tp.tools[i] for k, i in enumerate(sorted(set(tp.tool.tolist()) - {0}))}
    return tp, back.with_frames(given_frames, given_tools), out.read_text()


def test_krl_to_fanuc_keeps_every_pose(tmp_path):
    tp, back, text = _round_trip(tmp_path, "part.src", KRL)
    assert back.kind.tolist() == tp.kind.tolist() == [Kind.JOINT, Kind.LINEAR, Kind.CIRC_VIA, Kind.CIRC_END, Kind.ABSJ]
    cart = tp.kind != Kind.ABSJ
    placed = tp.with_frames({"{X 100, Y -20, Z 5, A 30, B 0, C 0}": tp.frames[1]}) if not tp.placed()[cart].all() else tp
    np.testing.assert_allclose(back.base_poses()[cart], placed.base_poses()[cart], atol=2e-3)
    np.testing.assert_allclose(back.joints[~cart], tp.joints[~cart], atol=1e-9)  # J3 written as J3 - J2, read back as J3 + J2
    assert "J3=   170.000 deg" in text  # 90 - (-80): the controller's J3 is the forearm to the horizontal
    assert "set UFRAME 1" in text and "set UTOOL 1" in text and "is written where the input gives no" not in text


def test_rapid_to_fanuc_through_the_cli(tmp_path):
    src = tmp_path / "part.mod"
    src.write_text(RAPID)
    out = tmp_path / "part.ls"
    res = runner.invoke(app, ["convert", str(src), "--to", "fanuc", "-o", str(out)])
    assert res.exit_code == 0, res.output
    tp = parse_program(src)
    back = parse_program(out).with_frames({"UFRAME[1]": tp.frames[tp.frame[0]]}, {"UTOOL[1]": tp.tools[tp.tool[0]]})
    np.testing.assert_allclose(back.base_poses(), tp.base_poses(), atol=2e-3)
    np.testing.assert_allclose(back.speed, [100, 250])
    text = out.read_text()
    assert "L P[1] 100mm/sec CNT100" in text and "L P[2] 250mm/sec FINE" in text


def test_configuration_data_stay_within_one_language(tmp_path):
    """A Fanuc input's CONFIG is written back by --to fanuc; no other language's writer gets
    it (ABB's confdata [cf1, cf4, cf6, cfx] are other numbers: RAPID gets its placeholder
    with ConfJ\\Off / ConfL\\Off, as for any input without confdata)."""
    from pathlib import Path

    sample = Path(__file__).parent / "data" / "fanuc_sample.ls"
    text = sample.read_text(encoding="latin-1").replace("CONFIG : 'N U T, 0, 0, 0',\n\tX =   900", "CONFIG : 'F D T, 1, 0, -1',\n\tX =   900")
    src = tmp_path / "in.ls"
    src.write_text(text)
    tp = parse_program(src)
    placed = tp.take(tp.resolved)  # PR[1] and the Offset,PR[2] target cannot be written
    fanuc = write_program(placed, "fanuc", "again")[0]
    assert "CONFIG : 'F D T, 1, 0, -1'" in fanuc and "is written where" not in fanuc  # every CONFIG from the input
    rapid = write_program(placed, "rapid", "again")[0]
    assert "[0,0,0,0]" in rapid and "ConfJ\\Off;" in rapid and "[4,1,0,-1]" not in rapid and "[6,1,0,-1]" not in rapid
