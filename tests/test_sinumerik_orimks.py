"""ORIMKS / ORIWKS with A3= B3= C3= vectors (postproc/programs/dialects/sinumerik/ori_reference.py).

SINUMERIK Job Planning (6FC5398-2BP40), "Orientation axis reference (ORIWKS, ORIMKS)": the
orientation vector is programmed in the workpiece coordinate system under both; ORIMKS sets how
the orientation runs between block ends (the rotary axes interpolated linearly). So the block
ends read the same; a vector under ORIMKS in a rotated frame (reference not stated) is refused.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from postproc.errors import ParseError
from postproc.programs import emit_texts, parse_program

VECTORS = "N10 G54 G71 G90\nN20 TRAORI\n{ref}N30 {frame}\nN40 G1 X0 Y0 Z0 A3=0 B3=0 C3=1 F100\nN50 G1 X1 Y0 Z0 A3=0 B3=1 C3=1\nN60 M30\n"


def _read(tmp_path: Path, text: str):
    path = tmp_path / "ORI.MPF"
    path.write_bytes(text.encode("latin-1"))
    return parse_program(path), path


def test_orimks_block_ends_read_as_under_oriwks(tmp_path):
    works, _ = _read(tmp_path, VECTORS.format(ref="", frame="TRANS X5"))
    machine, path = _read(tmp_path, VECTORS.format(ref="N25 ORIMKS\n", frame="TRANS X5"))
    np.testing.assert_array_equal(machine.values[:, 3:6], works.values[:, 3:6])
    np.testing.assert_array_equal(machine.base_positions(), works.base_positions())
    assert any("line 5: ORIMKS" in n and "interpolates the rotary axes linearly" in n for n in machine.notes), machine.notes
    assert emit_texts(machine, machine)[0].encode("latin-1") == path.read_bytes()


def test_orimks_vector_in_a_rotated_frame_is_refused(tmp_path):
    with pytest.raises(ParseError) as exc:
        _read(tmp_path, VECTORS.format(ref="N25 ORIMKS\n", frame="ROT Z30"))
    assert exc.value.line == 5 and "ORIMKS in a rotated frame" in exc.value.message
    tp, _ = _read(tmp_path, VECTORS.format(ref="N25 ORIMKS\nN26 ORIWKS\n", frame="ROT Z30"))  # ORIWKS again: the frame turns them
    assert tp.resolved.all() and not any("ORIMKS" in n for n in tp.notes)
