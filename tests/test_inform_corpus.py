"""Real INFORM jobs (tests/corpus/inform, SOURCES.md there): each is read as written (the
outcome below was checked by hand against the file and the manuals' rules) and
round-trips byte for byte; the fetched fixtures are read where the shared corpus holds them."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from postproc.errors import ParseError
from postproc.programs import emit_texts, parse_program
from postproc.programs.ir import Kind

HERE = Path(__file__).parent / "corpus" / "inform"
SHARED = Path(os.environ.get("POSTPROC_SHARED", "/nonexistent")) / "corpus" / "real" / "inform"

# file -> (targets, kinds, resolved, a phrase of the note that says why a target is not placed)
EXPECTED = {
    "tshikina_YaskawaInformSupport__TEST1.JBI": (1, [Kind.LINEAR], [False], "IMOV moves by the increment LP000"),
    "ros-industrial_motoman__INIT_ROS_call_job_main.JBI": (0, [], [], None),
    "ros-industrial_motoman__ROS_R1B1.JBI": (0, [], [], None),
    "MQCIA_yaskawa-cadcam__DROP01.JBI": (12, [Kind.LINEAR] * 12, [False] * 12, "EC00000: base or station axes move with the robot"),
    "Welding_Motoman__AAA_station.JBI": (1, [Kind.JOINT], [False], "moves base or station axes"),
    "Welding_Motoman__kink.JBI": (2, [Kind.LINEAR, Kind.LINEAR], [False, False], "in pulses"),
    "Welding_Motoman__linear.JBI": (2, [Kind.LINEAR, Kind.LINEAR], [False, False], "in pulses"),
    "Welding_Motoman__linear2.JBI": (1, [Kind.ABSJ], [False], "in pulses"),
}


# file -> (line, column, a phrase of the refusal)
REFUSED = {
    # MOVC C00008..C00013 run on across WVON lines: six consecutive MOVC, not one circle of three
    "MQCIA_yaskawa-cadcam__robot-cell_000.JBI": (86, 1, "6 consecutive MOVC lines"),
}
EXPECTED["icors2_Yaskawa-Job-Helper__CUT_ONLY.JBI"] = (7, [Kind.JOINT, Kind.JOINT, Kind.LINEAR, Kind.LINEAR, Kind.LINEAR, Kind.LINEAR, Kind.JOINT],
                                                      [False] * 7, "P105 is a position variable held by the controller (the job saves a value")


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


@pytest.mark.parametrize("name", sorted(REFUSED))
def test_real_job_is_refused_where_the_controller_rules_are_not_modelled(name):
    line, column, why = REFUSED[name]
    with pytest.raises(ParseError) as info:
        parse_program(_path(name))
    assert (info.value.line, info.value.column) == (line, column) and why in str(info.value)


def test_kept_files_are_listed_in_sources():
    listed = (HERE / "SOURCES.md").read_text()
    assert all(p.name in listed for p in HERE.glob("*.JBI"))
