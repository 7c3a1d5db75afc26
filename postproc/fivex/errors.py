"""Typed errors of the five-axis package (all bad input: the CLI maps them to exit 2)."""

from __future__ import annotations

from pathlib import Path

from postproc.errors import InputError, JobError, located


class MachineFileError(InputError):
    """A machine file is malformed: names the file and the key."""

    def __init__(self, path: str | Path, key: str, message: str):
        self.path, self.key = str(path), key
        super().__init__(f"{self.path}: key '{key}': {message}")


class UnknownMachineError(InputError):
    """A machine name that is neither bundled nor an existing file."""


class ProbeFileError(InputError):
    """A probing CSV is malformed: names the file, the CSV row (1-based data row) and column."""

    def __init__(self, path: str | Path, row: int | None, column: str | None, message: str):
        self.path, self.row, self.column = str(path), row, column
        super().__init__(f"{located(path, 'row', row, column)}: {message}")


class CalibrationError(InputError):
    """Probe data that cannot determine an axis (too few positions, collinear centres)."""


class UnreachableError(JobError):
    """Targets the machine cannot reach (rotary or linear limits): names the lines."""
