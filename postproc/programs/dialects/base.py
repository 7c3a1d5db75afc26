"""The Dialect interface: everything postproc knows about one robot or CNC language.

A dialect owns: recognising its files (``extensions``, ``sniff``), the set of files a
program spans (``read_sources``), parsing them to the IR (``parse_sources``; frames,
tools and bases are resolved there by the language's rules), the controller that runs the
language by default (``controller``: its rules live in ``postproc.programs.controller.Controller``
subclasses, one per controller, in the language's package), and writing back: ``emit``
returns the new text of every file that must be written, keyed by path, so the caller
writes one all-or-nothing set and cannot forget a file. The rest of postproc reaches a
dialect only through this interface and the registry in ``postproc.programs.dialects``.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from postproc.errors import EmitError, InputError, ParseError

from ..controller import GENERIC, Controller
from ..emit.insert import insert_points
from ..emit.splice import splice
from ..ir import SourceDoc, Toolpath
from . import bom


class Dialect:
    """Base class; a language overrides what differs from these defaults."""

    name: str = ""
    description: str = ""
    extensions: tuple[str, ...] = ()  # lower case, with the dot
    #: programs of this language drive machine axes (a CNC: five-axis emitters and machine
    #: kinematics apply), not a robot controller's Cartesian targets
    machine_program: bool = False
    #: the controller that runs this language's programs unless told otherwise: its rules
    #: (configuration data, interpolation, loads) are what compensation asks (postproc.programs.controller)
    controller: Controller = GENERIC
    #: the program's speeds (as the IR keeps them) times this are mm/s (G-code feeds: mm/min)
    speed_to_mm_per_s: float = 1.0
    #: a regular expression of one comment (or header line) in the language
    comment_pattern: str = "(?!)"
    #: the statements that move, for messages
    motion_words: str = "motion statements"

    # ---------------------------------------------------------------- reading
    def sniff(self, head: str) -> bool:
        """True if ``head`` (the first 4 KB of a file, upper case) is a program of this language."""
        return False

    def read_sources(self, path: str | Path, data: bytes | None = None) -> list[SourceDoc]:
        """Every file of the program at ``path`` (the program first); ``data`` is its bytes
        when already read (standard input: then the program's other files are not looked for)."""
        if data is None:
            data = read_bytes(path)
        return [SourceDoc(str(path), data.decode("latin-1"), "program")]

    def parse_sources(self, sources: list[SourceDoc]) -> Toolpath:
        """The IR of a program from its source files (as ``read_sources`` gives them); a
        UTF-8 byte order mark is read past and kept (``bom``)."""
        try:
            return bom.restored(self.read_ir(bom.blanked(sources)), sources)
        except ParseError as exc:
            raise bom.editor_columns(exc, sources) from None

    def read_ir(self, sources: list[SourceDoc]) -> Toolpath:
        """The IR of the program (the language's parser; no byte order mark in the texts)."""
        raise NotImplementedError

    def parse(self, path: str | Path, data: bytes | None = None, modules=()) -> Toolpath:
        return self.parse_sources(self.read_sources(path, data) + self.module_sources(path, modules))

    def with_robot(self, tp: Toolpath, robot) -> Toolpath:
        """``tp`` with what only the robot's own data determine filled in, where a robot is
        known (``inspect --robot``, ``convert --robot``, the model's robot of ``compensate`` and
        ``predict``): INFORM's pulse positions become joint angles. Most languages need none."""
        return tp

    def missing_program(self, role: str, text: str) -> tuple[int, str] | None:
        """(offset, why) where a file of ``role`` is not a program the controller would run
        (KRL: a .src without DEF); None where it is (``program_content.require_program``)."""
        return None

    def module_sources(self, program: str | Path, paths) -> list[SourceDoc]:
        """Other modules' files the program uses (``--data``): KRL only."""
        if paths:
            raise InputError(f"{program}: --data (other modules' data lists) is for KRL programs, not {self.name}")
        return []

    # ---------------------------------------------------------------- writing
    def insert_field(self, source: int, field: str, text: str) -> str | None:
        """Text that adds a component a target leaves out (``LIN {X 1}`` without Y), or None
        where the language cannot take one."""
        return None

    def output_paths(self, original: Toolpath, output: Path) -> list[Path]:
        """Where each source file of ``original`` goes when the program is written to
        ``output``: the program there, any other file beside it under its own name."""
        output = Path(output)
        return [output] + [output.parent / Path(doc.path).name for doc in original.sources[1:]]

    def travels_with_program(self, doc: SourceDoc) -> bool:
        """True for a file written with the program even when unchanged (KRL's .dat)."""
        return doc.role == "program"

    def emit_texts(self, original: Toolpath, modified: Toolpath) -> list[str]:
        """New text of every source file, in ``original.sources`` order (unchanged ones as they were)."""
        return splice(original, modified, self.insert_field)

    def files(self, original: Toolpath, texts: list[str], output: Path) -> dict[Path, str]:
        """{path: text} to write for the new ``texts`` of the program at ``output``: every
        file that changed and every file that travels with the program."""
        paths = self.output_paths(original, output)
        if len(paths) != len(original.sources) or len(texts) != len(original.sources):
            raise EmitError(f"{self.name}: {len(original.sources)} source files, {len(texts)} texts and {len(paths)} output paths: no file may be left out")
        written = [(path, text, doc) for path, text, doc in zip(paths, texts, original.sources) if text != doc.text or self.travels_with_program(doc)]
        clash = {p for p in (w[0] for w in written) if sum(Path(q).resolve() == Path(p).resolve() for q, _, _ in written) > 1}
        if clash:  # two changed files of one job (KRL: two modules' xPoints.dat) would land on one path
            raise EmitError(f"{', '.join(map(str, sorted(clash)))}: two changed input files ({', '.join(d.path for q, _, d in written if q in clash)}) would be written to this one path; nothing was written")
        return {path: text for path, text, _ in written}

    def emit(self, original: Toolpath, modified: Toolpath, output: Path) -> dict[Path, str]:
        """{path: text} of every file to write for ``modified`` at ``output`` (see ``files``)."""
        return self.files(original, self.emit_texts(original, modified), output)

    # ------------------------------------------------------- new targets (subdividing)
    #: longest name of a declared point (0: the language has no named points)
    point_name_limit: int = 0
    # which column of conf_of_joints is the arm configuration (shoulder, elbow, wrist), the rest
    # being turn data; None where the language states no configuration
    arm_conf_column: int | None = None
    #: what a joint motion to a Cartesian target takes its posture from, where a new program
    #: must state it (Fanuc's CONFIG); None: the language's joint motions need none written
    joint_motion_conf: str | None = None
    #: what ends a statement that may run over several lines ("\n": one line each)
    statement_end: str = "\n"

    def conf_of_joints(self, robot, q_deg: np.ndarray) -> np.ndarray:
        """Configuration data (N, 4) a new target reached at joints q (N, 6) is written with
        (NaN: the copy keeps the data of the target it was copied from)."""
        return np.full((len(q_deg), 4), np.nan)

    def set_conf_text(self, text: str, conf: np.ndarray) -> str:
        """``text`` (a copied target's declaration or motion) with configuration data ``conf``."""
        return text

    def clone_motion(self, text: str, where: str) -> str:
        """A copy of the motion statement ``text`` to drive to a new point before it (e.g.
        without a block number); an EmitError where the statement does more than move."""
        return text

    def insert_points(self, tp: Toolpath, points: list) -> tuple[list[SourceDoc], list[str]]:
        """New sources with new targets (``postproc.programs.emit.insert.NewPoint``) written before the
        motions they subdivide, the language's way, and each new point's name."""
        return insert_points(self, tp, points)

    def place_workpiece(self, text: str, frame_name: str, new_frame: np.ndarray, path: str) -> str:
        """``text`` (the program's main file) with its workpiece frame ``frame_name`` set to
        ``new_frame`` (base_T_workpiece), for ``postproc place -o``."""
        raise EmitError(f"{path}: writing a placed {self.name} program is not supported")

    def target_literal(self, text: str, first_number: int) -> tuple[int, int]:
        """(start, end) of the target literal (the aggregate holding its configuration data)
        whose first number starts at ``first_number``, for writing its configuration data."""
        raise EmitError(f"writing configuration data into a {self.name} program is not supported")

    # ------------------------------------------------------------- streaming
    def stream_rules(self) -> "StreamRules | None":
        """How a long program of this language may be compensated in chunks
        (``postproc.jobs.stream``), or None: its programs are always read whole."""
        return None

    # ------------------------------------------------------------ new programs
    def new_writer(self, name: str):
        """An event writer (see postproc.programs.emit.writer) for a new program, or None."""
        return None

    #: RTCP modes ``convert --to`` this language takes (the first the default where there is one;
    #: None: every mode of postproc.jobs.five_axis.emit, G-code's)
    rtcp_modes: tuple[str, ...] | None = None
    #: RTCP modes in which this language writes new five-axis programs itself
    #: (``five_axis_text``; empty: written as G-code by postproc.jobs.five_axis.emit)
    five_axis_modes: tuple[str, ...] = ()

    def five_axis_text(self, name: str, letters: tuple[str, ...], tip: np.ndarray, angles: np.ndarray, rapid: np.ndarray,
                       feed: np.ndarray, lines: np.ndarray, header: list[str], tool: int = 1) -> str:
        """A new five-axis program: tool tips (N, 3) mm, rotary positions (N, 2) deg of the
        machine's axes ``letters``, rapid flags, tip feeds mm/min, the input lines (messages)."""
        raise EmitError(f"{self.name} does not write five-axis programs itself")

    # ------------------------------------------------- five-axis compensation hooks
    def for_machine(self, tp: Toolpath, machine) -> Toolpath:
        """``tp`` with what the controller decides by its machine placed (Klartext PLANE: the
        rotary solution); as it is by default."""
        return tp

    def contour_for(self, tp: Toolpath, xyz: np.ndarray) -> Toolpath:
        """``tp`` whose text numbers give the tool path ``xyz`` (N, 3) under cutter radius
        compensation (Klartext RL / RR: the contour the control offsets). Default: the tool path
        itself, which the compensate read-back then refuses where the text holds a contour."""
        return tp.with_positions(xyz)

    def refuse_compensation(self, tp: Toolpath) -> None:
        """An InputError where the text cannot carry a five-axis compensation as block numbers
        (Klartext: a tilted plane); nothing by default."""

    def new_program_paths(self, output: Path) -> list[Path]:
        """Paths of the files a new program written to ``output`` consists of."""
        return [Path(output)]


@dataclass(frozen=True)
class StreamRules:
    """What ``postproc.jobs.stream`` needs from a language to cut a long program into chunks.

    A chunk after the first is parsed as: the program's header (its lines before the first
    ``move`` line, any target lines in it blanked), one line from ``restate`` that puts the
    parser where the program is after the previous chunk's last target, the chunk's lines,
    and ``tail`` (what closes a program, KRL's END) unless it is the last chunk. Chunks are
    cut only between ``body`` lines: lines that change no state but the position (moves,
    comments, M codes, ...); the restated target is checked against the previous chunk's
    last one (position, orientation, frame, tool, speed, motion kind) before it is used."""

    move: re.Pattern  # a line that starts the body: one plain Cartesian move
    body: re.Pattern  # (?:LINE\n)*: a run of lines the chunks may be cut between
    restate: Callable[[Toolpath, np.ndarray], str]  # (last target as a 1-row Toolpath, its carried field values (NF,)) -> a line
    tail: str = ""
    # (a chunk's bytes) -> a bytes pattern that tells one body line ('\n' included) from its
    # shape, the line with every digit written 0, or None where shapes do not tell for this
    # chunk: a long program repeats a few shapes, so ``body`` then runs once per shape.
    body_shape: Callable[[bytes], "re.Pattern | None"] | None = None


def plain_number(value: float) -> str:
    """``value`` exactly (shortest round trip), without an exponent: what a parser reads back as the same float."""
    return np.format_float_positional(float(value), unique=True, trim="-")


NUMBER = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"  # a plain decimal number literal


def short_number(value: float, decimals: int) -> str:
    """``value`` with at most ``decimals`` decimals and no trailing zeros ('-0' is '0')."""
    text = f"{value:.{decimals}f}".rstrip("0").rstrip(".")
    return "0" if text in ("-0", "") else text


def first_statement(text: str, comment: str) -> int:
    """Offset of the first character that is neither blank nor inside a comment (``comment``:
    a regular expression of one comment); the text's length when there is none."""
    return re.compile(rf"(?:\s+|{comment})*").match(text).end()


def read_bytes(path: str | Path) -> bytes:
    try:
        return Path(path).read_bytes()
    except OSError as exc:
        raise InputError(f"{path}: cannot read ({exc.strerror})") from None


def read_head(path: str | Path, size: int = 4096) -> bytes:
    """The first ``size`` bytes of a file (enough to tell its language)."""
    try:
        with open(path, "rb") as fh:
            return fh.read(size)
    except OSError as exc:
        raise InputError(f"{path}: cannot read ({exc.strerror})") from None


def aggregate_around(text: str, first_number: int, opener: str, depth: int) -> tuple[int, int]:
    """(start, end) of the aggregate whose first number starts at ``first_number``: ``depth``
    ``opener`` brackets back from it (whitespace and a component name between), to its match."""
    closer = {"[": "]", "{": "}"}[opener]
    start = first_number
    for _ in range(depth):
        start = text.rfind(opener, 0, start)
        if start < 0:
            raise EmitError(f"no '{opener}' before offset {first_number}: not a target literal")
    level = 0
    for end in range(start, len(text)):
        level += (text[end] == opener) - (text[end] == closer)
        if level == 0:
            return start, end + 1
    raise EmitError(f"target literal at offset {start} is not closed")
