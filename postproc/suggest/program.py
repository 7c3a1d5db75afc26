"""A robot program that visits the chosen poses, written through the same event writers
``postproc convert`` uses (``Dialect.new_writer``): one joint move per pose, stopping
exactly there (zone fine), each preceded by a comment naming the pose to measure."""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np

from postproc.errors import EmitError, OutputCheckError
from postproc.programs import dialects
from postproc.programs.program_io import parse_program

DEFAULT_SPEED_MM_S = 250.0


def visiting_program(language: str, name: str, q_deg: np.ndarray, ids, speed_mm_s: float = DEFAULT_SPEED_MM_S) -> list[str]:
    """Texts of the program's files (``Dialect.new_program_paths`` order)."""
    lang = dialects.get(language, "--program-language")
    writer = lang.new_writer(name)
    if writer is None:
        able = [d.name for d in dialects.REGISTRY.values() if d.new_writer("x") is not None]
        raise EmitError(f"--program-language: cannot write a new {language} program ({' or '.join(able)})")
    writer.start(name)
    # Joint moves: the tool frame does not change where the robot goes, and a tooldata of
    # our own would need a load we do not know (a wrong one changes what is measured), so
    # the controller's tool0 and its load as set on the robot.
    writer.tool("tool0", np.eye(4))
    if hasattr(writer, "load"):
        writer.load(None)
    writer.speed(speed_mm_s)
    writer.zone(0.0)  # fine: the robot stands still at each pose while it is measured
    for ident, q in zip(ids, q_deg):
        writer.raw(f"measure pose {ident}")
        writer.move_joints(q)
    return writer.end()


def program_paths(language: str, output: Path) -> list[Path]:
    return dialects.get(language, "--program-language").new_program_paths(Path(output))


def check_program(language: str, paths: list[Path], texts: list[str], q_deg: np.ndarray) -> None:
    """Read the new program back with postproc's own reader (from a scratch folder, files
    named as they will be) and confirm it visits exactly these joints in this order; else
    an OutputCheckError, before anything is written."""
    with tempfile.TemporaryDirectory() as scratch:
        staged = [Path(scratch) / p.name for p in paths]
        for path, text in zip(staged, texts):
            path.write_bytes(text.encode("latin-1"))
        back = parse_program(staged[0], language).joints
    if back.shape != q_deg.shape or not np.allclose(back, q_deg, rtol=0, atol=1e-9):
        raise OutputCheckError(f"{paths[0]}: the program written reads back as {len(back)} joint targets that differ from the "
                               f"{len(q_deg)} chosen poses; nothing was written")


def language_of(output: Path, language: str | None) -> str:
    """The language to write: as given, else the one whose extension ``output`` has (among those that can write a new program)."""
    if language is not None:
        return dialects.get(language, "--program-language").name
    suffix = Path(output).suffix.lower()
    able = [d for d in dialects.REGISTRY.values() if d.new_writer("x") is not None]
    for d in able:
        if suffix in d.extensions:
            return d.name
    raise EmitError(f"--program-out {output}: cannot tell the language from '{suffix}'; give --program-language ({', '.join(d.name for d in able)})")
