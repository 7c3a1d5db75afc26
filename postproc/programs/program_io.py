"""Programs as files: which dialect a file is, parse it, emit it, write the set atomically.

What differs between languages is asked of the dialect (``postproc.programs.dialects``); this
module only strings the steps together.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from postproc.errors import EmitError, OutputCheckError, OutputError
from postproc.files import write_all

from . import dialects
from .arcs import check_words
from .content import require_program
from .emit.load_plan import carried_loads
from .emit.readback import positions_read_back
from .emit.splice import TOLERANCE
from .emit.writer import drive, where
from .ir import F_POS, Kind, SourceDoc, Toolpath

DIALECTS = dialects.names()


def sniff(path: str | Path, data: bytes | None = None) -> str:
    """The dialect name of a program from its extension, or from its content when that is unknown."""
    return dialects.sniff(path, data).name


def language_of(tp: Toolpath):
    """The language ``tp`` was read in (its parser, writer and controller rules), for the
    steps below the languages that are handed it (``postproc.jobs.subdivide``)."""
    return dialects.of(tp)


def parse_program(path: str | Path, dialect: str | None = None, data: bytes | None = None, modules=()) -> Toolpath:
    """Parse a program file (or ``data`` read from it, e.g. standard input) into a Toolpath;
    ``modules``: other modules' files (or folders of them) whose global data it uses (KRL)."""
    lang = dialects.get(dialect) if dialect else dialects.sniff(path, data)
    return lang.parse(path, data, modules) if modules else lang.parse(path, data)


def with_robot(tp: Toolpath, robot) -> Toolpath:
    """``tp`` with what the robot's data determine placed (``Dialect.with_robot``), where a
    robot (a ``RobotModel``) is given; ``tp`` itself where none is."""
    return tp if robot is None else dialects.of(tp).with_robot(tp, robot)


def emit_texts(original: Toolpath, modified: Toolpath) -> list[str]:
    """New text of every source file of the program (unchanged files come back as they were)."""
    return dialects.of(original).emit_texts(original, modified)


def emit_files(original: Toolpath, modified: Toolpath, output: str | Path) -> dict[Path, str]:
    """{path: text} of every file to write for ``modified`` written at ``output``."""
    return dialects.of(original).emit(original, modified, Path(output))


def files_for(original: Toolpath, texts: list[str], output: str | Path) -> dict[Path, str]:
    """{path: text} to write for the new ``texts`` (one per source) at ``output``."""
    return dialects.of(original).files(original, texts, Path(output))


def refuse_stdout(tp: Toolpath) -> None:
    """Standard output carries one file: refused when target numbers live in another
    (KRL .dat or $config.dat), whose changes would be lost."""
    cart = tp.kind != Kind.ABSJ
    used = np.unique(tp.spans[cart][:, F_POS, 0])
    elsewhere = [tp.sources[int(i)].path for i in used if i > 0]
    if elsewhere:
        raise OutputError(f"-o -: targets of this program live in {', '.join(elsewhere)}, which standard output cannot carry; give -o PATH")


def refuse_overwrite(original: Toolpath, files: dict[Path, str], in_place: bool) -> None:
    """An output path that is one of the program's own files is refused unless ``in_place``."""
    if in_place:
        return
    inputs = {Path(doc.path).resolve() for doc in original.sources if doc.path != "-"}
    clash = [str(p) for p in files if Path(p).resolve() in inputs]
    if clash:
        raise OutputError(f"{', '.join(clash)}: the output would overwrite an input file; give another -o, or --in-place (keeps NAME.bak)")


def check_texts(original: Toolpath, modified: Toolpath, texts: list[str], rows: np.ndarray) -> None:
    """Re-parse the new ``texts`` (one per source) and confirm every target in ``rows``
    reads back where ``modified`` puts it, within the writing tolerance; else an OutputCheckError.
    Where only absolute position numbers changed, they are read back on their own instead
    (``emit.readback``: the same answer without the whole re-parse); anything else, or any
    doubt, takes the whole re-parse."""

    tol = TOLERANCE[F_POS] * (1 + 1e-6)
    if positions_read_back(original, modified, texts, rows, tol):
        return  # the same check without a whole re-parse (postproc.programs.emit.readback)
    lang = dialects.of(original)
    back = lang.parse_sources([SourceDoc(doc.path, text, doc.role) for doc, text in zip(original.sources, texts)])
    if len(back) != len(modified):
        raise OutputCheckError(f"{original.sources[0].path}: the new text has {len(back)} targets, the compensated program {len(modified)}; nothing was written")
    want, got = modified.position[rows], back.position[rows]
    bad = ~(np.abs(got - want) <= tol).all(axis=1)
    if bad.any():
        i = int(rows[np.nonzero(bad)[0][0]])
        raise OutputCheckError(
            f"{original.sources[int(original.file[i])].path}, line {original.line[i]}: the new text reads back as "
            f"{np.round(back.position[i], 4).tolist()}, not the compensated {np.round(modified.position[i], 4).tolist()}; nothing was written"
        )

    check_words(original, modified, back, rows)  # G2/G3 centre words as compensated


def write_set(files: dict[Path, str], backup: bool = False) -> None:
    """Write every program file of one job, all or none (see ``postproc.files.write_all``)."""
    write_all({Path(p): text.encode("latin-1") for p, text in files.items()}, backup=backup)  # encoding fails before any write


def write_texts(texts: list[str], outputs: list[str | Path]) -> None:
    """Write each program text to its output path (see ``write_set``)."""
    write_set(dict(zip(map(Path, outputs), texts)))


def write_program(tp: Toolpath, dialect: str, name: str = "converted", tool_load=None, arc_tol_mm: float | None = None,
                  conf: np.ndarray | None = None, robot=None) -> list[str]:
    """Texts of a new program in ``dialect`` with every target of ``tp`` (its files in
    ``Dialect.new_program_paths`` order); ``tool_load`` (emit.tool_load.ToolLoad) is the load
    every tool of it carries; without it, the load the input states is carried where it applies.
    ``arc_tol_mm``: helical and spiral G2/G3 are written as straight moves within this chord
    error (without it they are refused: no circular move holds them). ``conf``: (N, 4) the
    configuration data of every target in ``dialect``'s terms (``postproc.jobs.convert_conf``, from
    the joints the input's controller takes); without it, an input in another language whose
    joint motions need them in ``dialect`` (``Dialect.joint_motion_conf``) is refused. ``robot``:
    the robot the program runs on, for a writer that needs its own data (INFORM's pulses)."""
    require_program(tp)  # an empty input would give a program that does nothing
    lang = dialects.get(dialect, "--to")
    writer = lang.new_writer(name)
    if writer is None:
        able = [d.name for d in dialects.REGISTRY.values() if d.new_writer("x") is not None]
        raise EmitError(f"cannot write a new {dialect} program ({' or '.join(able)})")
    if robot is not None and hasattr(writer, "robot"):  # a writer that needs the robot's own data (INFORM: pulses of joint targets)
        writer.robot = robot
    if arc_tol_mm is not None and not arc_tol_mm > 0:
        raise EmitError(f"--arc-tol must be > 0 mm, got {arc_tol_mm}")
    source = dialects.of(tp)  # emit imports no language: the input's rules are given to it here
    # the program's own load, or --tool-load's; helices as straight moves within arc_tol_mm
    loads = carried_loads(tp, tool_load, source.controller.stated_loads(tp))
    if source is not lang:  # one controller's configuration data mean nothing to another's (ABB cfx is no Fanuc CONFIG): not carried
        if conf is None:
            _refuse_joint_motions_without_conf(tp, lang)
        tp = replace(tp, conf=np.full_like(tp.conf, np.nan) if conf is None else np.asarray(conf, dtype=float))
    elif conf is not None:
        raise EmitError(f"configuration data are computed for a program converted to another language, not for {dialect} to {dialect}")
    return drive(writer, tp, name, loads=loads, arc_tol_mm=arc_tol_mm, source=source)


def _refuse_joint_motions_without_conf(tp: Toolpath, lang) -> None:
    """An EmitError at the first joint motion to a Cartesian target where ``lang``'s joint
    motions take their posture from configuration data the input does not state in its terms."""
    if lang.joint_motion_conf is None:
        return
    joint = np.nonzero(np.isin(tp.kind, (Kind.JOINT, Kind.RAPID)))[0]
    if joint.size:
        raise EmitError(f"{where(tp, int(joint[0]))}: a joint motion to a Cartesian target: {lang.name}'s joint motion takes the posture "
                        f"its {lang.joint_motion_conf} names, which only the robot's joints determine ({joint.size} such motion(s)); "
                        "give --robot (the robot the program runs on) to compute it from the joints the input's controller takes")
