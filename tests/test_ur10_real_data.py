"""Real UR10 laser-tracker data (data/ur10_ipa): format handling and cross-series validation."""

from __future__ import annotations

import numpy as np
import pytest

import postproc
from postproc.errors import MeasurementError
from postproc.model.effects import parse_effects
from postproc.model.formats.ur10_ipa import read_series
from postproc.model.identify import Stats, fit, nominal_model, refit_base, residuals


@pytest.fixture(scope="module")
def series(shared):
    root = shared / "data" / "ur10_ipa"
    return {name: read_series(root / f"Series_{name}") for name in "AB"}


def test_format_is_read_in_the_shared_conventions(series):
    a, tool = series["A"]
    b, _ = series["B"]
    np.testing.assert_allclose(tool, [0.0, 0.0, 109.0], atol=1e-3)  # the T-Mac probe, 109 mm along flange z
    assert len(a) > 11000 and len(b) > 1400
    assert np.abs(a.q_deg).max() > 100  # radians became degrees
    assert a.time_s is not None and a.time_s[-1] > 86400  # measured over days
    assert (np.diff(a.time_s) >= 0).all()  # rows in measurement order, as the schema wants
    assert sorted(a.ids, key=int) == [str(i) for i in range(1, len(a) + 1)]
    assert b.time_s is None  # Series B's timestamps were mangled into one number
    assert 20 < a.temp_c.mean() < 25


def test_fit_on_one_series_validates_on_the_other(series):
    robot = postproc.load_robot("ur10")
    (a, tool), (b, _) = series["A"], series["B"]
    result = fit(robot, tool, parse_effects("geometric,base_frame,tool_offset,joint_compliance"), b, cv_folds=0)
    nominal = Stats.of(residuals(nominal_model(robot, tool, a, registered=True), a))
    fitted = Stats.of(residuals(refit_base(result.model, a), a))
    assert nominal.rms_mm > 2.5
    assert fitted.rms_mm < 0.25 * nominal.rms_mm


def test_malformed_series_names_line_and_column(tmp_path, shared):
    src = shared / "data" / "ur10_ipa" / "Series_B"
    (tmp_path / "Trafo_TM_F_init.txt").write_text((src / "Trafo_TM_F_init.txt").read_text())
    lines = (src / "measurements_joint_configurations.csv").read_text().splitlines()
    cells = lines[3].split(";")
    cells[9] = "elbow"
    lines[3] = ";".join(cells)
    (tmp_path / "measurements_x.csv").write_text("\n".join(lines) + "\n")
    with pytest.raises(MeasurementError, match="line 4, column 'elbow_joint'"):
        read_series(tmp_path)
