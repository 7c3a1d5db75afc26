"""Post a saved FreeCAD job with the postproc post, headless, as Path -> Post Process does.

Run with FreeCAD's own Python, after `postproc freecad-install-post`:
    POSTPROC_FCSTD=examples/freecad/part.FCStd POSTPROC_OUTPUT=$PWD/part.src \\
    POSTPROC_ARGS="--model $PWD/model.json --to krl --frame G54=900,-100,350 --tool 1=0,0,200 --initial-tool 1 --start 40,25,60" \\
    freecadcmd examples/freecad/post_job.py

The job's post processor becomes "postproc" with POSTPROC_ARGS as its arguments and
POSTPROC_OUTPUT as its output file; then FreeCAD's own Post Process code builds the list
of fixtures, tool changes and operations and hands it to the post.
"""
import os

import FreeCAD
import PathScripts.PathPost as PathPost
import PathScripts.PathPreferences as PathPreferences

doc = FreeCAD.openDocument(os.path.abspath(os.environ.get("POSTPROC_FCSTD", "part.FCStd")))
job = [o for o in doc.Objects if o.Name.startswith("Job")][0]
# The job keeps the posts FreeCAD found when it was made; list them again (as the job editor does).
job.PostProcessor = PathPreferences.allEnabledPostProcessors([""])
job.PostProcessor = "postproc"
job.PostProcessorArgs = os.environ.get("POSTPROC_ARGS", "--help")
job.PostProcessorOutputFile = os.path.abspath(os.environ.get("POSTPROC_OUTPUT", "part.src"))
command = PathPost.CommandPathPost()
results = [command.exportObjectsWith(objects, job) for objects in command.buildPostList(job)]
ok = all(text is not None for failed, text, filename in results)
print("POSTPROC-POST-RESULT: %s %s" % ("ok" if ok else "failed", ", ".join(str(r[2]) for r in results)))
