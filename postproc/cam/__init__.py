"""CAM hooks over one library entry point, ``postproc.cam.post.post``.

- ``post``: program text (or a Toolpath) + model -> compensated robot program texts;
- ``freecad``: FreeCAD path commands -> G-code text -> ``post`` (run in postproc's own
  Python, called by the post-processor module that FreeCAD loads);
- ``freecad_post``: that module (a thin shim: it runs in FreeCAD's Python and never
  imports postproc); ``install`` copies it into a user's FreeCAD macro folder.
"""
