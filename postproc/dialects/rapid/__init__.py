"""ABB RAPID modules (.mod, .modx, .prg, .sys)."""

from __future__ import annotations

import numpy as np

from ...ir import SourceDoc, Toolpath
from ..base import Dialect


class RapidDialect(Dialect):
    name = "rapid"
    description = "ABB RAPID module"
    extensions = (".mod", ".modx", ".prg", ".sys")

    def sniff(self, head: str) -> bool:
        return "MODULE " in head and ("ENDMODULE" in head or "PROC " in head)

    def parse_sources(self, sources: list[SourceDoc]) -> Toolpath:
        from .parse import RapidParser

        return RapidParser(sources[0]).parse()

    def branch_from_conf(self, robot, solutions, conf):
        """confdata cf1, cf4, cf6, cfx pick the branch (RAPID reference, 'confdata')."""
        from ...kinematics import select_by_abb_conf

        q, branch = super().branch_from_conf(robot, solutions, conf)
        has = ~np.isnan(conf).any(axis=1)
        if has.any():
            q[has], branch[has] = select_by_abb_conf(robot, solutions[has], conf[has].astype(int))
        return q, branch

    def new_writer(self, name: str):
        from .writer import RapidWriter

        return RapidWriter(name)


RAPID = RapidDialect()
