"""Issue 28, model coverage: measurement joints beyond any physical range are refused; every
fitted model records the joint ranges and region it was fitted on; evaluate reports the
poses outside them; compensate refuses targets outside them (whole program, chunks, many
programs, the CAM hook) unless --allow-extrapolation; summaries name the model's robot and
region; a KRL or RAPID program is refused for another maker's robot; --report PAGE.html."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import postproc
from postproc.cli import app
from postproc.cli.common import load_measurements
from postproc.errors import ModelFileError
from postproc.model.coverage import Coverage
from postproc.model.effects import EffectSum, parse_effects
from postproc.model.errormodel import ErrorModel
from postproc.model.identify import fit
from postproc.model.measurements import write_measurements
from postproc.model.model_io import load_model, save_model
from postproc.model.sim import Cylinder, random_truth, sample_poses, simulate

runner = CliRunner()
KR160 = "kr160_r1570"
TOOL = np.array([0.0, 0.0, 200.0])


@pytest.fixture(scope="module")
def measured(tmp_path_factory):
    """A KR160 measured at 120 poses of the example's region (z 300-800 mm, radius 700-1150 mm)
    and the model fitted on them: (folder, measurement CSV, model JSON)."""
    folder = tmp_path_factory.mktemp("coverage")
    robot = postproc.load_robot(KR160)
    rng = np.random.default_rng(3)
    effects = parse_effects("geometric,base_frame,tool_offset")
    truth = random_truth(robot, TOOL, effects, rng, magnitude=1.0)
    data = simulate(truth, sample_poses(robot, TOOL, 120, Cylinder(), rng), rng)
    write_measurements(folder / "meas.csv", data)
    result = fit(robot, TOOL, parse_effects("base_frame,tool_offset"), data, cv_folds=0)
    save_model(folder / "model.json", result.model, result, measurements="meas.csv")
    return folder, folder / "meas.csv", folder / "model.json"


def _pocket(path: Path, x0: float, x1: float, z: float = 448.0) -> Path:
    """The README example's pocket outline (KRL, tool pointing down) between x0 and x1."""
    lines = ["DEF pocket( )", "$BASE = {X 0, Y 0, Z 0, A 0, B 0, C 0}", "$TOOL = {X 0, Y 0, Z 200, A 0, B 0, C 0}"]
    corners = [(x0, -150), (x1, -150), (x1, 150), (x0, 150), (x0, -150)]
    for (xa, ya), (xb, yb) in zip(corners[:-1], corners[1:]):
        for t in np.linspace(0, 1, 6)[:-1]:
            lines.append(f"LIN {{X {xa + t * (xb - xa):.3f}, Y {ya + t * (yb - ya):.3f}, Z {z:.3f}, A 0, B 180, C 0}} C_DIS")
    lines.append("END")
    path.write_text("\r\n".join(lines) + "\r\n", encoding="latin-1")
    return path


def _edited(src: Path, dst: Path, row: int, column: str, value: str) -> Path:
    lines = src.read_text().splitlines()
    header = lines[0].split(",")
    cells = lines[row].split(",")
    cells[header.index(column)] = value
    lines[row] = ",".join(cells)
    dst.write_text("\n".join(lines) + "\n")
    return dst


# ------------------------------------------------------------------ measurement rows


def test_joint_beyond_360_is_refused_with_line_and_column_even_under_estimated_limits(measured, tmp_path):
    _, meas, model = measured
    bad = _edited(meas, tmp_path / "m.csv", 5, "q2", "400")
    result = runner.invoke(app, ["evaluate", str(model), str(bad), "--json"])
    assert result.exit_code == 2, result.output
    assert f"{bad}, line 6, column 'q2'" in result.output and "beyond +-360 deg: no revolute joint turns that far" in result.output


def test_joint_beyond_estimated_limits_plus_margin_is_refused(measured, tmp_path):
    """q5 = 185 deg: 65 deg beyond the KR160's estimated +-120 deg, more than the 60 deg margin."""
    _, meas, model = measured
    bad = _edited(meas, tmp_path / "m.csv", 3, "q5", "185")
    result = runner.invoke(app, ["evaluate", str(model), str(bad), "--json"])
    assert result.exit_code == 2, result.output
    assert "line 4, column 'q5'" in result.output and "60 deg" in result.output
    dropped = runner.invoke(app, ["evaluate", str(model), str(bad), "--json", "--drop-invalid"])
    assert dropped.exit_code == 0, dropped.output
    assert "dropped:" in dropped.output and "q5 = 185" in dropped.output


def test_joint_within_the_margin_is_kept_with_a_warning(measured, tmp_path):
    _, meas, model = measured
    bad = _edited(meas, tmp_path / "m.csv", 3, "q5", "150")
    result = runner.invoke(app, ["evaluate", str(model), str(bad), "--json"])
    assert result.exit_code == 0, result.output
    assert "warning:" in result.output and "within 60 deg" in result.output


@pytest.mark.parametrize("name", ["kr160_dev_a_train", "kr160_dev_a_val", "kr160_dev_b_train", "kr160_dev_b_val"])
def test_shared_kr160_sets_still_load(shared, name):
    """The shared sets reach 49.6 deg beyond the KR160's estimated limits (A3, A5): kept."""
    data = load_measurements(shared / "data" / f"{name}.csv", postproc.load_robot(KR160))
    assert len(data) >= 100


# ------------------------------------------------------------------ the model records its region


def test_fitted_model_records_its_ranges_and_region(measured):
    _, meas, model_path = measured
    doc = json.loads(model_path.read_text())
    cov = doc["coverage"]
    assert cov["poses"] == 120 and len(cov["joint_lower_deg"]) == 6 and len(cov["hull_vertices_mm"]) >= 4
    assert 295 <= cov["z_mm"][0] < cov["z_mm"][1] <= 805 and 695 <= cov["radius_mm"][0] < cov["radius_mm"][1] <= 1155
    model, _ = load_model(model_path)
    assert isinstance(model.coverage, Coverage)
    assert np.allclose(model.coverage.joint_lower_deg, cov["joint_lower_deg"])


def test_old_model_file_loads_with_region_unknown(measured, tmp_path):
    folder, meas, model_path = measured
    doc = json.loads(model_path.read_text())
    del doc["coverage"]
    old = tmp_path / "old.json"
    old.write_text(json.dumps(doc))
    model, _ = load_model(old)
    assert model.coverage is None
    result = runner.invoke(app, ["evaluate", str(old), str(meas), "--json", "--region"])
    assert result.exit_code == 0, result.output
    assert json.loads(result.stdout)["outside_region"] is None
    program = _pocket(tmp_path / "p.src", 1300, 1400)  # outside the region, but none is recorded
    result = runner.invoke(app, ["compensate", str(program), "--model", str(old), "-o", str(tmp_path / "o.src")])
    assert result.exit_code == 0, result.output
    assert "measured region: unknown" in result.output


def test_malformed_region_names_the_key(measured, tmp_path):
    _, _, model_path = measured
    doc = json.loads(model_path.read_text())
    doc["coverage"]["joint_lower_deg"] = [0, 0, 0]
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(doc))
    with pytest.raises(ModelFileError, match="coverage.joint_lower_deg"):
        load_model(bad)


# ------------------------------------------------------------------ evaluate


def test_evaluate_reports_poses_outside_the_fitted_joint_range(tmp_path):
    """The issue's case: a model fitted with q2 over a narrow range, evaluated where q2 is far outside it."""
    robot = postproc.load_robot(KR160)
    rng = np.random.default_rng(5)
    q = sample_poses(robot, TOOL, 160, Cylinder(), rng)
    truth = random_truth(robot, TOOL, parse_effects("tool_offset"), rng, magnitude=1.0)
    data = simulate(truth, q, rng)
    narrow = data.q_deg[:, 1] > np.median(data.q_deg[:, 1])
    result = fit(robot, TOOL, parse_effects("tool_offset"), data.subset(narrow), cv_folds=0)
    save_model(tmp_path / "m.json", result.model, result)
    write_measurements(tmp_path / "all.csv", data)
    out = runner.invoke(app, ["evaluate", str(tmp_path / "m.json"), str(tmp_path / "all.csv"), "--json", "--region"])
    assert out.exit_code == 0, out.output
    outside = json.loads(out.stdout)["outside_region"]
    assert outside["count"] >= 40 and outside["worst_joint_deg"] > 5.0
    plain = runner.invoke(app, ["evaluate", str(tmp_path / "m.json"), str(tmp_path / "all.csv"), "--json"])
    assert set(json.loads(plain.stdout)) == {"n", "rms_mm", "mean_mm", "max_mm"}  # spec/cli.md: exactly these keys
    assert re.search(r"\d+ of 160 poses lie outside", plain.stderr), plain.stderr  # said on stderr instead
    text = runner.invoke(app, ["evaluate", str(tmp_path / "m.json"), str(tmp_path / "all.csv")])
    assert re.search(r"\d+ of 160 poses lie outside the joint ranges or region the model was fitted on", text.output), text.output
    inside = runner.invoke(app, ["evaluate", str(tmp_path / "m.json"), str(tmp_path / "all.csv"), "--json"])
    assert json.loads(inside.stdout)["n"] == 160


# ------------------------------------------------------------------ compensate


def test_compensate_names_the_model_robot_and_region(measured, tmp_path):
    _, _, model = measured
    program = _pocket(tmp_path / "p.src", 900, 1100)
    result = runner.invoke(app, ["compensate", str(program), "--model", str(model), "-o", str(tmp_path / "o.src")])
    assert result.exit_code == 0, result.output
    assert "model for kr160_r1570 (KUKA KR160 R1570" in result.output and "measured region: 120 poses, z " in result.output


def test_compensate_refuses_targets_outside_the_region(measured, tmp_path):
    """The issue's case: a model measured at radius 700-1150 mm and a program at 1300-1400 mm."""
    _, _, model = measured
    program = _pocket(tmp_path / "p.src", 1300, 1400)
    out = tmp_path / "o.src"
    result = runner.invoke(app, ["compensate", str(program), "--model", str(model), "-o", str(out)])
    assert result.exit_code == 1, result.output
    assert re.search(rf"{re.escape(str(program))}:4:\d+: outside the region the model was measured in: .*mm outside the measured region", result.output)
    assert "--allow-extrapolation" in result.output and "nothing was written" in result.output and not out.exists()
    allowed = runner.invoke(app, ["compensate", str(program), "--model", str(model), "-o", str(out), "--allow-extrapolation"])
    assert allowed.exit_code == 0, allowed.output
    assert out.exists()


def test_streamed_compensation_refuses_them_too(measured, tmp_path):
    _, _, model = measured
    program = _pocket(tmp_path / "p.src", 1300, 1400)
    out = tmp_path / "o.src"
    result = runner.invoke(app, ["compensate", str(program), "--model", str(model), "-o", str(out), "--stream", "always"])
    assert result.exit_code == 1, result.output
    assert f"{program}:4:8: outside the region the model was measured in" in result.output and not out.exists()
    allowed = runner.invoke(app, ["compensate", str(program), "--model", str(model), "-o", str(out), "--stream", "always", "--allow-extrapolation"])
    assert allowed.exit_code == 0, allowed.output
    assert "model for kr160_r1570" in allowed.output


def test_batch_refuses_the_program_outside_the_region(measured, tmp_path):
    _, _, model = measured
    inside, outside = _pocket(tmp_path / "in.src", 900, 1100), _pocket(tmp_path / "out.src", 1300, 1400)
    (tmp_path / "done").mkdir()
    result = runner.invoke(app, ["compensate", str(inside), str(outside), "--model", str(model), "--out-dir", str(tmp_path / "done"), "--jobs", "1"])
    assert result.exit_code == 1, result.output
    assert "outside the region the model was measured in" in result.output and "model for kr160_r1570" in result.output
    assert (tmp_path / "done" / "in.src").exists() and not (tmp_path / "done" / "out.src").exists()


def test_cam_post_refuses_them_unless_allowed(measured):
    from postproc.jobs.compensate import CompensationError

    _, _, model = measured
    gcode = "G90 G54\nG0 X1300 Y-100 Z448\nG1 X1400 Y-100 F500\nG1 X1400 Y100\n"
    frames = {"G54": np.eye(4)}
    with pytest.raises(CompensationError) as caught:
        postproc.post(gcode, model=str(model), to="krl", frames=frames, allow_model_mismatch=True)
    assert "outside the region the model was measured in" in " ".join(r for _, r in caught.value.report.failures())
    files = postproc.post(gcode, model=str(model), to="krl", frames=frames, allow_model_mismatch=True, allow_extrapolation=True)
    assert files


def test_model_for_another_maker_is_refused(tmp_path):
    """The issue's case: an IRB6660 model compensating a KR160 (KRL) program, same tool, no --robot."""
    model = ErrorModel.create(postproc.load_robot("irb6660_205_190"), TOOL, EffectSum())
    save_model(tmp_path / "abb.json", model)
    program = _pocket(tmp_path / "p.src", 900, 1100)
    result = runner.invoke(app, ["compensate", str(program), "--model", str(tmp_path / "abb.json"), "-o", str(tmp_path / "o.src")])
    assert result.exit_code == 2, result.output
    assert "the program is KRL, the language of KUKA controllers" in result.output and "irb6660_205_190" in result.output
    streamed = runner.invoke(app, ["compensate", str(program), "--model", str(tmp_path / "abb.json"), "-o", str(tmp_path / "o.src"), "--stream", "always"])
    assert streamed.exit_code == 2, streamed.output
    assert "language of KUKA controllers" in streamed.output and not (tmp_path / "o.src").exists()


def test_five_axis_refuses_allow_extrapolation(tmp_path):
    machine = Path(postproc.__file__).parent.parent / "machines"
    toml = next(iter(sorted(machine.glob("*.toml"))), None)
    if toml is None:
        pytest.skip("no bundled machine file in this layout")
    result = runner.invoke(app, ["compensate", str(_pocket(tmp_path / "p.src", 900, 1100)), "--model", str(toml), "-o", str(tmp_path / "o"), "--allow-extrapolation"])
    assert result.exit_code == 2, result.output
    assert "--allow-extrapolation" in result.output and "never extrapolated" in result.output


# ------------------------------------------------------------------ --report


def test_report_page_shows_path_error_margins_and_region(measured, tmp_path):
    _, _, model = measured
    program = _pocket(tmp_path / "p.src", 900, 1100)
    page = tmp_path / "page.html"
    result = runner.invoke(app, ["compensate", str(program), "--model", str(model), "-o", str(tmp_path / "o.src"), "--report", str(page)])
    assert result.exit_code == 0, result.output
    text = page.read_text()
    assert text.count("data:image/png;base64,") == 5
    for words in ("Programmed path", "Predicted 3-D error at each target", "Margins at the compensated targets", "The region the model was measured in",
                  "model for kr160_r1570"):  # the captions of the five figures
        assert words in text, words
    as_json = tmp_path / "points.json"
    runner.invoke(app, ["compensate", str(program), "--model", str(model), "-o", str(tmp_path / "o2.src"), "--report", str(as_json)])
    summary = json.loads(as_json.read_text())["summary"]
    assert summary["model"]["robot"] == KR160 and summary["model"]["region"]["poses"] == 120


def test_report_page_lists_the_targets_outside(measured, tmp_path):
    _, _, model = measured
    program = _pocket(tmp_path / "p.src", 1300, 1400)
    page = tmp_path / "page.html"
    result = runner.invoke(app, ["compensate", str(program), "--model", str(model), "-o", str(tmp_path / "o.src"), "--report", str(page)])
    assert result.exit_code == 1
    text = page.read_text()
    assert "Targets that cannot be compensated" in text and "outside the region the model was measured in" in text


# ------------------------------------------------------------------ the region itself


def _cube_coverage(poses: int = 1000) -> Coverage:
    corners = np.array([[x, y, z] for x in (0.0, 100.0) for y in (0.0, 100.0) for z in (0.0, 100.0)]) + [1000.0, 0.0, 500.0]
    return Coverage(poses, np.full(6, -10.0), np.full(6, 10.0), (1000.0, 1105.0), (500.0, 600.0), corners)


def test_hull_distance_and_tolerances():
    cube = _cube_coverage()
    inside, beyond_face = [1050.0, 50.0, 550.0], [1050.0, 50.0, 625.0]
    np.testing.assert_allclose(cube.hull_excess(np.array([inside, beyond_face])), [0.0, 25.0], atol=1e-9)
    assert cube.hull_tolerance_mm == 10.0  # (1e6 mm^3 / 1000 poses)^(1/3) = 10 mm
    assert _cube_coverage(poses=8).hull_tolerance_mm == pytest.approx(50.0)  # sparser poses: one spacing
    # Joints: 5 % of the 20-deg range is 1 deg: 10.9 is inside, 11.5 outside.
    q = np.zeros((2, 6))
    q[:, 1] = [10.9, 11.5]
    out = cube.outside(q, np.array([inside, inside]))
    assert out.mask.tolist() == [False, True] and int(out.joint[1]) == 1
    assert "q2 is 1.5 deg beyond the fitted range [-10.0, 10.0]" in out.reason(1, cube)
    far = cube.outside(np.zeros((1, 6)), np.array([[1050.0, 50.0, 700.0]]))
    assert far.mask.tolist() == [True] and "100 mm outside the measured region" in far.reason(0, cube)


def test_flat_poses_fall_back_on_the_radius_and_z_ranges():
    robot = postproc.load_robot(KR160)
    q = np.zeros((20, 6))
    q[:, 0] = np.linspace(-20, 20, 20)  # joint 1 alone: the TCP sweeps a horizontal arc
    cov = Coverage.of(robot, TOOL, q)
    assert cov.hull_vertices_mm is None
    r = np.mean(cov.radius_mm)
    assert cov.hull_excess(np.array([[r, 0.0, cov.z_mm[0]], [r, 0.0, cov.z_mm[1] + 40.0]])).tolist() == pytest.approx([0.0, 40.0])


def test_region_round_trips_through_the_model_file(measured):
    _, _, model_path = measured
    model, doc = load_model(model_path)
    again = Coverage.from_document(json.loads(json.dumps(model.coverage.to_document())), "x")
    np.testing.assert_allclose(again.hull_vertices_mm, model.coverage.hull_vertices_mm, atol=0.01)
    assert again.poses == model.coverage.poses and again.z_mm == pytest.approx(model.coverage.z_mm, abs=1e-3)
