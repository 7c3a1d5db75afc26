"""What a SINUMERIK 840D does with a part program, beyond the language.

A ``postproc.programs.controller.Controller``: a machine tool has no robot configuration data, so
configuration data never apply; what the 840D states here is its interpolation mode.

Rotary-axis solution rules (SINUMERIK 840D sl Function Manual "Special functions",
F2 "Multi-axis transformations", "Orientation programming" / "Singular positions"):
- programmed rotary-axis positions (TRAORI with A/B/C words, ORIAXES) are taken as written:
  there is no solution to choose, the program states it;
- an orientation given as a vector (A3= B3= C3=, ORIVECT) leaves two solutions; the 840D
  takes the one with the shorter rotary-axis travel from the current position. postproc reads
  vectors as the tool axis (``translate.py``) and compensates them by this rule
  (``postproc.jobs.five_axis.compensate``, the controller's ``vector_solution``); its TRAORI writer
  (``postproc.jobs.five_axis.emit``) writes angles, chosen by the same nearest-travel rule
  (``postproc.fivex.kinematics.ik``: the branch nearest the previous angles).
"""

from __future__ import annotations

import re

import numpy as np

from ...controller import Controller
from ...ir import Toolpath

# Continuous-path mode: G64 and the smoothing modes G641..G645 leave the programmed corner
# (Fundamentals, "Continuous-path mode G64, G641, G642, G643, G644, G645"); G60 / G9 / G601 /
# G602 / G603 stop exactly at the block end.
_CONTINUOUS = re.compile(r"(?im)^[^;\n]*(?:\bG64[1-5]?\b|\bCOMP(?:CAD|CURV|ON)\b|\bCYCLE832[ \t]*\()")


class Sinumerik840D(Controller):
    name = "Siemens SINUMERIK 840D sl"
    maker = None  # a CNC: it drives no robot maker's arms
    # TRAORI turns a programmed A3= B3= C3= vector into the rotary solution with the shorter travel
    # (Function Manual Special Functions, F2 "Multi-axis transformations", "Orientation programming")
    vector_solution = "nearest"

    def conf_applies(self, tp: Toolpath) -> np.ndarray:
        return np.zeros(len(tp), bool)  # no robot configuration data in a part program

    def inexact_interpolation(self, tp: Toolpath) -> str | None:
        """``file:line: why`` at the first G64 / G641..G645 block, compressor (COMPON, COMPCAD,
        COMPCURV) or CYCLE832 (which sets them): the 840D then rounds the corners between
        blocks or fits a curve through them (Fundamentals, "Continuous-path mode"; Job
        Planning, "NC block compression"), which the path
        prediction does not model; None where the program never asks for it (the reset
        value of the group, machine data 20150, is the machine's: not in the program)."""
        for doc in tp.sources:
            m = _CONTINUOUS.search(doc.text)
            if m:
                line = doc.text.count("\n", 0, m.start()) + 1
                return f"{doc.path}:{line}: continuous-path mode or compressor (G64 / G641..G645, COMPCAD, CYCLE832): the 840D leaves the programmed corners"
        return None


SINUMERIK_840D = Sinumerik840D()
