"""freecad-install-post: the FreeCAD post-processor macro."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from postproc.cam.install import default_macro_dir, install_post

from .app import app, handles_errors, out


@app.command("freecad-install-post")
@handles_errors
def freecad_install_post_cmd(
    directory: Optional[Path] = typer.Option(None, "--dir", help="Folder to install into (default: FreeCAD's macro folder, asked of freecadcmd)."),
    python: Optional[str] = typer.Option(None, "--python", help="postproc's Python that the post runs (default: this one)."),
):
    """Install the postproc post-processor (postproc_post.py) where FreeCAD's Path/CAM workbench finds it."""
    how = "given with --dir"
    if directory is None:
        directory, how = default_macro_dir()
    target = install_post(directory, python)
    out.print(f"installed {target} ({how}); in FreeCAD choose the post processor 'postproc' and give its arguments (--help lists them)")
