"""What diagnose tells the user: every finding ends with the exact command that acts on
it, no two findings contradict each other, and the nominal RMS is one number everywhere."""

from __future__ import annotations

import json
import re
import shlex

import numpy as np
import pytest
from typer.testing import CliRunner

from postproc.cli import app
from postproc.model.diagnose import OTHER_WAY, Candidate, Files, _findings, split_command
from postproc.model.effects import parse_effects
from postproc.model.errormodel import ErrorModel
from postproc.model.model_io import load_model
from postproc.model.structure import Structure

runner = CliRunner()
FLOOR = 0.02 * np.sqrt(3)


def _candidate(spec, explained, significant):
    verdict = "" if significant else " (not beyond noise: leave it out)"
    return Candidate(spec, explained, 0.1, 0.01, 0.01 if significant else 0.5, significant, f"{spec} explains {100 * explained:.0f}% of them{verdict}")


def _breakdown(significant, variables=("q3",)):
    return Structure(variables, 0.3, 0.31, 1e-5, 1e-5 if significant else 0.5)


@pytest.fixture(scope="module")
def model():
    from helpers import TOOL, kr160

    return ErrorModel.create(kr160(), TOOL, parse_effects("geometric,base_frame,tool_offset,joint_compliance"))


CASES = {
    "one significant, one not": ([_breakdown(True)], [_candidate("link_bending", 0.6, True), _candidate("base_tilt", 0.3, False)], 0.3),
    "none significant, far from floor": ([_breakdown(True)], [_candidate("base_tilt", 0.01, False)], 0.3),
    "none significant, at the floor": ([_breakdown(True)], [_candidate("base_tilt", 0.01, False)], 1.05 * FLOOR),
    "no structure": ([_breakdown(False)], [_candidate("thermal", 0.0, False)], 1.0 * FLOOR),
    "catalog exhausted": ([_breakdown(True, ("tau2", "s2"))], [_candidate("backlash", 0.05, False)], 0.3),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_every_finding_ends_with_a_command_and_none_contradicts(case, model):
    breakdowns, ranked, cv = CASES[case]
    files = Files("my model.json", "A.csv")
    exhausted = case == "catalog exhausted"
    findings = _findings(breakdowns, ranked, cv, FLOOR, files, model, follows=breakdowns[0] if exhausted else None, exhausted=exhausted)
    if exhausted:  # the other way, a data-driven predictor, is offered in its own finding with its own command
        (other,) = [f for f in findings if f.startswith(OTHER_WAY)]
        assert "--predictor gpr" in split_command(other)[1]
        findings = [f for f in findings if f is not other]
        assert "catalog is exhausted" in findings[-1] and "tau2 x s2" in findings[-1]
    commands = set()
    for finding in findings:
        text, command = split_command(finding)
        assert command.startswith("postproc ") and finding.endswith(command), finding
        shlex.split(command)  # a shell can run it as written (the path with a space is quoted)
        commands.add(command)
        for c in ranked:
            if not c.significant:  # a candidate that is not significant is never recommended
                assert c.effect not in command and f"{c.effect} is the effect" not in text and "add it" not in text.split(c.effect)[-1][:40]
    assert len(commands) == 1, commands  # all findings point the same way
    (command,) = commands
    significant = [c for c in ranked if c.significant]
    if exhausted:
        assert command == "postproc effect new tau2_s2_effect"
    elif significant:
        assert command == f"postproc fit A.csv --from 'my model.json' --effects +{significant[0].effect} --cv 0 -o 'my model_next.json'"
    elif cv < 1.25 * FLOOR:
        assert command.startswith("postproc compensate PROGRAM --model 'my model.json'")
        assert not any("predictor" in f for f in findings)
    else:
        assert "--predictor gpr" in command and "--effects geometric,base_frame,tool_offset,joint_compliance" in command


def test_the_cli_finding_command_runs_and_adds_the_effect(tmp_path):
    """simulate -> fit -> diagnose: the nominal RMS is the same number in all three, and the
    command diagnose prints, run as printed, writes the extended model."""
    csv, model_path = tmp_path / "sim.csv", tmp_path / "m.json"
    sim = runner.invoke(app, ["simulate", "--robot", "kr160_r1570", "--n", "120", "--seed", "3", "-o", str(csv),
                              "--effects", "geometric,base_frame,tool_offset,joint_compliance,backlash"])
    assert sim.exit_code == 0, sim.output
    fitted = runner.invoke(app, ["fit", str(csv), "--robot", "kr160_r1570", "--tool", "0,0,200", "--cv", "0", "-o", str(model_path),
                                 "--effects", "geometric,base_frame,tool_offset,joint_compliance"])
    assert fitted.exit_code == 0, fitted.output
    nominal_sim = re.search(r"nominal error RMS (\d+\.\d+) mm", sim.output).group(1)
    nominal_fit = re.search(r"nominal \(mm\) │ (\d+\.\d+)", fitted.output).group(1)
    assert nominal_sim == nominal_fit
    report = tmp_path / "r.html"
    diag = runner.invoke(app, ["diagnose", str(model_path), str(csv), "--folds", "3", "--report", str(report)])
    assert diag.exit_code == 0, diag.output
    runs = [line.split("run: ", 1)[1] for line in diag.output.splitlines() if line.strip().startswith("run: ")]
    assert len(runs) == 1  # the suggested command, printed once
    ladder = runner.invoke(app, ["ladder", str(csv), "--robot", "kr160_r1570", "--tool", "0,0,200", "--effects", "base_frame", "--json"])
    assert ladder.exit_code == 0, ladder.output
    assert f"{json.loads(ladder.stdout)['steps'][0]['train_rms_mm']:.4f}" == nominal_sim  # the ladder's step 0: the same nominal RMS
    assert runs[0] == f"postproc fit {csv} --from {model_path} --effects +backlash --cv 0 -o {tmp_path / 'm_next.json'}"
    page = report.read_text()
    assert f"<td>{nominal_fit}</td>" in page  # the report's nominal row: the same number
    assert page.count("<code class='cmd'>") == page.count("<div class='finding'>") > 0
    again = runner.invoke(app, shlex.split(runs[0])[1:])
    assert again.exit_code == 0, again.output
    assert "backlash" in load_model(tmp_path / "m_next.json")[0].effects.names()


def test_each_command_is_printed_once_after_the_findings_it_acts_on():
    """Findings in a row that end in the same command are grouped (the CLI, the report and
    the examples print the command once)."""
    from postproc.model.diagnose import grouped_findings, with_command

    findings = [with_command("a follows s1", "postproc fit +backlash"), with_command("backlash explains 93%", "postproc fit +backlash"),
                "no command here", with_command("use it", "postproc compensate"), with_command("use it too", "postproc compensate")]
    assert grouped_findings(findings) == [(["a follows s1", "backlash explains 93%"], "postproc fit +backlash"),
                                          (["no command here"], ""), (["use it", "use it too"], "postproc compensate")]
