"""grammars-v4's ANTLR KRL grammar accepts every KRL text postproc writes (issue 12, "Judges").

The verdicts are recorded in tests/data/antlr_krl/recording.tsv (how: README.md beside it; the
grammar and its generated parser are third-party and not in this repository). This test writes
every KRL text again (tests/krl_outputs.py) and checks that each one's SHA-256 was judged: a
writer change that alters any output fails here until the new text is judged and recorded.
"""

from __future__ import annotations

import csv
import hashlib
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))
from krl_outputs import krl_outputs  # noqa: E402

RECORDING = Path(__file__).parent / "data" / "antlr_krl" / "recording.tsv"
ROWS = list(csv.DictReader(RECORDING.open(encoding="utf-8"), delimiter="\t"))
VERDICT = {r["sha256"]: r for r in ROWS}


@pytest.fixture(scope="module")
def outputs() -> dict[str, str]:
    return krl_outputs()


def test_recording_is_complete_and_explained():
    assert len(ROWS) >= 100 and all(r["accepted"] in ("yes", "no") for r in ROWS)
    for r in ROWS:
        assert (r["accepted"] == "yes") == (r["first_error"] == ""), r["file"]
        assert r["accepted"] == "yes" or r["explanation"], f"{r['file']}: rejected by ANTLR and not explained"
    written_by_new_program_writer = [r for r in ROWS if r["file"].startswith("convert/")]
    assert written_by_new_program_writer and all(r["accepted"] == "yes" for r in written_by_new_program_writer)


def test_every_krl_text_we_write_was_judged(outputs):
    kinds = {name.split("/")[0] for name in outputs}
    examples = [r for r in ROWS if r["file"].startswith("examples/")]  # judged once: they need a model fit
    assert len(examples) == 4 and all(r["accepted"] == "yes" for r in examples)
    assert kinds == {"emit", "moved", "convert", "place"} and any(n.endswith("$config.dat") for n in outputs)
    for name, text in sorted(outputs.items()):
        digest = hashlib.sha256(text.encode("latin-1")).hexdigest()
        row = VERDICT.get(digest)
        assert row is not None, f"{name}: this text (sha256 {digest[:12]}) was never judged by ANTLR: record it again (tests/data/antlr_krl/README.md)"
        assert row["accepted"] == "yes" or row["explanation"], f"{name}: ANTLR rejects it: {row['first_error']}"
