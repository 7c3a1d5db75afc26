"""Stäubli VAL3: an application folder with its project (.pjx), programs (.pgx) and data (.dtx).

A program is read with everything the controller runs it with: its data file (the points,
frames, tools and motion descriptors its motions name) and the programs it calls, all from
the application's folder. Compensating rewrites numbers of the data file, so every file of
the application is written together (``travels_with_program``).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from postproc.errors import InputError

from ...ir import SourceDoc, Toolpath
from ..base import Dialect, read_bytes
from .code import called_programs
from .controller import CS9, config_of_joints
from .parse import parse_application
from .writer import Val3Writer


class Val3Dialect(Dialect):
    name = "val3"
    description = "Stäubli VAL3 program (.pgx) with its application's data (.dtx), or the project (.pjx: its start program)"
    extensions = (".pgx", ".pjx")
    comment_pattern = r"//[^\n]*"
    motion_words = "movej, movel or movec"
    controller = CS9

    def sniff(self, head: str) -> bool:
        return "STAUBLI.COM/ROBOTICS/VAL3" in head

    def read_sources(self, path: str | Path, data: bytes | None = None) -> list[SourceDoc]:
        """The program (a .pjx: its start.pgx), the application's data file and the
        programs it calls (found by name in its folder), the project file last."""
        path = Path(path)
        if data is not None and str(path) in ("-", ""):
            return [SourceDoc(str(path), data.decode("latin-1"), "program")]
        folder = path.parent
        project = path if path.suffix.lower() == ".pjx" else _only(folder, "*.pjx")
        entry = folder / "start.pgx" if path.suffix.lower() == ".pjx" else path
        if path.suffix.lower() == ".pjx" and not entry.is_file():
            raise InputError(f"{path}: no start.pgx beside the project: give the program (.pgx) to read")
        text = (data if data is not None and entry == path else read_bytes(entry)).decode("latin-1")
        docs = [SourceDoc(str(entry), text, "program")]
        docs.append(SourceDoc.read(_data_file(entry, project), "data"))
        queue, seen = [text], {entry.stem}
        while queue:
            for name in called_programs(queue.pop()):
                callee = folder / f"{name}.pgx"
                if name not in seen and callee.is_file():
                    seen.add(name)
                    docs.append(SourceDoc.read(callee, "program"))
                    queue.append(docs[-1].text)
        if project is not None:
            docs.append(SourceDoc.read(project, "project"))
        return docs

    def read_ir(self, sources: list[SourceDoc]) -> Toolpath:
        return parse_application(sources)

    def travels_with_program(self, doc: SourceDoc) -> bool:
        return True  # an application is its whole folder: programs, data and project together

    def insert_field(self, source: int, field: str, text: str) -> str | None:
        """A pointRx / jointRx field the data left out (it was 0): a new attribute."""
        name = {"o1": "rx", "o2": "ry", "o3": "rz"}.get(field, field)
        return f' {name}="{text}"' if name in ("x", "y", "z", "rx", "ry", "rz", "j1", "j2", "j3", "j4", "j5", "j6") else None

    arm_conf_column = 0

    def conf_of_joints(self, robot, q_deg):
        out = np.full((len(q_deg), 4), np.nan)
        out[:, :3] = config_of_joints(robot, q_deg)
        return out

    # ---------------------------------------------------------- new programs
    def new_writer(self, name: str):
        return Val3Writer(name)

    def new_program_paths(self, output: Path) -> list[Path]:
        """A new application: the program at ``output`` (.pgx), its data and project beside it."""
        output = Path(output)
        return [output, output.with_suffix(".dtx"), output.with_suffix(".pjx")]


def _only(folder: Path, pattern: str) -> Path | None:
    found = sorted(folder.glob(pattern))
    return found[0] if len(found) == 1 else None


def _data_file(program: Path, project: Path | None) -> Path:
    """The application's data file: the one its project lists, else the only .dtx beside it."""
    folder = program.parent
    if project is not None:
        listed = re.findall(r"<Data\s+file\s*=\s*\"([^\"]+)\"", project.read_text(encoding="latin-1"))
        if listed:
            data = folder / listed[0].replace("\\", "/")
            if not data.is_file():
                raise InputError(f"{project}: lists the data file {listed[0]}, which is not in {folder}")
            return data
    data = _only(folder, "*.dtx")
    if data is None:
        raise InputError(f"{program}: no project (.pjx) and not exactly one data file (.dtx) beside it: the application's data cannot be found")
    return data


VAL3 = Val3Dialect()
