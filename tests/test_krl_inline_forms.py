"""KRL inline forms (issue 12 A): the frames BAS(#PTP_PARAMS / #CP_PARAMS / #FRAMES) take from FDAT_ACT.

Rule (KUKA BAS.SRC, KRC/R1/System/BAS.SRC of KSS 8, the controller's own KRL source; a copy is
public in github.com/EdgarMontielG/Cell-3_R10): ``CASE #PTP_PARAMS: PTP_DAT(); FRAMES();
VEL_PTP(REAL_PAR)``, ``CASE #CP_PARAMS: CP_DAT(); FRAMES(); VEL_CP(REAL_PAR)``. ``FRAMES()``:
``TOOL(FDAT_ACT.TOOL_NO)`` -> ``$TOOL = TOOL_DATA[n]`` ($NULLFRAME for n <= 0);
``BASE(FDAT_ACT.BASE_NO)`` -> ``$BASE = BASE_DATA[n]`` ($WORLD for n <= 0) when the base is on
no mechanism (``MACHINE_FRAME_DAT[n].MACH_DEF_INDEX`` 0, or the robot itself); the
corrections TOOL_CORR_ON, BASE_CORR_ON, ... are FALSE after ``INITMOV()`` (BAS(#INITMOV, 0)).
A Cartesian target is $BASE : point in the robot base frame (KSS 8 manual, "BASE").
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from postproc.errors import InputError
from postproc.jobs.compensate import _refuse_unplaced
from postproc.programs import parse_program

INI = "BAS (#INITMOV,0 )\n"


def fold(move: str, point: str, fdat: str, params: str) -> str:
    """One inline form as the KUKA smartPAD writes it."""
    dat = ("PDAT_ACT=PPDAT1", "BAS(#PTP_PARAMS,100)") if move == "PTP" else ("LDAT_ACT=LCPDAT1", "BAS(#CP_PARAMS,2)")
    return (f";FOLD {move} {point} Vel=100 % PDAT1 Tool[1] Base[2];%{{PE}}%R 8.3.31,%MKUKATPBASIS,%CMOVE\n"
            f"$BWDSTART=FALSE\n{dat[0]}\nFDAT_ACT={fdat}\n{params or dat[1]}\n{move} X{point}\n;ENDFOLD\n")


DAT = """DEFDAT p
DECL E6POS XP1={X 100,Y 0,Z 500,A 0,B 90,C 0,S 2,T 35,E1 0,E2 0,E3 0,E4 0,E5 0,E6 0}
DECL FDAT FP1={TOOL_NO 1,BASE_NO 2,IPO_FRAME #BASE,POINT2[] " "}
DECL E6POS XP2={X 200,Y 50,Z 400,A 0,B 90,C 0,S 2,T 35,E1 0,E2 0,E3 0,E4 0,E5 0,E6 0}
DECL FDAT FP2={TOOL_NO 1,BASE_NO 1,IPO_FRAME #BASE,POINT2[] " "}
DECL FDAT FP3={TOOL_NO 1,BASE_NO 1,IPO_FRAME #TCP,POINT2[] " "}
DECL FDAT FP4={TOOL_NO 0,BASE_NO 3,IPO_FRAME #BASE,POINT2[] " "}
DECL PDAT PPDAT1={VEL 100,ACC 100,APO_DIST 100,APO_MODE #CDIS}
DECL LDAT LCPDAT1={VEL 2,ACC 100,APO_DIST 100,APO_FAC 50,ORI_TYP #VAR,CIRC_TYP #BASE,JERK_FAC 50}
ENDDAT
"""
CONFIG = """DEFDAT $CONFIG
BASE_DATA[1]={X 1000,Y 0,Z 0,A 0,B 0,C 0}
BASE_DATA[2]={X 0,Y 2000,Z 0,A 90,B 0,C 0}
BASE_DATA[3]={X 0,Y 0,Z 300,A 0,B 0,C 0}
TOOL_DATA[1]={X 0,Y 0,Z 100,A 0,B 0,C 0}
ENDDAT
"""


def program(tmp_path: Path, body: str, config: str | None = CONFIG):
    (tmp_path / "p.src").write_text("DEF p( )\n" + body + "END\n")
    (tmp_path / "p.dat").write_text(DAT)
    if config is not None:
        (tmp_path / "$config.dat").write_text(config)
    return parse_program(tmp_path / "p.src")


def placed(tp) -> np.ndarray:
    return np.where(tp.placed()[:, None], tp.base_positions(), np.nan)


def test_ptp_and_lin_inline_forms_take_tool_and_base_from_their_fdat(tmp_path):
    # FP1: BASE_NO 2 -> $BASE = BASE_DATA[2] = {Y 2000, A 90}: XP1 (100, 0, 500) turned 90 deg
    # about Z is (0, 100, 500), + (0, 2000, 0). FP2: BASE_DATA[1] = {X 1000}: XP2 + (1000, 0, 0).
    # TOOL_NO 1 -> $TOOL = TOOL_DATA[1] = {Z 100}.
    tp = program(tmp_path, INI + fold("PTP", "P1", "FP1", "") + fold("LIN", "P2", "FP2", ""))
    np.testing.assert_allclose(placed(tp), [[0, 2100, 500], [1200, 50, 400]], atol=1e-9)
    np.testing.assert_allclose(tp.tools[tp.tool][:, :3, 3], [[0, 0, 100]] * 2, atol=1e-9)
    _refuse_unplaced(tp)  # nothing refused


def test_fdat_written_inline_and_bas_frames(tmp_path):
    # FDAT_ACT = {TOOL_NO 1, BASE_NO 1, IPO_FRAME #BASE} then BAS(#FRAMES): FRAMES() alone.
    tp = program(tmp_path, INI + fold("PTP", "P1", "{TOOL_NO 1,BASE_NO 1,IPO_FRAME #BASE}", "BAS(#FRAMES)"))
    np.testing.assert_allclose(placed(tp), [[1100, 0, 500]], atol=1e-9)


def test_tool_zero_is_the_flange(tmp_path):
    # FP4: TOOL_NO 0 -> TOOL(0) -> $TOOL = $NULLFRAME; BASE_NO 3 -> BASE_DATA[3] = {Z 300}.
    tp = program(tmp_path, INI + fold("LIN", "P2", "FP4", ""))
    np.testing.assert_allclose(placed(tp), [[200, 50, 700]], atol=1e-9)
    np.testing.assert_allclose(tp.tools[tp.tool[0]], np.eye(4), atol=1e-12)


@pytest.mark.parametrize("body, why", [
    (fold("PTP", "P1", "FP1", ""), "no INITMOV: the corrections of BAS.SRC are not known to be off"),
    (INI + "BASE_CORR_ON = TRUE\n" + fold("PTP", "P1", "FP1", ""), "a correction switched on"),
    (INI + fold("LIN", "P2", "FP3", ""), "IPO_FRAME #TCP: external TCP"),
    (INI + "PDAT_ACT=PPDAT1\nBAS(#PTP_PARAMS,100)\nPTP XP1\n", "FDAT_ACT never set: a global from before"),
    (INI + "IF $IN[1] THEN\nFDAT_ACT=FP2\nENDIF\nBAS(#PTP_PARAMS,100)\nPTP XP1\n", "FDAT_ACT set in a branch"),
    (INI + "FP1.BASE_NO = N\n" + fold("PTP", "P1", "FP1", ""), "the FDAT itself changed at run time"),
    (INI + "OTHERMODULE()\n" + fold("PTP", "P1", "FP1", ""), "a routine of another module may switch a correction on"),
    (INI + "FDAT_ACT=FP2\nOTHERMODULE()\nBAS(#PTP_PARAMS,100)\nPTP XP1\n", "a routine of another module may set FDAT_ACT"),
])
def test_frames_that_cannot_be_followed_are_refused_with_their_line(tmp_path, body, why):
    tp = program(tmp_path, body)
    assert not tp.placed().any(), why
    with pytest.raises(InputError, match="cannot be placed"):
        _refuse_unplaced(tp)


def test_fdat_act_set_in_a_subprogram_makes_every_use_unknown(tmp_path):
    body = INI + fold("PTP", "P1", "FP1", "") + "SUB()\n"
    (tmp_path / "p.src").write_text("DEF p( )\n" + body + "END\nDEF SUB()\nFDAT_ACT=FP2\nEND\n")
    (tmp_path / "p.dat").write_text(DAT)
    (tmp_path / "$config.dat").write_text(CONFIG)
    assert not parse_program(tmp_path / "p.src").placed().any()


def test_without_config_dat_the_frames_are_named_but_unknown(tmp_path):
    tp = program(tmp_path, INI + fold("PTP", "P1", "FP1", ""), config=None)
    assert not tp.placed().any()
    assert tp.frame_names[tp.frame[0]] == "BASE_DATA[2]" and tp.tool_names[tp.tool[0]] == "TOOL_DATA[1]"
    with pytest.raises(InputError, match=r"--frame BASE_DATA\[2\]"):
        _refuse_unplaced(tp)


def test_base_on_an_external_mechanism_is_not_guessed(tmp_path):
    # FRAMES(): MACHINE_FRAME_DAT[2].MACH_DEF_INDEX 2 -> MACHINE_DEF[2] a positioner (#EXT_AXIS):
    # EX_BASE() computes $BASE at run time; base 1 (MACH_DEF_INDEX 0) is BASE_DATA[1].
    config = CONFIG.replace("ENDDAT", 'MACHINE_FRAME_DAT[1]={MACH_DEF_INDEX 0,PARENT[] " ",GEOMETRY[] " "}\n'
                            'MACHINE_FRAME_DAT[2]={MACH_DEF_INDEX 2,PARENT[] " ",GEOMETRY[] " "}\n'
                            'MACHINE_DEF[2]={NAME[] "DKP",COOP_KRC_INDEX 1,PARENT[] " ",ROOT {X 0,Y 0,Z 0,A 0,B 0,C 0},MECH_TYPE #EXT_AXIS,GEOMETRY[] " "}\nENDDAT')
    tp = program(tmp_path, INI + fold("PTP", "P1", "FP1", "") + fold("LIN", "P2", "FP2", ""), config=config)
    assert tp.placed().tolist() == [False, True]
    np.testing.assert_allclose(tp.base_positions()[1], [1200, 50, 400], atol=1e-9)


def test_real_config_and_system_file_shapes_are_read(tmp_path):
    # Shapes every real KSS 8 $config.dat / BAS.SRC has: a row of a 2-D CHAR array
    # (TOOL_NAME[1,]="..."), ON_ERROR_PROCEED, and editor folds that are not balanced or that
    # cross DEF/END (folds are comments to the controller). The motion is still read exactly.
    config = CONFIG.replace("ENDDAT", ';FOLD TOOLS\nTOOL_NAME[1,]="Spindle"\n;ENDFOLD\n;ENDFOLD\nENDDAT')
    body = INI + ";FOLD MOVES\n" + fold("PTP", "P1", "FP1", "") + "ON_ERROR_PROCEED\nEND\n;ENDFOLD\nDEF sub( )\n"
    tp = program(tmp_path, body, config=config)
    np.testing.assert_allclose(placed(tp), [[0, 2100, 500]], atol=1e-9)
