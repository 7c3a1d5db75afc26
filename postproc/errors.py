"""Typed exceptions raised by the library.

Only the CLI maps them to exit codes (see ``postproc.cli``): every subclass of
``InputError`` is bad input (exit 2); ``JobError`` is a job that ran and found a
problem the user must act on (exit 1).
"""

from __future__ import annotations

from pathlib import Path


class PostprocError(Exception):
    """Base class of every error postproc raises on purpose."""


class InputError(PostprocError):
    """Bad input or usage: the message names the file and where in it."""


class JobError(PostprocError):
    """The job ran and found a problem the user must act on."""


class RobotFileError(InputError):
    """A robot data file is missing, malformed or inconsistent."""

    def __init__(self, path: str | Path, key: str, message: str):
        self.path = str(path)
        self.key = key
        super().__init__(f"{self.path}: key '{key}': {message}")


class UnknownRobotError(InputError):
    """A robot name that is neither a bundled robot nor an existing file."""


class KinematicsError(InputError):
    """A kinematics call was given arrays of the wrong shape or a robot it cannot serve."""


class FeatureUnavailableError(InputError):
    """A command is registered in the scripted interface but not built yet."""


def located(path: str | Path, place: str, number: int | None, column: str | None) -> str:
    """'FILE, line 3, column 'q2'' (or 'row 3'): the parts that are known."""
    where = str(path)
    if number is not None:
        where += f", {place} {number}"
    if column is not None:
        where += f", column '{column}'"
    return where


class MeasurementError(InputError):
    """A measurement file is malformed: names the file, the CSV line and the column."""

    def __init__(self, path: str | Path, line: int | None, column: str | None, message: str):
        self.path = str(path)
        self.line = line
        self.column = column
        super().__init__(f"{located(path, 'line', line, column)}: {message}")


class ModelFileError(InputError):
    """A model JSON file is missing, malformed or does not fit the data it is used with."""


class IdentificationError(JobError):
    """A fit ran but could not produce a usable model (too few poses, no convergence)."""


class ParseError(InputError):
    """A program that cannot be parsed: file, line, column and the offending line with a caret."""

    def __init__(self, path: str, line: int, column: int, message: str, excerpt: str = ""):
        self.path = path
        self.line = line
        self.column = column
        self.message = message
        self.excerpt = excerpt
        text = f"{path}:{line}:{column}: {message}"
        if excerpt:
            text += f"\n    {excerpt}\n    {' ' * max(column - 1, 0)}^"
        super().__init__(text)


class EmitError(InputError):
    """A modified toolpath cannot be written back into its source text."""


class SharedNumberError(EmitError):
    """One number of the text would need different new values for the targets that use it
    (a loop body or subroutine executed several times, a named point used by several moves)."""

    def __init__(self, path: str, line: int, column: int, message: str):
        self.path, self.line, self.column = path, line, column
        super().__init__(f"{path}:{line}:{column}: {message}")


class OutputError(InputError):
    """An output file cannot be written where the user asked (missing folder, no permission)."""


class OutputCheckError(JobError):
    """The text about to be written does not read back as the values it was meant to hold."""
