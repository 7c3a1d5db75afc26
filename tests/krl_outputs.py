"""Every kind of KRL text postproc writes, written to a folder (the texts ANTLR's KRL grammar judges).

    .venv/bin/python tests/krl_outputs.py OUT_DIR

writes, for the programs of tests/corpus (KRL, RAPID, G-code) and examples/data:
  emit/<name>            a KRL program's files re-emitted unchanged (.src, .dat, $config.dat)
  moved/<name>           the same with every Cartesian target moved (the splice a compensation writes,
                         numbers changed and missing components inserted)
  convert/<stem>.src/.dat  `convert --to krl` of every program (the new-program writer); the first
                         one also with `--tool-load` (convert/<stem>__tool_load.src: $LOAD)
  place/<name>           `place -o`: a program's one $BASE literal replaced
Inputs a step refuses (EmitError, InputError: nothing is written by postproc either) are skipped.
This script only writes KRL texts; tests/test_antlr_krl.py compares their SHA-256 with the
recorded ANTLR verdicts in tests/data/antlr_krl/.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
# The KRL, RAPID and G-code programs (the languages judged when the recording was made; a later
# language's examples, e.g. examples/data/FACE.JBI, are converted and read back by its own tests).
INPUTS = sorted(p for folder in ("tests/corpus/krl", "tests/corpus/rapid", "tests/corpus/gcode", "examples/data")
                for p in (REPO / folder).iterdir() if p.is_file() and p.suffix.lower() not in (".dat", ".md", ".jbi"))
SHIFT = np.array([0.1234, -0.0567, 0.0089])  # mm: every number moves, some by a carry


def _tool_load():
    from postproc.programs.emit.tool_load import ToolLoad

    return ToolLoad(12.5, (1.0, -2.0, 80.0), (0.05, 0.04, 0.01))


TOOL_LOAD = _tool_load()


def _out_name(path: Path, name: str) -> str:
    return f"{path.parent.name}__{name}"


def _krl_texts(tp, path: Path) -> dict[str, str]:
    """emit/ and moved/ texts of a KRL program (each file of the program)."""
    from postproc.errors import EmitError, InputError
    from postproc.programs import emit_texts

    out = {}
    names = [Path(doc.path).name for doc in tp.sources]
    for text, name in zip(emit_texts(tp, tp), names):
        out[f"emit/{_out_name(path, name)}"] = text
    known = ~np.isnan(tp.position).any(axis=1)
    try:
        moved = emit_texts(tp, tp.with_positions(np.where(known[:, None], tp.position + SHIFT, tp.position)))
    except (EmitError, InputError):
        return out
    for text, name in zip(moved, names):
        out[f"moved/{_out_name(path, name)}"] = text
    return out


def _placed(path: Path) -> dict[str, str]:
    from postproc.errors import EmitError
    from postproc.programs.dialects.krl.placing import set_base
    from postproc.robot.frames import abc_to_matrix, make_transform

    text = path.read_bytes().decode("latin-1")
    frame = make_transform(abc_to_matrix(np.array([[12.5, -3.25, 178.0]]))[0], np.array([1250.5, -300.25, 410.125]))
    try:
        return {f"place/{_out_name(path, path.name)}": set_base(text, frame, str(path))}
    except EmitError:
        return {}


# A program whose points live in its .dat and in the robot's $config.dat (our own text): the
# $config.dat that a compensation rewrites.
WITH_CONFIG = {
    "cell.src": "&ACCESS RVP\r\n&REL 1\r\nDEF cell( )\r\n$BASE = BASE_DATA[1]\r\n$TOOL = TOOL_DATA[1]\r\n"
                "PTP XHOME\r\nLIN XPDAT C_DIS\r\nLIN XPCFG\r\nLIN {X 950, Y 50, Z 420, A 0, B 180, C 0}\r\nEND\r\n",
    "cell.dat": "&ACCESS RVP\r\nDEFDAT cell\r\nDECL E6AXIS XHOME={A1 0,A2 -90,A3 90,A4 0,A5 0,A6 0}\r\n"
                "DECL E6POS XPDAT={X 1000,Y -60,Z 430,A 0,B 180,C 0,S 6,T 50}\r\nENDDAT\r\n",
    "$config.dat": "&ACCESS RVP\r\nDEFDAT $CONFIG\r\nDECL GLOBAL E6POS XPCFG={X 1050,Y 80,Z 440,A 0,B 180,C 0}\r\n"
                   "BASE_DATA[1]={X 500,Y -200,Z 0,A 90,B 0,C 0}\r\nTOOL_DATA[1]={X 0,Y 0,Z 200,A 0,B 0,C 0}\r\nENDDAT\r\n",
}


def _with_config() -> dict[str, str]:
    import tempfile

    from postproc.programs import parse_program

    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp) / "config"
        folder.mkdir()
        for name, text in WITH_CONFIG.items():
            (folder / name).write_bytes(text.encode("latin-1"))
        return _krl_texts(parse_program(folder / "cell.src"), folder / "cell.src")


def _undefined_as_identity(tp):
    """``tp`` with the frames and tools it does not define (G54 without G10, H1) given as the
    identity, as `convert --frame G54=0,0,0,0,0,0 --tool H1=0,0,0` gives them (convert refuses them otherwise)."""
    frames = {n.split("+")[0]: np.eye(4) for n, known in zip(tp.frame_names, tp.frame_known) if not known}
    tools = {n: np.eye(4) for n, known in zip(tp.tool_names, tp.tool_known) if not known}
    return tp.with_frames(frames, tools) if frames or tools else tp


def krl_outputs() -> dict[str, str]:
    """Relative output name -> KRL text, for every input and every way postproc writes KRL."""
    from postproc.errors import EmitError, InputError, ParseError
    from postproc.programs import parse_program, write_program

    out: dict[str, str] = _with_config()
    for path in INPUTS:
        try:
            tp = parse_program(path)
        except (ParseError, InputError):
            continue
        if tp.dialect == "krl":
            out.update(_krl_texts(tp, path))
            out.update(_placed(path))
        try:
            src, dat = write_program(_undefined_as_identity(tp), "krl", path.stem)
        except (EmitError, InputError):
            continue
        stem = _out_name(path, path.stem)
        out[f"convert/{stem}.src"], out[f"convert/{stem}.dat"] = src, dat
        if not any(name.endswith("__tool_load.src") for name in out):  # `convert --tool-load` ($LOAD), once
            try:
                src, dat = write_program(_undefined_as_identity(tp), "krl", path.stem, tool_load=TOOL_LOAD)
            except InputError:  # the program states another load: convert refuses --tool-load there
                continue
            out[f"convert/{stem}__tool_load.src"], out[f"convert/{stem}__tool_load.dat"] = src, dat
    return out


def write(folder: Path) -> list[Path]:
    written = []
    for name, text in sorted(krl_outputs().items()):
        target = folder / name
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_bytes(text.encode("latin-1"))
        written.append(target)
    return written


if __name__ == "__main__":
    for p in write(Path(sys.argv[1])):
        print(p)
