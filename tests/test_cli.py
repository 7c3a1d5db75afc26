"""The command line: version, working commands, exit codes of spec/cli.md."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest
from typer.testing import CliRunner

import postproc
from postproc.cli import app

runner = CliRunner()


def test_version():
    result = runner.invoke(app, ["--version"])
    assert result.exit_code == 0
    assert result.output.strip() == f"postproc {postproc.__version__}"


def test_console_script_is_installed():
    proc = subprocess.run([sys.executable, "-m", "postproc.cli", "--version"], capture_output=True, text=True)
    assert proc.returncode == 0 and "postproc" in proc.stdout


@pytest.mark.parametrize("command", ["fit", "evaluate", "diagnose", "compensate", "inspect", "roundtrip", "simulate", "ladder", "import-ur10", "similarity", "convert"])
def test_scripted_interface_commands_are_registered(command):
    result = runner.invoke(app, [command, "--help"])
    assert result.exit_code == 0, result.output


def test_robots_json_lists_every_bundled_robot():
    result = runner.invoke(app, ["robots", "--json"])
    assert result.exit_code == 0
    names = {r["name"] for r in json.loads(result.stdout)["robots"]}
    assert names == set(postproc.available_robots())


def test_fk_home_pose_json():
    result = runner.invoke(app, ["fk", "kr160_r1570", "--q", "0,0,0,0,0,0", "--json"])
    assert result.exit_code == 0
    xyz = json.loads(result.stdout)["xyz"]
    assert xyz == pytest.approx([1175.0, 0.0, 1040.0], abs=1e-9)


def test_ik_returns_the_fk_configuration():
    q = [10.0, -20.0, 15.0, 30.0, 45.0, -60.0]
    fk = json.loads(runner.invoke(app, ["fk", "kr160_r1570", "--q", ",".join(map(str, q)), "--json"]).stdout)
    result = runner.invoke(
        app, ["ik", "kr160_r1570", "--xyz", ",".join(map(str, fk["xyz"])), "--abc", ",".join(map(str, fk["abc"])), "--json"]
    )
    assert result.exit_code == 0
    sols = [s["q"] for s in json.loads(result.stdout)["solutions"] if s["q"] is not None]
    assert any(max(abs(a - b) for a, b in zip(s, q)) < 1e-6 for s in sols)


def test_ik_unreachable_exits_1():
    result = runner.invoke(app, ["ik", "kr160_r1570", "--xyz", "9000,0,0"])
    assert result.exit_code == 1
    assert "no solution" in result.stderr


def test_unknown_robot_exits_2_with_message():
    result = runner.invoke(app, ["fk", "no_such_robot", "--q", "0,0,0,0,0,0"])
    assert result.exit_code == 2
    assert "unknown robot 'no_such_robot'" in result.stderr


def test_malformed_numbers_exit_2():
    result = runner.invoke(app, ["fk", "kr160_r1570", "--q", "0,0,zero,0,0,0"])
    assert result.exit_code == 2
    assert "--q" in result.stderr


def test_bad_robot_file_exits_2_naming_file_and_key(tmp_path):
    bad = tmp_path / "broken.toml"
    bad.write_text('name = "broken"\n')
    result = runner.invoke(app, ["fk", str(bad), "--q", "0,0,0,0,0,0"])
    assert result.exit_code == 2
    assert "broken.toml" in result.stderr and "'description'" in result.stderr


@pytest.mark.parametrize("spec", ["joint_harmonics", "joint_harmonics[max_order=60]"])
def test_simulate_refuses_terms_left_to_a_fit_and_says_how_to_name_them(spec, tmp_path):
    out = runner.invoke(app, ["simulate", "--robot", "kr160_r1570", "--tool", "0,0,200", "--effects", spec, "--n", "5", "-o", str(tmp_path / "m.csv")])
    assert out.exit_code == 2
    assert "leaves its terms to a fit" in out.output and "name the terms" in out.output, out.output
    assert not (tmp_path / "m.csv").exists()
