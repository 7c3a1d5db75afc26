"""Every example runs to completion (they are documentation that must not rot)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

EXAMPLES = sorted((Path(__file__).resolve().parents[1] / "examples").glob("*.py"))


@pytest.mark.parametrize("script", EXAMPLES, ids=lambda p: p.name)
def test_example_runs(script, tmp_path, shared):
    args = [sys.executable, str(script)]
    if script.name == "explain_loop.py":
        args.append(str(tmp_path))
    if script.name == "seed_experiments.py":
        args.append("--quick")
    if script.name == "ur10_real_data.py":
        args.append(str(shared / "data" / "ur10_ipa"))
    if script.name == "ur10_error_budget.py":
        args += [str(shared / "data" / "ur10_ipa"), "--quick"]
    if script.name == "ur10_configurations.py":
        args += [str(tmp_path), str(shared / "data" / "ur10_ipa")]
    if script.name == "ur10_ladder.py":
        args += [str(tmp_path), str(shared / "data" / "ur10_ipa"), "--quick"]
    proc = subprocess.run(args, capture_output=True, text=True, timeout=600, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert proc.stdout.strip()
    if script.name == "explain_loop.py":
        assert (tmp_path / "explain_report.html").stat().st_size > 10_000
        assert "No candidate explains the residual beyond noise" in proc.stdout
