"""KRL programs of real robot cells read with and without their other modules (--data).

Run: .venv/bin/python benchmarks/krl_real_cells.py CELL [CELL ...]
A CELL is a controller tree (the folder holding KRC/R1/Program and KRC/R1/System), e.g. a
checkout of HugoDanielson/ChinaMilling, Naqiu06/KUKA-Robotics or Aleynikovich/Zinkerreka
(not in this repository: no licence). Every .src under KRC/R1/Program that uses inline forms
(FDAT_ACT) is parsed alone and with KRC/R1/Program and KRC/R1/System/*.dat as its other
modules (and KRC/R1/Mada/$machine.dat, for $ROBROOT); prints the targets whose point is known (resolved) and those placed (point, frame
and tool known).
"""

from __future__ import annotations

import sys
from pathlib import Path

from postproc.errors import PostprocError
from postproc.programs import parse_program


def count(cells: list[Path], with_modules: bool) -> tuple[int, int, int, int]:
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
            programs, targets = programs + 1, targets + len(tp)
            resolved, placed = resolved + int(tp.resolved.sum()), placed + int(tp.placed().sum())
    return programs, targets, resolved, placed


def main() -> None:
    cells = [Path(p) for p in sys.argv[1:]]
    for label, flag in (("alone", False), ("with --data", True)):
        programs, targets, resolved, placed = count(cells, flag)
        print(f"{label:12s} {programs} programs, {targets} targets: {resolved} with their point known, {placed} placed")


if __name__ == "__main__":
    main()
