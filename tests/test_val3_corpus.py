"""Real VAL3 applications: read right, or refused with the place and the reason.

``tests/corpus/val3/ros_server`` (Apache-2.0) is kept here; the programs listed in
``tests/corpus/val3/fetched.tsv`` (no licence stated) are checked where the shared corpus
holds them (see tests/corpus/val3/SOURCES.md)."""

from __future__ import annotations

import csv
import os
from pathlib import Path

import pytest

from postproc.errors import InputError, ParseError
from postproc.programs import emit_texts, parse_program

HERE = Path(__file__).parent / "corpus" / "val3"
ROS = HERE / "ros_server"
REFUSED = {"start.pgx": (123, 3, "taskCreateSync"), "motionControl.pgx": (65, 21, "movej inside 'if' (line 48)"),
           "dataReceiver.pgx": (68, 7, "call inside 'if' (line 67)")}


@pytest.mark.parametrize("program", sorted(p.name for p in ROS.glob("*.pgx")))
def test_ros_server_programs(program):
    if program in REFUSED:
        line, column, words = REFUSED[program]
        with pytest.raises(ParseError) as err:
            parse_program(ROS / program)
        assert (Path(err.value.path).name, err.value.line, err.value.column) == (program, line, column) and words in err.value.message
        return
    tp = parse_program(ROS / program)
    assert len(tp) == 0  # no motion outside the refused programs: the motions come from the socket
    assert emit_texts(tp, tp) == [s.text for s in tp.sources]


def _fetched():
    with open(HERE / "fetched.tsv", newline="", encoding="utf-8") as fh:
        return list(csv.DictReader(fh, delimiter="\t"))


def test_manifest_names_at_least_five_programs_of_real_cells():
    rows = _fetched()
    assert len(rows) >= 5 and len({r["repository"] for r in rows}) >= 5
    assert all(r["outcome"].startswith(("read ", "refused")) for r in rows)


@pytest.mark.parametrize("row", _fetched(), ids=lambda r: f"{r['repository']}:{r['path']}")
def test_fetched_program(row):
    root = Path(os.environ.get("POSTPROC_SHARED", "/nonexistent")) / "corpus" / "real" / "val3" / row["repository"].replace("/", "+") / row["commit"]
    if not (root / row["path"]).is_file():
        pytest.skip(f"{row['repository']} {row['path']} is not placed in the shared corpus")
    if row["outcome"].startswith("read "):
        tp = parse_program(root / row["path"])
        assert row["outcome"] == f"read {len(tp)} targets, {int(tp.resolved.sum())} resolved"
        assert emit_texts(tp, tp) == [s.text for s in tp.sources]
        return
    with pytest.raises(InputError) as err:
        parse_program(root / row["path"])
    if isinstance(err.value, ParseError):
        assert row["outcome"] == f"refused {Path(err.value.path).relative_to(root).as_posix()}:{err.value.line}:{err.value.column}"
    assert row["why"].split(":")[0] in str(err.value)
