"""simulate -> fit -> evaluate through the command line, with the spec's JSON and exit codes."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from postproc.cli import app
from postproc.model.model_io import load_model

runner = CliRunner()


@pytest.fixture(scope="module")
def sim(tmp_path_factory):
    d = tmp_path_factory.mktemp("sim")
    args = ["simulate", "--robot", "kr160_r1570", "--tool", "0,0,200", "--n", "260", "--seed", "4", "--workspace", "joints",
            "--effects", "geometric,base_frame,tool_offset,joint_compliance,joint_harmonics[joints=3;orders=2]",
            "-o", str(d / "sim.csv"), "--truth", str(d / "truth.json")]
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output
    return d


def test_fit_then_extend_then_evaluate(sim):
    base = ["fit", str(sim / "sim.csv"), "--robot", "kr160_r1570", "--tool", "0,0,200", "-o", str(sim / "m1.json"),
            "--effects", "geometric,base_frame,tool_offset,joint_compliance"]
    first = runner.invoke(app, base)
    assert first.exit_code == 0, first.output
    assert "nominal (mm)" in first.stdout and "not identified" in first.stdout
    second = runner.invoke(app, ["fit", str(sim / "sim.csv"), "--from", str(sim / "m1.json"), "--effects", "+joint_harmonics", "-o", str(sim / "m2.json")])
    assert second.exit_code == 0, second.output
    assert "joint_harmonics[joints=3;orders=2]" in second.stdout
    model, doc = load_model(sim / "m2.json")
    assert doc["fit"]["cv_rms_mm"] > 0 and "geometric.dtheta1" in doc["parameters"]
    assert doc["parameters"]["geometric.dtheta1"]["identified"] is False
    ev1 = json.loads(runner.invoke(app, ["evaluate", str(sim / "m1.json"), str(sim / "sim.csv"), "--json"]).stdout)
    ev2 = json.loads(runner.invoke(app, ["evaluate", str(sim / "m2.json"), str(sim / "sim.csv"), "--json"]).stdout)
    truth = json.loads(runner.invoke(app, ["evaluate", str(sim / "truth.json"), str(sim / "sim.csv"), "--json"]).stdout)
    assert set(ev2) == {"n", "rms_mm", "mean_mm", "max_mm"} and ev2["n"] == 260
    assert ev2["rms_mm"] < 0.5 * ev1["rms_mm"]  # adding the missing effect makes the error fall
    assert ev2["rms_mm"] < 1.05 * truth["rms_mm"]


def test_bad_inputs_exit_2_and_write_nothing(sim, tmp_path):
    out = tmp_path / "m.json"
    cases = [
        (["--effects", "geometric,heat"], "unknown effect 'heat'"),
        (["--effects", "geometric,external_load"], "fx, fy, fz"),
        (["--effects", "+backlash"], "--from"),
        (["--effects", "geometric", "--predictor", "svm"], "--predictor"),
        (["--effects", "geometric", "--loss", "l3"], "--loss"),
    ]
    for extra, message in cases:
        args = ["fit", str(sim / "sim.csv"), "--robot", "kr160_r1570", "--tool", "0,0,200", "-o", str(out)] + extra
        result = runner.invoke(app, args)
        assert result.exit_code == 2, (extra, result.output)
        assert message in result.stderr, (extra, result.stderr)
        assert not out.exists()
    broken = tmp_path / "broken.csv"
    broken.write_text((sim / "sim.csv").read_text().replace("\n3,", "\n3,x", 1))
    result = runner.invoke(app, ["fit", str(broken), "--robot", "kr160_r1570", "--tool", "0,0,200", "--effects", "geometric", "-o", str(out)])
    assert result.exit_code == 2 and "line 4, column 'q1'" in result.stderr
    assert not out.exists()


def test_evaluate_rejects_broken_model_files(sim, tmp_path):
    doc = json.loads((sim / "m1.json").read_text()) if (sim / "m1.json").exists() else None
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    result = runner.invoke(app, ["evaluate", str(bad), str(sim / "sim.csv")])
    assert result.exit_code == 2 and "line 1, column 2" in result.stderr
    truth = json.loads((sim / "truth.json").read_text())
    del truth["parameters"]["geometric.dd2"]
    bad.write_text(json.dumps(truth))
    result = runner.invoke(app, ["evaluate", str(bad), str(sim / "sim.csv")])
    assert result.exit_code == 2 and "parameters.geometric.dd2" in result.stderr
    assert doc is None or doc["format"] == "postproc-model"


def test_simulate_rejects_unknown_workspace(tmp_path):
    result = runner.invoke(app, ["simulate", "--robot", "kr160_r1570", "--workspace", "sphere", "-o", str(tmp_path / "x.csv")])
    assert result.exit_code == 2 and "--workspace" in result.stderr
    assert not (tmp_path / "x.csv").exists()


def test_simulate_workspace_regions(tmp_path):
    from postproc.model.measurements import read_measurements

    out = tmp_path / "cyl.csv"
    result = runner.invoke(app, ["simulate", "--robot", "kr160_r1570", "--n", "60", "--region", "theta1=-10:10;radius=900:1000;z=400:500;tilt=5", "-o", str(out)])
    assert result.exit_code == 0, result.output
    meas = read_measurements(out)
    r = np.hypot(meas.nominal_mm[:, 0], meas.nominal_mm[:, 1])
    theta = np.degrees(np.arctan2(meas.nominal_mm[:, 1], meas.nominal_mm[:, 0]))
    assert (r >= 900 - 1e-3).all() and (r <= 1000 + 1e-3).all()
    assert (np.abs(theta) <= 10 + 1e-6).all()
    assert ((meas.nominal_mm[:, 2] >= 400 - 1e-3) & (meas.nominal_mm[:, 2] <= 500 + 1e-3)).all()
    out = tmp_path / "joints.csv"
    result = runner.invoke(app, ["simulate", "--robot", "kr160_r1570", "--n", "40", "--workspace", "joints", "--region", "q1=-5:5;q2=-10:0", "-o", str(out)])
    assert result.exit_code == 0, result.output
    q = read_measurements(out).q_deg
    assert (np.abs(q[:, 0]) <= 5).all() and (q[:, 1] <= 0).all() and (q[:, 1] >= -10).all()
    result = runner.invoke(app, ["simulate", "--robot", "kr160_r1570", "--region", "radius=1000:900", "-o", str(tmp_path / "x.csv")])
    assert result.exit_code == 2 and "low < high" in result.stderr


def test_diagnose_json_and_report(sim, tmp_path):
    model = sim / "m1.json"
    if not model.exists():
        runner.invoke(app, ["fit", str(sim / "sim.csv"), "--robot", "kr160_r1570", "--tool", "0,0,200", "-o", str(model),
                            "--effects", "geometric,base_frame,tool_offset,joint_compliance"])
    report = tmp_path / "report.html"
    result = runner.invoke(app, ["diagnose", str(model), str(sim / "sim.csv"), "--json", "--report", str(report)])
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    assert isinstance(doc["rms_mm"], float)
    first = doc["candidates"][0]
    assert set(first) >= {"effect", "explained", "rms_if_added_mm"}
    assert first["effect"].startswith("joint_harmonics") and first["explained"] > 0.5
    assert [c["explained"] for c in doc["candidates"]] == sorted((c["explained"] for c in doc["candidates"]), reverse=True)
    page = report.read_text()
    # error histograms, error vectors, residual vs variables, partial residual of what it follows, candidates
    assert page.count("data:image/png;base64,") == 5 and "What is missing" in page and "Partial residual" in page


def test_ladder_cli_plot_and_json(sim, tmp_path):
    plot = tmp_path / "ladder.png"
    result = runner.invoke(app, ["ladder", str(sim / "sim.csv"), "--robot", "kr160_r1570", "--tool", "0,0,200",
                                 "--effects", "geometric,base_frame,joint_harmonics[joints=3;orders=2]", "--plot", str(plot), "--json"])
    assert result.exit_code == 0, result.output
    steps = json.loads(result.stdout)["steps"]
    assert [s["added"] for s in steps] == ["nominal", "geometric", "base_frame", "joint_harmonics[joints=3;orders=2]"]
    assert steps[-1]["cv_rms_mm"] < steps[1]["cv_rms_mm"]
    assert plot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    bad = runner.invoke(app, ["ladder", str(sim / "sim.csv"), "--robot", "kr160_r1570", "--tool", "0,0,200", "--effects", "geometric,magic"])
    assert bad.exit_code == 2 and "unknown effect 'magic'" in bad.stderr


def test_effects_none_is_the_nominal_model(sim, tmp_path):
    out = tmp_path / "none.json"
    result = runner.invoke(app, ["fit", str(sim / "sim.csv"), "--robot", "kr160_r1570", "--tool", "0,0,200", "--effects", "none", "-o", str(out)])
    assert result.exit_code == 0, result.output
    doc = json.loads(out.read_text())
    assert doc["effects"] == "none" and doc["parameters"] == {}
    ev = json.loads(runner.invoke(app, ["evaluate", str(out), str(sim / "sim.csv"), "--json"]).stdout)
    # 'after' is the model as saved (the nominal robot in its own frame); 'before', as everywhere,
    # the nominal robot registered onto the data, which can only be closer.
    assert ev["rms_mm"] == pytest.approx(doc["fit"]["after"]["rms_mm"]) and ev["rms_mm"] > 1.0
    assert doc["fit"]["before"]["rms_mm"] <= ev["rms_mm"]


def test_diagnose_from_the_nominal_model_names_the_geometry(sim, tmp_path):
    out = tmp_path / "none.json"
    runner.invoke(app, ["fit", str(sim / "sim.csv"), "--robot", "kr160_r1570", "--tool", "0,0,200", "--effects", "none", "-o", str(out)])
    result = runner.invoke(app, ["diagnose", str(out), str(sim / "sim.csv"), "--json"])
    assert result.exit_code == 0, result.output
    assert json.loads(result.stdout)["candidates"][0]["effect"] == "geometric"
