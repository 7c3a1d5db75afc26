"""Measurement CSV reading: the shared sets load; every bad input names file, line and column."""

from __future__ import annotations

import os

import numpy as np
import pytest

from postproc.errors import MeasurementError
from postproc.model.measurements import MeasurementSet, parse_measurements, read_measurements, write_measurements

HEADER = "id,q1,q2,q3,q4,q5,q6,mx,my,mz"
ROWS = [
    "1,10.0,-5.0,3.0,0.0,45.0,0.0,1000.0,20.0,500.0",
    "2,11.0,-4.0,2.0,1.0,44.0,1.0,1001.0,21.0,501.0",
    "3,12.0,-3.0,1.0,2.0,43.0,2.0,1002.0,22.0,502.0",
    "4,13.0,-2.0,0.0,3.0,42.0,3.0,1003.0,23.0,503.0",
    "5,14.0,-1.0,-1.0,4.0,41.0,4.0,1004.0,24.0,504.0",
]


def make(header=HEADER, rows=ROWS):
    return "\n".join([header] + rows) + "\n"


def test_shared_kr160_sets_load_with_all_optional_groups(shared):
    for name in ("kr160_dev_a_train", "kr160_dev_b_val"):
        meas = read_measurements(shared / "data" / f"{name}.csv")
        assert meas.q_deg.shape[1] == 6 and meas.measured_mm.shape[1] == 3
        assert meas.has("approach") and meas.has("temp") and meas.has("t") and meas.has("nominal")
    assert read_measurements(shared / "data" / "kr160_dev_b_train.csv").has("force")
    assert not read_measurements(shared / "data" / "kr160_dev_a_train.csv").has("force")


def test_extra_columns_are_kept_and_ignored():
    text = make(HEADER + ",operator", [r + ",7" for r in ROWS])
    meas = parse_measurements(text, "x.csv")
    assert meas.extra["operator"].tolist() == [7.0] * 5


@pytest.mark.parametrize(
    ("header", "rows", "line", "column", "message"),
    [
        ("id,q1,q2,q3,q4,q5,mx,my,mz", [r.rsplit(",", 4)[0] + "," + r.rsplit(",", 3)[1] + "," + r.rsplit(",", 2)[1] + "," + r.rsplit(",", 1)[1] for r in ROWS], 1, "q6", "required column missing"),
        (HEADER, ROWS[:2] + ["3,12.0,-3.0,abc,2.0,43.0,2.0,1002.0,22.0,502.0"] + ROWS[3:], 4, "q3", "not a number: 'abc'"),
        (HEADER, ROWS[:1] + ["2,11.0,-4.0,2.0,1.0,44.0,1.0,nan,21.0,501.0"] + ROWS[2:], 3, "mx", "not a finite number"),
        (HEADER, ROWS[:1] + ["2,11.0,-4.0,2.0,1.0,44.0,1.0,,21.0,501.0"] + ROWS[2:], 3, "mx", "not a number: ''"),
        (HEADER, ROWS[:3] + ["2,13.0,-2.0,0.0,3.0,42.0,3.0,1003.0,23.0,503.0"] + ROWS[4:], 5, "id", "duplicate id '2' (first on line 3)"),
        (HEADER, [r.rsplit(",", 3)[0] + ",1.0,0.02,0.5" for r in ROWS], 2, None, "look like metres"),
        (HEADER, ["%d,0.1,-0.1,0.2,0.0,0.7,0.0,1000.0,20.0,500.0" % i for i in range(1, 6)], None, "q1", "radians"),
        (HEADER.replace(",", ";"), [r.replace(",", ";") for r in ROWS], 1, None, "not comma-separated"),
        (HEADER + ",fx,fy", [r + ",1,2" for r in ROWS], 1, "fz", "incomplete column group"),
        (HEADER + ",s1,s2,s3,s4,s5,s6", [r + ",1,1,1,0,1,1" for r in ROWS], 2, "s4", "+1 or -1"),
        (HEADER, ROWS[:1] + ["2,11.0,-4.0,2.0,1.0,44.0,1.0,1001.0,21.0"] + ROWS[2:], 3, None, "9 cells, the header has 10"),
        (HEADER + ",q1", [r + ",1" for r in ROWS], 1, "q1", "column appears twice"),
        (HEADER, [], 2, None, "no data rows"),
    ],
)
def test_bad_input_names_line_and_column(header, rows, line, column, message):
    with pytest.raises(MeasurementError) as info:
        parse_measurements(make(header, rows), "meas.csv")
    err = info.value
    assert message in str(err)
    assert str(err).startswith("meas.csv")
    if line is not None:
        assert err.line == line
    if column is not None:
        assert err.column == column


def test_decimal_comma_hint():
    rows = ROWS[:1] + ['2,"11,5",-4.0,2.0,1.0,44.0,1.0,1001.0,21.0,501.0'] + ROWS[2:]
    with pytest.raises(MeasurementError, match="decimal mark"):
        parse_measurements(make(rows=rows), "m.csv")


def test_missing_file_and_non_utf8(tmp_path):
    with pytest.raises(MeasurementError, match="cannot read"):
        read_measurements(tmp_path / "absent.csv")
    bad = tmp_path / "latin.csv"
    bad.write_bytes(make().encode() + "7,1,1,1,1,1,1,1000,1,\xe9\n".encode("latin-1"))
    with pytest.raises(MeasurementError, match="line 7.*not UTF-8"):
        read_measurements(bad)


def test_write_read_round_trip(tmp_path):
    rng = np.random.default_rng(0)
    n = 12
    meas = MeasurementSet(
        q_deg=rng.uniform(-90, 90, (n, 6)),
        measured_mm=rng.uniform(-1500, 1500, (n, 3)),
        ids=tuple(f"p{i}" for i in range(n)),
        nominal_mm=rng.uniform(-1500, 1500, (n, 3)),
        force_n=rng.normal(0, 100, (n, 3)),
        approach=rng.choice([-1.0, 1.0], (n, 6)),
        temp_c=rng.uniform(19, 23, n),
        time_s=np.arange(n) * 30.0,
    )
    path = tmp_path / "out.csv"
    write_measurements(path, meas)
    back = read_measurements(path)
    assert back.ids == meas.ids
    np.testing.assert_allclose(back.q_deg, meas.q_deg, atol=1e-6)
    np.testing.assert_allclose(back.measured_mm, meas.measured_mm, atol=1e-4)
    np.testing.assert_array_equal(back.approach, meas.approach)
    np.testing.assert_allclose(back.force_n, meas.force_n, atol=1e-4)
    assert not list(tmp_path.glob(".out.csv.*"))  # no temp file left behind


def test_atomic_write_errors_are_typed_and_modes_are_ordinary(tmp_path):
    from postproc.errors import OutputError
    from postproc.model.measurements import write_text_atomic

    with pytest.raises(OutputError, match=r"missing/x\.txt: cannot write"):
        write_text_atomic(tmp_path / "missing" / "x.txt", "a")
    with pytest.raises(OutputError, match="cannot write"):
        write_text_atomic(tmp_path, "a")  # a folder, not a file
    assert [p.name for p in tmp_path.iterdir()] == []  # no temp file left behind

    new = tmp_path / "new.txt"
    write_text_atomic(new, "a")
    mask = os.umask(0o022)
    os.umask(mask)
    assert new.stat().st_mode & 0o777 == 0o666 & ~mask  # as open() would create it, not mkstemp's 0600
    kept = tmp_path / "kept.txt"
    kept.write_text("old")
    kept.chmod(0o640)
    write_text_atomic(kept, "new")
    assert kept.read_text() == "new" and kept.stat().st_mode & 0o777 == 0o640
