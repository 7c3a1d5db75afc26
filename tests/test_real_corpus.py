"""Real public programs (tests/corpus/real/SOURCES.md): read as the controller reads them, or refused.

Every file of the corpus must either come back byte-identical through parse + emit, or be
refused with a ParseError naming file, line and column: never another exception, never a
different text. Files that do not round-trip yet are listed in ROUND_TRIP_XFAIL with the
construct and the line that stops them (strict: a fix shows up as XPASS, remove the entry).

LinuxCNC's rs274 judges the G-code: its canonical output for every G-code file it accepts is
recorded in tests/corpus/real/rs274/<file>.txt (regenerate: python tests/test_real_corpus.py
--record), the IR's motion end points in the machine frame are compared with the recorded
ones (rs274's program coordinates put through the work offsets it announces), and the
recordings are compared with a fresh rs274 run where rs274 is installed. rs274 prints 4
decimals in the program's length unit, so the comparison is as tight as that print: 5e-5
program units (0.00005 mm, 0.00127 mm in G20 programs; twice that where offsets, also
printed to 4 decimals, are added) plus 1e-6 mm. Straight moves that do not move (rs274 prints
one for `G0 S12000`) are left out on both sides; arcs never are.

The program files themselves are third-party (licences in SOURCES.md); they are looked up in
tests/corpus/real/<dialect>/ and then in $POSTPROC_SHARED/corpus/real/<dialect>/ (default
../shared beside the checkout), and checked against the SHA-256 recorded in manifest.tsv.
"""

from __future__ import annotations

import csv
import hashlib
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pytest

from postproc.errors import InputError, ParseError
from postproc.programs import emit_texts, parse_program
from postproc.programs.ir import Kind

REPO = Path(__file__).resolve().parents[1]
REAL = Path(__file__).parent / "corpus" / "real"
RECORDINGS = REAL / "rs274"
TOOL_TABLE = RECORDINGS / "tools.tbl"  # tools 1..99, zero length and diameter: rs274 needs them for T/M6/G43
ROWS = list(csv.DictReader((REAL / "manifest.tsv").open(encoding="utf-8"), delimiter="\t"))
GCODE = [r["file"] for r in ROWS if r["file"].startswith("gcode/")]

# file -> why it does not round-trip today (the first construct the parser stops at, file:line)
ROUND_TRIP_XFAIL = {
    # G-code
    "gcode/LinuxCNC_linuxcnc__cone.ngc": "`g1 w100` moves the W axis, which the IR cannot hold: refused at cone.ngc:34:5 (before, the block was dropped with exit 0; rs274 refuses the file too)",
    "gcode/LinuxCNC_linuxcnc__nestedcall.ngc": "`O<g20sub> callsub`: `callsub` is no O-word keyword, refused at nestedcall.ngc:11:12 as rs274 refuses it (Unexpected character after O-word)",
    # KRL
    # RAPID
}

# G-code files rs274 refuses (no recording): what LinuxCNC says
RS274_REFUSED = {
    "gcode/AlloyX-MFG_syil-X7-warmup-routines__DAILY.MPF": "Siemens dialect: 'Unknown word where unary operation could be' (line 9)",
    "gcode/AlloyX-MFG_syil-X7-warmup-routines__FIRST_SPINDLE_RUN_IN.MPF": "Siemens dialect: 'Unknown word where unary operation could be' (line 10)",
    "gcode/AlloyX-MFG_syil-X7-warmup-routines__WARMUP_CYCLE.SPF": "Siemens dialect: 'Unknown word starting with r' (line 9)",
    "gcode/CauldronDevelopmentLLC_CAMotics__mt_kazbegi_2013.ngc": "'Cannot do g1 with zero feed rate' (line 5: the file sets no F)",
    "gcode/LinuxCNC_linuxcnc__cone.ngc": "'Bad character 'w' used' (the simulated 5-axis machine's W axis)",
    "gcode/LinuxCNC_linuxcnc__nestedcall.ngc": "'Unexpected character after O-word' (O<g20sub> callsub, needs the sub file on the search path)",
    "gcode/LinuxCNC_linuxcnc__plasmac_metric_wrench.ngc": "'Named parameter #<_hal[plasmac.cut-feed-rate]> not defined' (needs a running HAL)",
}

# file -> why the IR's motion differs from rs274's today
RS274_XFAIL: dict[str, str] = {}  # none: every recorded program's motion equals rs274's (cutter compensation: cutter_comp.py)


# ------------------------------------------------------------------ corpus files

def _roots() -> list[Path]:
    shared = Path(os.environ.get("POSTPROC_SHARED", REPO.parent / "shared"))
    roots = [REAL, shared / "corpus" / "real"]
    if os.environ.get("POSTPROC_CORPUS"):
        roots.insert(0, Path(os.environ["POSTPROC_CORPUS"]))
    return roots


def corpus_file(name: str) -> Path:
    """The corpus file ``dialect/file`` (in the checkout or in the shared folder), byte-checked."""
    row = next(r for r in ROWS if r["file"] == name)
    for root in _roots():
        path = root / name
        if path.is_file():
            digest = hashlib.sha256(path.read_bytes()).hexdigest()
            assert digest == row["sha256"], f"{path}: not the bytes of {row['repository']}:{row['path']}@{row['commit'][:12]} (line ends or encoding changed?)"
            return path
    # The programs are third-party files: the project lists them (manifest.tsv, SOURCES.md)
    # but does not commit them; they are placed in shared/corpus/real (or $POSTPROC_CORPUS).
    pytest.skip(f"{name}: third-party corpus file not placed under {' or '.join(map(str, _roots()))} (see {REAL / 'SOURCES.md'})")


def _programs() -> list[str]:
    """Program entry files: every file but a .dat whose .src is in the corpus (parsed with it)."""
    names = {r["file"] for r in ROWS}
    return [n for n in sorted(names) if not (n.lower().endswith(".dat") and n[:-4] + ".src" in names)]


def _marked(names, table):
    """Parameters with the strict xfails of ``table``; a crash in an xfailed file is still caught
    by test_read_exactly_or_refused_with_a_position, which has no xfails."""
    return [pytest.param(n, id=n, marks=pytest.mark.xfail(strict=True, reason=table[n])) if n in table else pytest.param(n, id=n) for n in names]


def test_corpus_is_real_varied_and_listed():
    dialects = [r["file"].split("/")[0] for r in ROWS]
    assert len(ROWS) >= 40 and min(dialects.count(d) for d in ("rapid", "krl", "gcode")) >= 10
    assert len({r["repository"] for r in ROWS}) >= 12
    sources = (REAL / "SOURCES.md").read_text(encoding="utf-8")
    for row in ROWS:
        assert row["licence"] and len(row["commit"]) == 40 and f"`{Path(row['file']).name}`" in sources
    for table in (ROUND_TRIP_XFAIL, RS274_REFUSED, RS274_XFAIL):
        assert set(table) <= {r["file"] for r in ROWS}
    texts = [corpus_file(r["file"]).read_bytes() for r in ROWS]
    assert sum(b"\r\n" in t for t in texts) >= 10  # controller files saved on Windows


# ------------------------------------------------------------------ round trip

def _round_trip(path: Path):
    """(identical, toolpath) or raises what the parser raises."""
    tp = parse_program(path)
    texts = emit_texts(tp, tp)
    identical = all(t.encode("latin-1") == Path(doc.path).read_bytes() for t, doc in zip(texts, tp.sources))
    return identical, tp


@pytest.mark.parametrize("name", _programs())
def test_read_exactly_or_refused_with_a_position(name):
    """Never a crash of another type, never a silently different text."""
    path = corpus_file(name)
    try:
        identical, _ = _round_trip(path)
    except ParseError as exc:
        lines = Path(exc.path).read_bytes().decode("latin-1").splitlines()
        assert Path(exc.path).parent == path.parent and 1 <= exc.line <= len(lines), str(exc)
        assert 1 <= exc.column <= len(lines[exc.line - 1]) + 1, str(exc)
        assert str(exc).startswith(f"{exc.path}:{exc.line}:{exc.column}: ")
        return
    except InputError as exc:  # a file-level refusal (e.g. the dialect) must name the file
        assert str(exc).startswith(str(path)), str(exc)
        return
    assert identical, f"{name}: parsed and re-emitted, but the text differs"


@pytest.mark.parametrize("name", _marked(_programs(), ROUND_TRIP_XFAIL))
def test_round_trips_byte_identically(name):
    identical, _ = _round_trip(corpus_file(name))
    assert identical


# ------------------------------------------------------------------ rs274, the judge

CANON = re.compile(r"(STRAIGHT_TRAVERSE|STRAIGHT_FEED|ARC_FEED|RIGID_TAP|USE_LENGTH_UNITS|SELECT_PLANE|SET_G5X_OFFSET|SET_G92_OFFSET|SET_XY_ROTATION)\(([^)]*)\)")
BENIGN_END = "File ended with no percent sign or program end"  # rs274 has run every block; only M2/M30/% is missing


def recording(name: str) -> Path:
    return RECORDINGS / (Path(name).name + ".txt")


def run_rs274(path: Path) -> tuple[bool, str, str]:
    """(accepted, canonical calls, stderr) of LinuxCNC's interpreter on a program. The calls are
    rs274's stdout without its running count and without COMMENT/MESSAGE calls (they echo the
    program's comments, which stay in the third-party file)."""
    with tempfile.TemporaryDirectory() as home:  # rs274 shares its tool table through $HOME/.tool.mmap: a private one per run
        proc = subprocess.run(["rs274", "-g", "-t", str(TOOL_TABLE), path.name], cwd=path.parent, stdin=subprocess.DEVNULL,
                              capture_output=True, timeout=60, env={**os.environ, "HOME": home})
    out, err = proc.stdout.decode("latin-1"), proc.stderr.decode("latin-1")
    calls = [re.sub(r"^\s*\d+ ", "", line) for line in out.splitlines()]
    calls = [c for c in calls if not re.match(r"N\S*\s+(COMMENT|MESSAGE)\(", c)]
    return proc.returncode == 0 or BENIGN_END in err, "".join(c + "\n" for c in calls), err


def canonical_endpoints(text: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """End points (N, 3) of rs274's moves in the machine frame, mm; each one's print tolerance, mm;
    which are arcs. rs274's motion calls are in program coordinates; the offsets it announces
    (SET_G5X_OFFSET, SET_G92_OFFSET, SET_XY_ROTATION) are applied as LinuxCNC's canon does:
    machine = rotate(program + G92) + G5x (tool length offsets are 0: every tool in tools.tbl has Z0).
    RIGID_TAP(x, y, z) (G33.1) is two moves: in to (x, y, z) and back to where it started
    (LinuxCNC manual, "G33.1 Rigid Tapping": "G33.1 moves end at the original coordinate")."""
    scale, plane, points, tol, arc = 1.0, "XY", [], [], []
    g5x, g92, turn = np.zeros(3), np.zeros(3), 0.0
    for call, args in CANON.findall(text):
        v = [float(a) for a in args.split(",")] if call not in ("USE_LENGTH_UNITS", "SELECT_PLANE") else []
        if call == "USE_LENGTH_UNITS":
            scale = 25.4 if "INCHES" in args else 1.0
        elif call == "SELECT_PLANE":
            plane = args.split("_")[-1]
        elif call == "SET_G5X_OFFSET":
            g5x = np.array(v[1:4]) * scale
        elif call == "SET_G92_OFFSET":
            g92 = np.array(v[0:3]) * scale
        elif call == "SET_XY_ROTATION":
            turn = np.radians(v[0])
        else:
            if call == "ARC_FEED":  # first_end, second_end, first_axis, second_axis, rotation, axis_end_point
                xyz = {"XY": (v[0], v[1], v[5]), "YZ": (v[5], v[0], v[1]), "XZ": (v[1], v[5], v[0])}[plane]
            else:
                xyz = v[:3]
            p = np.array(xyz) * scale + g92
            c, s_ = np.cos(turn), np.sin(turn)
            start = points[-1] if points else np.zeros(3)
            points.append(np.array([c * p[0] - s_ * p[1], s_ * p[0] + c * p[1], p[2]]) + g5x)
            offset = bool(g5x.any() or g92.any() or turn)  # the offsets are printed to 4 decimals too
            tol.append(5e-5 * scale * (2 if offset else 1) + 1e-6)
            arc.append(call == "ARC_FEED")
            if call == "RIGID_TAP":
                points.append(start)
                tol.append(tol[-1])
                arc.append(False)
    return np.array(points).reshape(-1, 3), np.array(tol), np.array(arc, bool)


def _moves(points: np.ndarray, tol: np.ndarray, arc: np.ndarray) -> np.ndarray:
    """Indices of the points that move the tool. A straight move to where the tool already is
    (rs274 prints one for a bare `G0 S12000` or `G1 F100` block; the IR has no target there)
    is left out; arcs are kept (a full circle ends where it starts). Both sides start at the
    origin and read an unknown coordinate as 0 here, as rs274 does."""
    known = np.nan_to_num(points, nan=0.0)
    before = np.vstack([np.zeros((1, 3)), known[:-1]])
    still = (np.abs(known - before) <= tol[:, None]).all(axis=1)
    return np.nonzero(~still | arc)[0]


def machine_positions(tp) -> np.ndarray:
    """(N, 3) target positions in the machine frame, an unknown axis staying unknown: a work
    offset that only translates moves each axis alone (base_positions() would spread one NaN
    over the whole row through the 4x4 product)."""
    frames = tp.frames[tp.frame]
    rot, shift = frames[:, :3, :3], frames[:, :3, 3]
    # A work offset turned about Z only (G10 L2 ... R) keeps Z apart from X and Y.
    about_z = np.abs(rot[:, 2, 2] - 1) < 1e-12
    xy = np.einsum("nij,nj->ni", rot[:, :2, :2], tp.position[:, :2]) + shift[:, :2]
    turned = np.hstack([xy, tp.position[:, 2:3] + shift[:, 2:3]])
    return np.where(about_z[:, None], turned, tp.base_positions())


def test_rs274_judges_every_gcode_file():
    """Each G-code file is either recorded or listed as refused by rs274, never both."""
    for name in GCODE:
        assert recording(name).is_file() != (name in RS274_REFUSED), name


RECORDED = [n for n in GCODE if n not in RS274_REFUSED]


@pytest.mark.parametrize("name", _marked(RECORDED, RS274_XFAIL))
def test_ir_motion_matches_rs274(name):
    tp = parse_program(corpus_file(name))
    canon, tol, arc = canonical_endpoints(recording(name).read_text(encoding="latin-1"))
    keep = _moves(canon, tol, arc)
    canon, tol = canon[keep], tol[keep]
    ir_arc = np.isin(tp.kind, (Kind.ARC_CW, Kind.ARC_CCW))
    machine = machine_positions(tp)
    rows = _moves(machine, np.full(len(tp), 1e-9), ir_arc)
    assert len(rows) == len(canon), f"{name}: rs274 made {len(canon)} moves, the IR has {len(rows)} (of {len(tp)} targets)"
    ir = machine[rows]
    known = ~np.isnan(ir)  # an axis the program has not given yet: the IR says unknown, rs274 assumes 0
    err = np.abs(ir - canon)
    bad = known & (err > tol[:, None])
    if bad.any():
        first = int(np.nonzero(bad.any(axis=1))[0][0])
        row = rows[first]
        pytest.fail(f"{name}: target {row} (line {tp.line[row]}): IR {ir[first]} vs rs274 {canon[first]}; {int(bad.any(axis=1).sum())} targets differ")


@pytest.mark.skipif(shutil.which("rs274") is None, reason="LinuxCNC's rs274 is not installed (apt-get install linuxcnc-uspace)")
@pytest.mark.parametrize("name", GCODE)
def test_rs274_recordings_are_current(name):
    accepted, out, err = run_rs274(corpus_file(name))
    assert accepted == (name not in RS274_REFUSED), f"{name}: rs274 {'accepts' if accepted else 'refuses'} it now: {err.strip()[-200:]}"
    if accepted:
        assert out == recording(name).read_text(encoding="latin-1")


def record() -> None:
    """Rewrite the rs274 recordings of the accepted G-code files (needs rs274)."""
    for name in GCODE:
        accepted, out, err = run_rs274(corpus_file(name))
        target = recording(name)
        if accepted:
            target.write_bytes(out.encode("latin-1"))
        else:
            target.unlink(missing_ok=True)
            print(f"refused {name}: {[line for line in err.splitlines() if line != 'executing'][:1]}")


if __name__ == "__main__":
    if sys.argv[1:] == ["--record"]:
        record()
