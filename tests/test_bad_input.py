"""Bad input everywhere (issue 13): a clear message naming file and line/row and column,
exit 2, no traceback and no output file written or changed."""

from __future__ import annotations

import shutil

import pytest
from typer.testing import CliRunner

from postproc.cli import app

runner = CliRunner()


@pytest.fixture(scope="module")
def val_csv(shared):
    return shared / "data" / "kr160_dev_a_val.csv"


@pytest.fixture(scope="module")
def model_json(tmp_path_factory, val_csv):
    path = tmp_path_factory.mktemp("model") / "m.json"
    result = runner.invoke(app, ["fit", str(val_csv), "--robot", "kr160_r1570", "--tool", "0,0,200", "--effects", "base_frame", "--cv", "0", "-o", str(path)])
    assert result.exit_code == 0, result.output
    return path


def _fails_cleanly(args, *needles):
    result = runner.invoke(app, args)
    assert result.exit_code == 2, result.output
    assert result.exception is None or isinstance(result.exception, SystemExit), repr(result.exception)
    for needle in needles:
        assert needle in result.output, result.output
    return result


def test_binary_model_file(tmp_path, val_csv):
    bad = tmp_path / "bad.json"
    bad.write_bytes(bytes(range(256)) * 2)
    _fails_cleanly(["evaluate", str(bad), str(val_csv), "--json"], str(bad), "not UTF-8")


def test_truncated_model_file(tmp_path, val_csv, model_json):
    cut = tmp_path / "cut.json"
    cut.write_bytes(model_json.read_bytes()[:200])
    _fails_cleanly(["evaluate", str(cut), str(val_csv), "--json"], str(cut), "line", "column")


def test_binary_robot_file(tmp_path, val_csv):
    bad = tmp_path / "robot.toml"
    bad.write_bytes(b"\xff\xfe\x00\x01" * 40)
    out = tmp_path / "m.json"
    _fails_cleanly(["fit", str(val_csv), "--robot", str(bad), "--tool", "0,0,200", "--effects", "base_frame", "-o", str(out)], str(bad), "not UTF-8")
    assert not out.exists()


def _edited_csv(src, dst, row, column, value):
    lines = src.read_text().splitlines()
    header = lines[0].split(",")
    cells = lines[row].split(",")
    cells[header.index(column)] = value
    lines[row] = ",".join(cells)
    dst.write_text("\n".join(lines) + "\n")
    return dst


@pytest.fixture(scope="module")
def verified_robot(tmp_path_factory):
    """The KR160 file with its limits marked verified and wide enough for the shared sets,
    so that only the row edited below lies outside them."""
    import postproc

    text = (postproc.robot.robots.resources.files("postproc.robot_files") / "kr160_r1570.toml").read_text()
    start = text.index("[limits]")
    end = text.index("\n[", start + 1) + 1
    limits = '[limits]\nsource = "test"\nestimate = false\nlower = [-185.0, -160.0, -170.0, -350.0, -180.0, -350.0]\nupper = [185.0, 60.0, 170.0, 350.0, 180.0, 350.0]\n\n'
    path = tmp_path_factory.mktemp("robot") / "kr160_r1570.toml"
    path.write_text(text[:start] + limits + text[end:])
    return path


def test_joint_beyond_limits_names_line_and_column(tmp_path, val_csv, verified_robot):
    bad = _edited_csv(val_csv, tmp_path / "m.csv", 7, "q3", "171")
    out = tmp_path / "m.json"
    _fails_cleanly(["fit", str(bad), "--robot", str(verified_robot), "--tool", "0,0,200", "--effects", "base_frame", "-o", str(out)],
                   str(bad), "line 8", "'q3'", "outside the robot's limits")
    assert not out.exists()


def test_drop_invalid_lists_the_dropped_rows(tmp_path, val_csv, verified_robot):
    bad = _edited_csv(val_csv, tmp_path / "m.csv", 7, "q3", "171")
    out = tmp_path / "m.json"
    result = runner.invoke(app, ["fit", str(bad), "--robot", str(verified_robot), "--tool", "0,0,200", "--effects", "base_frame",
                                 "--cv", "0", "-o", str(out), "--drop-invalid"])
    assert result.exit_code == 0, result.output
    assert "dropped:" in result.output and "line 8" in result.output and "q3 = 171" in result.output
    assert out.exists()


def test_estimated_limits_warn_and_keep_the_rows(tmp_path, val_csv, model_json):
    """Every bundled robot's limits are marked estimates: rows beyond them are listed, not refused."""
    bad = _edited_csv(val_csv, tmp_path / "m.csv", 7, "q3", "171")
    result = runner.invoke(app, ["evaluate", str(model_json), str(bad), "--json"])
    assert result.exit_code == 0, result.output
    assert "warning:" in result.output and "estimates" in result.output
    n_rows = len(val_csv.read_text().splitlines()) - 1
    assert f'"n": {n_rows}' in result.stdout


def test_absurd_position_names_line_and_column(tmp_path, val_csv, model_json):
    bad = _edited_csv(val_csv, tmp_path / "m.csv", 4, "my", "25000.0")
    _fails_cleanly(["evaluate", str(model_json), str(bad), "--json"], str(bad), "line 5", "'my'", "10 m")


def test_duplicated_id_names_line(tmp_path, val_csv, model_json):
    lines = val_csv.read_text().splitlines()
    dup = tmp_path / "dup.csv"
    dup.write_text("\n".join(lines + [lines[3]]) + "\n")
    _fails_cleanly(["evaluate", str(model_json), str(dup), "--json"], str(dup), f"line {len(lines) + 1}", "'id'", "duplicate id")


def test_reregister_needs_enough_rows(tmp_path, val_csv, model_json):
    lines = val_csv.read_text().splitlines()
    few = tmp_path / "few.csv"
    few.write_text("\n".join(lines[:5]) + "\n")
    _fails_cleanly(["evaluate", str(model_json), str(few), "--reregister"], str(few), "6-DOF", "at least")


def test_ladder_plot_to_missing_folder_fails_before_work(tmp_path, val_csv):
    target = tmp_path / "nowhere" / "ladder.png"
    _fails_cleanly(["ladder", str(val_csv), "--robot", "kr160_r1570", "--tool", "0,0,200", "--effects", "base_frame", "--plot", str(target)],
                   "--plot", "does not exist")
    assert not target.parent.exists()


def test_diagnose_report_to_missing_folder_fails_before_work(tmp_path, val_csv, model_json):
    target = tmp_path / "nowhere" / "r.html"
    _fails_cleanly(["diagnose", str(model_json), str(val_csv), "--report", str(target)], "--report", "does not exist")


def test_no_stray_temp_files(tmp_path, val_csv, model_json):
    work = tmp_path / "work"
    work.mkdir()
    shutil.copy(model_json, work / "m.json")
    runner.invoke(app, ["ladder", str(val_csv), "--robot", "kr160_r1570", "--tool", "0,0,200", "--effects", "base_frame", "--plot", str(work / "l.png")])
    assert sorted(p.name for p in work.iterdir()) == ["l.png", "m.json"]
