# postproc post-processor for FreeCAD's Path / CAM workbench.
#
# Installed by `postproc freecad-install-post` as postproc_post.py in FreeCAD's macro
# folder; pick "postproc" as the job's post processor and give its options in the job's
# post-processor arguments, e.g.
#   --model m.json --to krl --frame G54=900,-100,350,0,0,0 --tool 1=0,0,200 --initial-tool 1 --start 0,0,50
#
# Why a subprocess: FreeCAD runs this module in its own Python (Debian's python3 with
# Debian's numpy, often already imported by FreeCAD), while postproc and its compiled
# dependencies (numpy, numba, scipy, torch) live in postproc's virtual environment. Adding
# that environment's site-packages to FreeCAD's sys.path would load two builds of numpy
# into one process (or fail on an ABI or Python version mismatch). So this module only
# collects the path commands, sends them as JSON to `python -m postproc.cam.freecad` in
# postproc's own Python, and reports its answer as FreeCAD posts do: messages on the
# report view/console, the program text returned, None (and no file) on any error.
import json
import os
import shlex
import subprocess

import FreeCAD

# Filled in by `postproc freecad-install-post`: postproc's Python and the options' help.
POSTPROC_PYTHON = "@POSTPROC_PYTHON@"
TOOLTIP_ARGS = """@TOOLTIP_ARGS@"""

TOOLTIP = """postproc: the job's paths compensated under a robot error model
(fitted with `postproc fit`) and written as a KUKA KRL or ABB RAPID program.
Arcs become straight moves within --arc-tol. Use --help for the options."""

UNITS = "G21"


def _python():
    return os.environ.get("POSTPROC_PYTHON") or POSTPROC_PYTHON


def _commands(obj):
    return [[c.Name, dict(c.Parameters)] for c in obj.Path.Commands]


def _objects(objectslist):
    """The path objects FreeCAD hands a post (fixtures, tool controllers, operations), in order."""
    out = []
    for obj in objectslist:
        if hasattr(obj, "Active") and not obj.Active:
            continue
        if hasattr(obj, "Base") and hasattr(obj.Base, "Active") and not obj.Base.Active:
            continue
        if hasattr(obj, "Group") and not hasattr(obj, "Path"):
            out.extend(_objects(obj.Group))
            continue
        if not hasattr(obj, "Path"):
            raise ValueError("the object %s is not a path; select only path objects" % obj.Name)
        out.append({"label": str(obj.Label), "commands": _commands(obj)})
    return out


def _environment():
    """FreeCAD's environment without what points a Python at FreeCAD's own (bundled builds set
    PYTHONHOME / PYTHONPATH, AppImages LD_LIBRARY_PATH): postproc's Python must find only its own."""
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONHOME", "PYTHONPATH", "PYTHONSTARTUP", "PYTHONEXECUTABLE")}
    if "APPIMAGE" in env or "APPDIR" in env:
        env.pop("LD_LIBRARY_PATH", None)
    return env


def _run(objects, filename, argstring, name=None):
    """The answer of postproc's own Python to one post request (a dict; 'ok' False on any error)."""
    request = json.dumps({"argstring": argstring or "", "filename": filename, "name": name, "objects": objects})
    try:
        done = subprocess.run([_python(), "-m", "postproc.cam.freecad"], input=request, capture_output=True, text=True,
                              check=False, env=_environment())
    except OSError as exc:
        return {"ok": False, "error": "cannot run postproc's Python %s (%s); reinstall the post with `postproc freecad-install-post`" % (_python(), exc)}
    try:
        answer = json.loads(done.stdout)
    except ValueError:
        answer = {"ok": False, "error": "postproc failed (exit %d): %s" % (done.returncode, done.stderr.strip()[-2000:])}
    answer["status"] = done.returncode
    return answer


def post_text(objectslist, filename, argstring, name=None):
    """The one implementation both post APIs share: the program text, or None after reporting why.

    filename '-': nothing is written; ``name`` then names the program (KRL: DEF name = file name)."""
    if "--help" in shlex.split(argstring or ""):
        FreeCAD.Console.PrintMessage(TOOLTIP_ARGS + "\n")
        return None
    try:
        objects = _objects(objectslist)
    except ValueError as exc:
        FreeCAD.Console.PrintError("postproc: %s\n" % exc)
        return None
    answer = _run(objects, filename, argstring, name)
    if not answer.get("ok"):
        FreeCAD.Console.PrintError("postproc: %s\n" % answer.get("error", "unknown error"))
        return None
    for message in answer.get("messages", []):
        FreeCAD.Console.PrintMessage(message + "\n")
    return answer.get("text")


def export(objectslist, filename, argstring):
    """FreeCAD 0.20 / 0.21 post API: writes the program (and a KRL .dat) unless filename is '-'."""
    return post_text(objectslist, filename, argstring)


try:  # FreeCAD 1.x: class-based posts; FreeCAD writes the sections it gets back.
    from Path.Post.Processor import PostProcessor as _PostProcessor
except ImportError:  # FreeCAD 0.20 / 0.21: the module-level export() above is the API
    _PostProcessor = None

if _PostProcessor is not None:

    class Postproc(_PostProcessor):
        def __init__(self, job):
            super().__init__(job, tooltip=TOOLTIP, tooltipargs=TOOLTIP_ARGS, units="Metric")

        def export(self):
            # FreeCAD writes each section to its file; for KRL that is the .src (its .dat
            # holds nothing: every target is inline). The program takes the output file's name.
            output = getattr(self._job, "PostProcessorOutputFile", "") or ""
            stem = os.path.splitext(os.path.basename(output))[0]
            sections = []
            for name, objects in self._buildPostList():
                program = stem if stem and "%" not in stem else name
                text = post_text(objects, "-", getattr(self._job, "PostProcessorArgs", ""), program)
                if text is None:
                    return None
                sections.append((name, text))
            return sections

        @property
        def tooltip(self):
            return TOOLTIP

        @property
        def tooltipArgs(self):
            return TOOLTIP_ARGS

        @property
        def units(self):
            return "Metric"
