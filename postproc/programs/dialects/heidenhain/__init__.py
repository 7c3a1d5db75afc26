"""Heidenhain Klartext (TNC conversational, ``.h``): reading, writing back, new programs."""

from __future__ import annotations

import re

import numpy as np

from postproc.errors import EmitError, InputError

from ...ir import SourceDoc, Toolpath
from ..base import Dialect
from .controller import TNC
from .parse import read_klartext
from .plane_solution import place_tilted
from .radius_comp import contour_for
from .writer import MODES, tcpm_text


class HeidenhainDialect(Dialect):
    name = "heidenhain"
    description = "Heidenhain Klartext (TNC 640 / iTNC 530 conversational)"
    extensions = (".h",)
    machine_program = True
    speed_to_mm_per_s = 1.0 / 60.0  # F is mm/min
    comment_pattern = r";[^\n]*"
    motion_words = "L, LN, C, CR, CT, LP or CP"
    controller = TNC

    def sniff(self, head: str) -> bool:
        return re.search(r"^\s*\d*\s*BEGIN PGM\s", head, re.MULTILINE) is not None

    def read_ir(self, sources: list[SourceDoc]) -> Toolpath:
        return read_klartext(sources[0])

    def emit_texts(self, original: Toolpath, modified: Toolpath) -> list[str]:
        """Changed numbers are written only where every target is determined by the text: a
        target the reader flagged (radius compensation, a tilted plane, a cycle, a value from
        the control) would be compensated from a position the machine does not take."""
        moved = ~np.isclose(modified.position, original.position, rtol=0, atol=0, equal_nan=True).all(axis=1)
        moved |= ~np.isclose(modified.ext, original.ext, rtol=0, atol=0, equal_nan=True).all(axis=1)
        _refuse_missing_words(original, modified)
        if moved.any() and not original.resolved.all():
            i = int(np.argmin(original.resolved))
            note = next((n for n in original.notes if n.startswith(f"line {int(original.line[i])}:")), "see the notes of `postproc inspect`")
            raise EmitError(f"{original.sources[int(original.file[i])].path}:{int(original.line[i])}: the target's position is not determined by the "
                            f"program text ({note}); nothing was written")
        return super().emit_texts(original, modified)

    def contour_for(self, tp: Toolpath, xyz: np.ndarray) -> Toolpath:
        """Under RL / RR the text holds the contour the TNC offsets: the contour whose offset path is ``xyz``."""
        return contour_for(tp, xyz)

    def for_machine(self, tp: Toolpath, machine) -> Toolpath:
        """The targets of a tilted plane (PLANE SPATIAL ... MOVE) placed on ``machine``: the TNC's rotary solution."""
        return place_tilted(tp, machine)

    def refuse_compensation(self, tp: Toolpath) -> None:
        """A tilted working plane is not compensated: the correction would change the PLANE's angles
        and with them the rotary solution the TNC takes, not numbers of the blocks under it."""
        plane = tp.extras.get("heidenhain.plane_line")
        if plane is not None and (plane > 0).any():
            i = int(np.argmax(plane > 0))
            raise InputError(f"{tp.sources[0].path}:{int(plane[i])}: targets in a tilted working plane (PLANE SPATIAL) are not compensated: "
                             "the correction would change the plane's angles and the rotary solution the TNC takes, not numbers of its blocks; "
                             "convert the program to M128 (convert --to heidenhain --rtcp tcpm) and compensate that")

    def insert_field(self, source: int, field: str, text: str) -> str:
        sign = "" if text.startswith("-") else "+"
        return f" {field.upper()}{sign}{text}"  # Klartext writes the sign: X+10

    rtcp_modes = MODES  # convert --to heidenhain --machine M [--rtcp tcpm]: the one mode, the default
    five_axis_modes = MODES  # written here (five_axis_text), not by the G-code emitter

    def five_axis_text(self, name, letters, tip, angles, rapid, feed, lines, header, tool=1) -> str:
        return tcpm_text(name, letters, tip, angles, rapid, feed, lines, header, tool)


def _refuse_missing_words(original: Toolpath, modified: Toolpath) -> None:
    """A changed coordinate that its block does not write (a modal axis of C, CR, CT, LP or
    CP, where no word is added) is refused naming the block, never left as it was."""
    moved = ~np.isclose(modified.position, original.position, rtol=0, atol=1e-9, equal_nan=True)
    absent = np.isnan(original.values[:, :3]) & (original.spans[:, :3, 1] < 0) & (original.insert_at[:, 1] < 0)[:, None]
    bad = moved & absent
    if bad.any():
        i, k = (int(v[0]) for v in np.nonzero(bad))
        raise EmitError(f"{original.sources[int(original.file[i])].path}:{int(original.line[i])}:1: {'XYZ'[k]} of this circle / polar block "
                        f"cannot be changed: the block does not write it (it is modal) and no word is added to a Klartext circle or polar block")


HEIDENHAIN = HeidenhainDialect()
