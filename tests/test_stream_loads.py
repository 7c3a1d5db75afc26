"""A load the program sets after its plain moves (in a later chunk of a streamed program) is
checked against the model as in the whole program: the streamed path checked the first
chunk alone, and compensated a program whose load the whole-program path refuses."""

from __future__ import annotations

import pytest
from helpers import kr160
from typer.testing import CliRunner

from postproc.cli import app
from postproc.jobs.stream import StreamFallback, compensate_streamed, stream_request
from postproc.model.effects import parse_effects
from postproc.model.errormodel import ErrorModel
from postproc.model.model_io import save_model

runner = CliRunner()
TOOL = [0.0, 0.0, 200.0]
CHUNK = 50


@pytest.fixture()
def model_path(tmp_path):
    path = tmp_path / "m.json"
    save_model(path, ErrorModel.create(kr160(), TOOL, parse_effects("geometric,joint_compliance[payload=20]")))
    return path


def _krl(path, later_load: float, n: int = 200):
    """$LOAD.M = 20 (the model's) before the moves, ``later_load`` kg after them (line n + 6)."""
    lines = ["DEF raster( )", "$BASE = {X 0, Y 0, Z 0, A 0, B 0, C 0}", "$TOOL = {X 0, Y 0, Z 200, A 0, B 0, C 0}", "$LOAD.M = 20",
             "LIN {X 900, Y -200, Z 450, A 0, B 180, C 0} C_DIS"]
    lines += [f"LIN {{X {900 + i * 0.5:.3f}, Y {-200 + (i % 40) * 10:.3f}}} C_DIS" for i in range(n)]
    lines += [f"$LOAD.M = {later_load:g}", "LIN {X 950, Y 0, Z 440, A 0, B 180, C 0}", "LIN {X 960}", "END"]
    path.write_text("\n".join(lines) + "\n")
    return path


def _rapid(path, n: int = 120):
    """tooldata of 20 kg; GripLoad of 30 kg more in the middle of the moves."""
    move = "    MoveL [[{x},{y},0],[0,0,1,0],[0,0,0,1],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, z1, t1\\WObj:=w1;\n"
    body = "".join(move.format(x=i % 50, y=i // 50) for i in range(n // 2)) + "    GripLoad piece;\n"
    body += "".join(move.format(x=i % 50, y=10 + i // 50) for i in range(n // 2))
    path.write_text("MODULE part\n  PERS tooldata t1 := [TRUE,[[0,0,200],[1,0,0,0]],[20,[0,0,100],[1,0,0,0],0,0,0]];\n"
                    "  PERS loaddata piece := [30,[0,0,200],[1,0,0,0],0,0,0];\n"
                    "  TASK PERS wobjdata w1 := [FALSE,TRUE,\"\",[[1000,0,500],[1,0,0,0]],[[0,0,0],[1,0,0,0]]];\n"
                    f"  PROC main()\n{body}  ENDPROC\nENDMODULE\n")
    return path


def _cli(program, model_path, out, stream, *extra):
    return runner.invoke(app, ["compensate", str(program), "--model", str(model_path), "-o", str(out), "--stream", stream, *extra])


@pytest.fixture()
def small_chunks(monkeypatch):
    """The CLI's streamed path in chunks of CHUNK lines, in this process (a test program is
    short): ``stream_request``'s defaults, whichever module of the CLI calls it."""
    monkeypatch.setitem(stream_request.__kwdefaults__, "chunk_lines", CHUNK)
    monkeypatch.setitem(stream_request.__kwdefaults__, "workers", 0)


@pytest.mark.parametrize("make,name,line", [(_krl, "p.src", 206), (_rapid, "p.mod", 66)])
def test_a_load_set_after_the_first_chunk_gives_the_whole_programs_output(tmp_path, model_path, small_chunks, make, name, line):
    program = make(tmp_path / name, **({"later_load": 50} if make is _krl else {}))
    outs = {}
    for stream in ("always", "never"):
        refused = _cli(program, model_path, tmp_path / f"refused_{stream}{program.suffix}", stream)
        assert refused.exit_code == 2 and f"line {line}" in refused.output and "payload is 50 kg" in refused.output, refused.output
        assert not (tmp_path / f"refused_{stream}{program.suffix}").exists()
        if stream == "always":  # KRL: cut into chunks, handed to the whole-program path at the later load; RAPID: not cut
            assert ("later chunk does not fit the model" in refused.output) == (make is _krl), refused.output
        outs[stream] = tmp_path / f"{stream}{program.suffix}"
        allowed = _cli(program, model_path, outs[stream], stream, "--allow-model-mismatch")
        assert allowed.exit_code == 0, allowed.output
        assert f"line {line}" in allowed.output and "payload is 50 kg" in allowed.output
    assert outs["always"].read_bytes() == outs["never"].read_bytes()


def test_a_later_load_the_model_fits_is_still_streamed(tmp_path, model_path):
    program = _krl(tmp_path / "p.src", later_load=20)
    result = compensate_streamed(program, ErrorModel.create(kr160(), TOOL, parse_effects("geometric,joint_compliance[payload=20]")),
                                 tmp_path / "s.src", chunk_lines=CHUNK, workers=0, model_check=(str(model_path), None, False))
    assert result.summary["chunks"] > 3
    assert _cli(program, model_path, tmp_path / "w.src", "never").exit_code == 0
    assert (tmp_path / "s.src").read_bytes() == (tmp_path / "w.src").read_bytes()


def test_the_streamed_path_hands_a_later_load_to_the_whole_program(tmp_path, model_path):
    program = _krl(tmp_path / "p.src", later_load=50)
    model = ErrorModel.create(kr160(), TOOL, parse_effects("geometric,joint_compliance[payload=20]"))
    with pytest.raises(StreamFallback, match="later chunk"):
        compensate_streamed(program, model, tmp_path / "s.src", chunk_lines=CHUNK, workers=0, model_check=(str(model_path), None, True))
    assert not (tmp_path / "s.src").exists()
