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

import numpy as np

from ...controller import Controller
from ...ir import Toolpath
from .facts import CONTINUOUS


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
        where = tp.extras[CONTINUOUS][0] if len(tp) else ""  # the reader's (facts.py)
        if not where:
            return None
        return f"{where}: continuous-path mode or compressor (G64 / G641..G645, COMPCAD, CYCLE832): the 840D leaves the programmed corners"


SINUMERIK_840D = Sinumerik840D()
