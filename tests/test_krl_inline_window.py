"""KRL inline forms read where they stand (postproc/programs/dialects/krl/inline_window.py).

Shapes of real robot cells (HugoDanielson/ChinaMilling's KukaMiling: a SWITCH on a routine's
parameter whose CASEs each run one inline form, a jump table of GOTOs into a list of folds,
calls of another module's routines and TRIGGER routines before the folds).

Rules (KSS 8, Operating and Programming Instructions for System Integrators):
- "SWITCH ... CASE": one CASE (or DEFAULT) runs, its statements in order; "GOTO": the program
  continues at a label (``Marker:``), so a row of statements with no label in it is entered
  only at its top and runs in order (the selector and the jump need not be known).
- BAS.SRC (KRC/R1/System): ``BAS(#PTP_PARAMS/#CP_PARAMS/#FRAMES)`` runs ``FRAMES()``: ``$TOOL =
  TOOL_DATA[FDAT_ACT.TOOL_NO]``, ``$BASE = BASE_DATA[FDAT_ACT.BASE_NO]`` ($WORLD for 0), each
  with a correction chained in when TOOL_CORR_ON / BASE_CORR_ON ... is TRUE; BAS.SRC only ever
  sets those FALSE. "Data lists": $config.dat keeps their value on the controller.
- $ROBROOT ($machine.dat): the robot base in world coordinates; null: $WORLD is the robot base.
A target is $BASE : point in the robot base frame (KSS 8, "BASE").
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from postproc.programs import parse_program

SWITCHES = "BOOL TOOL_CORR_ON=FALSE\nBOOL TOOL_CORR_W_ON=FALSE\nBOOL BASE_CORR_ON=FALSE\nBOOL M_BAS_COR_ON=FALSE\n"
CONFIG = ("DEFDAT $CONFIG\n" + SWITCHES + "BASE_DATA[1]={X 1000,Y 0,Z 0,A 0,B 0,C 0}\n"
          "BASE_DATA[2]={X 0,Y 2000,Z 0,A 90,B 0,C 0}\nTOOL_DATA[1]={X 0,Y 0,Z 100,A 0,B 0,C 0}\nENDDAT\n")
MACHINE = "DEFDAT $MACHINE PUBLIC\nFRAME $ROBROOT={X 0.0,Y 0.0,Z 0.0,A 0.0,B 0.0,C 0.0}\nENDDAT\n"
POINTS = """DEFDAT POINTS PUBLIC
DECL GLOBAL E6POS XP1={X 100,Y 0,Z 500,A 0,B 90,C 0,S 2,T 35,E1 0,E2 0,E3 0,E4 0,E5 0,E6 0}
DECL GLOBAL E6POS XP2={X 200,Y 50,Z 400,A 0,B 90,C 0,S 2,T 35,E1 0,E2 0,E3 0,E4 0,E5 0,E6 0}
DECL GLOBAL E6POS XP3={X 10,Y 20,Z 30,A 0,B 90,C 0,S 2,T 35,E1 0,E2 0,E3 0,E4 0,E5 0,E6 0}
DECL GLOBAL FDAT FP1={TOOL_NO 1,BASE_NO 2,IPO_FRAME #BASE}
DECL GLOBAL FDAT FP2={TOOL_NO 1,BASE_NO 1,IPO_FRAME #BASE}
DECL GLOBAL FDAT FP0={TOOL_NO 1,BASE_NO 0,IPO_FRAME #BASE}
DECL GLOBAL PDAT PDATWORK={VEL 100,ACC 100,APO_DIST 100,APO_MODE #CDIS}
ENDDAT
"""
# FP1: BASE_DATA[2] = {Y 2000, A 90}: (x, y, z) -> (-y, x + 2000, z); FP2: BASE_DATA[1] = {X 1000};
# FP0: $WORLD, the robot base ($ROBROOT null).
P1_IN_FP1, P2_IN_FP2, P3_IN_FP0 = [0, 2100, 500], [1200, 50, 400], [10, 20, 30]


def fold(point: str, fdat: str) -> str:
    """One inline form as the smartPAD writes it (the real cells' shape)."""
    return (f";FOLD PTP {point} CONT Vel= 100 % DATWork;%{{PE}}%R 5.4.35,%MKUKATPBASIS,%CMOVE\n"
            f"$BWDSTART = FALSE\nPDAT_ACT=PDATWork\nFDAT_ACT={fdat}\nBAS(#PTP_PARAMS,PDATWork.VEL)\nPTP {point} C_PTP\n;ENDFOLD\n")


def cell(tmp_path: Path, body: str, *, config: str = CONFIG, machine: str | None = MACHINE, module_src: str | None = None,
         tail: str = "", header: str = "DEF p (n :IN)\nINT n\n"):
    """A program p.src with the cell's other modules (--data): points.dat, $config.dat, $machine.dat, lib.src."""
    (tmp_path / "p.src").write_text(header + body + "END\n" + tail)
    data = tmp_path / "data"
    data.mkdir(exist_ok=True)
    (data / "points.dat").write_text(POINTS)
    (data / "$config.dat").write_text(config)
    if machine is not None:
        (data / "$machine.dat").write_text(machine)
    if module_src is not None:
        (data / "lib.src").write_text(module_src)
    return parse_program(tmp_path / "p.src", modules=[data])


def placed(tp) -> np.ndarray:
    return np.where(tp.placed()[:, None], tp.base_positions(), np.nan)


SWITCH_TABLE = ("CONTINUE\nSWITCH n\nCASE 1\n" + fold("XP1", "FP1") + "RETURN\nCASE 2\n" + fold("XP2", "FP2") + "RETURN\n"
                "CASE 3\n" + fold("XP3", "FP0") + "DEFAULT\nENDSWITCH\n")
JUMP_TABLE = ("SWITCH n\nCASE 1\nGOTO JUMP1\nCASE 2\nGOTO JUMP2\nENDSWITCH\nJUMP1:\nn = 2\n"
              "TRIGGER WHEN DISTANCE=0 DELAY=0 DO SAVELAST(1) PRIO=-1\n" + fold("XP1", "FP1") + "JUMP2:\n" + fold("XP2", "FP2"))
SAVELAST = "GLOBAL DEF SAVELAST(k :IN)\nINT k\nIF VARSTATE(\"k\") == #INITIALIZED THEN\nLASTK = k\nENDIF\nEND\n"
MOVESETTINGS = ("GLOBAL DEF MOVESETTINGS(nBase :IN, nTool :IN)\nINT nBase, nTool\nFDAT_ACT = FP1\nFDAT_ACT.BASE_NO = nBase\n"
                "BAS(#FRAMES)\nIF nBase == 0 THEN\n$BASE = $NULLFRAME\nENDIF\nBAS(#TOOL,nTool)\nEND\n")


def test_each_case_of_a_switch_on_an_unknown_selector_is_placed(tmp_path):
    # MoveToPrepos's shape: n is the routine's parameter (unknown here); whichever CASE runs,
    # its three lines run in order and FRAMES() sets both frames from its FDAT.
    tp = cell(tmp_path, SWITCH_TABLE)
    np.testing.assert_allclose(placed(tp), [P1_IN_FP1, P2_IN_FP2, P3_IN_FP0], atol=1e-9)
    np.testing.assert_allclose(tp.tools[tp.tool][:, :3, 3], [[0, 0, 100]] * 3, atol=1e-9)


def test_folds_after_a_goto_jump_table_and_a_trigger_routine_are_placed(tmp_path):
    # st1_st2's shape: a SWITCH of GOTOs into a list of labelled folds, a TRIGGER whose routine
    # (another module's, given) only sets a flag.
    tp = cell(tmp_path, JUMP_TABLE, module_src=SAVELAST)
    np.testing.assert_allclose(placed(tp), [P1_IN_FP1, P2_IN_FP2], atol=1e-9)


def test_a_fold_after_a_call_of_another_modules_routine_is_placed(tmp_path):
    # Home's shape: MOVESETTINGS (lib.src, given) sets FDAT_ACT and the frames; the fold after
    # it sets them again from its own FDAT.
    tp = cell(tmp_path, "MOVESETTINGS(0, 1)\n" + fold("XP2", "FP2"), module_src=MOVESETTINGS)
    np.testing.assert_allclose(placed(tp), [P2_IN_FP2], atol=1e-9)


@pytest.mark.parametrize("body, module_src, config, machine, why", [
    (JUMP_TABLE, None, CONFIG, MACHINE, "the TRIGGER routine is not in the given files"),
    (JUMP_TABLE, SAVELAST.replace("LASTK = k", "$BASE = BASE_DATA[1]"), CONFIG, MACHINE, "the TRIGGER routine changes $BASE"),
    (JUMP_TABLE, SAVELAST.replace("LASTK = k", "OTHER()"), CONFIG, MACHINE, "the TRIGGER routine calls a routine"),
    ("OTHER()\n" + SWITCH_TABLE, None, CONFIG, MACHINE, "a routine not in the given files may switch a correction on"),
    ("ARM()\n" + SWITCH_TABLE, "GLOBAL DEF ARM( )\nINTERRUPT DECL 5 WHEN $IN[5] DO IR5( )\nINTERRUPT ON 5\nEND\n"
     "GLOBAL DEF IR5( )\n$TOOL = $NULLFRAME\nEND\n", CONFIG, MACHINE, "an interrupt a called routine declares changes $TOOL"),
    ("MOVESETTINGS(0, 1)\n" + SWITCH_TABLE, MOVESETTINGS.replace("BAS(#FRAMES)", "BASE_CORR_ON = TRUE"), CONFIG, MACHINE,
     "a called routine switches a correction on"),
    ("MOVESETTINGS(0, 1)\n" + SWITCH_TABLE, MOVESETTINGS.replace("BAS(#FRAMES)", "TOOL_DATA[1].Z = n"), CONFIG, MACHINE,
     "a called routine changes TOOL_DATA"),
    ("SETT(TOOL_DATA[1])\n" + SWITCH_TABLE, "GLOBAL DEF SETT(t :OUT)\nDECL FRAME t\nt.Z = 5\nEND\n", CONFIG, MACHINE,
     "TOOL_DATA passed to a routine's :OUT parameter"),
    (SWITCH_TABLE, None, CONFIG.replace("BASE_CORR_ON=FALSE", "BASE_CORR_ON=TRUE"), MACHINE, "a correction is on in $config.dat"),
    (SWITCH_TABLE, None, CONFIG.replace("BOOL M_BAS_COR_ON=FALSE\n", ""), MACHINE, "a switch not declared"),
    ("SWITCH n\nCASE 1\n" + fold("XP1", "FP1").replace("BAS(", "LAB1:\nBAS(") + "ENDSWITCH\n", None, CONFIG, MACHINE, "a label inside the fold"),
    ("SWITCH n\nCASE 1\n" + fold("XP1", "FP1").replace("BAS(", "n = 3\nBAS(") + "ENDSWITCH\n", None, CONFIG, MACHINE, "another statement in the fold"),
    (fold("XP1", "FP1").replace("BAS(", "FDAT_ACT.BASE_NO = n\nBAS("), None, CONFIG, MACHINE, "FDAT_ACT changed in the fold"),
])
def test_what_the_given_files_do_not_prove_stays_unplaced(tmp_path, body, module_src, config, machine, why):
    # Before each fold a GOTO or a call, so only the fold itself could place the motion.
    tp = cell(tmp_path, "GOTO SKIP\nSKIP:\n" + body, module_src=module_src, config=config, machine=machine)
    assert not tp.placed().any(), why


def test_an_fdat_a_called_routine_changes_is_not_used(tmp_path):
    # MOVESETTINGS sets FP1.BASE_NO at run time: the fold of FP1 is unknown, the others are not.
    tp = cell(tmp_path, "MOVESETTINGS(0, 1)\n" + SWITCH_TABLE, module_src=MOVESETTINGS.replace("BAS(#FRAMES)", "FP1.BASE_NO = n"))
    assert tp.placed().tolist() == [False, True, True]


@pytest.mark.parametrize("machine", [None, MACHINE.replace("Z 0.0", "Z 400.0"), MACHINE + MACHINE])
def test_base_zero_is_the_robot_base_only_with_a_null_robroot(tmp_path, machine):
    # FP0 (BASE_NO 0): $BASE = $WORLD; without $ROBROOT, or with one that is not null (or
    # given twice), where the world is in the robot base frame is not claimed.
    tp = cell(tmp_path, SWITCH_TABLE, machine=machine)
    assert tp.placed().tolist() == [True, True, False]


def test_a_fold_of_a_routine_no_call_reaches_is_not_placed(tmp_path):
    # SUB is run by no call of p (another module may call it, after code not read here).
    tp = cell(tmp_path, SWITCH_TABLE, tail="GLOBAL DEF SUB( )\n" + fold("XP2", "FP2") + "END\n")
    assert tp.placed().tolist() == [True, True, True, False]
