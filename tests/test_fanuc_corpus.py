"""Real Fanuc TP programs (tests/corpus/fanuc/SOURCES.md): each read as the controller reads
it (byte-identical round trip, the targets counted here) or refused with file:line:column.

The expectations were checked by hand against the programs' text: targets are the motion
lines' positions; 'placed' counts targets whose frame, tool and position the program itself
determines (a user frame or tool number other than 0 is set on the pendant, a PR[] or an
Offset,PR[] holds values set outside the program, COORD / GP2 move with a positioner)."""

from __future__ import annotations

import csv
import hashlib
import os
from pathlib import Path

import pytest

from postproc.errors import ParseError
from postproc.programs import emit_texts, parse_program

HERE = Path(__file__).parent
KEPT = HERE / "corpus" / "fanuc"
FETCHED = {row["file"]: row for row in csv.DictReader((KEPT / "FETCHED.tsv").open(encoding="utf-8"), delimiter="\t")}

# file -> ("read", targets, placed) or ("refused", line, column, what the message says)
EXPECTED = {
    "ros-industrial_fanuc__ros.ls": ("read", 0, 0),
    "ros-industrial_fanuc__ros_movesm.ls": ("read", 1, 0),  # J PR[2] R[1]% CNT R[2]: the ROS driver's streamed point
    "ros-industrial_fanuc__rosrelay.ls": ("read", 0, 0),
    "ros-industrial_fanuc__rosstate.ls": ("read", 0, 0),
    "Surfacerobot_crs_ws_fanuc__surface.ls": ("read", 2177, 0),  # UT 1 (Tool_Offset,PR[15] on some versions)
    "Surfacerobot_crs_ws_fanuc__surface_cartesian.ls": ("read", 102, 0),  # UT 1: the tool is set on the pendant
    "Surfacerobot_crs_ws_fanuc__surfaceSc.ls": ("read", 89, 0),
    "Surfacerobot_crs_ws_fanuc__surjoints.ls": ("refused", 1, 1, "must start with '/PROG name'"),  # a /POS fragment with 'joint1 =' components
    "Creearc_welding_project__cub.ls": ("read", 999, 0),  # COORD with a positioner (DEFAULT_GROUP 1,1)
    "Creearc_welding_project__layer_1.ls": ("read", 176, 0),  # COORD, GP2 positions
    "Creearc_welding_project__main.ls": ("read", 0, 0),
    "Creearc_welding_project__move.ls": ("refused", 17, 2, "not closed by ';'"),  # a bare ':' line before /POS
    "Creearc_welding_project__second_power_source.ls": ("refused", 17, 2, "not closed by ';'"),
    # Car body plant backups (spot welding and handling, servo guns as groups 2-4)
    "JuniorNatalin_VASC__15.07.2024_LTVL_kjltvl411550r01_english_folge011.ls": ("read", 7, 0),  # GP2-4 in the positions, TB ..,P-SPS blocks
    "JuniorNatalin_VASC__15.07.2024_LTVL_kjltvl411550r01_english_motn012.ls": ("read", 1, 0),  # P[1] never taught ('********')
    "JuniorNatalin_VASC__15.07.2024_LTVL_kjltvl411550r01_english_motn014.ls": ("read", 2, 0),  # PR[49], UF : F
    "JuniorNatalin_VASC__15.07.2024_LTVL_kjltvl411550r01_english_up222.ls": ("read", 25, 0),
    "JuniorNatalin_VASC__07.10.24_KJBVTU211160R01_GERMAN_FOLGE020.LS": ("refused", 110, 19, "German"),  # KONFIG, mm/sek: the pendant in German
    "JuniorNatalin_VASC__07.10.24_kjbvtu411450r01_UP002.LS": ("refused", 168, 2, "RX .. RR"),
    "JuniorNatalin_VASC__24.06.2024_LTVR_kjltvr111150r01_UP021.LS": ("refused", 27, 1, "not closed by ';'"),  # '   4:  ' without ';'
}


def _roots() -> list[Path]:
    shared = Path(os.environ.get("POSTPROC_SHARED", HERE.parent.parent / "shared"))  # ../shared beside the checkout
    roots = [shared / "corpus" / "real" / "fanuc"]
    if os.environ.get("POSTPROC_CORPUS"):
        roots.insert(0, Path(os.environ["POSTPROC_CORPUS"]) / "fanuc")
    return roots


def corpus_file(name: str) -> Path:
    if (KEPT / name).is_file():
        return KEPT / name
    row = FETCHED[f"fanuc/{name}"]
    for root in _roots():
        path = root / name
        if path.is_file():
            assert hashlib.sha256(path.read_bytes()).hexdigest() == row["sha256"], f"{path}: not the bytes of {row['repository']}:{row['path']}"
            return path
    pytest.skip(f"{name}: fetched fixture not placed under {' or '.join(map(str, _roots()))} (see {KEPT / 'SOURCES.md'})")


def test_every_program_is_listed():
    kept = {p.name for p in KEPT.glob("*.ls")}
    assert set(EXPECTED) == kept | {Path(f).name for f in FETCHED}
    assert len(EXPECTED) >= 5 and len({r["repository"] for r in FETCHED.values()} | {"ros-industrial/fanuc"}) >= 4


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_read_exactly_or_refused_with_a_position(name):
    path = corpus_file(name)
    want = EXPECTED[name]
    if want[0] == "refused":
        with pytest.raises(ParseError) as exc:
            parse_program(path)
        assert (exc.value.line, exc.value.column) == want[1:3] and want[3] in str(exc.value), str(exc.value)
        return
    tp = parse_program(path)
    assert emit_texts(tp, tp)[0].encode("latin-1") == path.read_bytes()
    assert (len(tp), int(tp.placed().sum())) == want[1:], (len(tp), int(tp.placed().sum()))
    assert tp.resolved.all() or tp.notes  # an unresolved target always comes with the reason
