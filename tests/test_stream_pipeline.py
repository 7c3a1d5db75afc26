"""The main process of the streamed pipeline (postproc.jobs.stream): body lines told by their
shape agree with the body pattern line for line; the posture handed from worker to worker
(``_Baton``) is the one the whole program carries, anchors in later chunks included."""

from __future__ import annotations

import multiprocessing

import numpy as np
import pytest
from helpers import FRAME_AND_COMPLIANCE, TOOL

import postproc
from postproc.jobs.compensate import compensate, reference_postures
from postproc.jobs.stream import StreamFallback, _Baton, _is_body, compensate_streamed
from postproc.model.effects import parse_effects
from postproc.model.sim import random_truth
from postproc.programs import emit_texts, parse_program
from postproc.programs.dialects.gcode.stream import RULES as GCODE
from postproc.programs.dialects.krl.stream import RULES as KRL

KRL_BODY = "LIN {X 900.125, Y -200.5, Z 450, A 0, B 180, C 0} C_DIS"
KRL_LINES = [KRL_BODY, "LIN {X 1}", "PTP {X 1, Y 2} C_PTP ; 12 a comment", "$VEL.CP = 0.2", "$APO.CDIS=12.5", "; 123 comment",
             ";FOLD 12", "; ENDFOLD", "", "   ", "\r", "$BASE = {X 0, Y 0, Z 0, A 0, B 0, C 0}", "PTP HOME", "LIN P12 C_DIS",
             "SLIN {X 1, Y 2}", "IF $IN[12] THEN", "$VEL.CP = 0.2e3", "lin {x 1.5e-3} c_dis", "$OV_PRO = 50"]
GCODE_BODY = "G1 X12.345 Y-0.5 Z0 I0.0123 J0 K0.999 F3000"
GCODE_LINES = [GCODE_BODY, "X1 Y2", "G0 X1", "G00 X1", "G01 X1", "G1X1", "g1 x1", "G2 X1 Y1 I1 J0", "G02 X1", "G03 X1", "G10 L2 P1 X0",
               "G11", "G1.5 X1", "G17", "G90", "G91", "G43.5 H1", "G54", "N10 G1 X1", "M3 S1000", "T1 M6", "(G2 in a comment) G1 X1",
               "(note 12) X1", "; G3 X1", "G4 P1", "G0", "G100 X1", "#1 = 2", "O100 sub", "G1 X1 (a (nested) comment)", "", "\r"]


@pytest.mark.parametrize("rules,body,lines", [(KRL, KRL_BODY, KRL_LINES), (GCODE, GCODE_BODY, GCODE_LINES)])
def test_body_by_shape_agrees_with_the_body_pattern(rules, body, lines):
    """Every candidate line between body lines, and at the end without its '\\n': the length
    of the body run is the one the body pattern gives over every character."""
    for line in lines:
        for text in (f"{body}\n{body}\n{line}\n{body}\n", f"{body}\n{line}", f"{line}\n{body}\n{line}\n"):
            probe = text if text.endswith("\n") else text + "\n"
            assert _is_body(rules, text) == min(rules.body.match(probe).end(), len(text)), repr(text)


def test_baton_hands_the_end_posture_on_in_order():
    baton = _Baton(multiprocessing.get_context("fork"))
    q = np.array([1.0, -2.0, 3.5, -0.0, 5.0, 6.0])
    baton.give(0, q)
    assert baton.take(1).tobytes() == q.tobytes()
    baton.give(1, None)
    assert baton.take(2) is None
    baton.give(2, q, failed=True)
    with pytest.raises(StreamFallback, match="chunk before failed"):
        baton.take(3)
    with pytest.raises(RuntimeError):
        baton.take(2)  # chunk 1's end was overwritten: a chunk out of order is a bug, not a posture


@pytest.fixture(scope="module")
def model():
    robot = postproc.load_robot("kr160_r1570")
    return random_truth(robot, TOOL, parse_effects(FRAME_AND_COMPLIANCE), np.random.default_rng(3))


def test_anchors_in_later_chunks_are_carried_by_the_workers(tmp_path, model):
    """PTP targets with Status and Turn (they set the branch) in later chunks, LIN moves
    between them carrying it: the pipeline's workers hand the posture on as the whole
    program carries it."""
    from postproc.robot import kinematics as kin

    head = ["DEF raster( )", "$BASE = {X 0, Y 0, Z 0, A 0, B 0, C 0}", "$TOOL = {X 0, Y 0, Z 200, A 0, B 0, C 0}", "$APO.CDIS = 0.2"]
    xy = [(900.0 + 200.0 * (i // 30) / 12, -200.0 + 400.0 * (i % 30) / 30) for i in range(360)]
    program = tmp_path / "p.src"
    lines = [f"LIN {{X {x:.3f}, Y {y:.3f}, Z 450, A 0, B 180, C 0}} C_DIS" for x, y in xy]
    program.write_text("\n".join(head + lines + ["END"]) + "\n", encoding="latin-1")
    tp = parse_program(program)
    sols = kin.ik(model.robot, tp.base_poses() @ np.linalg.inv(tp.tools[tp.tool]))
    for k, i in enumerate(range(35, 360, 70)):  # every other anchor flips the wrist, the others flip it back
        ok = [q for q in sols[i] if not np.isnan(q).any() and kin.within_limits(model.robot, q[None])[0]]
        q = min(ok, key=lambda q: (np.sign(q[4]) == (-1) ** k, np.abs(q).sum()))
        status, turn = kin.kuka_status_turn(model.robot, q[None])
        x, y = xy[i]
        lines[i] = f"PTP {{X {x:.3f}, Y {y:.3f}, Z 450, A 0, B 180, C 0, S {status[0]}, T {turn[0]}}} C_PTP"
    program.write_text("\n".join(head + lines + ["END"]) + "\n", encoding="latin-1")
    tp = parse_program(program)
    new, rep = compensate(tp, model)
    (tmp_path / "whole.src").write_text(emit_texts(tp, new)[0], encoding="latin-1")
    assert rep.failed.sum() == 0
    assert len(np.unique(reference_postures(tp, model).branch)) > 1  # the anchors change the branch
    for workers in (0, 2):
        out = tmp_path / f"stream{workers}.src"
        result = compensate_streamed(program, model, out, chunk_lines=50, workers=workers)
        assert result.summary["chunks"] > 5
        assert out.read_bytes() == (tmp_path / "whole.src").read_bytes(), workers


@pytest.mark.parametrize("read_chars", [1, 7, 64, 1 << 22])
@pytest.mark.parametrize("ending", ["\n", ""])
def test_line_reader_hands_out_whole_lines_in_order(tmp_path, monkeypatch, read_chars, ending):
    """Blocks of any size: each take(n) is the next n lines ('\\n' ends a line), the last
    one without its '\\n' where the file has none."""
    import io

    from postproc.jobs.stream import _LineReader

    lines = [f"LIN {{X {i}.5}} ; é {i * i}\r\n" if i % 3 else f"{'x' * (i % 11)}\n" for i in range(200)]
    text = "first line\n" + "".join(lines)
    text = text if ending else text[:-1]
    monkeypatch.setattr(_LineReader, "READ_CHARS", read_chars)
    fh = io.StringIO(text[len("first line\n"):])
    reader = _LineReader(fh, "first line\n")
    want = text.splitlines(keepends=True)
    got, at = [], 0
    for n in (1, 5, 50, 3, 1000, 10):
        part = reader.take(n)
        assert part == "".join(want[at : at + n])
        got.append(part)
        at += n
    assert "".join(got) == text


def test_a_chunk_that_fails_in_a_worker_hands_the_failure_on(monkeypatch):
    """A chunk whose postures cannot be computed (here: no toolpath at all) posts that it
    failed, so the next chunk stops at once instead of waiting for a posture."""
    from postproc.jobs import stream
    from postproc.jobs.stream import _postures, _Task

    monkeypatch.setattr(stream, "BATON_WAIT_S", 2.0)
    baton = _Baton(multiprocessing.get_context("fork"))
    baton.give(2, np.zeros(6))
    with pytest.raises(AttributeError):
        _postures(None, {}, _Task(None, None, None, -1, "", chunk=3), baton)
    with pytest.raises(StreamFallback, match="chunk before failed"):
        baton.take(4)


def test_shared_slots_give_back_what_was_put_or_refuse_what_does_not_fit():
    """A task's arrays go through shared memory as they are (bits, dtype, shape, writable in
    the taker); an object whose arrays exceed the slot is refused, for the pipe to take."""
    from postproc.jobs.stream import _Slots

    slots = _Slots(2, capacity=4096)
    values = np.array([1.5, np.nan, -0.0, 3.0])
    obj = {"values": values, "rows": np.arange(7, dtype=np.int16), "text": np.frombuffer(b"LIN {X 1}\n", np.uint8), "name": "P1"}
    got = slots.take(1, *slots.put(1, obj))
    assert got["name"] == "P1" and got["values"].tobytes() == values.tobytes()
    assert got["rows"].dtype == np.int16 and got["rows"].tolist() == list(range(7)) and got["text"].tobytes() == b"LIN {X 1}\n"
    got["values"][0] = 2.0  # the taker's own copy: the slot may be reused at once
    assert slots.put(0, {"big": np.zeros(1000)}) is None


def test_chunks_through_shared_slots_and_through_the_pipe_write_the_same_bytes(tmp_path, model, monkeypatch):
    """The workers take their chunks through shared slots where they fit and through the pipe
    where they do not: the same output either way, and the same as one process."""
    from postproc.jobs import stream

    program = tmp_path / "p.src"
    xy = [(900.0 + 200.0 * (i // 40) / 10, -200.0 + 400.0 * (i % 40) / 40) for i in range(400)]
    lines = [f"LIN {{X {x:.3f}, Y {y:.3f}, Z 450, A 0, B 180, C 0}} C_DIS" for x, y in xy]
    head = ["DEF raster( )", "$BASE = {X 0, Y 0, Z 0, A 0, B 0, C 0}", "$TOOL = {X 0, Y 0, Z 200, A 0, B 0, C 0}", "$APO.CDIS = 0.2"]
    program.write_text("\n".join(head + lines + ["END"]) + "\n", encoding="latin-1")
    put = stream._Slots.put
    placed = []

    def recorded(self, slot, obj):
        packed = put(self, slot, obj)
        placed.append(packed is not None)
        return packed

    monkeypatch.setattr(stream._Slots, "put", recorded)
    outputs = {}
    for capacity in (stream._Slots.CAPACITY, 256):
        monkeypatch.setattr(stream._Slots, "CAPACITY", capacity)
        placed.clear()
        compensate_streamed(program, model, tmp_path / f"{capacity}.src", chunk_lines=60, workers=2)
        outputs[capacity] = (tmp_path / f"{capacity}.src").read_bytes()
        assert placed and all(placed) == (capacity > 256) and any(placed) == (capacity > 256)
    compensate_streamed(program, model, tmp_path / "serial.src", chunk_lines=60, workers=0)
    assert outputs[stream._Slots.CAPACITY] == outputs[256] == (tmp_path / "serial.src").read_bytes()


def test_worker_warm_up_runs_the_first_move_and_leaves_errors_to_the_chunk(tmp_path, model, monkeypatch):
    """A worker compensates the program's first move once at its start (kernels loaded while
    the main process parses); a move that cannot be compensated is not reported there but by
    the chunk itself."""
    from postproc.jobs import stream

    head = "DEF p( )\n$BASE = {X 0, Y 0, Z 0, A 0, B 0, C 0}\n$TOOL = {X 0, Y 0, Z 200, A 0, B 0, C 0}\n"
    good, bad = tmp_path / "good.src", tmp_path / "bad.src"
    good.write_text(head + "LIN {X 900, Y 0, Z 450, A 0, B 180, C 0}\nLIN {X 901, Y 0, Z 450, A 0, B 180, C 0}\nEND\n", encoding="latin-1")
    bad.write_text(head.replace("$TOOL = {X 0, Y 0, Z 200, A 0, B 0, C 0}", "$TOOL = TOOL_DATA[7]") + "LIN {X 900, Y 0, Z 450, A 0, B 180, C 0}\nEND\n",
                   encoding="latin-1")
    opened = {}
    for path in (good, bad):
        lang, rules = stream.stream_rules_for(path, None, model)
        with open(path, encoding="latin-1", newline="") as fh:
            opened[path] = stream._open(path, lang, rules, fh)
        assert stream._warm_up(model, {}, *opened[path]) is None
    from postproc.errors import OutputCheckError

    def check_fails(*args):
        raise OutputCheckError("the written numbers do not read back")

    monkeypatch.setattr(stream, "_finish", check_fails)  # any error: raised in the pool's initializer it would break the pool
    assert stream._warm_up(model, {}, *opened[good]) is None
    monkeypatch.undo()
    with pytest.raises(StreamFallback, match="input error"):
        compensate_streamed(bad, model, tmp_path / "out.src", workers=2)
