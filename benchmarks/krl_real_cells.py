"""KRL programs of real robot cells read with and without their other modules (--data).

Run: .venv/bin/python benchmarks/krl_real_cells.py [--why] CELL [CELL ...]
A CELL is a controller tree (the folder holding KRC/R1/Program and KRC/R1/System), e.g. a
checkout of HugoDanielson/ChinaMilling, Naqiu06/KUKA-Robotics or Aleynikovich/Zinkerreka
(not in this repository: no licence). Every .src under KRC/R1/Program that uses inline forms
(FDAT_ACT) is parsed alone and with KRC/R1/Program and KRC/R1/System/*.dat as its other
modules (and KRC/R1/Mada/$machine.dat, for $ROBROOT); prints the targets whose point is known (resolved) and those placed (point, frame
and tool known). ``--why``: every target not placed with --data, with what is unknown (its
point, or the name of its frame and tool) and the program's notes.
"""

from __future__ import annotations

import sys
from pathlib import Path

from postproc.errors import PostprocError
from postproc.programs import parse_program


def why_not(src: Path, tp) -> None:
    """The targets of one program not placed: point known?, frame and tool as named, then the notes."""
    ok = tp.placed()
    if ok.all():
        return
    for i in (~ok).nonzero()[0].tolist():
        frame, tool = tp.frame_names[tp.frame[i]], tp.tool_names[tp.tool[i]]
        print(f"  {src}:{tp.line[i]} {tp.target_name[i] or '(inline)'}: point {'known' if tp.resolved[i] else 'unknown'}; frame {frame}; tool {tool}")
    for note in tp.notes:
        print(f"    note: {note}")


def count(cells: list[Path], with_modules: bool, why: bool = False) -> tuple[int, int, int, int]:
    programs = targets = resolved = placed = 0
    for cell in cells:
        folder = cell / "KRC/R1/Program"
        machine = [p for p in [cell / "KRC/R1/Mada/$machine.dat"] if p.is_file()]  # $ROBROOT: where $WORLD is
        modules = [folder, *sorted((cell / "KRC/R1/System").glob("*.dat")), *machine] if with_modules else []
        for src in sorted(folder.rglob("*.src")):
            if "FDAT_ACT" not in src.read_text("latin-1").upper():
                continue
            try:
                tp = parse_program(src, modules=modules)
            except PostprocError as exc:
                print(f"refused: {exc}")
                continue
            if why:
                why_not(src, tp)
            programs, targets = programs + 1, targets + len(tp)
            resolved, placed = resolved + int(tp.resolved.sum()), placed + int(tp.placed().sum())
    return programs, targets, resolved, placed


def main() -> None:
    why = "--why" in sys.argv[1:]
    cells = [Path(p) for p in sys.argv[1:] if p != "--why"]
    for label, flag in (("alone", False), ("with --data", True)):
        programs, targets, resolved, placed = count(cells, flag, why and flag)
        print(f"{label:12s} {programs} programs, {targets} targets: {resolved} with their point known, {placed} placed")


if __name__ == "__main__":
    main()
