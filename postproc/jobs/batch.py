"""Many programs against one model: local processes or an existing Dask cluster.

``run_batch`` sends one task per program to a ``dask.distributed`` cluster: a
``LocalCluster`` of ``jobs`` worker processes, or the scheduler at ``scheduler``. The model
file is read once per worker (a worker plugin loads it at worker start-up and every task on
that worker uses it), never once per program. Each program succeeds or fails on its own:
a task returns a ``ProgramResult`` (its summary or its error message), a program that
fails writes nothing, and the others go on. Each program's files (KRL: .src and .dat) are
written together or not at all. Compensation itself is ``compensate_file``, the same
library calls as the single-program ``postproc compensate PROGRAM -o OUT``: parse, compensate,
emit, write.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from distributed import Client, LocalCluster, WorkerPlugin, as_completed, get_worker

from postproc.compensation.request import CompensationRequest
from postproc.errors import InputError, JobError, PostprocError
from postproc.model.model_io import load_model
from postproc.plugins import load_plugins, loaded_plugin_files
from postproc.programs.content import require_program
from postproc.programs.program_io import check_texts, emit_texts, files_for, parse_program, refuse_overwrite, write_set

from .compensate import CompensationError, compensate
from .program_check import check_model_fits

PLUGIN_NAME = "postproc-model"


@dataclass(frozen=True)
class ProgramResult:
    program: str
    outputs: tuple[str, ...] = ()
    ok: bool = False
    error: str | None = None
    exit_code: int = 0  # this program alone: 0 written, 1 job problem, 2 bad input
    summary: dict = field(default_factory=dict)


def compensate_file(program: str | Path, model, out_dir: str | Path, options: dict, dialect: str | None = None) -> ProgramResult:
    """Compensate one program file into out_dir; never raises for a bad program, reports it."""
    program = Path(program)
    try:
        tp = parse_program(program, dialect)
        require_program(tp)
        check = options.get("model_check")  # (model path, --robot, --allow-model-mismatch)
        if check is not None:
            check_model_fits(tp, model, *check)
        new, rep = compensate(tp, model, **{k: v for k, v in options.items() if k != "model_check"})
        failures = rep.failures()
        if failures:
            first = "; ".join(f"line {line}: {reason}" for line, reason in failures[:3])
            raise CompensationError(f"{len(failures)} target(s) cannot be compensated ({first}); nothing was written", rep)
        # The same steps as one program: every changed file (the dialect's set), re-parsed
        # before writing, never over an input, all written or none.
        texts = emit_texts(tp, new)
        check_texts(tp, new, texts, np.nonzero(rep.compensated)[0])
        files = files_for(tp, texts, Path(out_dir) / program.name)
        refuse_overwrite(tp, files, in_place=False)
        write_set(files)
        outputs = list(files)
    except PostprocError as exc:
        return ProgramResult(str(program), error=str(exc), exit_code=1 if isinstance(exc, JobError) else 2)
    return ProgramResult(str(program), tuple(str(o) for o in outputs), True, summary=rep.summary())


class ModelPlugin(WorkerPlugin):
    """Worker plugin: loads the model file once when the worker starts; tasks read ``model``."""

    name = PLUGIN_NAME

    def __init__(self, model_path: str, plugin_files: tuple[str, ...] = ()):
        self.model_path = model_path
        self.plugin_files = tuple(plugin_files)  # the plugins this process loaded from files (--plugins, POSTPROC_PLUGINS)
        self.model = None

    def setup(self, worker=None):
        # The worker loads the same plugin files (and its own entry points) before the
        # model, which refuses a plugin that is missing or changed there.
        load_plugins(self.plugin_files)
        self.model, _ = load_model(self.model_path)

    def teardown(self, worker=None):
        self.model = None


def _task(program: str, out_dir: str, options: dict, dialect: str | None) -> ProgramResult:
    return compensate_file(program, get_worker().plugins[PLUGIN_NAME].model, out_dir, options, dialect)


def check_programs(programs: list[Path], out_dir: Path) -> None:
    """Refuse before any work: a missing out-dir, or two programs that would write the same file."""
    if not out_dir.is_dir():
        raise InputError(f"--out-dir {out_dir}: not an existing folder")
    seen: dict[str, Path] = {}
    for program in programs:
        if program.name in seen:
            raise InputError(f"{program} and {seen[program.name]} would both be written to {out_dir / program.name}")
        seen[program.name] = program


def run_batch_request(request: CompensationRequest, on_done=None) -> list[ProgramResult]:
    """Compensate every program of ``request`` (several, ``out_dir``, ``jobs`` or ``scheduler``)
    on a Dask cluster; results in the programs' order, ``on_done`` as in ``run_batch``."""
    options = {**request.solver_options(), "model_check": request.model_check()}
    return run_batch([Path(p) for p in request.programs], Path(request.machine.source), request.out_dir, options, jobs=request.jobs,
                     scheduler=request.scheduler, dialect=request.dialect, on_done=on_done)


def run_batch(programs: list[Path], model_path: Path, out_dir: Path, options: dict, *, jobs: int | None = None,
              scheduler: str | None = None, dialect: str | None = None, on_done=None) -> list[ProgramResult]:
    """Compensate every program on a Dask cluster; results in the programs' order.

    on_done(result) is called as each program finishes (for a progress display)."""
    check_programs(programs, out_dir)
    if scheduler is None:
        cluster = LocalCluster(n_workers=max(jobs or 1, 1), threads_per_worker=1, processes=True, dashboard_address=None)
        client = Client(cluster)
    else:
        cluster = None
        client = _connect(scheduler)
    try:
        client.register_plugin(ModelPlugin(str(model_path.resolve()), tuple(loaded_plugin_files())), name=PLUGIN_NAME)
        futures = {client.submit(_task, str(p.resolve()), str(out_dir.resolve()), options, dialect, pure=False): str(p) for p in programs}
        results = {}
        for fut in as_completed(futures):
            results[futures[fut]] = _result_of(fut, futures[fut])
            if on_done is not None:
                on_done(results[futures[fut]])
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
    return [results[str(p)] for p in programs]


def _connect(address: str):
    try:
        return Client(address, timeout="10s")
    except (OSError, TimeoutError) as exc:
        raise InputError(f"--scheduler {address}: cannot connect ({exc})") from None


def _result_of(future, program: str) -> ProgramResult:
    """A finished task's result; a task that crashed (a bug, a lost worker) is that program's failure."""
    try:
        return future.result()
    except Exception as exc:  # noqa: BLE001 - any crash is reported as this program's failure
        return ProgramResult(program, error=f"internal error: {type(exc).__name__}: {exc}", exit_code=2)
