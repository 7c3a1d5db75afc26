"""Real public URScript programs (tests/corpus/urscript/real, sources and licences in its
SOURCES.md): each is read as its SOURCES.md row says, read right (byte-identical round
trip, the targets counted by reading the file) or refused at the place and for the reason given."""

from __future__ import annotations

import os
import re
from pathlib import Path

import pytest

from postproc.errors import ParseError
from postproc.programs import emit_texts, parse_program

REAL = Path(__file__).parent / "corpus" / "urscript" / "real"
ROWS = [line.split("|")[1:-1] for line in (REAL / "SOURCES.md").read_text().splitlines() if line.startswith("| `")]
KEPT = [(row[0].strip(" `"), row[-1].strip()) for row in ROWS if (REAL / row[0].strip(" `")).is_file()]
# Fetched fixtures: read where the shared corpus holds them ($POSTPROC_SHARED/corpus/real/urscript)
SHARED = Path(os.environ.get("POSTPROC_SHARED", Path(__file__).resolve().parents[2] / "shared")) / "corpus" / "real" / "urscript"
FETCHED = [(row[0].strip(" `"), row[-1].strip()) for row in ROWS if not (REAL / row[0].strip(" `")).is_file()]


def test_the_sources_table_lists_every_kept_file_and_five_or_more_programs():
    assert {name for name, _ in KEPT} == {p.name for p in REAL.iterdir() if p.name != "SOURCES.md"}
    assert len(ROWS) >= 5 and len(FETCHED) >= 1


@pytest.mark.parametrize("name, verdict", KEPT + FETCHED)
def test_each_real_program_is_read_as_its_row_says(name, verdict):
    path = REAL / name if (REAL / name).is_file() else SHARED / name
    if not path.is_file():
        pytest.skip(f"fetched fixture {name} is not in {SHARED}")
    refused = re.match(r"refused (\d+):(\d+): (.*?) \(", verdict)
    if refused:
        with pytest.raises(ParseError) as caught:
            parse_program(path, "urscript")
        assert (caught.value.line, caught.value.column) == (int(refused.group(1)), int(refused.group(2)))
        assert refused.group(3) in caught.value.message
        return
    tp = parse_program(path, "urscript")
    counted = re.match(r"(\d+) targets(?:, (\d+) resolved)?", verdict)
    assert len(tp) == int(counted.group(1))
    if counted.group(2) is not None:
        assert int(tp.placed().sum()) == int(counted.group(2))
    assert emit_texts(tp, tp)[0] == tp.sources[0].text
