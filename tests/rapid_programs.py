"""The RAPID module of the reading tests: a spindle tool, a work object and a point p1, and a
main routine that switches ConfL off; each test gives what its main runs next."""

from __future__ import annotations

_HEAD = """MODULE m
  PERS tooldata tSpindle := [TRUE,[[0,0,200],[1,0,0,0]],[10,[0,0,80],[1,0,0,0],0,0,0]];
  TASK PERS wobjdata wobj1 := [FALSE,TRUE,"",[[900,-100,300],[1,0,0,0]],[[0,0,0],[1,0,0,0]]];
  VAR robtarget p1 := [[10,20,150],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];
  PROC main()
    ConfL\\Off;
"""


def spindle_module(statements: str) -> str:
    """The module with ``statements`` (lines indented four spaces) after main's ConfL\\Off."""
    return _HEAD + statements + "  ENDPROC\nENDMODULE\n"
