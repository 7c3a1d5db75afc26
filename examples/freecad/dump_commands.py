"""Record the path commands FreeCAD hands the postproc post for a saved job, as the post sends them (JSON).

Run with FreeCAD's own Python, after `postproc freecad-install-post`:
    POSTPROC_FCSTD=examples/freecad/part.FCStd POSTPROC_OUTPUT=examples/freecad/part_commands.json \\
    freecadcmd examples/freecad/dump_commands.py

The recording lets postproc's tests check the post's own half where FreeCAD is absent.
"""
import json
import os
import sys

import FreeCAD
import PathScripts.PathPost as PathPost
import PathScripts.PathPreferences as PathPreferences

sys.path.insert(0, PathPreferences.macroFilePath())
import postproc_post  # noqa: E402  (the installed post)

doc = FreeCAD.openDocument(os.path.abspath(os.environ.get("POSTPROC_FCSTD", "part.FCStd")))
job = [o for o in doc.Objects if o.Name.startswith("Job")][0]
sections = [postproc_post._objects(objects) for objects in PathPost.CommandPathPost().buildPostList(job)]
with open(os.environ.get("POSTPROC_OUTPUT", "part_commands.json"), "w") as fh:
    json.dump({"freecad": ".".join(FreeCAD.Version()[:3]), "document": os.path.basename(doc.FileName), "sections": sections}, fh, indent=1, sort_keys=True)
    fh.write("\n")
print("POSTPROC-DUMP-RESULT: ok %d section(s)" % len(sections))
