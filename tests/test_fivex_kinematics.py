"""Five-axis machine files and kinematics: LinuxCNC's trt formulas, IK branches, the pole, limits."""

from __future__ import annotations

import numpy as np
import pytest

from postproc.errors import InputError
from postproc.fivex.errors import MachineFileError
from postproc.fivex.kinematics import fk, ik, rotary_solutions
from postproc.fivex.machine import available_machines, load_machine, machine_toml, parse_machine_toml
from postproc.fivex.simulate import perturbed

MACHINES = ("xyzac-trt", "xyzbc-trt")  # table-table; the head-head xyzbc-5axiskins is tested below


def linuxcnc_forward(name: str, joints: np.ndarray) -> np.ndarray:
    """trtfuncs.c xyz{a,b}cKinematicsForward with the demo ini's offsets, tool offset 0
    (re-derived here: workpiece = Rz(-c) (R(-tilt) (joints - offsets) + offsets), rot point 0)."""
    t, c = np.radians(joints[:, 3]), np.radians(joints[:, 4])
    if name == "xyzac-trt":
        d = np.array([0.0, 20.0, 10.0])
        v = joints[:, :3] - d
        w = np.stack([v[:, 0], np.cos(t) * v[:, 1] + np.sin(t) * v[:, 2], -np.sin(t) * v[:, 1] + np.cos(t) * v[:, 2]], axis=1) + d
    else:
        d = np.array([-20.0, 0.0, -15.0])
        v = joints[:, :3] - d
        w = np.stack([np.cos(t) * v[:, 0] - np.sin(t) * v[:, 2], v[:, 1], np.sin(t) * v[:, 0] + np.cos(t) * v[:, 2]], axis=1) + d
    return np.stack([np.cos(c) * w[:, 0] + np.sin(c) * w[:, 1], -np.sin(c) * w[:, 0] + np.cos(c) * w[:, 1], w[:, 2]], axis=1)


def random_axes(machine, n, rng):
    lo = np.r_[machine.linear_limits[:, 0] * 0.3, machine.rotary[0].limits[0], -180.0]
    hi = np.r_[machine.linear_limits[:, 1] * 0.3, machine.rotary[0].limits[1], 180.0]
    return rng.uniform(lo, hi, (n, 5))


def test_bundled_machines_load_and_cite_sources():
    assert set(MACHINES) <= set(available_machines())
    for name in MACHINES:
        m = load_machine(name)
        assert m.name == name and "LinuxCNC" in m.sources["geometry"] and "GPL" in m.sources["geometry"]


@pytest.mark.parametrize("name", MACHINES)
def test_fk_equals_linuxcnc_trt_kinematics(name):
    m = load_machine(name)
    joints = random_axes(m, 500, np.random.default_rng(1))
    tip, axis = fk(m, joints)
    np.testing.assert_allclose(tip, linuxcnc_forward(name, joints), atol=1e-9)
    # the tool axis (machine +Z) seen from the turned table
    np.testing.assert_allclose(np.linalg.norm(axis, axis=1), 1.0, atol=1e-12)


@pytest.mark.parametrize("name", MACHINES)
@pytest.mark.parametrize("calibrated", [False, True])
def test_ik_round_trip_both_branches(name, calibrated):
    rng = np.random.default_rng(2)
    m = load_machine(name)
    if calibrated:
        m = perturbed(m, rng, tilt_rad=(1e-3, 3e-3), offset_mm=(0.5, 1.0))
    joints = random_axes(m, 300, rng)
    tip, axis = fk(m, joints)
    cand, free = rotary_solutions(m, axis)
    assert not free.any()
    for b in range(2):  # both branches reach the same tool axis
        sol = np.c_[np.zeros((len(tip), 3)), cand[:, b]]
        _, reached = fk(m, sol)
        np.testing.assert_allclose(reached, axis, atol=1e-10)
    # one of the branches is the generating one (modulo a turn of C)
    diff = (cand - joints[:, None, 3:5] + 180.0) % 360.0 - 180.0
    assert np.all(np.min(np.abs(diff).max(axis=2), axis=1) < 1e-7)
    result = ik(m, tip, axis, start_deg=joints[0, 3:5])
    tip2, axis2 = fk(m, result.axes)
    np.testing.assert_allclose(tip2, tip, atol=1e-9)
    np.testing.assert_allclose(axis2, axis, atol=1e-10)
    assert result.reachable.all() and not result.held.any()


def test_ik_continuity_unwraps_c_and_picks_nearest_branch():
    m = load_machine("xyzac-trt")
    c = np.linspace(0.0, 720.0, 73)  # two turns of C at a constant tilt
    joints = np.c_[np.zeros((73, 3)), np.full(73, -30.0), c]
    tip, axis = fk(m, joints)
    result = ik(m, tip, axis)
    np.testing.assert_allclose(result.axes[:, 3:5], joints[:, 3:5], atol=1e-9)  # no jump to the other branch, no wrap


def test_ik_rotary_limit_excludes_a_branch():
    m = load_machine("xyzac-trt")  # A within -100..50: A = +40 is reachable, its twin A = -40 also
    joints = np.array([[0.0, 0.0, 0.0, 40.0, 10.0]])
    tip, axis = fk(m, joints)
    cand, _ = rotary_solutions(m, axis)
    assert sorted(np.round(cand[0, :, 0], 6)) == [-40.0, 40.0]
    # from a start near A = -40 the nearer branch is -40 ...
    assert ik(m, tip, axis, start_deg=(-40.0, 190.0)).axes[0, 3] == pytest.approx(-40.0)
    # ... and a tilt of 60 degrees is only reachable as A = -60 (A = +60 is beyond +50)
    joints = np.array([[0.0, 0.0, 0.0, 60.0, 0.0]])
    tip, axis = fk(m, joints)
    assert ik(m, tip, axis, start_deg=(60.0, 0.0)).axes[0, 3] == pytest.approx(-60.0)


def test_singular_pole_holds_the_rotary_angle_and_reports_it():
    m = load_machine("xyzac-trt")
    joints = np.array([[10.0, 5.0, 0.0, -20.0, 35.0], [10.0, 5.0, 0.0, 0.0, 123.0], [12.0, 5.0, 0.0, 0.0, -50.0]])
    tip, axis = fk(m, joints)  # rows 2 and 3: tool axis along C (any C gives it)
    result = ik(m, tip, axis)
    assert result.held.tolist() == [False, True, True]
    np.testing.assert_allclose(result.axes[1:, 4], 35.0)  # C kept where it was
    tip2, axis2 = fk(m, result.axes)
    np.testing.assert_allclose(tip2, tip, atol=1e-9)
    np.testing.assert_allclose(axis2, axis, atol=1e-12)


def test_linear_limits_reported_unreachable():
    m = load_machine("xyzac-trt")
    tip = np.array([[500.0, 0.0, 0.0]])
    result = ik(m, tip, np.array([[0.0, 0.0, 1.0]]))
    assert not result.reachable[0]


@pytest.mark.parametrize("edit,key", [
    (lambda t: t.replace("direction = [1.0, 0.0, 0.0]", "direction = [1.0, 0.1, 0.0]"), "rotary[0].direction"),
    (lambda t: t.replace('carrier = "table"\ndirection = [1.0', 'carrier = "head"\ndirection = [1.0'), "rotary[0].carrier"),
    (lambda t: t.replace("limits = [-100.0, 50.0]", "limits = [50.0, -100.0]"), "rotary[0].limits"),
    (lambda t: t.replace('length = "mm"', 'length = "in"'), "units.length"),
    (lambda t: t.replace("X = [-200.0, 200.0]", "X = [-200.0]"), "linear.X"),
    (lambda t: t.replace('axes = ["X", "Y", "Z", "A", "C"]', 'axes = ["X", "Y", "Z", "C", "A"]'), "machine.axes"),
    (lambda t: t + "\n[extra]\n", "extra"),
])
def test_machine_file_errors_name_file_and_key(tmp_path, edit, key):
    from importlib import resources

    text = (resources.files("postproc.machine_files") / "xyzac-trt.toml").read_text()
    bad = tmp_path / "bad.toml"
    bad.write_text(edit(text))
    with pytest.raises(MachineFileError) as exc:
        load_machine(bad)
    assert str(bad) in str(exc.value) and f"'{key}'" in str(exc.value)
    assert isinstance(exc.value, InputError)


def test_calibrated_file_round_trips():
    m = perturbed(load_machine("xyzac-trt"), np.random.default_rng(3))
    back = parse_machine_toml(machine_toml(m, "test"), "calibrated.toml")
    for a, b in zip(m.rotary, back.rotary):
        np.testing.assert_allclose(a.direction, b.direction, atol=1e-9)
        np.testing.assert_allclose(a.point, b.point, atol=1e-9)


HEAD_MACHINES = {
    "head-table": ('name = "B"\ncarrier = "head"\ndirection = [0.0, 1.0, 0.0]\npoint = [0.0, 0.0, 150.0]\nlimits = [-110.0, 110.0]',
                   'name = "C"\ncarrier = "table"\ndirection = [0.0, 0.0, 1.0]\npoint = [5.0, -3.0, 0.0]\nlimits = [-36000.0, 36000.0]'),
    "head-head": ('name = "C"\ncarrier = "head"\ndirection = [0.0, 0.0, 1.0]\npoint = [0.0, 0.0, 0.0]\nlimits = [-36000.0, 36000.0]',
                  'name = "A"\ncarrier = "head"\ndirection = [1.0, 0.0, 0.0]\npoint = [0.0, 0.0, 180.0]\nlimits = [-100.0, 100.0]'),
}


def synthetic_machine(kind: str):
    first, second = HEAD_MACHINES[kind]
    names = [first.split('"')[1], second.split('"')[1]]
    text = (f'[machine]\nname = "{kind}-test"\ndescription = "synthetic {kind} machine for tests"\nkind = "{kind}"\n'
            f'axes = ["X", "Y", "Z", "{names[0]}", "{names[1]}"]\ntool_axis = [0.0, 0.0, 1.0]\n[units]\nlength = "mm"\nangle = "deg"\n'
            '[sources]\ngeometry = "synthetic (tests)"\n[linear]\nX = [-1000.0, 1000.0]\nY = [-1000.0, 1000.0]\nZ = [-1000.0, 1000.0]\n'
            f"[[rotary]]\n{first}\n[[rotary]]\n{second}\n")
    return parse_machine_toml(text, f"{kind}-test.toml")


@pytest.mark.parametrize("kind", sorted(HEAD_MACHINES))
@pytest.mark.parametrize("tool_length", [0.0, 120.0])
def test_head_machines_round_trip(kind, tool_length):
    rng = np.random.default_rng(7)
    m = perturbed(synthetic_machine(kind), rng, tilt_rad=(1e-3, 2e-3), offset_mm=(0.2, 0.5))
    lim = np.array([ax.limits for ax in m.rotary])
    joints = np.c_[rng.uniform(-200, 200, (200, 3)), rng.uniform(np.maximum(lim[:, 0], -100), np.minimum(lim[:, 1], 100), (200, 2))]
    tip, axis = fk(m, joints, tool_length)
    result = ik(m, tip, axis, start_deg=joints[0, 3:5], tool_length=tool_length)
    tip2, axis2 = fk(m, result.axes, tool_length)
    np.testing.assert_allclose(tip2, tip, atol=1e-8)
    np.testing.assert_allclose(axis2, axis, atol=1e-10)


def test_head_head_machine_equals_linuxcnc_5axiskins():
    """5axiskins.c: tip = joints + (0, 0, L) + L (sin b cos c, sin b sin c, -cos b), L = 250."""
    m = load_machine("xyzbc-5axiskins")
    rng = np.random.default_rng(8)
    j = np.c_[rng.uniform(-300, 300, (300, 2)), rng.uniform(-300, 0, 300), rng.uniform(-180, 180, 300), rng.uniform(-110, 110, 300)]  # X Y Z C B
    b, c = np.radians(j[:, 4]), np.radians(j[:, 3])
    want = j[:, :3] + 250.0 * np.stack([np.sin(b) * np.cos(c), np.sin(b) * np.sin(c), 1.0 - np.cos(b)], axis=1)
    tip, axis = fk(m, j)
    np.testing.assert_allclose(tip, want, atol=1e-9)
    np.testing.assert_allclose(axis, np.stack([-np.sin(b) * np.cos(c), -np.sin(b) * np.sin(c), np.cos(b)], axis=1), atol=1e-12)
    result = ik(m, tip, axis, start_deg=j[0, 3:5])
    np.testing.assert_allclose(fk(m, result.axes)[0], tip, atol=1e-8)
