"""Public SINUMERIK programs (tests/corpus/sinumerik/SOURCES.md): read exactly, or refused with the reason.

Every program either comes back byte-identical through parse + emit or is refused with a
ParseError naming its line and column; never another exception. ``OUTCOME`` lists what each
gives today (strict: a change shows up here). Where CEAD's own Sinumerik-flavoured
interpreter recorded its output beside a program (``<name>.csv``), the positions postproc
reads are those it printed. Those programs start with axis words and no G0/G1 (that
interpreter's start state): postproc refuses that (the reset motion mode is machine data),
so the comparison reads them after a first block ``G1 X0 Y0 Z0 F100``.
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest

from postproc.errors import ParseError
from postproc.programs import emit_texts, parse_program

CORPUS = Path(__file__).parent / "corpus" / "sinumerik"
NO_MOTION_MODE = "axis words before any G0 / G1 / G2 / G3"
# file -> ("read", targets, unresolved targets) or ("refused", line, column, reason)
OUTCOME = {
    "actual_position.mpf": ("read", 4, 3),  # IC() and $AA_IW (the machine's actual position): flagged
    "arc.mpf": ("refused", 11, 23, "K is not a centre word of the G17 plane"),
    "arrays.mpf": ("refused", 11, 7, "array elements"),
    "axis_index_assignment.mpf": ("refused", 2, 1, "array elements and axis-indexed settings"),
    "basic_math.mpf": ("refused", 1, 1, NO_MOTION_MODE),
    "case.mpf": ("refused", 5, 5, "CASE ... OF ... GOTOF is a program jump"),
    "case_insensitive_variables.mpf": ("read", 4, 3),  # Z=IC(...): flagged, and every target after it until Z is absolute again
    "custom_vars.mpf": ("refused", 1, 1, NO_MOTION_MODE),
    "def_string.mpf": ("read", 3, 0),
    "defaults.mpf": ("refused", 6, 1, NO_MOTION_MODE),
    "edge_cases.mpf": ("refused", 18, 23, "ELX=: an address or variable set inside a motion block"),
    "flatten_demo.mpf": ("refused", 10, 1, "spline interpolation"),
    "for_loop.mpf": ("refused", 4, 1, NO_MOTION_MODE),
    "function_calls.mpf": ("read", 1, 1),  # SETAL(12345): a cycle whose .SPF is not here, flagged from there on
    "goto.mpf": ("refused", 14, 1, NO_MOTION_MODE),  # reached by its first jump (GOTOF MIDDLE)
    "if_statement.mpf": ("refused", 3, 1, NO_MOTION_MODE),
    "increment.mpf": ("refused", 2, 1, NO_MOTION_MODE),
    "logic_operators.mpf": ("read", 6, 4),  # NOT and B_AND are not evaluated: the IF after them flags the rest
    "loop.mpf": ("read", 205, 0),
    "multiple_m_codes.mpf": ("read", 3, 3),  # X only: Y and Z never given, so no target is known
    "precedence.mpf": ("refused", 4, 1, NO_MOTION_MODE),
    "r_param.mpf": ("read", 2, 2),  # DEF REAL R0: an R parameter declared as a variable (an 840D alarm): not evaluated
    "repeat.mpf": ("refused", 4, 1, NO_MOTION_MODE),
    "simple.mpf": ("read", 2, 1),  # G2 X3 Z100 without a centre or radius: flagged
    "spline.mpf": ("refused", 10, 1, "spline interpolation"),
    "tool.mpf": ("read", 0, 0),
    "trans.mpf": ("refused", 1, 1, NO_MOTION_MODE),
    "trans2.mpf": ("refused", 1, 1, NO_MOTION_MODE),
    "trans_ic.mpf": ("read", 3, 3),  # IC(): flagged
    "trans_reset.mpf": ("refused", 5, 1, NO_MOTION_MODE),
    "trig.mpf": ("refused", 4, 1, NO_MOTION_MODE),
    "variables.mpf": ("refused", 2, 1, NO_MOTION_MODE),
}


def test_every_program_is_listed():
    assert {p.name for p in CORPUS.glob("*.mpf")} == set(OUTCOME)
    sources = (CORPUS / "SOURCES.md").read_text(encoding="utf-8")
    assert "892e32a697c5b80014c0826db759276546c9e689" in sources and "MIT License" in sources


@pytest.mark.parametrize("name", sorted(OUTCOME))
def test_read_exactly_or_refused_with_the_reason(name):
    path = CORPUS / name
    want = OUTCOME[name]
    if want[0] == "refused":
        with pytest.raises(ParseError) as exc:
            parse_program(path)
        assert (exc.value.line, exc.value.column) == want[1:3] and want[3] in exc.value.message
        return
    tp = parse_program(path)
    assert tp.dialect == "sinumerik"
    assert emit_texts(tp, tp)[0].encode("latin-1") == path.read_bytes()
    assert (len(tp), int((~tp.resolved).sum())) == want[1:]


def _runs(rows: np.ndarray) -> np.ndarray:
    """Rows with repeats of the row before removed (the interpreter prints one row per block)."""
    keep = np.r_[True, np.abs(np.diff(rows, axis=0)).max(axis=1) > 1e-9] if len(rows) else np.zeros(0, bool)
    return rows[keep]


@pytest.mark.parametrize("name", ["loop", "trans", "trans_reset", "def_string", "variables", "goto"])
def test_positions_are_the_ones_ceads_interpreter_printed(tmp_path, name):
    rows = list(csv.DictReader((CORPUS / f"{name}.csv").open(encoding="utf-8")))
    axes = [k for k in "XYZ" if k in rows[0]]
    printed = np.array([[float(r[k]) if r[k] else 0.0 for k in axes] for r in rows if any(r[k] for k in axes)])
    program = tmp_path / f"{name}.mpf"
    program.write_bytes(b"G1 X0 Y0 Z0 F100\n" + (CORPUS / f"{name}.mpf").read_bytes())
    tp = parse_program(program)
    assert tp.resolved.all()
    read = tp.base_poses()[1:, :3, 3][:, ["XYZ".index(k) for k in axes]]
    np.testing.assert_allclose(_runs(read), _runs(printed), atol=5e-4)  # it prints 3 decimals
