"""Run by freecadcmd from tests/test_freecad_post.py: the post's --help and both post APIs.

FreeCAD 1.x's class-based post is loaded over a stand-in for Path.Post.Processor (this
FreeCAD is 0.20): the base class keeps the job and lists the job's objects, as 1.x does.
"""
import importlib
import os
import sys
import types

import FreeCAD
import PathScripts.PathPost as PathPost

sys.path.insert(0, os.environ["POSTPROC_POST_DIR"])
import postproc_post  # noqa: E402

doc = FreeCAD.openDocument(os.environ["POSTPROC_FCSTD"])
job = [o for o in doc.Objects if o.Name.startswith("Job")][0]
objects = PathPost.CommandPathPost().buildPostList(job)[0]
args = os.environ["POSTPROC_ARGS"]
os.environ["PYTHONHOME"] = "/nonexistent"  # as bundled FreeCAD builds set it: the post must not pass it on
helped = postproc_post.export(objects, os.environ["POSTPROC_OUTPUT"] + ".help", "--help")
text = postproc_post.export(objects, os.environ["POSTPROC_OUTPUT"], args)
written = open(os.environ["POSTPROC_OUTPUT"], encoding="latin-1", newline="").read()


class StandInPostProcessor:
    def __init__(self, job, tooltip, tooltipargs, units, *args, **kwargs):
        self._job = job

    def _buildPostList(self):
        return [("allitems", objects)]


processor = types.ModuleType("Path.Post.Processor")
processor.PostProcessor = StandInPostProcessor
sys.modules["Path.Post"] = types.ModuleType("Path.Post")
sys.modules["Path.Post.Processor"] = processor
importlib.reload(postproc_post)
job.PostProcessorArgs = args
job.PostProcessorOutputFile = os.environ["POSTPROC_OUTPUT"]
sections = postproc_post.Postproc(job).export()
print("POSTPROC-APIS: help %s, export %s, class %s" % (
    helped, "same" if text == written else "DIFFERENT", "same" if sections == [("allitems", text)] else "DIFFERENT %r" % (sections,)))
