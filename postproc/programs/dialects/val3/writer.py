"""A new VAL3 application (program .pgx, data .dtx, project .pjx) from the writer events
(see postproc.programs.emit.writer).

Every target becomes an element of a pointRx array linked to the frame in force (a
frame array linked to world), every tool an element of a tool array linked to flange,
every (speed, zone) pair an mdesc: ``tmax`` the speed (mm/s), ``blend`` Cartesian with
``leave`` = ``reach`` = the zone (mm), or off where the zone is 0 or not given (the
point is then reached exactly). A movej point carries the configuration the events give
(a VAL3 input's own, or one computed from the joints the input's controller takes:
``convert --robot``, postproc.jobs.convert_conf); every other point, and a movej point without
one, carries ``ssame esame wsame``: the arm keeps the configuration it is in (VAL3
reference manual, "config").
"""

from __future__ import annotations

from xml.sax.saxutils import escape

import numpy as np

from ...emit.writer import legal_name, short_number
from .rotation import matrix_to_rxyz

_NS = 'xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance"'
SAME = 'shoulder="ssame" elbow="esame" wrist="wsame"'
# Toolpath.conf codes of a VAL3 config (parse.py's CONFIG, read the other way)
_WORDS = (("shoulder", {1.0: "righty", -1.0: "lefty", 0.0: "ssame", 2.0: "sfree"}), ("elbow", {1.0: "epositive", -1.0: "enegative", 0.0: "esame", 2.0: "efree"}),
          ("wrist", {1.0: "wpositive", -1.0: "wnegative", 0.0: "wsame", 2.0: "wfree"}))


def _config_attrs(conf) -> str:
    """The config attributes of codes ``conf`` (shoulder, elbow, wrist, ...), SAME where they are not all given."""
    if conf is None or not np.isfinite(conf[:3]).all() or any(float(c) not in words for c, (_, words) in zip(conf[:3], _WORDS)):
        return SAME
    return " ".join(f'{name}="{words[float(c)]}"' for c, (name, words) in zip(conf[:3], _WORDS))


def _mdesc_value(key: int, speed: float | None, zone: float) -> str:
    tmax = "" if speed is None else f' tmax="{short_number(speed, 6)}"'
    blend = f'blend="Cartesian" leave="{short_number(zone, 6)}" reach="{short_number(zone, 6)}"' if zone > 0 else 'blend="off"'
    return f'      <Value key="{key}"{tmax} {blend} />'


def _pose_attrs(t: np.ndarray) -> str:
    rxyz = matrix_to_rxyz(t[None, :3, :3])[0]
    return " ".join(f'{k}="{short_number(v, 6)}"' for k, v in zip(("x", "y", "z", "rx", "ry", "rz"), [*t[:3, 3], *rxyz]))


class Val3Writer:
    def __init__(self, name: str = "converted"):
        self.name = legal_name(name, "prog")
        self.code: list[str] = []
        self.frames: list[str] = []
        self.tools: list[str] = []
        self.mdescs: dict[tuple, int] = {}
        self.points: list[str] = []
        self.joints: list[str] = []
        self.frame_ref = "world[0]"
        self.tool_ref = "flange"
        self.speed_now, self.zone_now = np.nan, np.nan

    def start(self, name: str) -> None:
        pass

    def frame(self, name: str, base_T_frame: np.ndarray) -> None:
        if np.allclose(base_T_frame, np.eye(4), atol=1e-12):
            self.frame_ref = "world[0]"
            return
        self.frames.append(f'      <Value key="{len(self.frames)}" {_pose_attrs(base_T_frame)} fatherId="world[0]" />')
        self.frame_ref = f"fFrame[{len(self.frames) - 1}]"

    def tool(self, name: str, flange_T_tcp: np.ndarray) -> None:
        if np.allclose(flange_T_tcp, np.eye(4), atol=1e-12):
            self.tool_ref = "flange"
            return
        self.tools.append(f'      <Value key="{len(self.tools)}" {_pose_attrs(flange_T_tcp)} fatherId="flange[0]" />')
        self.tool_ref = f"tTool[{len(self.tools) - 1}]"

    def speed(self, mm_s: float) -> None:
        self.speed_now = mm_s

    def zone(self, mm: float) -> None:
        self.zone_now = mm

    def _mdesc(self) -> str:
        key = (None if not np.isfinite(self.speed_now) else round(float(self.speed_now), 6), round(float(self.zone_now), 6) if np.isfinite(self.zone_now) and self.zone_now > 0 else 0.0)
        index = self.mdescs.setdefault(key, len(self.mdescs))
        return f"mDesc[{index}]"

    def _point(self, pose: np.ndarray, config: str = SAME) -> str:
        self.points.append(f'      <Value key="{len(self.points)}" {_pose_attrs(pose)} {config} fatherId="{self.frame_ref}" />')
        return f"pPoint[{len(self.points) - 1}]"

    def move_joint(self, pose, conf=None) -> None:
        self.code.append(f"  movej({self._point(pose, _config_attrs(conf))}, {self.tool_ref}, {self._mdesc()})")

    def move_linear(self, pose, conf=None) -> None:
        self.code.append(f"  movel({self._point(pose)}, {self.tool_ref}, {self._mdesc()})")

    def move_circular(self, via, end, conf=None) -> None:
        self.code.append(f"  movec({self._point(via)}, {self._point(end)}, {self.tool_ref}, {self._mdesc()})")

    def move_joints(self, q) -> None:
        attrs = " ".join(f'j{i + 1}="{short_number(v, 6)}"' for i, v in enumerate(q))
        self.joints.append(f'      <Value key="{len(self.joints)}" {attrs} />')
        self.code.append(f"  movej(jPoint[{len(self.joints) - 1}], {self.tool_ref}, {self._mdesc()})")

    def raw(self, line: str) -> None:
        self.code.append(f"  // {line}")

    def end(self) -> list[str]:
        code = "\n".join(["begin", *self.code, "  waitEndMove()", "end"])
        pgx = ['<?xml version="1.0" encoding="utf-8"?>', f'<Programs {_NS} xmlns="http://www.staubli.com/robotics/VAL3/Program/2">',
               f'  <Program name="{self.name}" access="public">', f"    <Code><![CDATA[{code}\n]]></Code>", "  </Program>", "</Programs>", ""]
        mdescs = [_mdesc_value(i, speed, zone) for (speed, zone), i in self.mdescs.items()]
        datas = []
        for name, kind, values in (("fFrame", "frame", self.frames), ("tTool", "tool", self.tools), ("mDesc", "mdesc", mdescs),
                                   ("pPoint", "pointRx", self.points), ("jPoint", "jointRx", self.joints)):
            if values:
                datas += [f'    <Data name="{name}" access="public" xsi:type="array" type="{kind}" size="{len(values)}">', *values, "    </Data>"]
        dtx = ['<?xml version="1.0" encoding="utf-8"?>', f'<Database {_NS} xmlns="http://www.staubli.com/robotics/VAL3/Data/2">', "  <Datas>", *datas, "  </Datas>", "</Database>", ""]
        pjx = ['<?xml version="1.0" encoding="utf-8"?>', '<Project xmlns="http://www.staubli.com/robotics/VAL3/Project/3">',
               '  <Parameters version="s7.3.1" stackSize="5000" millimeterUnit="true" />', "  <Programs>",
               f'    <Program file="{escape(self.name)}.pgx" />', "  </Programs>", "  <Database>", f'    <Data file="{escape(self.name)}.dtx" />',
               "  </Database>", "  <Libraries />", "</Project>", ""]
        return ["\r\n".join(pgx), "\r\n".join(dtx), "\r\n".join(pjx)]
