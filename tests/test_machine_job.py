"""Five-axis behind the ``Machine`` protocol, not a class or a suffix (issue 27).

``postproc compensate`` builds a ``CompensationRequest`` and calls
``postproc.jobs.compensate_files.compensate_files``, which asks the machine how its programs
are compensated (``Machine.own_job``): a job of its own, or the shared one. A five-axis-like
head defined here, outside the package, takes both ways, through the library entry and
through the command line itself; and nothing in cli/, jobs/ or cam/ chooses by the class
of our own machines.
"""

from __future__ import annotations

import ast
import io
from pathlib import Path

import numpy as np
import pytest
from rich.console import Console
from typer.testing import CliRunner

import postproc
import postproc.jobs.target_file
from postproc.cli import app
from postproc.compensation.machine import Machine
from postproc.compensation.request import CompensationRequest
from postproc.errors import InputError
from postproc.jobs.compensate_files import JobLog, compensate_files
from postproc.programs import emit_texts, parse_program

PACKAGE = Path(postproc.__file__).parent
PROGRAM = "G21 G90\nG0 X0 Y0 Z50\nG1 X100 Y20 Z5 F600\nG1 X250.5 Y-40 Z5\nG1 X300 Y300 Z10\nM30\n"
TOOL_MM = 150.0  # pivot to tool tip


class TiltingHead:
    """A five-axis head: X Y Z place the pivot, A tilts the tool about X, C turns it about Z.
    Commands are X Y Z (mm) A C (deg) of the tool tip; the real A axis sits 0.05 deg off and
    the linear axes carry a scale error, so the tip misses a little everywhere."""

    kind = "five-axis test head"
    source = "a head defined in the test"
    takes = frozenset({"programs", "output", "dialect", "tol_mm", "max_iter", "frames", "tools"})
    why_unused: dict = {}
    A_ERROR_DEG = 0.05
    SCALE = np.array([1.0002, 0.9997, 1.0001])

    @staticmethod
    def _axis(a_deg, c_deg):
        a, c = np.radians(a_deg), np.radians(c_deg)
        return np.stack([np.sin(a) * np.sin(c), -np.sin(a) * np.cos(c), np.cos(a)], axis=1)

    def forward(self, commands):
        commands = np.asarray(commands, dtype=float)
        poses = np.repeat(np.eye(4)[None], len(commands), axis=0)
        poses[:, :3, 3], poses[:, :3, 2] = commands[:, :3], self._axis(commands[:, 3], commands[:, 4])
        return poses

    def inverse(self, poses):
        poses = np.asarray(poses, dtype=float)
        axis = poses[:, :3, 2]
        a = np.degrees(np.arccos(np.clip(axis[:, 2], -1.0, 1.0)))
        c = np.degrees(np.arctan2(axis[:, 0], -axis[:, 1]))
        return np.column_stack([poses[:, :3, 3], a, c])

    def predict(self, commands):
        commands = np.asarray(commands, dtype=float)
        pivot = (commands[:, :3] + TOOL_MM * self._axis(commands[:, 3], commands[:, 4])) * self.SCALE
        return pivot - TOOL_MM * self._axis(commands[:, 3] + self.A_ERROR_DEG, commands[:, 4])

    def read_program(self, path, dialect=None, data=None):
        return parse_program(path, dialect, data=data)

    def write_texts(self, tp, new):
        return emit_texts(tp, new)

    # No own_job: it is optional, and without it the head takes the shared job (a machine
    # class written before own_job existed still works).


class HeadWithItsOwnJob(TiltingHead):
    """The same head, with a job of its own: it writes its output itself and says so."""

    def own_job(self, request):
        tp = self.read_program(request.programs[0])
        Path(request.output).write_text(f"; {len(tp)} targets, by the head's own job\n")
        return [f"own job: {len(tp)} targets written to {request.output}"]


def _log():
    out, err = io.StringIO(), io.StringIO()
    return JobLog(Console(file=out, width=400), Console(file=err, width=400)), out, err


def _request(tmp_path, machine, **more):
    (tmp_path / "part.nc").write_text(PROGRAM)
    return CompensationRequest(machine, programs=(str(tmp_path / "part.nc"),), output=str(tmp_path / "out.nc"),
                               frames={"G54": np.eye(4)}, **more)


def test_the_heads_are_machines():
    assert isinstance(TiltingHead(), Machine) and isinstance(HeadWithItsOwnJob(), Machine)

    class NoJob:  # everything but own_job, which is optional (tests/test_own_machine.py's Gantry has none)
        kind, source, takes, why_unused = "x", "y", frozenset(), {}
        forward = inverse = predict = read_program = write_texts = TiltingHead.forward

    assert isinstance(NoJob(), Machine)


def test_a_five_axis_like_head_takes_the_shared_job_through_the_public_entry(tmp_path):
    head = TiltingHead()
    request = _request(tmp_path, head, tol_mm=1e-5)
    log, out, err = _log()
    assert compensate_files(request, log) == 0
    tp, written = head.read_program(tmp_path / "part.nc"), head.read_program(tmp_path / "out.nc")
    goal = tp.base_poses()
    commands = head.inverse(written.base_poses())
    before = np.linalg.norm(head.predict(head.inverse(goal)) - goal[:, :3, 3], axis=1)
    after = np.linalg.norm(head.predict(commands) - goal[:, :3, 3], axis=1)
    assert before.min() > 0.1  # A's 0.05 deg at 150 mm: the tip misses every point as written
    assert after.max() < 0.002  # as written back (G-code keeps 3 decimals)
    lines = out.getvalue().splitlines()
    assert lines[0] == "compensated for the five-axis test head (a head defined in the test)"
    assert lines[1].startswith(f"{len(tp)} of {len(tp)} targets compensated (fixed point); predicted error RMS")
    assert err.getvalue() == ""


def test_a_head_with_its_own_job_runs_it_through_the_public_entry(tmp_path):
    log, out, _ = _log()
    assert compensate_files(_request(tmp_path, HeadWithItsOwnJob()), log) == 0
    assert out.getvalue() == f"own job: 4 targets written to {tmp_path / 'out.nc'}\n"
    assert (tmp_path / "out.nc").read_text() == "; 4 targets, by the head's own job\n"


@pytest.mark.parametrize("machine", [TiltingHead, HeadWithItsOwnJob])
def test_the_command_line_compensates_a_users_machine_the_same_way(tmp_path, monkeypatch, machine):
    """``postproc compensate`` with the model file read as the user's machine: the command
    takes the machine's way (its own job, or the shared one), as it does ours."""
    monkeypatch.setattr(postproc.jobs.target_file, "load_target", lambda path: machine())
    (tmp_path / "part.nc").write_text(PROGRAM)
    result = CliRunner().invoke(app, ["compensate", str(tmp_path / "part.nc"), "--model", str(tmp_path / "head.any"),
                                      "-o", str(tmp_path / "out.nc"), "--frame", "G54=0,0,0,0,0,0"])
    assert result.exit_code == 0, result.output
    again = tmp_path / "again"
    again.mkdir()
    log, out, _ = _log()
    assert compensate_files(_request(again, machine()), log) == 0
    assert (tmp_path / "out.nc").read_text() == (again / "out.nc").read_text()
    assert result.stdout.splitlines()[0] == out.getvalue().replace(str(again), str(tmp_path)).splitlines()[0]


def test_what_only_a_robot_does_is_refused_naming_the_machine(tmp_path):
    class TakesAll(TiltingHead):
        takes = TiltingHead.takes | {"out_dir", "subdivide", "stream"}

    (tmp_path / "out").mkdir()
    for more, option in (({"subdivide": True}, "--subdivide"), ({"stream": "always"}, "--stream")):
        with pytest.raises(InputError, match=f"{option}: only for a robot under a fitted error model, not a five-axis test head"):
            compensate_files(_request(tmp_path, TakesAll(), **more), _log()[0])
    request = CompensationRequest(TakesAll(), programs=(str(tmp_path / "part.nc"),) * 2, out_dir=tmp_path / "out")
    with pytest.raises(InputError, match="--out-dir: only for a robot"):
        compensate_files(request, _log()[0])


# --- nothing chooses by the class of our machines -------------------------------------------

def _classes_of(*modules: str) -> set[str]:
    """The names of the classes defined in these modules of postproc (our concrete machines,
    robots and their parts)."""
    names = set()
    for module in modules:
        tree = ast.parse((PACKAGE.parent / (module.replace(".", "/") + ".py")).read_text(encoding="utf-8"))
        names |= {node.name for node in tree.body if isinstance(node, ast.ClassDef)}
    return names


MACHINE_CLASSES = _classes_of("postproc.jobs.targets", "postproc.fivex.machine", "postproc.robot.robots")
CHOOSERS = ("cli", "jobs", "cam")  # the folders that run jobs: they ask the machine, never its class


def _named(node: ast.AST) -> set[str]:
    """Class names an isinstance's second argument names (a name, an attribute, a tuple of them)."""
    if isinstance(node, ast.Tuple):
        return set().union(*(_named(e) for e in node.elts))
    if isinstance(node, ast.Name):
        return {node.id}
    if isinstance(node, ast.Attribute):
        return {node.attr}
    return set()


def class_choices(source: str) -> list[tuple[int, str]]:
    """(line, class) of every isinstance / issubclass / ``type(x) is`` naming one of ours, and
    every file suffix compared with a model or machine file's (.toml, .json)."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in ("isinstance", "issubclass") and len(node.args) == 2:
            found += [(node.lineno, name) for name in sorted(_named(node.args[1]) & MACHINE_CLASSES)]
        elif isinstance(node, ast.Compare):
            parts = [node.left, *node.comparators]
            text = ast.unparse(node)
            if any(isinstance(p, ast.Call) and isinstance(p.func, ast.Name) and p.func.id == "type" for p in parts):
                found += [(node.lineno, name) for p in parts for name in sorted(_named(p) & MACHINE_CLASSES)]
            if ".suffix" in text and any(ext in text for ext in ("'.toml'", "'.json'", '".toml"', '".json"')):
                found.append((node.lineno, text))
    return found


def test_the_check_sees_a_choice_by_class_or_suffix():
    source = ("def f(m, p):\n    if isinstance(m.machine, FiveAxisTarget):\n        return 1\n"
              "    if isinstance(m, (int, jobs.targets.RobotTarget)):\n        return 2\n"
              "    if type(m) is RobotModel:\n        return 3\n"
              "    return p.suffix.lower() == '.toml' or isinstance(m, ErrorModel) or p.suffix == '.html'\n")
    assert class_choices(source) == [(2, "FiveAxisTarget"), (4, "RobotTarget"), (6, "RobotModel"), (8, "p.suffix.lower() == '.toml'")]


def test_cli_jobs_and_cam_ask_the_machine_never_its_class():
    assert {"RobotTarget", "FiveAxisTarget", "Machine", "RobotModel"} <= MACHINE_CLASSES
    bad = []
    for folder in CHOOSERS:
        for path in sorted((PACKAGE / folder).rglob("*.py")):
            rel = path.relative_to(PACKAGE.parent).as_posix()
            bad += [f"{rel}:{line}: {what}" for line, what in class_choices(path.read_text(encoding="utf-8"))]
    assert not bad, "a job chosen by our machine's class or a file suffix (ask the machine: Machine.own_job):\n" + "\n".join(bad)

