"""KUKA KRL: a .src program with its .dat and the robot's $config.dat."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from postproc.robot.kinematics import kuka_status_turn

from ...ir import SourceDoc, Toolpath
from ..base import Dialect, aggregate_around, first_statement, read_bytes
from .controller import KRC
from .facts import with_controller_facts
from .load_facts import with_load_facts
from .modules import module_docs
from .parse import KrlParser
from .placing import set_base
from .stream import RULES
from .tool_relative import held_and_moved, write_steps
from .writer import KrlWriter

CONFIG_DAT = "$config.dat"  # the robot's global data list (BASE_DATA, TOOL_DATA, global points)


class KrlDialect(Dialect):
    name = "krl"
    description = "KUKA KRL (.src with its .dat and $config.dat)"
    controller = KRC
    extensions = (".src", ".sub")
    comment_pattern = r"[;&][^\n]*"  # comments and the &ACCESS / &REL header lines
    motion_words = "PTP, LIN, CIRC, SPTP, SLIN, SCIRC or their _REL forms"

    def missing_program(self, role: str, text: str) -> tuple[int, str] | None:
        """A .src runs from its DEF (KSS 8.x operating and programming manual, 'Structure
        of a KRL program'): without one the controller does not select it."""
        if role != "src" or re.search(r"^[ \t]*(?:GLOBAL[ \t]+)?DEF[ \t]", text, re.MULTILINE | re.IGNORECASE):
            return None
        return first_statement(text, self.comment_pattern), "no DEF in this .src: KSS runs a program from 'DEF name( )' to END; give the program's .src"

    def sniff(self, head: str) -> bool:
        # A data list on its own starts with DEFDAT; a program with DEF and its motions.
        return "DEFDAT " in head or ("DEF " in head and ("PTP " in head or "LIN " in head or "END" in head))

    def read_sources(self, path: str | Path, data: bytes | None = None) -> list[SourceDoc]:
        """The .src (or a .dat on its own), its .dat of the same name, and $config.dat of its folder."""
        path = Path(path)
        if data is None:
            data = read_bytes(path)
        own_role = "dat" if path.suffix.lower() == ".dat" else "src"
        docs = [SourceDoc(str(path), data.decode("latin-1"), own_role)]
        if str(path) == "-":
            return docs  # standard input: no files beside it
        dat = path.with_suffix(".dat")
        if own_role == "src" and dat.is_file():
            docs.append(SourceDoc.read(dat, "dat"))
        config = path.parent / CONFIG_DAT
        if config.is_file() and path.name.lower() != CONFIG_DAT:
            docs.append(SourceDoc.read(config, "config"))
        return docs

    def emit_texts(self, original: Toolpath, modified: Toolpath) -> list[str]:
        """The splice, with LIN_REL / PTP_REL ... #TOOL steps written in the tool frame (tool_relative.py)."""

        held, steps = held_and_moved(original, modified)
        texts = super().emit_texts(original, held)
        return write_steps(texts, original, modified, steps, self.parse_sources, self.insert_field) if steps.any() else texts

    def module_sources(self, program, paths) -> list[SourceDoc]:
        """Other modules' data lists (.dat: their GLOBAL points) and modules (.src: their
        functions), or folders of them (modules.py)."""
        return module_docs(program, paths) if paths else []

    def read_ir(self, sources: list[SourceDoc]) -> Toolpath:
        return with_load_facts(with_controller_facts(KrlParser(sources).parse()))

    def target_literal(self, text, first_number):
        return aggregate_around(text, first_number, "{", 1)  # {X .., S .., T ..}

    def place_workpiece(self, text, frame_name, new_frame, path):
        return set_base(text, new_frame, path)

    def stream_rules(self):
        return RULES

    def insert_field(self, source: int, field: str, text: str) -> str:
        return f", {field.upper()} {text}"  # one more component of the aggregate

    def output_paths(self, original: Toolpath, output: Path) -> list[Path]:
        """The .src at ``output``, its .dat beside it (same name), $config.dat in that folder."""
        output = Path(output)
        where = {"src": output, "dat": output.with_suffix(".dat"), "config": output.parent / CONFIG_DAT}
        in_place = str(original.sources[0].path) != "-" and output.resolve() == Path(original.sources[0].path).resolve()

        def other(doc):  # another module's file (--data): its own place when in place, else beside OUT
            return Path(doc.path) if in_place else output.parent / Path(doc.path).name

        kept = {"src", "dat"} | ({"config"} if not in_place else set())
        return [where[doc.role] if doc.role in kept else other(doc) for doc in original.sources]

    def travels_with_program(self, doc: SourceDoc) -> bool:
        return doc.role in ("src", "dat")  # a module is its .src and its .dat

    point_name_limit = 24  # KRL names: at most 24 characters (KSS 8 programming manual, "Names")
    arm_conf_column = 0  # Status (overhead, elbow, wrist flip); Turn is the joints' signs

    def conf_of_joints(self, robot, q_deg):
        """S and T of new points (LIN ignores them; a PTP to the point later would take them)."""
        status, turn = kuka_status_turn(robot, q_deg)
        return np.column_stack([status, turn, np.full((len(status), 2), np.nan)])

    def set_conf_text(self, text: str, conf) -> str:
        """The S and T components of a copied aggregate set to ``conf`` (left out where absent)."""
        for name, value in (("S", conf[0]), ("T", conf[1])):
            if np.isfinite(value):
                text = re.sub(rf"([{{,][ \t]*){name}[ \t]+\d+", lambda m: f"{m.group(1)}{name} {int(value)}", text, count=1, flags=re.IGNORECASE)
        return text

    def new_writer(self, name: str):
        return KrlWriter(name)

    def new_program_paths(self, output: Path) -> list[Path]:
        return [Path(output), Path(output).with_suffix(".dat")]


KRL = KrlDialect()
