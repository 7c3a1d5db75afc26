"""Run a Fanuc TP program, as written and compensated, on a simulated true robot.

Usage: python examples/fanuc_true_robot.py TRUTH.json WRITTEN.ls COMPENSATED.ls --frame 'UFRAME[1]=0,0,-100,0,0,0' --tool 'UTOOL[1]=0,0,200'
(TRUTH.json from `postproc simulate --truth`). The controller's joints for each target are
those its CONFIG selects on the nominal robot (postproc/dialects/fanuc/controller.py), as
the R-30iB computes them; the true robot's TCP at those joints is compared with the target.
"""

from __future__ import annotations

import argparse
from dataclasses import replace

import numpy as np

from postproc import kinematics as kin
from postproc.cli.common import named_frames  # the --frame / --tool parsing of the CLI
from postproc.dialects.fanuc.controller import R30IB
from postproc.model_io import load_model
from postproc.programs import parse_program


def true_tcp(truth, tp) -> np.ndarray:
    """(N, 3) mm: where the true robot's TCP goes at the joints the controller computes."""
    flange = tp.base_poses() @ np.linalg.inv(tp.tools[tp.tool])
    q, branch = R30IB.branch_from_conf(truth.robot, kin.ik(truth.robot, flange), tp.conf)
    if (branch < 0).any():
        raise SystemExit(f"line {tp.line[np.argmax(branch < 0)]}: no IK solution with the target's CONFIG")
    out = np.zeros((len(tp), 3))
    for t in np.unique(tp.tool):
        sel = tp.tool == t
        m = replace(truth, tool_mm=tp.tools[t][:3, 3])
        out[sel] = m.predict_prepared(m.prepare(q_deg=q[sel]))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("truth")
    parser.add_argument("written")
    parser.add_argument("compensated")
    parser.add_argument("--frame", action="append", default=[])
    parser.add_argument("--tool", action="append", default=[])
    args = parser.parse_args()
    truth, _ = load_model(args.truth)
    frames, tools = named_frames(args.frame, "--frame"), named_frames(args.tool, "--tool")
    written = parse_program(args.written).with_frames(frames, tools)
    compensated = parse_program(args.compensated).with_frames(frames, tools)
    goal = written.base_positions()
    for name, tp in (("as written", written), ("compensated", compensated)):
        err = np.linalg.norm(true_tcp(truth, tp) - goal, axis=1)
        print(f"{name:<12} true TCP error: RMS {np.sqrt(np.mean(err ** 2)):.4f} mm, max {err.max():.4f} mm ({len(err)} targets)")


if __name__ == "__main__":
    main()
