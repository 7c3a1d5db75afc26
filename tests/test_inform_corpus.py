"""Real INFORM jobs (tests/corpus/inform, SOURCES.md there): each is read as written (the
outcome below was checked by hand against the file and the manuals' rules) and
round-trips byte for byte; the fetched fixtures are read where the shared corpus holds them."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from postproc.ir import Kind
from postproc.programs import emit_texts, parse_program

HERE = Path(__file__).parent / "corpus" / "inform"
SHARED = Path(os.environ.get("POSTPROC_SHARED", "/nonexistent")) / "corpus" / "real" / "inform"

# file -> (targets, kinds, resolved, a phrase of the note that says why a target is not placed)
EXPECTED = {
    "tshikina_YaskawaInformSupport__TEST1.JBI": (1, [Kind.LINEAR], [False], "IMOV moves by the increment LP000"),
    "ros-industrial_motoman__INIT_ROS_call_job_main.JBI": (0, [], [], None),
    "ros-industrial_motoman__ROS_R1B1.JBI": (0, [], [], None),
    "Welding_Motoman__AAA_station.JBI": (1, [Kind.JOINT], [False], "moves base or station axes"),
    "Welding_Motoman__kink.JBI": (2, [Kind.LINEAR, Kind.LINEAR], [False, False], "in pulses"),
    "Welding_Motoman__linear.JBI": (2, [Kind.LINEAR, Kind.LINEAR], [False, False], "in pulses"),
    "Welding_Motoman__linear2.JBI": (1, [Kind.ABSJ], [False], "in pulses"),
}


def _path(name: str) -> Path:
    for folder in (HERE, SHARED):
        if (folder / name).is_file():
            return folder / name
    pytest.skip(f"{name}: a fetched fixture, not in the shared corpus here")


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_real_job_reads_as_written(name):
    path = _path(name)
    tp = parse_program(path)
    count, kinds, resolved, why = EXPECTED[name]
    assert tp.dialect == "inform" and len(tp) == count
    assert tp.kind.tolist() == kinds and tp.resolved.tolist() == resolved
    if why:
        assert any(why in note for note in tp.notes), tp.notes
    assert emit_texts(tp, tp)[0] == tp.sources[0].text


def test_kept_files_are_listed_in_sources():
    listed = (HERE / "SOURCES.md").read_text()
    assert all(p.name in listed for p in HERE.glob("*.JBI"))
