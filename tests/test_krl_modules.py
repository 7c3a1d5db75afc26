"""KRL points of another module's data list (``--data``; postproc/programs/dialects/krl/modules.py).

The cell in tests/data/krl_modules/ has the layout of a real KUKA milling cell
(KRC/R1/Program/KukaMiling/Dat/xPoints.dat with the stations' points, the motion modules in
Moves/, $config.dat in System/). Expected positions by hand from "KUKA System Software 8.x,
Operating and Programming Instructions for System Integrators" (KSS 8 SI):
- "Data lists": a name declared ``DECL GLOBAL`` in a data list opened ``DEFDAT NAME PUBLIC``
  is seen by every module; a declaration without GLOBAL, or in a data list without PUBLIC,
  is seen only by its own module; $CONFIG.DAT's names are seen by all;
- "Global declarations": a local name hides a global one of the same name;
- "Coordinate systems" / "BASE": a target is at $BASE : target, $BASE = BASE_DATA[1] =
  {X 1000} (System/$config.dat) puts XST1 {X 900, Y 960, Z 1190} at (1900, 960, 1190).
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from postproc.cli import app
from postproc.errors import InputError
from postproc.programs import emit_texts, files_for, parse_program, write_set

CELL = Path(__file__).parent / "data" / "krl_modules"


@pytest.fixture
def cell(tmp_path: Path) -> Path:
    shutil.copytree(CELL, tmp_path / "cell")
    return tmp_path / "cell" / "KukaMiling"


def read(cell: Path, name: str = "st1_st2"):
    return parse_program(cell / "Moves" / f"{name}.src", modules=[cell / "Dat", cell.parent / "System" / "$config.dat"])


def placed(tp) -> np.ndarray:
    return np.where(tp.placed()[:, None], tp.base_positions(), np.nan)


def test_global_points_of_a_public_data_list_are_read_from_it(cell):
    tp = read(cell)
    # XST1, XST2 of Dat/xPoints.dat under BASE_DATA[1] = {X 1000}; XSHARED is declared GLOBAL
    # in xPoints.dat (X 500, Z 700) and locally in st1_st2.dat (X 400, Z 800): the local one.
    np.testing.assert_allclose(placed(tp), [[1900, 960, 1190], [1160, -1116, 504], [1400, 0, 800]])
    assert Path(tp.sources[int(tp.spans[0, 0, 0])].path).name == "xPoints.dat"
    assert Path(tp.sources[int(tp.spans[2, 0, 0])].path).name == "st1_st2.dat"


def test_without_the_other_module_the_point_is_not_declared(cell):
    tp = parse_program(cell / "Moves" / "st1_st2.src")
    assert not tp.placed()[:2].any()
    assert any("point XST1 is not declared" in n for n in tp.notes)


def test_a_point_another_module_does_not_make_global_is_not_seen(cell):
    tp = read(cell, "hidden")
    # XLOCAL: DECL without GLOBAL (xPoints.dat line 9); XPRIV: GLOBAL in 'DEFDAT PRIVATE' (not PUBLIC)
    assert tp.placed().tolist() == [True, False, False]
    np.testing.assert_allclose(tp.base_positions()[0], [1900, 960, 1190])
    notes = " ".join(tp.notes)
    assert "xPoints.dat:9 declares it without GLOBAL" in notes
    assert "private.dat:2 declares it without GLOBAL or in a data list that is not PUBLIC" in notes


def test_compensation_writes_the_point_into_the_data_list_that_declares_it(cell, tmp_path):
    tp = read(cell)
    new = tp.with_positions(tp.position + [[0.5, 0, 0], [0, 0, 0], [0, 0, 0]])
    texts = emit_texts(tp, new)
    out = tmp_path / "out" / "st1_st2.src"
    out.parent.mkdir()
    files = files_for(tp, texts, out)
    written = {p.name for p in files}
    assert written == {"st1_st2.src", "st1_st2.dat", "xPoints.dat"}  # all of one job, written together (write_set)
    write_set(files)
    assert "DECL GLOBAL E6POS XST1={X 900.5,Y 960.0" in (out.parent / "xPoints.dat").read_text()
    again = parse_program(out, modules=[out.parent / "xPoints.dat", cell.parent / "System" / "$config.dat"])
    np.testing.assert_allclose(again.base_positions()[0], [1900.5, 960, 1190])
    in_place = files_for(tp, texts, cell / "Moves" / "st1_st2.src")  # --in-place: back into Dat/xPoints.dat
    assert cell / "Dat" / "xPoints.dat" in in_place


def test_inspect_takes_other_modules_with_data(cell):
    src = cell / "Moves" / "st1_st2.src"
    result = CliRunner().invoke(app, ["inspect", str(src), "--json", "--data", str(cell / "Dat"), "--data", str(cell.parent / "System" / "$config.dat")])
    assert result.exit_code == 0, result.output
    moves = json.loads(result.stdout)["moves"]
    assert [m["xyz"] for m in moves] == [[1900, 960, 1190], [1160, -1116, 504], [1400, 0, 800]]
    bad = CliRunner().invoke(app, ["inspect", str(src), "--json", "--data", str(cell / "missing.dat")])
    assert bad.exit_code == 2 and "missing.dat" in bad.output


def test_data_is_for_krl_only(tmp_path):
    (tmp_path / "m.mod").write_text("MODULE m\nENDMODULE\n")
    with pytest.raises(InputError, match="--data"):
        parse_program(tmp_path / "m.mod", modules=[tmp_path])


def test_functions_of_another_module_are_evaluated_when_straight_line(cell):
    # Lib/offsets.src: GLOBAL DEFFCT REAL Offset(n:IN) with step = 10.0, RETURN n * step + 0.5
    # (KSS 8 SI "Subprograms and functions": IN parameters by value, RETURN gives the value).
    # XST1.X = Offset(3) = 30.5: PTP XST1 at BASE_DATA[1] {X 1000} : (30.5, 960, 1190) = (1030.5, 960, 1190).
    # Measured( ) has an IF on $IN[n]: not straight-line; Hidden( ) is not GLOBAL (and not the
    # module's main routine): other modules do not see it. Both targets stay unresolved,
    # never at the declared values, with the call's line and the function's file:line.
    modules = [cell / "Dat", cell / "Lib", cell.parent / "System" / "$config.dat"]
    tp = parse_program(cell / "Moves" / "fct.src", modules=modules)
    assert tp.placed().tolist() == [True, False, False]
    np.testing.assert_allclose(tp.base_positions()[0], [1030.5, 960, 1190])
    notes = "\n".join(tp.notes)
    assert "fct.src:5: MEASURED(): " in notes and "offsets.src:12: its body is not straight-line" in notes
    assert "fct.src:7: HIDDEN(): " in notes and "offsets.src:20: declared without GLOBAL" in notes
    without = parse_program(cell / "Moves" / "fct.src", modules=modules[:1] + modules[2:])
    assert without.placed().tolist() == [False, False, False]  # Offset( ) not given: not evaluated
    assert "fct.src:3: OFFSET(): not a function of the given files" in "\n".join(without.notes)


def test_builtin_arithmetic_functions(tmp_path):
    # KSS 8 SI "Arithmetic functions": SIN/COS in degrees, SQRT, ABS.
    (tmp_path / "p.src").write_text("DEF p( )\nXP1.X = 100 * COS(60) + SQRT(16) + ABS(-2)\nLIN XP1\nEND\n")
    (tmp_path / "p.dat").write_text("DEFDAT p\nDECL E6POS XP1={X 0,Y 0,Z 500,A 0,B 90,C 0}\nENDDAT\n")
    tp = parse_program(tmp_path / "p.src")
    np.testing.assert_allclose(tp.base_positions()[0], [56, 0, 500])


def test_compensate_with_data_writes_the_module_data_list_with_the_program(tmp_path):
    # The whole job through the CLI: the target's numbers live in Dat/xPoints.dat (GLOBAL, PUBLIC),
    # so OUT's folder gets the .src and the changed xPoints.dat, written together (postproc.files.write_all).
    from helpers import TOOL, kr160

    from postproc.model.effects import parse_effects
    from postproc.model.errormodel import ErrorModel
    from postproc.model.model_io import save_model

    (tmp_path / "Dat").mkdir()
    (tmp_path / "Dat" / "xPoints.dat").write_text("DEFDAT XPOINTS PUBLIC\nDECL GLOBAL E6POS XCUT={X 1000.0,Y 0.0,Z 400.0,A 0.0,B 180.0,C 0.0}\nENDDAT\n")
    (tmp_path / "part.src").write_text("DEF part( )\n$BASE = {X 0, Y 0, Z 0, A 0, B 0, C 0}\n$TOOL = {X 0, Y 0, Z 200, A 0, B 0, C 0}\nLIN XCUT\nEND\n")
    model = tmp_path / "thermal.json"
    save_model(model, ErrorModel.create(kr160(), TOOL, parse_effects("thermal"), {"thermal.alpha": 1.2e-5}))
    out = tmp_path / "out" / "part.src"
    out.parent.mkdir()
    args = ["compensate", str(tmp_path / "part.src"), "--model", str(model), "-o", str(out), "--temp", "40", "--allow-model-mismatch"]
    refused = CliRunner().invoke(app, args)
    assert refused.exit_code != 0 and not (out.parent / "part.src").exists()  # XCUT not declared without --data
    result = CliRunner().invoke(app, args + ["--data", str(tmp_path / "Dat")])
    assert result.exit_code == 0, result.output
    assert sorted(p.name for p in out.parent.iterdir()) == ["part.src", "xPoints.dat"]
    assert (out.parent / "part.src").read_text() == (tmp_path / "part.src").read_text()
    written = (out.parent / "xPoints.dat").read_text()
    assert written != (tmp_path / "Dat" / "xPoints.dat").read_text() and "DECL GLOBAL E6POS XCUT={X " in written


def test_two_changed_data_lists_of_one_name_are_refused_not_merged(tmp_path):
    # A/xPoints.dat and B/xPoints.dat both hold a corrected point: beside OUT they would be one
    # file; the job is refused before anything is written.
    from postproc.errors import EmitError

    for folder, name in (("A", "XA"), ("B", "XB")):
        (tmp_path / folder).mkdir()
        (tmp_path / folder / "xPoints.dat").write_text(f"DEFDAT XPOINTS PUBLIC\nDECL GLOBAL E6POS {name}={{X 1000.0,Y 0.0,Z 400.0,A 0.0,B 180.0,C 0.0}}\nENDDAT\n")
    (tmp_path / "p.src").write_text("DEF p( )\nLIN XA\nLIN XB\nEND\n")
    tp = parse_program(tmp_path / "p.src", modules=[tmp_path / "A", tmp_path / "B"])
    texts = emit_texts(tp, tp.with_positions(tp.position + 0.5))
    with pytest.raises(EmitError, match="would be written to this one path"):
        files_for(tp, texts, tmp_path / "out" / "p.src")
