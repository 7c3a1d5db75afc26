"""One typed request: everything a compensation job needs, checked once when it is built.

The command line builds a ``CompensationRequest`` from its options; the library entries
(``postproc.jobs.compensate.compensate``, ``postproc.jobs.stream``, ``postproc.jobs.batch``,
``postproc.jobs.subdivide``, ``postproc.post``) take one, and their older keyword signatures
build one. Every rule about which options go together (the three force options, one
program or many, what a five-axis machine takes) lives in ``__post_init__`` here and
nowhere else.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any, Mapping

from postproc.errors import InputError

from .machine import Machine

SCHEMES = ("broyden", "seed000")
STREAM_MODES = ("auto", "always", "never")

# The command-line option of each field, for messages (spec/cli.md's names).
OPTION = {
    "programs": "PROGRAM", "output": "-o", "out_dir": "--out-dir", "jobs": "--jobs", "scheduler": "--scheduler",
    "dialect": "--dialect", "in_place": "--in-place", "tol_mm": "--tol", "max_iter": "--max-iter", "scheme": "--scheme",
    "temp_c": "--temp", "force_n": "--force", "report": "--report", "frames": "--frame", "tools": "--tool",
    "start_joints": "--start-joints", "cut": "--cut", "max_deviation_mm": "--max-deviation", "robot": "--robot",
    "allow_mismatch": "--allow-model-mismatch", "force_file": "--force-file", "subdivide": "--subdivide", "grid": "--grid",
    "input_axes": "--input-axes", "stream": "--stream", "data": "--data", "allow_extrapolation": "--allow-extrapolation",
    "force_per_target": "force_per_target",
}
# The sources of the process force, of which a request takes one, and what each gives.
FORCE_SOURCES = {"force_n": "one constant force", "cut": "the force of every cutting move",
                 "force_file": "the force of every motion block", "force_per_target": "the force of every target"}
# What one program at a time needs (not with --out-dir / several programs).
ONE_PROGRAM_ONLY = ("cut", "force_file", "in_place", "subdivide", "data")


@dataclass(frozen=True, eq=False)
class CompensationRequest:
    """A compensation job. ``machine``: the robot or machine (``postproc.jobs.targets.load_target``).
    ``programs``: program paths (``-``: standard input), empty where the caller hands a
    parsed Toolpath to the library. Forces: at most one of ``force_n`` (constant, N, tool
    frame), ``force_file`` (a CSV, a force per motion block), ``cut`` (a cut file: the
    milling force of every cutting move) and ``force_per_target`` (N, 3 in the base frame)."""

    machine: Machine
    programs: tuple[str, ...] = ()
    output: str | None = None
    out_dir: Path | None = None
    jobs: int | None = None
    scheduler: str | None = None
    dialect: str | None = None
    data: tuple[Path, ...] = ()
    in_place: bool = False
    tol_mm: float = 0.01
    max_iter: int = 25
    scheme: str = "broyden"
    temp_c: float | None = None
    force_n: tuple[float, float, float] | None = None
    force_file: Path | None = None
    cut: Path | None = None
    force_per_target: Any = None  # (N, 3) N, base frame, one row per target: a library caller's own forces
    frames: Mapping[str, Any] = field(default_factory=dict)
    tools: Mapping[str, Any] = field(default_factory=dict)
    start_joints: tuple[float, ...] | None = None
    max_deviation_mm: float | None = None
    subdivide: bool = False
    stream: str = "auto"
    report: Path | None = None
    robot: str | None = None
    allow_mismatch: bool = False
    allow_extrapolation: bool = False
    grid: Path | None = None
    input_axes: str | None = None

    def __post_init__(self) -> None:
        self._refuse_what_the_machine_does_not_take()
        self._check_numbers()
        self._check_forces()
        if self.programs:
            self._check_job_shape()

    def given(self) -> list[str]:
        """The fields set to other than their default (the options the user gave)."""
        out = []
        for f in fields(self):
            if f.name == "machine":
                continue
            default = f.default_factory() if callable(f.default_factory) else f.default
            value = getattr(self, f.name)
            if (value is not None and default is None) or (default is not None and value != default):
                out.append(f.name)
        return out

    def _refuse_what_the_machine_does_not_take(self) -> None:
        unused = [OPTION[name] + (f" ({self.machine.why_unused[name]})" if name in self.machine.why_unused else "")
                  for name in self.given() if name not in self.machine.takes]
        if unused:
            raise InputError(f"{', '.join(unused)}: not used by the compensation of a {self.machine.kind} "
                             f"(--model {self.machine.source}); leave {'it' if len(unused) == 1 else 'them'} out")

    def _check_numbers(self) -> None:
        if not (self.tol_mm > 0) or self.max_iter < 1:
            raise InputError("--tol must be > 0 and --max-iter >= 1")
        if self.max_deviation_mm is not None and not self.max_deviation_mm > 0:
            raise InputError(f"--max-deviation must be > 0 mm, got {self.max_deviation_mm}")
        if self.scheme not in SCHEMES:
            raise InputError(f"unknown compensation scheme '{self.scheme}' (broyden or seed000)")
        if self.stream not in STREAM_MODES:
            raise InputError(f"--stream must be {', '.join(STREAM_MODES)}, got '{self.stream}'")
        for name, size in (("force_n", 3), ("start_joints", 6)):
            value = getattr(self, name)
            if value is not None and (len(value) != size or not all(math.isfinite(v) for v in value)):
                raise InputError(f"{OPTION[name]} needs {size} finite numbers, got {list(value)}")

    def _check_forces(self) -> None:
        """At most one source of the process force (the one place this is checked)."""
        given = [name for name in FORCE_SOURCES if getattr(self, name) is not None]
        if len(given) > 1:
            chosen = given[-1]
            others = " or ".join(OPTION[name] for name in FORCE_SOURCES if name != chosen and (name in given or name != "force_per_target"))
            raise InputError(f"{OPTION[chosen]} gives {FORCE_SOURCES[chosen]}: not with {others} (give either one source of "
                             "the process force or none)")

    def _check_job_shape(self) -> None:
        """One program with -o, or several (or --out-dir / --jobs / --scheduler) with --out-dir."""
        if len(self.programs) > 1 and "out_dir" not in self.machine.takes:
            raise InputError(f"the compensation of a {self.machine.kind} takes one program and -o OUT")
        if self.is_batch:
            together = [OPTION[name] for name in ONE_PROGRAM_ONLY if name in self.given()]
            if together:
                raise InputError(f"{', '.join(together)}: work on one program at a time (not with --out-dir)")
            if self.out_dir is None or self.output is not None:
                raise InputError("several programs take --out-dir DIR (not -o)")
            if self.jobs is not None and self.scheduler is not None:
                raise InputError("give --jobs N or --scheduler ADDRESS, not both")
            if self.jobs is not None and self.jobs < 1:
                raise InputError("--jobs must be at least 1")
            if "-" in self.programs:
                raise InputError("standard input (-) is for a single program with -o")
        elif self.output is None:
            raise InputError(f"compensate needs -o OUT{' (or --out-dir DIR for many programs)' if 'out_dir' in self.machine.takes else ''}")
        if self.programs == ("-",) and self.dialect is None:
            raise InputError("reading a program from standard input needs --dialect")

    @property
    def is_batch(self) -> bool:
        return len(self.programs) > 1 or self.out_dir is not None or self.jobs is not None or self.scheduler is not None

    def solver_options(self) -> dict[str, Any]:
        """The keyword options of ``compensation.core.compensate`` this request sets."""
        return {"tol_mm": self.tol_mm, "max_iter": self.max_iter, "scheme": self.scheme, "temp_c": self.temp_c,
                "force_n": None if self.force_n is None else list(self.force_n), "frames": dict(self.frames),
                "tools": dict(self.tools), "start_joints": None if self.start_joints is None else list(self.start_joints),
                "allow_extrapolation": self.allow_extrapolation, "max_deviation_mm": self.max_deviation_mm}

    def model_check(self) -> tuple[str, str | None, bool]:
        """(model file, --robot, --allow-model-mismatch), as ``program_check.check_model_fits`` takes them."""
        return self.machine.source, self.robot, self.allow_mismatch
