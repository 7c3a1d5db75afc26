"""KRL: the payload a program states ($LOAD), from the IR (``load_facts``: the parser's)."""

from __future__ import annotations

from postproc.errors import InputError

from ...emit.load_plan import plan_from_index
from ...ir import Toolpath
from .load_facts import LOAD, LOADS, KrlLoads


def load_masses(tp: Toolpath) -> list[tuple[float, str]]:
    """(mass kg, 'FILE, line N') of every payload the program's files state."""
    facts: KrlLoads = tp.facts[LOADS]
    return list(facts.masses)


def stated_loads(tp: Toolpath):
    """LoadPlan of the program: the $LOAD in force at each target ($LOAD = {...}, $LOAD.M = m,
    $LOAD = LOAD_DATA[n] and BAS(#TOOL, n) with LOAD_DATA[n] declared, e.g. in $config.dat)."""
    facts: KrlLoads = tp.facts[LOADS]
    if facts.refused:
        raise InputError(facts.refused)
    return plan_from_index(list(facts.states), tp.extras[LOAD])
