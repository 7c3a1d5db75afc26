"""Programs of any length: parse -> compensate -> emit -> check, one chunk of lines at a time.

A program whose targets are all written in its one main file (a CAM G-code program, a KRL
.src with inline targets) is read in chunks of ``chunk_lines`` lines; memory depends on the
chunk, not on the program's length. The language says which lines may be cut between and
how to restate the state at a cut (``Dialect.stream_rules``, ``dialects.base.StreamRules``):

- the program's header (the lines before its first plain move, target lines blanked) and
  one restated move to the previous chunk's last target are put before every later chunk,
  so the parser reads each chunk where the whole program would be (modal axes, motion mode,
  feed, frame and tool); the restated target must parse back as exactly the previous
  chunk's last target (position, orientation, external axes, frame, tool, speed, kind),
  else the program is not streamed;
- compensation starts each chunk from the posture the controller holds at the previous
  chunk's last target (``Report.end_joints``), and the restated target gives the first
  segment of the chunk its start (straight-line reach, path between targets); its own
  result, the same as in the previous chunk, is dropped;
- every chunk's new text is checked (``programs.check_texts``: its position numbers read
  back where only those changed, ``emit.readback``, else a whole re-parse) and appended to one
  temporary file beside the output; the program's other files (KRL .dat) are staged with
  it and all are renamed at the end (``files.write_all``): all or nothing.

The chunks go through a pipeline of processes (``workers``, default one per core up to
WORKERS_MAX): this process reads the program in blocks, cuts it (body lines told by their
shape, ``StreamRules.body_shape``), parses each chunk and hands it to a worker (the IR's
varying columns only, ``_Task.for_pipe``, through shared memory, ``_Slots``) while it reads
the next; results come back the same way and are taken in program order, at most
``workers + 1`` chunks in flight. The worker computes the chunk's
postures as written (``compensate.reference_postures``) from the posture at the previous
chunk's end, which the worker of that chunk hands on through shared memory (``_Baton``: the
chain waits only for postures, not for compensation), then compensates, emits and checks it.
Each worker first compensates the program's first move once and throws it away
(``_warm_up``: its compiled kernels load while this process parses the first chunk).
``workers=0`` does every stage here; both write the same bytes.

What is not streamed (``StreamFallback``; the caller reads the program whole, as before): a
language without stream rules, a model with an effect that depends on the path's history
(backlash's approach direction couples every target to the one before, across any cut),
a header of more than HEADER_MAX_LINES lines, more than TRAILER_MAX_LINES lines after the
last cut that are not plain moves, a restated target that does not read back exactly, a
later chunk that does not fit the model as the first does (a payload set after the plain
moves: ``program_check.mismatch_keys``), and any input error (the whole-program path reports
it with the program's own line numbers).
Both paths give byte-identical output on a program both can take
(tests/test_stream.py).
"""

from __future__ import annotations

import ctypes
import mmap
import multiprocessing
import os
import pickle
import sys
from collections import deque
from concurrent.futures import ProcessPoolExecutor
from contextlib import contextmanager
from dataclasses import dataclass, field, fields, replace
from itertools import chain
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

from postproc.compensation.request import CompensationRequest
from postproc.errors import InputError
from postproc.files import write_all
from postproc.programs import dialects
from postproc.programs.ir import SourceDoc, Toolpath
from postproc.programs.program_io import check_texts, refuse_overwrite

from .compensate import (
    PATH_TOLERANCE_MM,
    CompensationError,
    Reference,
    Report,
    compensate,
    reference_postures,
    request_for,
)
from .program_check import check_model_fits, mismatch_keys

STREAM_MIN_BYTES = 16 * 2**20  # auto: programs of more than ~300,000 lines are streamed
CHUNK_LINES = 50_000  # of 1.25 x 10^4 .. 10^5, the fastest on 2 cores (benchmarks/stream.py's rasters, sizes run alternately), half the memory of 10^5
HEADER_MAX_LINES = 10_000
TRAILER_MAX_LINES = 100_000


class StreamFallback(Exception):
    """The program cannot be compensated in chunks (the reason); read it whole instead."""


def stream_rules_for(path: str | Path, dialect: str | None, model) -> tuple[object, object]:
    """(dialect, its stream rules) for compensating ``path`` in chunks; StreamFallback if not."""
    lang = dialects.get(dialect) if dialect else dialects.sniff(path)
    rules = lang.stream_rules()
    if rules is None:
        raise StreamFallback(f"{lang.name} programs are not read in chunks")
    probe = np.zeros((3, 6))
    history = [f"{e.name} effect" for e in model.effects if e.path_columns(probe)]
    if getattr(model.residual, "reads_history", False):
        history.append(f"{model.residual.kind} predictor (--gp-features {model.residual.feature_kind})")
    if history:
        raise StreamFallback(f"the model's {' and '.join(history)} depend{'s' if len(history) == 1 else ''} on the path before each target")
    return lang, rules


def wants_stream(path: str | Path, mode: str) -> bool:
    """--stream auto|always|never: auto streams files of more than STREAM_MIN_BYTES."""
    if mode not in ("auto", "always", "never"):
        raise InputError(f"--stream: '{mode}' is not one of auto, always, never")
    if mode == "never" or str(path) == "-":
        return False
    try:
        return mode == "always" or Path(path).stat().st_size > STREAM_MIN_BYTES
    except OSError:
        return False  # the whole-program path says why it cannot be read


@dataclass
class Totals:
    """The summary of every chunk's report, gathered without keeping per-target arrays."""

    targets: int = 0
    compensated: int = 0
    sq_before: float = 0.0
    sq_after: float = 0.0
    n_before: int = 0
    n_after: int = 0
    max_before: float = 0.0
    max_after: float = 0.0
    max_correction: float = 0.0
    iterations: np.ndarray = field(default_factory=lambda: np.zeros(1, dtype=np.int64))
    path_max: float = -1.0
    path_line: int = 0
    segments: int = 0
    over_tolerance: int = 0
    failed: int = 0
    failures: list = field(default_factory=list)
    columns: dict = field(default_factory=dict)  # program line of a failure -> its column
    chunks: int = 0

    def add(self, rep: Report, keep: np.ndarray, line_shift: int, first_line: int, columns: list[int] | None = None) -> None:
        """One chunk's report: its targets ``keep`` (from line ``first_line`` of the chunk) count;
        ``line_shift`` turns the chunk's line numbers into the program's; ``columns``: those of
        its failures (``Report.failure_columns``)."""
        self.chunks += 1
        self.targets += int(keep.sum())
        c = rep.compensated & keep
        self.compensated += int(c.sum())
        for name in ("before", "after"):
            v = getattr(rep, f"{name}_mm")[c]
            v = v[np.isfinite(v)]
            setattr(self, f"sq_{name}", getattr(self, f"sq_{name}") + float(np.sum(v * v)))
            setattr(self, f"n_{name}", getattr(self, f"n_{name}") + len(v))
            if len(v):
                setattr(self, f"max_{name}", max(getattr(self, f"max_{name}"), float(v.max())))
        if c.any():
            self.max_correction = max(self.max_correction, float(np.nanmax(rep.correction_mm[c])))
            counts = np.bincount(rep.iterations[c])
            if len(counts) > len(self.iterations):
                self.iterations = np.pad(self.iterations, (0, len(counts) - len(self.iterations)))
            self.iterations[: len(counts)] += counts
        self._add_path(rep, keep, line_shift)
        failed = rep.failed & keep
        self.failed += int(failed.sum())
        if failed.any() and len(self.failures) < 1000:
            listed = [(line + line_shift, reason, column) for (line, reason), column in zip(rep.failures(), columns or [None] * int(rep.failed.sum()))
                      if line >= first_line][:1000]
            self.failures += [(line, reason) for line, reason, _ in listed]
            self.columns.update({line: column for line, _, column in listed if column is not None})

    def _add_path(self, rep: Report, keep: np.ndarray, line_shift: int) -> None:
        if rep.path_mm is None:
            return
        p = np.where(keep, rep.path_mm, np.nan)
        finite = np.isfinite(p)
        self.segments += int(finite.sum())
        self.over_tolerance += int((p[finite] > PATH_TOLERANCE_MM).sum())
        if finite.any() and np.nanmax(p) > self.path_max:
            i = int(np.nanargmax(p))
            self.path_max, self.path_line = float(p[i]), int(rep.line[i]) + line_shift

    def summary(self) -> dict:
        """As ``Report.summary``."""
        def stats(sq, n, mx):
            return {"rms_mm": float(np.sqrt(sq / n)) if n else None, "max_mm": mx if n else None}

        it = self.iterations
        median = None
        if it.sum():
            cum = np.cumsum(it)
            total = cum[-1]
            lo, hi = int(np.searchsorted(cum, (total + 1) // 2)), int(np.searchsorted(cum, total // 2 + 1))
            median = 0.5 * (lo + hi)
        return {
            "targets": self.targets, "compensated": self.compensated,
            "predicted_before": stats(self.sq_before, self.n_before, self.max_before),
            "predicted_after": stats(self.sq_after, self.n_after, self.max_after),
            "iterations_median": median, "iterations_max": int(np.nonzero(it)[0].max()) if it.sum() else None,
            "max_correction_mm": self.max_correction if self.compensated else None,
            "failed": self.failed,
            "path": None if self.path_max < 0 else {"max_mm": self.path_max, "line": self.path_line, "segments": self.segments,
                                                     "over_tolerance": self.over_tolerance, "tolerance_mm": PATH_TOLERANCE_MM},
            "chunks": self.chunks,
        }


@dataclass
class _Program:
    """A program being read in chunks: its header, where each chunk starts, its other files."""

    path: Path
    lang: object
    rules: object
    header: list[str]
    others: list[SourceDoc]
    role: str

    def docs(self, text: str) -> list[SourceDoc]:
        return [SourceDoc(str(self.path), text, self.role)] + self.others


def _open(path: Path, lang, rules, fh) -> tuple[_Program, str]:
    """The program's header (lines before its first plain move) and that move's line."""
    header = []
    for line in fh:
        if rules.move.match(line):
            docs = lang.read_sources(path, "".join(header).encode("latin-1"))
            return _Program(path, lang, rules, header, docs[1:], docs[0].role), line
        header.append(line)
        if len(header) > HEADER_MAX_LINES:
            raise StreamFallback(f"no plain move in the first {HEADER_MAX_LINES} lines")
    raise StreamFallback("no plain move")


def _is_body(rules, text: str) -> int:
    """Length of the run of body lines at the start of ``text``."""
    probe = text if text.endswith("\n") else text + "\n"
    if _all_body_by_shape(rules, probe):
        return len(text)
    return min(rules.body.match(probe).end(), len(text))


_ZEROS = bytes.maketrans(b"123456789", b"000000000")


def _all_body_by_shape(rules, probe: str) -> bool:
    """True where every line of ``probe`` (it ends in a newline) is a body line by its shape
    (``StreamRules.body_shape``): the body pattern runs once per distinct shape, not over
    every character (~2 us a line). False where it is not, or shapes cannot tell."""
    if rules.body_shape is None:
        return False
    raw = probe.encode("latin-1")
    pattern = rules.body_shape(raw)
    if pattern is None:
        return False
    shapes = raw.translate(_ZEROS).split(b"\n")
    shapes.pop()  # after the last newline: not a line
    return all(pattern.fullmatch(shape.decode("latin-1") + "\n") for shape in set(shapes))


def _batches(fh, first: str, rules, chunk_lines: int):
    """(text, is_last) of each chunk's own lines; cuts only inside the run of body lines."""
    reader = _LineReader(fh, first)
    text = reader.take(chunk_lines)
    while True:
        if _is_body(rules, text) < len(text):
            rest = reader.take(TRAILER_MAX_LINES + 1)
            if _count_lines(rest) > TRAILER_MAX_LINES:
                raise StreamFallback(f"more than {TRAILER_MAX_LINES} lines after the last plain moves")
            yield text + rest, True
            return
        following = reader.take(chunk_lines)
        yield text, not following
        if not following:
            return
        text = following


def _count_lines(text: str) -> int:
    return text.count("\n") + (not text.endswith("\n") and bool(text))


class _LineReader:
    """Whole lines of a text file (a newline ends a line), read in blocks of READ_CHARS characters:
    a chunk of 5 x 10^4 lines is a few reads and one join, not 5 x 10^4 line objects."""

    READ_CHARS = 1 << 22

    def __init__(self, fh, first: str):
        self.fh, self.rest = fh, first  # read, not yet handed out

    def take(self, n: int) -> str:
        """The next ``n`` lines (fewer at the end of the file, the last one maybe without its newline)."""
        parts, got = [], 0
        while got < n:
            if not self.rest:
                self.rest = self.fh.read(self.READ_CHARS)
                if not self.rest:
                    break
            count = self.rest.count("\n")
            if got + count < n:
                parts.append(self.rest)
                got, self.rest = got + count, ""
                continue
            # the (n - got)-th newline of the block (latin-1: one byte a character)
            cut = int(np.flatnonzero(np.frombuffer(self.rest.encode("latin-1"), np.uint8) == 10)[n - got - 1]) + 1
            parts.append(self.rest[:cut])
            got, self.rest = n, self.rest[cut:]
        return "".join(parts)


@dataclass
class _Carry:
    """What the next chunk needs from the one before: its last target and the posture there."""

    last: Toolpath
    carried: np.ndarray  # (NF,) every field's last value as read
    joints: np.ndarray | None


def _carry_of(tp: Toolpath, end_joints: np.ndarray | None) -> _Carry:
    values = tp.values
    has = ~np.isnan(values)
    idx = np.where(has.any(axis=0), len(values) - 1 - np.argmax(has[::-1], axis=0), -1)
    carried = np.where(idx >= 0, values[np.maximum(idx, 0), np.arange(values.shape[1])], np.nan)
    return _Carry(tp.take([len(tp) - 1]), carried, end_joints)


_SAME = ("kind", "position", "orientation", "ext", "relative", "resolved")


def _check_restated(tp: Toolpath, row: int, prev: _Carry, line: int) -> None:
    """The restated target must read back as exactly the previous chunk's last target."""
    if len(tp) <= row or int(tp.line[row]) != line:
        raise StreamFallback("the restated target was not read as a target")
    a, b = tp.take([row]), prev.last
    same = all(np.array_equal(getattr(a, k), getattr(b, k), equal_nan=True) for k in _SAME)
    same &= np.array_equal(a.speed, b.speed, equal_nan=True)
    same &= a.frame_names[a.frame[0]] == b.frame_names[b.frame[0]] and np.array_equal(a.frames[a.frame[0]], b.frames[b.frame[0]])
    same &= a.tool_names[a.tool[0]] == b.tool_names[b.tool[0]] and np.array_equal(a.tools[a.tool[0]], b.tools[b.tool[0]])
    if not same:
        raise StreamFallback(f"the state at the cut before line {line} is not restated exactly (frame, tool, speed or mode changes)")


@dataclass
class _Task:
    """One chunk as parsed, for ``_finish`` (in this process or a worker)."""

    tp: Toolpath
    start_joints: np.ndarray | None  # the posture the chunk starts from (later chunks in a worker: from the baton)
    reference: Reference | None  # the postures as written; None: the worker computes them (``_postures``)
    header_chars: int  # length of the (blanked) header before the restated line; -1 for the first chunk
    tail: str
    packed: dict | None = None  # tp's wide arrays, for a worker (``for_pipe``: through the pipe or a shared slot)
    texts: tuple = ()  # with ``packed``: the text of each of tp's sources, Latin-1 bytes (uint8)
    chunk: int = 0  # its place in the program (0: the first)

    def for_pipe(self) -> "_Task":
        """This task with the toolpath's wide per-target arrays cut to their varying columns:
        a long program's moves set few of the IR's fields, and the whole arrays would be
        ~1.3 kB a target through the pipe. ``toolpath`` restores them bit for bit."""
        packed = {}
        for name in _WIDE:
            a = getattr(self.tp, name)
            if a is None or a.ndim < 2 or not len(a) or a.dtype.itemsize not in (1, 2, 4, 8):
                continue
            flat = a.reshape(len(a), -1)
            bits = flat.view(f"u{a.dtype.itemsize}")  # bits, not values: NaN and -0.0 kept as they are
            varies = (bits != bits[0]).any(axis=0)
            packed[name] = (a.shape, a.dtype, flat[0].copy(), varies, flat[:, varies].copy())
        # Whole arrays and the chunk's text as bytes: a shared slot (``_Slots``) takes them as they are.
        contiguous = {f.name: np.ascontiguousarray(v) for f in fields(self.tp)
                      if f.name not in packed and isinstance(v := getattr(self.tp, f.name), np.ndarray) and not v.flags.c_contiguous}
        texts = tuple(np.frombuffer(doc.encode(), np.uint8) for doc in self.tp.sources)
        sources = tuple(replace(doc, text="") for doc in self.tp.sources)
        tp = replace(self.tp, **{name: None for name in packed}, **contiguous, sources=sources)
        return replace(self, tp=tp, packed=packed, texts=texts)

    def toolpath(self) -> Toolpath:
        if not self.packed:
            return self.tp
        arrays = {}
        for name, (shape, dtype, first, varies, columns) in self.packed.items():
            flat = np.empty((shape[0], first.size), dtype)
            flat[:] = first
            flat[:, varies] = columns
            arrays[name] = flat.reshape(shape)
        sources = tuple(replace(doc, text=text.tobytes().decode("latin-1")) for doc, text in zip(self.tp.sources, self.texts))
        return replace(self.tp, **arrays, sources=sources)


_WIDE = ("spans", "scale", "values", "joints", "ext", "conf", "orientation", "insert_at")


@dataclass
class _Meta:
    """What this process keeps of a chunk in flight, to fold its result in."""

    keep: np.ndarray
    shift: int
    first_line: int
    first: bool


def _finish(model, options: dict, task: _Task) -> tuple[bytes, Report, tuple, list[str] | None]:
    """Compensate, emit and re-parse check one chunk: (its own new text, the report, the notes,
    the other files' texts). No text (and no check) where a target failed: nothing will be written."""

    options = dict(options)
    if task.reference is None:
        tp, reference, start = _postures(model, options, task, _WORKER_BATON)
    else:
        tp, reference, start = task.toolpath(), task.reference, task.start_joints
    if start is not None:
        options["start_joints"] = start
    try:
        new, rep = compensate(tp, model, reference=reference, **options)
    except InputError as exc:
        raise StreamFallback(f"input error in a chunk ({exc})") from None
    if rep.failed.any():
        return b"", rep, new.notes, rep.failure_columns(tp)  # no text: nothing will be written; where the failures are
    texts = dialects.of(tp).emit_texts(tp, new)
    check_texts(tp, new, texts, np.nonzero(rep.compensated)[0])
    main = texts[0]
    if task.header_chars >= 0:
        # The header has no target left (blanked), so only the restated line changed length.
        main = main[main.find("\n", task.header_chars) + 1 :]
    if task.tail:
        if not main.endswith(task.tail):
            raise StreamFallback("the chunk's closing text changed")
        main = main[: len(main) - len(task.tail)]
    return main.encode("latin-1"), rep, new.notes, texts[1:]


def _finish_shared(model, options: dict, slot: int, head: bytes, layout: list) -> tuple:
    """``_finish`` in a worker of a task put in shared slot ``slot`` (``_Slots``); its result
    is put back there: ("slot", head, layout), or ("pipe", result) where it does not fit."""
    slots = _WORKER_SLOTS
    text, rep, notes, others = _finish(model, options, slots.take(slot, head, layout))
    result = (np.frombuffer(text, np.uint8), rep, notes, others)
    packed = slots.put(slot, result)
    return ("pipe", result) if packed is None else ("slot", *packed)


def _postures(model, options: dict, task: _Task, baton: "_Baton") -> tuple[Toolpath, Reference, np.ndarray | None]:
    """A chunk in a worker: its toolpath, its postures as written and its start posture.
    They start where the previous chunk ends, as the worker that computed that hands on
    (``_Baton``); this one hands on its own end before it compensates, or that it failed.
    The chain only waits for postures (~3 us a target), not for the compensation before."""
    ended = False
    try:
        tp = task.toolpath()
        start = task.start_joints if task.chunk == 0 else baton.take(task.chunk)
        reference = reference_postures(tp, model, **{**options, "start_joints": start})
        baton.give(task.chunk, reference.end_joints)
        ended = True
        return tp, reference, start
    except InputError as exc:
        raise StreamFallback(f"input error in a chunk ({exc})") from None
    finally:
        if not ended:
            baton.give(task.chunk, None, failed=True)  # the next chunk stops too, and does not wait


BATON_WAIT_S = 3600.0  # a chunk's postures take well under a second; this only guards against a hang


class _Baton:
    """The posture at the end of the last chunk whose postures are computed, handed from
    worker to worker in shared memory (inherited by the workers at their start). Chunks are
    taken by the workers in program order, so the chunk before the one waiting is running or
    done: one slot suffices, and no wait can be for a chunk that will not run."""

    def __init__(self, context):
        self._posted = context.Condition()
        self._chunk = context.RawValue("q", -1)  # the last chunk whose end is posted
        self._state = context.RawValue("i", 0)  # 0: joints; 1: no Cartesian target (None); 2: it failed
        self._joints = context.RawArray("d", 6)

    def take(self, chunk: int) -> np.ndarray | None:
        """The posture at the end of chunk ``chunk - 1`` (waits until it is posted)."""
        with self._posted:
            if not self._posted.wait_for(lambda: self._chunk.value >= chunk - 1, timeout=BATON_WAIT_S):
                raise StreamFallback(f"chunk {chunk}: the posture at the end of the chunk before was never handed on")
            if self._chunk.value != chunk - 1:
                raise RuntimeError(f"chunk {chunk} took the posture of chunk {self._chunk.value}")
            state, joints = self._state.value, np.array(self._joints[:], dtype=float)
        if state == 2:
            raise StreamFallback(f"chunk {chunk}: the chunk before failed")
        return None if state == 1 else joints

    def give(self, chunk: int, joints: np.ndarray | None, failed: bool = False) -> None:
        with self._posted:
            self._state.value = 2 if failed else 1 if joints is None else 0
            if joints is not None and not failed:
                self._joints[:] = np.asarray(joints, dtype=float).tolist()
            self._chunk.value = chunk
            self._posted.notify_all()


# Set in each worker process by ``_worker_start``, its only per-process state:
_WORKER_BATON: _Baton | None = None
_WORKER_SLOTS: "_Slots | None" = None


class _Job:
    """One program compensated chunk by chunk: this process reads and parses each chunk and
    carries the restated state to the next (``prepare``); ``_finish`` compensates, emits and checks it,
    here or in a worker process; ``collect`` folds the results in, in program order."""

    def __init__(self, program: _Program, model, options: dict, progress, model_check: tuple | None = None):
        self.program, self.model, self.options, self.progress = program, model, options, progress
        self.model_check = model_check  # (model path, --robot, --allow-model-mismatch): checked on the first chunk, later ones against it
        self.mismatches: list[str] = []
        self.first_mismatch_keys: set[str] = set()  # the first chunk's (``mismatch_keys``): a later one must state nothing else
        self.totals = Totals()
        self.notes: list[str] = []
        self.first_tp: Toolpath | None = None
        self.other_texts: list[str] | None = None
        self.blanked = list(program.header)  # the header, its target lines blanked after the first chunk
        self.prefix_lines = len(self.blanked) + 1  # header, then the restated target

    def _prefix(self, carry: _Carry) -> str:
        line = self.program.rules.restate(carry.last, carry.carried)
        if line is None:
            raise StreamFallback("the last target before a cut has no complete position to restate")
        return "".join(self.blanked) + line + "\n"

    def prepare(self, own: str, is_last: bool, first_line: int, carry: _Carry | None, chunk: int, here: bool) -> tuple[_Task, _Meta, _Carry]:
        """Parse one chunk's own lines (``own`` starts at program line ``first_line``) after the
        restated state; the task for ``_finish`` and the state the next chunk starts from.
        ``here``: its postures are computed here (else by the worker, ``_postures``)."""
        lang, rules = self.program.lang, self.program.rules
        prefix = "" if carry is None else self._prefix(carry)
        tail = "" if is_last else rules.tail
        start = self.options.get("start_joints") if carry is None else carry.joints
        reference = None
        try:
            tp = lang.parse_sources(self.program.docs(prefix + own + tail))
            if carry is not None:
                _check_restated(tp, 0, carry, self.prefix_lines)
            if here:
                reference = reference_postures(tp, self.model, **{**self.options, "start_joints": start})
        except InputError as exc:
            raise StreamFallback(f"input error in a chunk ({exc})") from None
        if carry is None:
            self._first(tp)
            keep, shift, header_chars = np.ones(len(tp), dtype=bool), 0, -1
        else:
            self._check_later(tp)
            keep, shift, header_chars = tp.line > self.prefix_lines, first_line - 1 - self.prefix_lines, sum(map(len, self.blanked))
        meta = _Meta(keep, shift, 1 if carry is None else self.prefix_lines + 1, carry is None)
        task = _Task(tp, start, reference, header_chars, tail, chunk=chunk)
        return task, meta, _carry_of(tp, None if reference is None else reference.end_joints)

    def _check_later(self, tp: Toolpath) -> None:
        """A later chunk that states what the first did not (a load set after the plain moves, a
        joint target out of the model's range) is not streamed: its message would name the
        chunk's lines, and only the whole program's check names the program's."""
        if self.model_check is None:
            return
        if mismatch_keys(tp, self.model, *self.model_check[:2]) - self.first_mismatch_keys:
            raise StreamFallback("a later chunk does not fit the model as the first does (e.g. it sets another payload)")

    def collect(self, meta: _Meta, result) -> bytes:
        """One chunk's result (in program order): its report counted, its new text."""
        text, rep, notes, others = result
        self.totals.add(rep, meta.keep, meta.shift, meta.first_line, others if rep.failed.any() else None)
        if meta.first:
            self.notes = list(notes)
        self.progress(f"chunk {self.totals.chunks}: {self.totals.targets:,} targets")
        if self.totals.failed:
            return b""  # nothing will be written; go on to report every failure
        if self.other_texts is None:
            self.other_texts = others
        elif others != self.other_texts:
            raise StreamFallback("a later chunk changes the program's other files")
        return text

    def _submit(self, pool, slots, task: _Task, chunk: int):
        """(slot or None, future): the task to a worker, through shared slot chunk % len(slots) where it fits."""
        task = task.for_pipe()
        if slots is not None:
            slot = chunk % len(slots)
            packed = slots.put(slot, task)
            if packed is not None:
                return slot, pool.submit(_finish_shared, self.model, self.options, slot, *packed)
        return None, pool.submit(_finish, self.model, self.options, task)

    def _first(self, tp: Toolpath) -> None:
        """The first chunk: the model checked against it (robot, tools, payload), the header's
        target lines blanked for the later chunks."""
        self.first_tp = tp
        if self.model_check is not None:
            self.mismatches = check_model_fits(tp, self.model, *self.model_check)
            self.first_mismatch_keys = mismatch_keys(tp, self.model, *self.model_check[:2])
        in_header = tp.line[(tp.line <= len(self.blanked)) & (tp.file == 0)]
        for line in np.unique(in_header):
            self.blanked[int(line) - 1] = "\n"

    def results(self, batches, first_own: str, pool, depth: int, slots: "_Slots | None" = None):
        """The new text of every chunk in order; with a pool, up to ``depth`` chunks are
        compensated in its worker processes while this one reads and parses the next.
        ``slots``: shared memory for them (``_Slots``, more slots than ``depth``), else the pipe."""
        if slots is not None and len(slots) <= depth:
            raise ValueError(f"{len(slots)} shared slots for {depth + 1} chunks in flight")
        pending: deque = deque()
        carry, first_line = None, 1
        for chunk, (own, is_last) in enumerate(batches):
            own = first_own + own if carry is None else own
            task, meta, carry = self.prepare(own, is_last, first_line, carry, chunk, here=pool is None)
            first_line += own.count("\n")
            pending.append((meta, self._submit(pool, slots, task, chunk) if pool else _finish(self.model, self.options, task)))
            while len(pending) > depth:
                meta, done = pending.popleft()
                yield self.collect(meta, _result(done, slots) if pool else done)
        while pending:
            meta, done = pending.popleft()
            yield self.collect(meta, _result(done, slots) if pool else done)
        if self.totals.failed:
            raise CompensationError(f"{self.totals.failed} target(s) cannot be compensated; nothing was written", None)


def _result(submitted, slots: "_Slots | None") -> tuple:
    """A worker's result (``_finish``), taken out of its shared slot where it came back there."""
    slot, future = submitted
    out = future.result()
    if slot is None:
        return out
    kind, *rest = out
    text, rep, notes, others = slots.take(slot, *rest) if kind == "slot" else rest[0]
    return text.tobytes(), rep, notes, others


class _Slots:
    """Shared memory for the chunks in flight, one slot each (chunk % count: a slot is used
    again only after its chunk's result was taken, so count must exceed the chunks in
    flight). A task's arrays and text go to the worker, and its result comes back, copied
    once each way, where the pool's pipe would pickle, write, read and unpickle them (~1 CPU s
    per 10^6 points in the processes together). Anonymous shared mappings: forked workers
    inherit them; pages are only touched as used. What does not fit a slot takes the pipe."""

    CAPACITY = 64 * 2**20  # a chunk of CHUNK_LINES raster moves takes ~13 MB

    def __init__(self, count: int, capacity: int | None = None):
        self._maps = [mmap.mmap(-1, capacity or self.CAPACITY) for _ in range(count)]

    def __len__(self) -> int:
        return len(self._maps)

    def put(self, slot: int, obj) -> tuple[bytes, list] | None:
        """Put ``obj`` in ``slot``: (its pickle without its arrays' data, where that data lies),
        or None where it does not fit (nothing usable is left in the slot)."""
        buffers: list[pickle.PickleBuffer] = []
        head = pickle.dumps(obj, protocol=5, buffer_callback=buffers.append)
        layout, at = [], 0
        with memoryview(self._maps[slot]) as view:
            for buffer in buffers:
                with buffer.raw() as raw:
                    if at + raw.nbytes > len(view):
                        return None
                    view[at : at + raw.nbytes] = raw
                    layout.append((at, raw.nbytes))
                    at += -(-raw.nbytes // 64) * 64  # each array 64-byte aligned
        return head, layout

    def take(self, slot: int, head: bytes, layout: list):
        """The object put in ``slot``, its arrays in memory of this process (one copy): the slot is free again."""
        end = max((at + size for at, size in layout), default=0)
        with memoryview(self._maps[slot]) as view:
            private = memoryview(bytearray(view[:end]))
        return pickle.loads(head, buffers=[private[at : at + size] for at, size in layout])


@dataclass
class StreamResult:
    summary: dict
    notes: list[str]
    outputs: list[Path]


def stream_request(request: CompensationRequest, *, chunk_lines: int = CHUNK_LINES, progress=lambda msg: None,
                   workers: int | None = None, tune_malloc: bool = False) -> StreamResult:
    """Compensate ``request``'s one program into its output chunk by chunk (module docstring),
    the program checked against the model first (``request.model_check()``).
    ``workers``: processes that compensate, emit and check chunks while this one reads the
    next (None: one per core up to WORKERS_MAX; 0: all in this process). Raises
    StreamFallback (nothing written) when the program cannot be streamed; a
    CompensationError (nothing written) whose ``failures`` list the targets that failed.
    ``tune_malloc``: also change this process's malloc thresholds (_keep_freed_memory; the
    CLI and the benchmarks do; a library caller's process keeps its own unless it asks)."""
    return _stream(request, request.model_check(), chunk_lines, progress, workers, tune_malloc)


def compensate_streamed(path: str | Path, model, output: str | Path, *, dialect: str | None = None, chunk_lines: int = CHUNK_LINES,
                        in_place: bool = False, progress=lambda msg: None, workers: int | None = None, tune_malloc: bool = False,
                        **options) -> StreamResult:
    """``stream_request`` in keyword form: ``options`` as ``compensate``'s, and ``model_check``
    (model path, --robot, --allow-model-mismatch) to check the program against the model."""
    model_check = options.pop("model_check", None)
    request = request_for(model, programs=(str(path),), output=str(output), dialect=dialect, in_place=in_place, **options)
    return _stream(request, model_check, chunk_lines, progress, workers, tune_malloc)


def _stream(request: CompensationRequest, model_check: tuple | None, chunk_lines: int, progress, workers: int | None,
            tune_malloc: bool) -> StreamResult:
    path, output, model = Path(request.programs[0]), Path(request.output), request.robot_model("--stream")
    options = request.solver_options()
    lang, rules = stream_rules_for(path, request.dialect, model)
    if tune_malloc:
        _keep_freed_memory()
    try:
        fh = open(path, encoding="latin-1", newline="")
    except OSError as exc:
        raise InputError(f"{path}: cannot read ({exc.strerror})") from None
    workers = default_workers() if workers is None else workers
    with fh:
        program, first = _open(path, lang, rules, fh)
        with _pool(workers, warm=(model, options, program, first)) as (pool, slots):
            return _run(program, first, fh, model, options, progress, chunk_lines, output, request.in_place, pool, workers, slots,
                        model_check)


def _run(program: _Program, first: str, fh, model, options: dict, progress, chunk_lines: int, output: Path, in_place: bool,
         pool, workers: int, slots, model_check: tuple | None = None) -> StreamResult:
    """``compensate_streamed`` once the program is open and the workers (if any) started."""

    lang, rules = program.lang, program.rules
    job = _Job(program, model, options, progress, model_check)
    results = job.results(_batches(fh, first, rules, chunk_lines), "".join(program.header), pool, workers, slots)
    try:
        text = next(results)
    except CompensationError as exc:
        exc.failures, exc.columns = job.totals.failures, job.totals.columns
        raise
    main = lang.output_paths(job.first_tp, output)[0]
    files = lang.files(job.first_tp, [job.first_tp.sources[0].text] + (job.other_texts or [d.text for d in program.others]), output)
    files[main] = ""
    refuse_overwrite(job.first_tp, files, in_place)
    try:
        write_all({main: chain([text], results),
                   **{p: t.encode("latin-1") for p, t in files.items() if p != main}}, backup=in_place)
    except CompensationError as exc:
        exc.failures, exc.columns = job.totals.failures, job.totals.columns
        raise
    notes = [f"{m} (--allow-model-mismatch)" for m in job.mismatches] + job.notes
    return StreamResult(job.totals.summary(), notes, list(files))


HEAP_BLOCK_MAX = 256 * 2**20  # arrays up to this size come from the heap, not from their own mapping
HEAP_KEEP = 512 * 2**20  # freed heap memory up to this size is kept for the next chunk


def _keep_freed_memory() -> None:
    """Each chunk allocates and frees arrays of tens of MB (a chunk's IR, its reports). glibc
    maps each such array fresh and unmaps it when freed, so every chunk page-faults its
    memory in again (~1 CPU s per 10^6 points in this process, as much in the workers).
    Taken from the heap and kept when freed (up to HEAP_KEEP), the next chunk reuses it;
    the peak stays that of the chunks in flight. A process-wide malloc setting (mallopt):
    made in each worker (our own processes) and, when asked, in the calling process; nothing
    where the C library has none."""

    try:
        mallopt = ctypes.CDLL(None).mallopt
    except (OSError, AttributeError):
        return
    m_trim_threshold, m_mmap_threshold = -1, -3
    mallopt(m_mmap_threshold, HEAP_BLOCK_MAX)
    mallopt(m_trim_threshold, HEAP_KEEP)


WORKERS_MAX = 2  # the pipeline is this process (read, cut, parse) and these (postures, compensate, emit, check)


def default_workers() -> int:
    """One worker process per core up to WORKERS_MAX; none on one core."""
    cores = os.cpu_count() or 1
    return min(WORKERS_MAX, cores) if cores > 1 else 0


def _worker_start(baton: _Baton, slots: "_Slots | None", warm: tuple | None = None) -> None:
    """Worker start: the job's baton (``_postures``) and shared slots (``_finish_shared``);
    one torch thread (a forked child whose parent already ran torch's thread pool, a learned
    predictor, hangs in its first parallel torch operation; the workers are the parallelism;
    torch is not imported for a model without one); the warm-up (``_warm_up``)."""

    global _WORKER_BATON, _WORKER_SLOTS
    _WORKER_BATON, _WORKER_SLOTS = baton, slots
    _keep_freed_memory()
    if "torch" in sys.modules:
        sys.modules["torch"].set_num_threads(1)

    threadpool_limits(1, user_api="blas")  # for this worker's life: a second BLAS thread only spins on the thin products here
    if warm is not None:
        _warm_up(*warm)


def _warm_up(model, options: dict, program: _Program, first: str) -> None:
    """The program's first move compensated, emitted and checked in this worker, and thrown
    away: the compiled kernels and lazy imports a worker needs (~0.2 s) load while the main
    process parses the first chunk, not inside the worker's first chunk. Whatever fails here
    fails again, and is reported, in the chunk itself; raised here, in the pool's initializer,
    it would break the pool (BrokenProcessPool) and hide that report. So nothing is raised."""
    try:
        task = _Job(program, model, options, lambda msg: None).prepare("".join(program.header) + first, False, 1, None, 0, here=True)[0]
        _finish(model, options, task)
    except Exception:  # noqa: BLE001  (the chunk repeats this work and reports its error)
        pass


@contextmanager
def _pool(workers: int, warm: tuple | None = None):
    """(worker processes for ``_finish`` or None, their shared slots or None): forked where
    the system can (no re-import, and the slots are inherited; spawned workers take the pipe)."""
    if workers < 1:
        yield None, None
        return
    import scipy.spatial.transform  # noqa: F401  (posture's lazy import of scipy.spatial, done once before the fork, not in every worker)

    methods = multiprocessing.get_all_start_methods()
    context = multiprocessing.get_context("fork" if "fork" in methods else "spawn")
    slots = _Slots(workers + 1) if context.get_start_method() == "fork" else None  # results(): up to workers + 1 chunks in flight
    pool = ProcessPoolExecutor(workers, mp_context=context, initializer=_worker_start, initargs=(_Baton(context), slots, warm))
    try:
        yield pool, slots
    finally:
        pool.shutdown(wait=True, cancel_futures=True)
