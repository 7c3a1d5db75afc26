"""The CNC controllers that run ISO G-code here (LinuxCNC, Fanuc G43.4, Siemens TRAORI subset):
no configuration data, exact interpolation, no stated loads; their axis rules live with the
machine (postproc.fivex.controllers), since a five-axis program drives the machine's axes."""

from __future__ import annotations

from ...controller import Controller


class CncController(Controller):
    name = "an ISO G-code CNC (LinuxCNC and alike)"


CNC = CncController()
