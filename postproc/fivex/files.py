"""Write the files of one job together or not at all."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

from ..errors import OutputError


def write_all(files: dict[Path, str], encoding: str = "utf-8") -> None:
    """Every file to a temporary sibling first; renamed over the targets only when all were written."""
    temps: list[tuple[str, Path]] = []
    try:
        for path, text in files.items():
            path = Path(path)
            try:
                fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent if str(path.parent) else ".")
            except OSError as exc:
                raise OutputError(f"{path}: cannot write ({exc.strerror})") from None
            temps.append((tmp, path))
            with os.fdopen(fd, "w", encoding=encoding, newline="") as fh:
                os.fchmod(fh.fileno(), 0o644)
                fh.write(text)
        for tmp, path in temps:
            os.replace(tmp, path)
    except OSError as exc:
        raise OutputError(f"cannot write ({exc.strerror})") from None
    finally:
        for tmp, _ in temps:
            Path(tmp).unlink(missing_ok=True)
