"""Install the FreeCAD post (``freecad_post.py``) into a user's FreeCAD macro folder."""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from importlib import resources
from pathlib import Path

from postproc.errors import InputError
from postproc.model.measurements import write_text_atomic

from .freecad import help_text

POST_FILE = "postproc_post.py"  # FreeCAD lists posts by their *_post.py file names: "postproc"


def default_macro_dir() -> tuple[Path, str]:
    """FreeCAD's user macro folder, where it looks for posts, and how it was found.

    Asked of ``freecadcmd`` when it is installed (it knows a MacroPath the user set);
    else FreeCAD 0.20+'s default on Linux, ~/.local/share/FreeCAD/Macro.
    """
    freecadcmd = shutil.which("freecadcmd")
    if freecadcmd is not None:
        script = ("import FreeCAD; print('POSTPROC-MACRO-DIR=' + FreeCAD.ParamGet('User parameter:BaseApp/Preferences/Macro')"
                  ".GetString('MacroPath', FreeCAD.getUserMacroDir(True)))")
        try:
            done = subprocess.run([freecadcmd, "-c", script], capture_output=True, text=True, timeout=120, check=False)
        except (OSError, subprocess.TimeoutExpired):
            done = None
        found = re.search(r"POSTPROC-MACRO-DIR=(.+)", done.stdout) if done is not None else None
        if found:
            return Path(found.group(1).strip()), f"asked {freecadcmd}"
    return Path.home() / ".local" / "share" / "FreeCAD" / "Macro", "FreeCAD's default (freecadcmd not found)"


def render_post(python: str | None = None) -> str:
    """The post module's text with postproc's Python and the options' help filled in."""

    template = resources.files("postproc.cam").joinpath("freecad_post.py").read_text(encoding="utf-8")
    python = python or sys.executable
    return template.replace("@POSTPROC_PYTHON@", python.replace("\\", "\\\\").replace('"', '\\"')).replace("@TOOLTIP_ARGS@", help_text().replace('"""', "'''"))


def install_post(directory: str | Path | None = None, python: str | None = None) -> Path:
    """Write postproc_post.py into ``directory`` (default: FreeCAD's macro folder, created if missing)."""
    target_dir = Path(directory) if directory is not None else default_macro_dir()[0]
    if directory is None:
        target_dir.mkdir(parents=True, exist_ok=True)
    if not target_dir.is_dir():
        raise InputError(f"{target_dir}: no such folder")
    target = target_dir / POST_FILE
    write_text_atomic(target, render_post(python))
    return target
