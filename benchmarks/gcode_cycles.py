"""G-code parse throughput (lines/s, wall and CPU) on plain motion and on canned-cycle drilling.

Run: .venv/bin/python benchmarks/gcode_cycles.py [--lines 1000000] [--holes 100000]
The plain program is benchmarks/parse.py's G-code program (vectorised resolver); the drill
program is one G81 followed by a hole-only block per hole (block-by-block reader, runs of
holes expanded at once: 3 targets a hole). CPU seconds are given beside the wall time
because on a shared machine the wall time is mostly waiting for a core. Best of 2 runs.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path


def write_plain(path: Path, n: int) -> None:
    with open(path, "w", encoding="latin-1") as fh:
        fh.write("G21 G90 G17\nG0 X0 Y0 Z5\nF1500\n")
        for i in range(n - 4):
            fh.write(f"G1 X{(i % 400) * 0.5:.3f} Y{(i // 400) % 400:.3f} Z{-1 - (i % 7) * 0.125:.3f}\n")
        fh.write("M2\n")


def write_drill(path: Path, holes: int) -> None:
    with open(path, "w", encoding="latin-1") as fh:
        fh.write("G21 G17 G90 F100\nG0 X0 Y0 Z5\nG81 R1 Z-2 X0 Y0\n")
        for i in range(holes):
            fh.write(f"X{(i % 300) * 2.5:.3f} Y{(i // 300) * 2.5:.3f}\n")
        fh.write("G80\nM2\n")


def measure(path: Path) -> tuple[int, int, float, float]:
    from postproc.programs import parse_program

    lines = path.read_bytes().count(b"\n")
    best = (0, 0.0, 0.0)
    for _ in range(2):
        c0, t0 = time.process_time(), time.perf_counter()
        tp = parse_program(path)
        cpu, wall = time.process_time() - c0, time.perf_counter() - t0
        if best[0] == 0 or cpu < best[1]:
            best = (len(tp), cpu, wall)
    return lines, best[0], lines / best[2], lines / best[1]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--lines", type=int, default=1_000_000)
    parser.add_argument("--holes", type=int, default=100_000)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        plain, drill = Path(tmp) / "plain.ngc", Path(tmp) / "drill.ngc"
        write_plain(plain, args.lines)
        write_drill(drill, args.holes)
        print(f"{'program':<22}{'lines':>10}{'targets':>10}{'lines/s wall':>14}{'lines/s CPU':>13}   target >= 1.5e5 lines/s")
        for name, path in (("plain G1 moves", plain), ("G81 holes", drill)):
            lines, targets, wall, cpu = measure(path)
            print(f"{name:<22}{lines:>10,}{targets:>10,}{wall:>14,.0f}{cpu:>13,.0f}")


if __name__ == "__main__":
    main()
