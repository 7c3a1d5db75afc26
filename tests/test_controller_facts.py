"""The controllers read the facts a program states from the IR (``Toolpath.extras``, written
by each language's parser), never the program text (issue 27): a toolpath whose text is
blanked after parsing gets the same answers from its controller."""

from __future__ import annotations

import ast
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import postproc
from postproc.errors import InputError
from postproc.programs import dialects, parse_program
from postproc.programs.ir import SourceDoc

T = "[[900,0,900],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]]"


def _blanked(tp):
    """``tp`` with every source's text replaced by spaces (same length): only the IR is left."""
    return replace(tp, sources=tuple(SourceDoc(d.path, " " * len(d.text), d.role) for d in tp.sources))


def _read(tmp_path, name, text):
    (tmp_path / name).write_text(text)
    tp = parse_program(tmp_path / name)
    return tp, dialects.of(tp).controller


def test_rapid_confl_and_confj_are_ir_columns_the_controller_reads(tmp_path):
    text = ("MODULE P\n  PROC main()\n    approach;\n    ConfL\\Off;\n    cut;\n    ConfJ\\Off;\n"
            f"    MoveJ {T}, v100, z1, tool0;\n  ENDPROC\n"
            f"  PROC approach()\n    MoveL {T}, v100, z1, tool0;\n  ENDPROC\n"
            f"  PROC cut()\n    MoveL {T}, v100, z1, tool0;\n  ENDPROC\nENDMODULE\n")
    tp, controller = _read(tmp_path, "p.mod", text)
    order = np.argsort(tp.line)  # rows in program (text) order: MoveJ (7), approach (10), cut (13)
    assert tp.extras["rapid.confl_off"][order].tolist() == [True, False, True]
    assert tp.extras["rapid.confj_off"][order].tolist() == [True, False, False]
    assert controller.conf_applies(tp)[order].tolist() == [False, True, False]
    assert controller.conf_applies(_blanked(tp)).tolist() == controller.conf_applies(tp).tolist()


def test_a_rapid_switch_under_a_condition_is_refused_from_the_ir(tmp_path):
    text = f"MODULE P\n  PROC main()\n    IF di1 = 1 ConfL\\Off;\n    MoveL {T}, v100, z1, tool0;\n  ENDPROC\nENDMODULE\n"
    tp, controller = _read(tmp_path, "p.mod", text)  # reading it is fine: only the posture rule is refused
    assert "p.mod:3:16" in tp.extras["rapid.conf_refused"][0]
    with pytest.raises(InputError, match=r"p.mod:3:16: ConfL\\Off runs only under a condition"):
        controller.conf_applies(_blanked(tp))


def test_rapid_singarea_is_an_ir_column(tmp_path):
    text = f"MODULE P\n  PROC main()\n    ! SingArea \\Wrist;\n    SingArea \\LockAxis4;\n    MoveL {T}, v100, z1, tool0;\n  ENDPROC\nENDMODULE\n"
    tp, controller = _read(tmp_path, "p.mod", text)
    assert tp.extras["rapid.singarea"].tolist() == [f"{tmp_path / 'p.mod'}:4: SingArea \\LockAxis4"]
    assert controller.inexact_interpolation(_blanked(tp)).startswith(f"{tmp_path / 'p.mod'}:4: SingArea \\LockAxis4: between targets")
    plain, _ = _read(tmp_path, "q.mod", text.replace("    SingArea \\LockAxis4;\n", ""))
    assert controller.inexact_interpolation(plain) is None


def test_krl_circular_angle_is_an_ir_column(tmp_path):
    text = ("DEF arcs( )\n  PTP {A1 0, A2 -90, A3 90, A4 0, A5 0, A6 0}\n"
            "  CIRC {X 110, Y 10, Z 500}, {X 120, Y 0, Z 500, A 0, B 90, C 0}, CA 90\n"
            "  CIRC {X 130, Y 10, Z 500}, {X 140, Y 0, Z 500, A 0, B 90, C 0}\nEND\n")
    tp, controller = _read(tmp_path, "arcs.src", text)
    ends = tp.kind == 3  # Kind.CIRC_END
    assert tp.extras["krl.circular_angle"][ends].tolist() == [True, False]
    assert controller.arc_ends_at_target(_blanked(tp))[ends].tolist() == [False, True]


def test_sinumerik_continuous_path_mode_is_an_ir_column(tmp_path):
    tp, controller = _read(tmp_path, "p.mpf", "G54 G71\nG1 X1 Y2 Z3 F100\nG642\nG1 X2\nM30\n")
    assert controller.inexact_interpolation(_blanked(tp)).startswith(f"{tmp_path / 'p.mpf'}:3: continuous-path mode")
    plain, _ = _read(tmp_path, "q.mpf", "G54 G71\nG1 X1 Y2 Z3 F100\nG1 X2\nM30\n")
    assert controller.inexact_interpolation(_blanked(plain)) is None


def test_sinumerik_continuous_words_in_comments_or_other_words_do_not_count(tmp_path):
    text = "G54 G71 ; G64 here is a comment\nG1 X1 Y2 Z3 F100\nR1=1 ; COMPCAD too\nG1 X2\nG6420 X3\ncompcad\nG1 X4\nM30\n"
    tp, controller = _read(tmp_path, "c.mpf", text)
    assert tp.extras["sinumerik.continuous"][0] == f"{tmp_path / 'c.mpf'}:6"
    none, _ = _read(tmp_path, "d.mpf", "G54 G71 ; G642\nG1 X1 Y2 Z3 F100\nG1 X2\nM30\n")
    assert controller.inexact_interpolation(_blanked(none)) is None


# ------------------------------------------------------------------ loads (program-level facts)

def _move(x: int, tool: str = "t1", load: str = "") -> str:
    return f"    MoveL [[{x},0,0],[0,0,1,0],[0,0,0,1],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, {tool}{load}\\WObj:=w1;\n"


def _rapid_module(decls: str, body: str) -> str:
    return (f"MODULE part\n{decls}  TASK PERS wobjdata w1 := [FALSE,TRUE,\"\",[[1000,0,500],[1,0,0,0]],[[0,0,0],[1,0,0,0]]];\n"
            f"  PROC main()\n{body}  ENDPROC\nENDMODULE\n")


TOOLDATA = "  PERS tooldata t1 := [TRUE,[[0,0,200],[1,0,0,0]],[3,[0,0,100],[1,0,0,0],0,0,0]];\n"
LOADDATA = "  PERS loaddata piece := [2,[0,0,200],[1,0,0,0],0.1,0.2,0.3];\n"
GRIPS = _rapid_module(TOOLDATA + LOADDATA, _move(0) + "    GripLoad piece;\n" + _move(50) + _move(60) + "    GripLoad load0;\n" + _move(100))


def _plan(plan):
    """A LoadPlan as comparable values: each target's (total mass, cog, where it was stated)."""
    return [None if k < 0 else (plan.states[k].total.mass_kg, plan.states[k].total.cog_mm, plan.states[k].stated_at) for k in plan.index]


def test_rapid_tooldata_loaddata_and_gripload_are_ir_facts_the_controller_reads(tmp_path):
    tp, controller = _read(tmp_path, "part.mod", GRIPS)
    path = tmp_path / "part.mod"
    plan = _plan(controller.stated_loads(tp))
    assert [p[0] for p in plan] == [3, 5, 5, 3]  # the tool's 3 kg; with the gripped 2 kg from GripLoad piece to GripLoad load0
    assert plan[1][2] == f"{path}:7:5" and plan[0][2] == f"{path}:2:8"
    assert controller.payloads(tp) == [(3.0, f"{path}, line 2 (tooldata t1)"), (5.0, f"{path}, line 7 (GripLoad piece)")]
    blank = _blanked(tp)
    assert _plan(controller.stated_loads(blank)) == plan and controller.payloads(blank) == controller.payloads(tp)


def test_rapid_tload_and_an_unknown_gripload_are_refused_from_the_ir(tmp_path):
    tload, controller = _read(tmp_path, "t.mod", _rapid_module(TOOLDATA + LOADDATA, _move(0) + _move(5, load="\\TLoad:=piece")))
    assert controller.payloads(_blanked(tload))[-1] == (2.0, f"{tmp_path / 't.mod'}, line 7 (\\TLoad:=piece)")  # the whole load of that motion
    with pytest.raises(InputError, match=r"t.mod:7:82: \\TLoad \(the whole load of one motion\) is not carried"):
        controller.stated_loads(_blanked(tload))
    unknown, _ = _read(tmp_path, "u.mod", GRIPS.replace("GripLoad piece", "GripLoad other"))
    with pytest.raises(InputError, match=r"u.mod:7:5: GripLoad other: no loaddata other"):
        controller.stated_loads(_blanked(unknown))


KRL_LOADS = ("DEF part( )\n$BASE = {X 1000, Y 0, Z 500, A 0, B 0, C 0}\n$TOOL = {X 0, Y 0, Z 200, A 0, B 0, C 0}\n"
             "$LOAD = {M 12.5, CM {X 0, Y -5, Z 120, A 0, B 90, C 0}, J {X 0.2, Y 0.1, Z 0.05}}\n"
             "LIN {X 0, Y 0, Z 0, A 0, B 180, C 0}\nLIN {X 0, Y 10, Z 0, A 0, B 180, C 0}\n"
             "$LOAD = LOAD_DATA[3]\nLIN {X 0, Y 50, Z 0, A 0, B 180, C 0}\nEND\n")
KRL_DAT = "DEFDAT part\nDECL LOAD LOAD_DATA[3]={M 7.5,CM {X 1,Y 2,Z 60,A 0,B 0,C 0},J {X 0.1,Y 0.1,Z 0.02}}\nENDDAT\n"


def test_krl_load_statements_are_ir_facts_the_controller_reads(tmp_path):
    (tmp_path / "part.dat").write_text(KRL_DAT)
    tp, controller = _read(tmp_path, "part.src", KRL_LOADS)
    path = tmp_path / "part.src"
    plan = _plan(controller.stated_loads(tp))
    assert [(m, at) for m, _, at in plan] == [(12.5, f"{path}:4:1"), (12.5, f"{path}:4:1"), (7.5, f"{path}:7:1")]
    assert controller.payloads(tp) == [(12.5, f"{path}, line 4"), (7.5, f"{path}, line 7 (LOAD_DATA[3])")]
    blank = _blanked(tp)
    assert _plan(controller.stated_loads(blank)) == plan and controller.payloads(blank) == controller.payloads(tp)


def test_a_krl_load_data_the_files_do_not_declare_is_refused_from_the_ir(tmp_path):
    tp, controller = _read(tmp_path, "part.src", KRL_LOADS)  # no part.dat
    with pytest.raises(InputError, match=r"part.src:7:1: LOAD_DATA\[3\] is not in the program's files"):
        controller.stated_loads(_blanked(tp))


@pytest.mark.parametrize("language", ["rapid", "krl"])
def test_a_subset_of_the_targets_keeps_the_load_each_carries(tmp_path, language):
    """``take`` keeps the program-level facts and slices the column of the one in force."""
    if language == "rapid":
        tp, controller = _read(tmp_path, "part.mod", GRIPS)
    else:
        (tmp_path / "part.dat").write_text(KRL_DAT)
        tp, controller = _read(tmp_path, "part.src", KRL_LOADS)
    whole = _plan(controller.stated_loads(tp))
    for rows in ([1, 2], [len(tp) - 1], [2, 0], np.arange(len(tp))[::-1]):
        part = tp.take(rows)
        assert part.facts == tp.facts
        assert _plan(controller.stated_loads(_blanked(part))) == [whole[r] for r in rows], rows


# ------------------------------------------------------ no controller reads the program text

PACKAGE = Path(postproc.__file__).parent
TEXT_READS = {"text", "read_text", "read_bytes"}  # SourceDoc.text, Path.read_text / read_bytes


def _module_file(dotted: str) -> Path | None:
    base = PACKAGE.parent.joinpath(*dotted.split("."))
    return next((p for p in (base.with_suffix(".py"), base / "__init__.py") if p.is_file()), None)


def _absolute(file: Path, node: ast.ImportFrom) -> str:
    if not node.level:
        return node.module or ""
    package = list(file.relative_to(PACKAGE.parent).with_suffix("").parts)
    package = package[: len(package) - node.level]  # level 1: the file's own package
    return ".".join(package + ([node.module] if node.module else []))


def _definitions(file: Path) -> tuple[dict, dict]:
    """The module's top-level functions by name (classes are the IR's and the loads' data types, or
    the Controller base, scanned on its own), and its imported names -> (module file, name)."""
    tree = ast.parse(file.read_text())
    defined = {n.name: n for n in tree.body if isinstance(n, ast.FunctionDef)}
    imported = {}
    for n in tree.body:
        if isinstance(n, ast.ImportFrom) and (n.level or (n.module or "").startswith("postproc")):
            target = _module_file(_absolute(file, n))
            imported.update({a.asname or a.name: (target, a.name) for a in n.names if target is not None})
    return defined, imported


def _text_reads(controller: Path) -> list[str]:
    """``file:line: .attr`` of every read of program text in the controller module and in every
    function of the package it reaches through the names it uses."""
    found, seen = [], set()
    todo = [(controller, ast.parse(controller.read_text()))]
    while todo:
        file, node = todo.pop()
        defined, imported = _definitions(file)
        for sub in ast.walk(node):
            if isinstance(sub, ast.Attribute) and sub.attr in TEXT_READS:
                found.append(f"{file.relative_to(PACKAGE.parent)}:{sub.lineno}: .{sub.attr}")
            if isinstance(sub, ast.Call) and isinstance(sub.func, ast.Name) and sub.func.id == "open":
                found.append(f"{file.relative_to(PACKAGE.parent)}:{sub.lineno}: open()")
            if isinstance(sub, ast.Name):
                where = (file, sub.id) if sub.id in defined else imported.get(sub.id)
                if where is not None and where not in seen:
                    seen.add(where)
                    target_defined, _ = _definitions(where[0])
                    if where[1] in target_defined and target_defined[where[1]] is not node:
                        todo.append((where[0], target_defined[where[1]]))
    return found


CONTROLLERS = sorted(PACKAGE.glob("programs/dialects/*/controller.py")) + [PACKAGE / "programs" / "controller.py"]


@pytest.mark.parametrize("controller", CONTROLLERS, ids=[p.parent.name if p.parent.parent.name == "dialects" else "base" for p in CONTROLLERS])
def test_no_controller_reads_the_program_text(controller):
    """The controller module and what it calls (its package's loads, facts' readers, emit's
    load plan) read the IR only: the parser wrote what the text states into it."""
    assert _text_reads(controller) == []


def test_the_text_read_scan_finds_a_read(tmp_path):
    """The scan above sees a read through a called function (its guard works)."""
    assert any(".text" in hit for hit in _text_reads(PACKAGE / "programs" / "dialects" / "rapid" / "facts.py"))
    module = tmp_path / "controller.py"  # a function of the package reached by name from the module: emit's in_force reads the text
    module.write_text("from postproc.programs.emit.load_plan import in_force\n\n\ndef plan(tp):\n    return in_force(tp, [])\n")
    assert any("load_plan.py" in hit and ".text" in hit for hit in _text_reads(module))
    assert {"rapid", "krl", "fanuc"} <= {p.parent.name for p in CONTROLLERS}
