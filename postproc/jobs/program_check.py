"""Does the model belong to the program? Robot, tool and payload checked before compensating.

A model predicts one robot's error with one measured tool and the load it carried during
the measurements. A program written for another robot, cutting with another tool or
carrying another payload would be "compensated" with the wrong numbers and exit 0. So:

- robot: the robot the user names (``--robot``) must be the model's; a program in a
  maker's own language (KRL: KUKA, RAPID: ABB) must be for a robot of that maker, as the
  robot file's description names it; every joint target of the program must lie within
  the model robot's joint ranges (a program for a robot with other ranges is for another
  robot);
- tool: every tool the program's Cartesian targets use (its frame, ``$TOOL``/``TOOL_DATA``,
  RAPID tooldata) must put the TCP where the model's tool is (``TOOL_TOLERANCE_MM``);
- payload: where the model has an effect that gravity drives (``payload_dependent``: joint
  compliance, non-linear stiffness, link bending, base tilt) and the program states a load
  (KRL ``$LOAD``/``LOAD_DATA``, RAPID tooldata's tload and ``GripLoad``), the model must
  state the payload it was fitted at (``joint_compliance[payload=KG]``, 0 included) and the
  two agree (``PAYLOAD_TOLERANCE_KG``); a model that states none is refused too, as its
  compliances then hold whatever load was on the flange when it was measured. A model
  without such an effect predicts the same under any load: nothing to compare.

A mismatch is a ``ModelMismatchError`` naming both sides; ``allow`` (``--allow-model-mismatch``)
turns the errors into notes for a user who knows why they differ.
"""

from __future__ import annotations

import numpy as np

from postproc.errors import InputError
from postproc.programs import dialects
from postproc.programs.ir import Kind, Toolpath

TOOL_TOLERANCE_MM = 0.1
PAYLOAD_TOLERANCE_KG = 0.5


class ModelMismatchError(InputError):
    """The model was made for another robot, tool or payload than the program uses."""


def check_model_fits(tp: Toolpath, model, model_path: str, robot_name: str | None = None, allow: bool = False) -> list[str]:
    """Every mismatch between the program and the model, as errors (or notes with ``allow``)."""
    robot, tools, payload, maker = _findings(tp, model, model_path, robot_name)
    # The maker's last: where the tool or payload differ too, the message names them first.
    problems = robot + tools + payload + maker
    if problems and not allow:
        more = f" (and {len(problems) - 1} more)" if len(problems) > 1 else ""
        raise ModelMismatchError(f"{problems[0]}{more}; give the model fitted for this set-up, or --allow-model-mismatch if the difference is known to be harmless")
    return problems


def mismatch_keys(tp: Toolpath, model, model_path: str, robot_name: str | None = None) -> set[str]:
    """What of ``tp`` does not fit the model, as keys that compare across parts of one program
    (a streamed chunk and the first): a tool's message without the place of its first target
    (each part has its own first), every other message as it is (a payload statement's and a
    joint target's name their own line, the same in every part that holds them)."""
    robot, tools, payload, maker = _findings(tp, model, model_path, robot_name)
    return {m.split(": ", 1)[-1] for m in tools} | set(robot + payload + maker)


def _findings(tp: Toolpath, model, model_path: str, robot_name: str | None) -> tuple[list[str], list[str], list[str], list[str]]:
    """The mismatches of each kind: robot, tools, payload, the robot maker's conventions."""
    return _robot(tp, model, model_path, robot_name), _tools(tp, model, model_path), _payload(tp, model, model_path), _maker(tp, model.robot, model_path)


def _robot(tp: Toolpath, model, model_path: str, robot_name: str | None) -> list[str]:
    robot = model.robot
    out = []
    if robot_name is not None and robot_name not in (robot.name, robot.source_path):
        out.append(f"--robot {robot_name}: the model {model_path} is for robot {robot.name}")
    joints = (tp.kind == Kind.ABSJ) & ~np.isnan(tp.joints).any(axis=1)
    if joints.any():
        q = tp.joints[joints]
        outside = (q < robot.lower_deg - 1e-6) | (q > robot.upper_deg + 1e-6)
        if outside.any():
            i, j = np.argwhere(outside)[0]
            row = int(np.nonzero(joints)[0][i])
            out.append(f"{_where(tp, row)}: axis {j + 1} = {q[i, j]:g} deg is outside the range [{robot.lower_deg[j]:g}, {robot.upper_deg[j]:g}] "
                       f"of the model's robot {robot.name} ({model_path}): the program is for another robot")
    return out


# Robot makers as robot files' descriptions name them (their first word).
_MAKERS = ("KUKA", "ABB", "FANUC", "Yaskawa", "Universal", "Staubli", "Kawasaki", "Comau", "Nachi", "Denso")


def _maker(tp: Toolpath, robot, model_path: str) -> list[str]:
    """A KRL program is for a KUKA robot, a RAPID program for an ABB one: a model of another
    maker's robot is for another robot. Robot files whose description names no known maker
    are not judged."""
    want = dialects.of(tp).controller.maker
    words = robot.description.split()
    maker = words[0] if words and words[0] in _MAKERS else None
    if want is None or maker is None or maker == want:
        return []
    return [f"{tp.sources[0].path}: the program is {tp.dialect.upper()}, the language of {want} controllers; the model {model_path} "
            f"is for robot {robot.name} ({robot.description}): the program is for another robot"]


def _tools(tp: Toolpath, model, model_path: str) -> list[str]:
    out = []
    cart = np.nonzero(tp.kind != Kind.ABSJ)[0]
    for t in np.unique(tp.tool[cart]):
        if tp.tool_known is not None and not tp.tool_known[t]:
            continue  # undefined in the program: --tool gives it, or compensation refuses
        offset = tp.tools[t][:3, 3]
        if np.linalg.norm(offset - model.tool_mm) > TOOL_TOLERANCE_MM:
            row = int(cart[tp.tool[cart] == t][0])
            out.append(f"{_where(tp, row)}: the program's tool {tp.tool_names[t]} has its TCP at {_xyz(offset)} mm from the flange; "
                       f"the model {model_path} was fitted for the tool at {_xyz(model.tool_mm)} mm")
    return out


def _payload(tp: Toolpath, model, model_path: str) -> list[str]:
    """The payloads the program states against the one the model was fitted at. Only effects
    that gravity drives (``payload_dependent``) change with the load; a model with one of them
    must state its payload (``joint_compliance[payload=KG]``) to compensate a program that
    states a load, or the numbers would be right only by luck."""
    gravity = [e.name for e in model.effects if e.payload_dependent]
    if not gravity:
        return []  # the prediction does not change with the load: nothing to compare
    stated = [e.stated_payload_kg for e in model.effects if e.stated_payload_kg is not None]
    out = []
    for mass, where in dialects.of(tp).controller.payloads(tp):
        if not stated:
            out.append(f"{where}: the program's payload is {mass:g} kg; the model {model_path} has {', '.join(gravity)} "
                       "(its prediction depends on the load) but does not state the payload it was fitted at: "
                       "fit it with joint_compliance[payload=KG]")
        elif abs(mass - stated[0]) > PAYLOAD_TOLERANCE_KG:
            out.append(f"{where}: the program's payload is {mass:g} kg; the model {model_path} was fitted with {stated[0]:g} kg")
    return out


def _where(tp: Toolpath, row: int) -> str:
    return f"{tp.sources[int(tp.file[row])].path}, line {tp.line[row]}"


def _xyz(v) -> str:
    return "(" + ", ".join(f"{x:g}" for x in np.round(v, 3)) + ")"
