"""rs274's canonical calls for the tests' own G-code programs: recorded in the repository so
CI compares without LinuxCNC, checked against a fresh run where rs274 is installed, and
written again with ``python tests/test_x.py --record``."""

from __future__ import annotations

import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Iterable, Mapping

import numpy as np
import pytest
from test_real_corpus import _moves, canonical_endpoints, machine_positions, run_rs274

from postproc.programs import parse_program

needs_rs274 = pytest.mark.skipif(shutil.which("rs274") is None, reason="LinuxCNC's rs274 is not installed (apt-get install linuxcnc-uspace)")


def assert_current(program: Path, recorded: Path) -> None:
    """rs274 on ``program`` gives exactly the recorded calls."""
    accepted, calls, err = run_rs274(program)
    assert accepted, err
    assert calls == recorded.read_text(encoding="latin-1")


def record_all(names: Iterable[str], program_in: Callable[[Path, str], Path], folder: Path) -> None:
    """Every program (``program_in(scratch folder, name)`` writes it) through rs274 into ``folder/NAME.canon``."""
    folder.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as scratch:
        for name in names:
            accepted, calls, err = run_rs274(program_in(Path(scratch), name))
            assert accepted, f"{name}: {err}"
            (folder / f"{name}.canon").write_bytes(calls.encode("latin-1"))


@dataclass(frozen=True)
class Recordings:
    """A test file's G-code programs (name -> text) and the folder of their recorded rs274 calls."""

    programs: Mapping[str, str]
    folder: Path

    def write(self, folder: Path, name: str) -> Path:
        """The program ``name`` written as ``folder``/NAME.ngc."""
        path = folder / f"{name}.ngc"
        path.write_text(self.programs[name], encoding="latin-1")
        return path

    def moves(self, folder: Path, name: str) -> tuple[np.ndarray, np.ndarray]:
        """(the IR's, rs274's recorded) machine positions of program ``name``'s moves, mm, after
        checking they are as many; the IR is read from the program written to ``folder``."""
        tp = parse_program(self.write(folder, name))
        canon, tol, arc = canonical_endpoints((self.folder / f"{name}.canon").read_text(encoding="latin-1"))
        keep = _moves(canon, tol, arc)
        machine = machine_positions(tp)
        rows = _moves(machine, np.full(len(tp), 1e-9), np.zeros(len(tp), bool))
        assert len(rows) == len(keep), f"rs274 made {len(keep)} moves, the IR {len(rows)}"
        return machine[rows], canon[keep]

    def freshness_test(self) -> Callable:
        """The test that a fresh rs274 run gives every program's recording (skipped without rs274);
        a test file binds it to a ``test_...`` name."""

        @needs_rs274
        @pytest.mark.parametrize("name", sorted(self.programs))
        def test(name: str, tmp_path: Path) -> None:
            assert_current(self.write(tmp_path, name), self.folder / f"{name}.canon")

        return test

    def record_if_asked(self, argv: list[str]) -> None:
        """``python tests/test_x.py --record``: every program through rs274 into the folder again."""
        if "--record" in argv[1:]:
            record_all(self.programs, self.write, self.folder)
