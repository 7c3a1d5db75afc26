"""Programs as files: which dialect a file is, parse it, write it back (atomically)."""

from __future__ import annotations

from pathlib import Path

from .errors import InputError
from .ir import Toolpath
from .measurements import write_text_atomic

DIALECTS = ("rapid", "krl", "gcode")
_EXTENSIONS = {
    ".mod": "rapid", ".modx": "rapid", ".prg": "rapid", ".sys": "rapid",
    ".src": "krl", ".sub": "krl",
    ".nc": "gcode", ".ngc": "gcode", ".gcode": "gcode", ".tap": "gcode", ".cnc": "gcode", ".mpf": "gcode", ".spf": "gcode", ".iso": "gcode", ".txt": "gcode",
}


def sniff(path: str | Path, data: bytes | None = None) -> str:
    """The dialect of a program from its extension, or from its content when that is unknown."""
    suffix = Path(str(path)).suffix.lower()
    if suffix in _EXTENSIONS and suffix != ".txt":
        return _EXTENSIONS[suffix]
    if data is None:
        try:
            data = Path(path).read_bytes()[:4096]
        except OSError as exc:
            raise InputError(f"{path}: cannot read ({exc.strerror})") from None
    head = data[:4096].decode("latin-1").upper()
    if "MODULE " in head and ("ENDMODULE" in head or "PROC " in head):
        return "rapid"
    if "DEF " in head and ("PTP " in head or "LIN " in head or "END" in head):
        return "krl"
    if any(tok in head for tok in ("G0", "G1", "G2", "G3", "M3", "M30", "M2")):
        return "gcode"
    raise InputError(f"{path}: cannot tell the dialect (give --dialect rapid, krl or gcode)")


def parse_program(path: str | Path, dialect: str | None = None, data: bytes | None = None) -> Toolpath:
    """Parse a program file (or ``data`` read from it, e.g. standard input) into a Toolpath."""
    dialect = dialect or sniff(path, data)
    if dialect not in DIALECTS:
        raise InputError(f"--dialect: '{dialect}' is not one of {', '.join(DIALECTS)}")
    if data is None:
        try:
            data = Path(path).read_bytes()
        except OSError as exc:
            raise InputError(f"{path}: cannot read ({exc.strerror})") from None
    if dialect == "krl":
        from .parse.krl import parse_krl

        return parse_krl(path, data)
    if dialect == "rapid":
        from .parse.rapid import parse_rapid

        return parse_rapid(str(path), data)
    from .parse.gcode import parse_gcode

    return parse_gcode(str(path), data)


def emit_texts(original: Toolpath, modified: Toolpath) -> list[str]:
    """New text of every source file of the program (unchanged files come back as they were)."""
    from .emit.splice import splice

    inserter = None
    if original.dialect == "krl":
        inserter = lambda file, name, text: f", {name.upper()} {text}"  # noqa: E731
    elif original.dialect == "gcode":
        inserter = lambda file, name, text: f" {name.upper()}{text}"  # noqa: E731
    return splice(original, modified, inserter)


def write_texts(texts: list[str], outputs: list[str | Path]) -> None:
    """Write each program text to its output path, each atomically, all only if all succeed to encode."""
    encoded = [t.encode("latin-1") for t in texts]  # fails before anything is written
    for data, out in zip(encoded, outputs):
        write_text_atomic(out, data.decode("latin-1"), encoding="latin-1")
