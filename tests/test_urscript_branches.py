"""URScript if / elif / else whose branch the text fixes (URScript manual, "Flow of control":
the first branch whose condition holds runs, else the else). Expected targets written by
hand from that rule: only the branch that runs gives targets, and the motions after the
block keep a known posture."""

from __future__ import annotations

import numpy as np

from postproc.programs import dialects
from postproc.programs.ir import Kind

START = "def p():\n  movej([0, -1.57, 1.57, 0, 0, 0])\n"
A, B, C, D = (f"p[{x}, 0, 0.3, 0, 3.14, 0]" for x in ("0.4", "0.5", "0.6", "0.7"))


def parse(body: str):
    return dialects.get("urscript").parse("<text>.script", (START + body + "end\n").encode("latin-1"))


def xs(tp) -> list[float]:
    return np.round(tp.position[tp.kind != Kind.ABSJ, 0], 3).tolist()


def test_if_true_runs_its_branch_and_the_motions_after_it_are_placed():
    tp = parse(f"  if True:\n    movel({A})\n  else:\n    movel({B})\n  end\n  movel({C})\n")
    assert xs(tp) == [400.0, 600.0] and tp.resolved.all()
    assert "line 3: the if's condition is True: its first branch runs" in tp.notes


def test_comparisons_of_constants_and_of_straight_line_variables():
    body = (f"  n = 3\n  flag = False\n  if n > 5:\n    movel({A})\n  elif (n == 3):\n    movel({B})\n  else:\n    movel({C})\n  end\n"
            f"  if not flag:\n    movel({D})\n  end\n  if 2.5 <= 2:\n    movel({A})\n  end\n  movel({C})\n")
    tp = parse(body)
    assert xs(tp) == [500.0, 700.0, 600.0] and tp.resolved.all()


def test_conditions_on_inputs_or_on_variables_a_block_may_set_stay_as_before():
    body = (f"  n = 3\n  if digital_in(0):\n    n = 4\n  end\n  if n == 3:\n    movel({A})\n  end\n  movel({B})\n")
    tp = parse(body)
    assert xs(tp) == [400.0, 500.0]
    assert tp.resolved.tolist() == [True, True, False]  # after an if that may or may not run: posture unknown
    assert any("after the if of line 7" in n for n in tp.notes)


def test_a_condition_inside_a_counted_loop_follows_the_counter():
    body = f"  i = 0\n  while i < 3:\n    if i == 1:\n      movel({A})\n    else:\n      movel({B})\n    end\n    i = i + 1\n  end\n"
    tp = parse(body)
    assert xs(tp) == [500.0, 400.0, 500.0] and tp.resolved.all()


def test_with_a_thread_only_literal_conditions_are_fixed():
    body = f"  thread t():\n    n = 1\n  end\n  n = 3\n  if n == 3:\n    movel({A})\n  end\n  if True:\n    movel({B})\n  end\n"
    tp = parse(body)
    assert xs(tp) == [400.0, 500.0] and tp.resolved.tolist() == [True, True, False]
