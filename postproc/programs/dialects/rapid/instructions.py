"""What RAPID instructions do to the motion, as far as postproc must know it.

- the argument layout of each motion instruction it reads (which positional argument is the
  target, the speed, the zone, the tool);
- the instructions that do not move the robot (a call to anything else that is not a
  procedure of the program is reported; one that looks like motion stops the job);
- the data a running program changes (assignments, INOUT arguments, SearchL's search
  point, program displacement), whose moves cannot be read from the declarations.

Sections cited: ABB "Technical reference manual - RAPID Instructions, Functions and Data
types" (3HAC050917-001), each instruction's "Syntax".
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

# positional indices: (targets, speed, zone or None, tool or None)
LINEAR_LAYOUT = ((0,), 1, 2, 3)
LAYOUTS = {
    "SEARCHL": ((2,), 3, None, 4),  # SearchL Signal SearchPoint ToPoint Speed Tool
    "SEARCHC": ((2, 3), 4, None, 5),  # SearchC Signal SearchPoint CirPoint ToPoint Speed Tool
    "TRIGGL": ((0,), 1, 3, 4),  # TriggL ToPoint Speed Trigg_1 Zone Tool
    "TRIGGJ": ((0,), 1, 3, 4),
    "TRIGGC": ((0, 1), 2, 4, 5),  # TriggC CirPoint ToPoint Speed Trigg_1 Zone Tool
    "CONTACTL": ((0,), 1, None, 2),
    "MOVEEXTJ": ((0,), 1, 2, None),  # MoveExtJ ToJointPos Speed Zone (external axes only, no tool)  # ContactL [\DesiredTorque] ToPoint Speed [\Zone] Tool
}
CIRCULAR_LAYOUT = ((0, 1), 2, 3, 4)
SEARCH_POINT = {"SEARCHL": 1, "SEARCHC": 1}  # the INOUT robtarget the instruction writes

# Program displacement and external-axis offsets move every later target (PDispOn, PDispSet,
# EOffsOn, EOffsSet; CorrCon adds a path correction).
DISPLACEMENT = {"PDISPON", "PDISPSET", "EOFFSON", "EOFFSSET", "CORRCON"}

# Instructions that do not move the robot (RobotWare 6 instruction list, abridged).
NOT_MOTION = {n.upper() for n in """
AccSet ActUnit Add AliasIO BitClear BitSet BookErrNo CallByVar CancelLoad CheckProgRef CirPathMode Clear ClearIOBuff
ClearPath ClearRawBytes ClkReset ClkStart ClkStop Close CloseDir ConfJ ConfL CopyFile CopyRawBytes CorrClear CorrCon
CorrDiscon CorrWrite DeactUnit Decr DitherAct DitherDeact DropWObj EOffsOff EOffsOn EOffsSet EraseModule ErrLog ErrRaise
ErrWrite ExitCycle GetDataVal GetSysData GetTrapData GripLoad IDelete IDisable IEnable IError IPers IRMQMessage ISignalAI
ISignalAO ISignalDI ISignalDO ISignalGI ISignalGO ISleep ITimer IVarValue IWatch Incr InvertDO IOBusStart IODisable
IOEnable Load LoadId MakeDir MechUnitLoad MotionSup Open OpenDir PackDNHeader PackRawBytes PathAccLim PathRecStart
PathRecStop PathResol PDispOff PDispOn PDispSet ProcerrRecovery PulseDO ReadAnyBin ReadBlock ReadCfgData ReadErrData
ReadRawBytes RemoveDir RemoveFile RenameFile Reset ResetPPMoved ResetRetryCount RestoPath Rewind RMQEmptyQueue
RMQFindSlot RMQGetMessage RMQGetMsgData RMQGetMsgHeader RMQReadWait RMQSendMessage RMQSendWait Save SCWrite Set
SetAllDataVal SetAO SetDataSearch SetDataVal SetDO SetGO SetSysData SingArea SkipWarn SocketAccept SocketBind
SocketClose SocketConnect SocketCreate SocketListen SocketReceive SocketReceiveFrom SocketSend SocketSendTo SoftAct
SoftDeact SpeedLimAxis SpeedLimCheckPoint SpeedRefresh SpyStart SpyStop StartLoad StartMove StartMoveRetry Stop StopMove
StopMoveReset StorePath SyncMoveOff SyncMoveOn SyncMoveResume SyncMoveSuspend SyncMoveUndo SystemStopAction
TestSignDefine TestSignReset TextTabInstall TPErase TPReadFK TPReadNum TPReadDnum TPShow TPWrite TriggCheckIO TriggEquip
TriggInt TriggIO TriggRampAO TriggSpeed TriggStopProc TryInt TuneReset TuneServo UIMsgBox UIShow UnLoad UnpackRawBytes
VelSet WaitAI WaitAO WaitDI WaitDO WaitGI WaitGO WaitLoad WaitRob WaitSensor WaitSyncTask WaitTestAndSet WaitTime
WaitUntil WaitWObj WarmStart WorldAccLim Write WriteAnyBin WriteBin WriteBlock WriteCfgData WriteRawBytes WriteStrBin
WriteVar WZBoxDef WZCylDef WZDisable WZDOSet WZEnable WZFree WZHomeJointDef WZLimJointDef WZLimSup WZSphDef
""".split()}

# Instructions that move the robot with no target in the program text (externally guided
# motion, a recorded path run backwards, independent axes): the program's own targets are
# read; this motion is not, and a note says so.
UNMODELLED_MOTION = {n.upper() for n in """
EGMRunJoint EGMRunPose EGMStreamStart PathRecMoveBwd PathRecMoveFwd StepBwdPath IndAMove IndCMove IndDMove IndRMove
IndReset SearchExtJ
""".split()}

# Any other call whose name says it moves the robot to a target (MoveQ, ArcL, SpotL, CapL,
# PaintL, DispL, EGMMoveL, ...) is refused with its line: its target would go uncorrected.
LOOKS_LIKE_MOTION = re.compile(r"^(MOVE|SEARCH|TRIGG[LJC]|ARC[LC]|SPOT[LJ]|CAP[LC]|PAINT[LC]|CONTACT|DISP[LJ]|EGMMOVE|CSS.*MOVE)", re.IGNORECASE)


@dataclass
class RuntimeFacts:
    """What the program's statements do to its data, collected over all its modules."""

    procs: dict[str, list[bool]] = field(default_factory=dict)  # PROC name -> per parameter: may it be written (INOUT/VAR/PERS)
    changed: dict[str, str] = field(default_factory=dict)  # DATA NAME -> first 'file:line: p1 is assigned'
    calls: list[tuple[str, list[str | None], str, object]] = field(default_factory=list)  # name, lvalue roots, 'file:line', error maker
    displaced: list[str] = field(default_factory=list)  # 'file:line: PDispOn' ...

    def change(self, name: str, where: str) -> None:
        self.changed.setdefault(name.upper(), where.replace("{name}", name))


def check_calls(facts: RuntimeFacts, notes: list[str]) -> None:
    """Calls of procedures: INOUT arguments of the program's own procedures are changed data;
    an unknown instruction is a note, or an error where it may move the robot."""
    unknown: dict[str, list[str]] = {}
    for name, roots, where, fail in facts.calls:
        upper = name.upper()
        if upper in facts.procs:
            for root, writable in zip(roots, facts.procs[upper]):
                if writable and root:
                    facts.change(root, f"{where}: {{name}} is passed to {name} as INOUT/VAR/PERS")
        elif upper in UNMODELLED_MOTION:
            notes.append(f"{where}: {name} moves the robot along a path that is not in the program text; that motion is not read")
        elif upper not in NOT_MOTION:
            if LOOKS_LIKE_MOTION.match(name):
                raise fail(f"{name} is not an instruction postproc can read the motion of, nor a PROC of this program (give the whole program, "
                           "a .pgf, if it is a PROC of another module): refusing rather than dropping its motion")
            unknown.setdefault(name, []).append(where)
        if upper in DISPLACEMENT:
            facts.displaced.append(f"{where}: {name}")
    for name, wheres in unknown.items():
        more = f" (and {len(wheres) - 1} more calls)" if len(wheres) > 1 else ""
        notes.append(f"{wheres[0]}: {name} is neither a PROC of this program nor a RAPID instruction postproc knows; read as not moving the robot{more}")
