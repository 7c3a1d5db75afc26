"""Writing files all or none: a temporary file beside each target, renamed when all are ready."""

from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path
from typing import Iterable

from .errors import OutputError


def write_all(files: dict[Path, bytes | Iterable[bytes]], backup: bool = False) -> None:
    """Write every file of one job, or none of them.

    A file's content may be an iterable of byte strings (a long program written as it is
    computed, postproc.jobs.stream): it is staged piece by piece, and an exception raised while
    producing it leaves nothing behind.

    Each file is written to a temporary file in its target's folder first (a missing
    folder or a full disk fails here, before anything is replaced); only when all are
    ready are they renamed over their targets. ``backup`` keeps the previous content of
    each file it replaces as NAME.bak (``prog.src`` -> ``prog.src.bak``)."""
    staged: list[tuple[str, Path]] = []
    try:
        for path, data in files.items():
            path = Path(path)
            staged.append((_stage(path, data), path))
        if backup:
            for _, path in staged:
                if path.exists():
                    shutil.copy2(path, path.with_name(path.name + ".bak"))
        for tmp, path in staged:
            os.replace(tmp, path)
    except OSError as exc:
        where = exc.filename if exc.filename and not str(exc.filename).endswith(".tmp") else (staged[-1][1] if staged else next(iter(files), "output"))
        raise OutputError(f"{where}: cannot write ({exc.strerror})") from None
    finally:
        for tmp, _ in staged:
            Path(tmp).unlink(missing_ok=True)


def _stage(path: Path, data: bytes) -> str:
    """A temporary file beside ``path`` holding ``data``, with the mode ``path`` has (or a new file would get)."""
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent if str(path.parent) else ".")
    except OSError as exc:
        raise OutputError(f"{path}: cannot write ({exc.strerror})") from None
    try:
        with os.fdopen(fd, "wb") as fh:
            # mkstemp creates the file private (0600); give it the mode a plain open() would.
            os.fchmod(fh.fileno(), path.stat().st_mode & 0o7777 if path.exists() else 0o666 & ~_current_umask())
            if isinstance(data, (bytes, bytearray)):
                fh.write(data)
            else:
                for part in data:
                    fh.write(part)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return tmp


def _current_umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask
