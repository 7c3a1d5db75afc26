"""Build the FreeCAD job fixture part.FCStd: an 80 x 50 x 20 mm box, a Job with work offset
G54 and one tool (T1, 5 mm end mill, 600 mm/min), and a Profile operation around the box.

Run with FreeCAD's own Python (it is not a postproc script):
    POSTPROC_FCSTD=examples/freecad/part.FCStd freecadcmd examples/freecad/make_job.py
"""
import os

import FreeCAD
import PathScripts.PathJob as PathJob
import PathScripts.PathProfile as PathProfile

target = os.path.abspath(os.environ.get("POSTPROC_FCSTD", "part.FCStd"))
doc = FreeCAD.newDocument("part")
box = doc.addObject("Part::Box", "Box")
box.Length, box.Width, box.Height = 80, 50, 20
doc.recompute()
job = PathJob.Create("Job", [box], None)
tc = job.Tools.Group[0]
tc.HorizFeed = "600 mm/min"
tc.VertFeed = "300 mm/min"
tc.SpindleSpeed = 12000
op = PathProfile.Create("Profile")
doc.recompute()
doc.saveAs(target)
print("saved %s: job %s, %d commands in %s" % (target, job.Label, len(op.Path.Commands), op.Label))
