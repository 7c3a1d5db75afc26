"""Fanuc TP listings of real robot cells: how many are read (byte-identical round trip) and
why the others are refused.

Run: .venv/bin/python benchmarks/fanuc_real_cells.py [--git] SOURCE [SOURCE ...]
A SOURCE is a folder of controller backups (every *.ls under it), or with --git a git
repository whose HEAD holds them (read with `git cat-file`, no checkout), e.g. a clone of
JuniorNatalin/VASC (car body plant backups; not in this repository: no licence). Files
that do not start with /PROG (LOGBOOK.LS, ERRALL.LS: system listings) are counted apart.
Prints counts, the targets read and placed, and the refusals by reason with one
file:line:column each; a line on stderr every 10 s.
"""

from __future__ import annotations

import argparse
import collections
import subprocess
import sys
import time
from pathlib import Path

from postproc.errors import ParseError
from postproc.programs import emit_texts, parse_program


def folder_files(root: Path):
    for path in sorted(p for p in root.rglob("*") if p.suffix.lower() == ".ls" and p.is_file()):
        yield str(path), path.read_bytes()


def git_files(repo: Path):
    """(path, bytes) of every *.ls at HEAD of ``repo``, through one `git cat-file --batch`."""
    listing = subprocess.run(["git", "-C", str(repo), "ls-tree", "-r", "HEAD"], capture_output=True, text=True, check=True).stdout.splitlines()
    blobs = [(line.split()[2], line.split("\t", 1)[1]) for line in listing if line.lower().endswith(".ls")]
    with subprocess.Popen(["git", "-C", str(repo), "cat-file", "--batch"], stdin=subprocess.PIPE, stdout=subprocess.PIPE) as cat:
        for sha, path in blobs:
            cat.stdin.write(sha.encode() + b"\n")
            cat.stdin.flush()
            size = int(cat.stdout.readline().split()[2])
            data = cat.stdout.read(size)
            cat.stdout.read(1)
            yield path, data
        cat.stdin.close()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("sources", nargs="+", type=Path)
    parser.add_argument("--git", action="store_true", help="SOURCEs are git repositories (their HEAD)")
    args = parser.parse_args()
    counts: collections.Counter = collections.Counter()
    reasons: collections.Counter = collections.Counter()
    example: dict[str, str] = {}
    targets = placed = 0
    last = time.perf_counter()
    for source in args.sources:
        for path, data in (git_files(source) if args.git else folder_files(source)):
            if time.perf_counter() - last > 10:
                last = time.perf_counter()
                print(f"{sum(counts.values())} files, {dict(counts)}", file=sys.stderr, flush=True)
            if not data.lstrip().startswith(b"/PROG"):
                counts["not a TP program (a system listing)"] += 1
                continue
            try:
                tp = parse_program(Path(path).name, "fanuc", data)
            except ParseError as exc:
                counts["refused with file:line:column"] += 1
                why = str(exc).splitlines()[0].split(": ", 1)[1][:90]
                reasons[why] += 1
                example.setdefault(why, f"{path}:{exc.line}:{exc.column}")
                continue
            same = emit_texts(tp, tp)[0].encode("latin-1") == data
            counts["read, byte-identical" if same else "read, TEXT CHANGED"] += 1
            targets, placed = targets + len(tp), placed + int(tp.placed().sum())
    print(", ".join(f"{k}: {v}" for k, v in counts.items()) + f"; targets {targets}, placed by the program alone {placed}")
    for why, n in reasons.most_common():
        print(f"{n:6d}  {why}  (e.g. {example[why]})")


if __name__ == "__main__":
    main()
