"""ABB RAPID: one module (.mod, .modx, .prg, .sys), or a program file (.pgf) and its modules."""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from pathlib import Path

from postproc.errors import InputError
from postproc.robot.kinematics import abb_confdata

from ...ir import SourceDoc, Toolpath
from ..base import Dialect, aggregate_around, first_statement, read_bytes
from .controller import IRC5
from .facts import with_controller_facts
from .load_facts import with_load_facts
from .parse import parse_modules
from .placing import set_work_object
from .targets import set_robtarget_conf
from .writer import RapidWriter


class RapidDialect(Dialect):
    name = "rapid"
    description = "ABB RAPID module, or a program file (.pgf) with its modules"
    controller = IRC5
    extensions = (".mod", ".modx", ".prg", ".sys", ".pgf")

    def sniff(self, head: str) -> bool:
        return "MODULE " in head and ("ENDMODULE" in head or "PROC " in head)

    comment_pattern = r"![^\n]*"
    motion_words = "MoveJ, MoveL, MoveC, MoveAbsJ or another Move instruction"

    def missing_program(self, role: str, text: str) -> tuple[int, str] | None:
        """A module file starts with MODULE name and ends with ENDMODULE (RAPID kernel
        reference, 'Module declarations'); the controller loads nothing else."""
        if role == "pgf" or re.search(r"^[ \t]*MODULE[ \t]", text, re.MULTILINE | re.IGNORECASE):
            return None
        return first_statement(text, self.comment_pattern), "no MODULE in this file: the controller loads RAPID code as 'MODULE name' ... ENDMODULE"

    def read_sources(self, path: str | Path, data: bytes | None = None) -> list[SourceDoc]:
        """A module on its own; or a program file (.pgf) and every module it lists, which
        share their data (robtargets, tools, work objects) as the task's modules do."""
        if Path(str(path)).suffix.lower() != ".pgf":
            return super().read_sources(path, data)
        path = Path(path)
        data = read_bytes(path) if data is None else data
        docs = [SourceDoc(str(path), data.decode("latin-1"), "pgf")]
        for module in _pgf_modules(path, data):
            if not (path.parent / module).is_file():
                raise InputError(f"{path}: module {module} listed in the program file is not in {path.parent}")
            docs.append(SourceDoc.read(path.parent / module, "module"))
        return docs

    def read_ir(self, sources: list[SourceDoc]) -> Toolpath:
        return with_load_facts(with_controller_facts(parse_modules(sources)))

    def target_literal(self, text, first_number):
        return aggregate_around(text, first_number, "[", 2)  # [[x,y,z],[q],[conf],[ext]]

    def place_workpiece(self, text, frame_name, new_frame, path):
        return set_work_object(text, frame_name, new_frame, path)

    def output_paths(self, original: Toolpath, output: Path) -> list[Path]:
        """A module at ``output``; a program file at ``output`` with its modules beside it
        (in the same places relative to it as in the input)."""
        first = original.sources[0]
        if first.role != "pgf":
            return [Path(output)]
        folder = Path(first.path).parent
        return [Path(output)] + [Path(output).parent / Path(doc.path).relative_to(folder) for doc in original.sources[1:]]

    def travels_with_program(self, doc: SourceDoc) -> bool:
        return True  # a program is all its modules

    point_name_limit = 32  # RAPID identifiers: at most 32 characters (RAPID overview, "Identifiers")
    arm_conf_column = 3  # cfx (shoulder, elbow, wrist); cf1, cf4, cf6 are quadrants
    statement_end = ";"

    def conf_of_joints(self, robot, q_deg):
        return abb_confdata(robot, q_deg).astype(float)

    def set_conf_text(self, text: str, conf) -> str:
        return set_robtarget_conf(text, conf)

    def new_writer(self, name: str):
        return RapidWriter(name)


def _pgf_modules(path: Path, data: bytes) -> list[str]:
    """The module file names a RobotWare program file lists (<Program><Module>x.mod</Module>...)."""
    try:
        root = ET.fromstring(data)
    except ET.ParseError as exc:
        line, column = exc.position
        raise InputError(f"{path}:{line}:{column + 1}: not a RAPID program file ({exc})") from None
    modules = [m.text.strip() for m in root.iter("Module") if m.text and m.text.strip()]
    if not modules:
        raise InputError(f"{path}: the program file lists no <Module>")
    return modules


RAPID = RapidDialect()
