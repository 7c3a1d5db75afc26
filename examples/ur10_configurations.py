"""Series B: the same probe pose reached in two arm configurations. What differs, and what could carry it.

Data: data/ur10_ipa (Landgraf et al., CASE 2021). Series B reaches each of its 738 goal
poses in two joint configurations (elbow up and elbow down) one right after the other.
Model: the catalog's physics (geometry, base frame, tool offset, joint compliance) fitted
on all of Series B, i.e. the best this model can do on B. Prints:

1. the split of its residual into the part both configurations share (the pair mean) and
   the part that differs (half the pair difference), against the repeatability (the same
   joints measured twice);
2. what the two configurations share: joints 1, 5, 6, the probe's orientation to the
   tracker and the moment of measurement (consecutive rows); what differs: joints 2, 3, 4
   and the gravity torques;
3. how much of the difference each candidate variable explains (least squares, in
   sample, so an upper bound): gravity torques and their sign (load reversal across the
   gear's lost motion), the tracker direction; joint-angle errors of every joint at every
   order 1..259 (through the Jacobian; strain-wave gears put their kinematic error at
   orders 1, 2 and twice the gear ratio: Ghorbel et al. 2001);
4. what the common part follows: the tracker direction and the probe's orientation;
5. elbow-configuration-dependent geometry: one physics model per elbow configuration,
   fitted on half of the commanded positions and scored on the other half.

Figure (``OUT/ur10_configurations.png``): the joint-angle spectrum of the residual, and the
pair difference against the gravity-torque change of joint 3 before (catalog physics) and
after adding the best catalog candidate (joint_harmonics, terms chosen by the fit).

Run: .venv/bin/python examples/ur10_configurations.py OUT [path/to/ur10_ipa]   (about 1 min)
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import postproc  # noqa: E402
from postproc.model.effects import parse_effects  # noqa: E402
from postproc.model.formats.ur10_ipa import read_series  # noqa: E402
from postproc.model.identify import fit, residuals  # noqa: E402
from postproc.model.validate import every_kth_group  # noqa: E402
from postproc.robot.kinematics import gravity_torque, jacobian  # noqa: E402

PHYSICS = "geometric,base_frame,tool_offset,joint_compliance"
MAX_ORDER = 259


def rms(vectors: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.sum(vectors**2, axis=-1))))


def explained(features: np.ndarray, target: np.ndarray) -> float:
    """Share of the target's variance (all three axes) a least-squares fit on the features explains."""
    design = np.column_stack([features, np.ones(len(features))])
    coef, *_ = np.linalg.lstsq(design, target, rcond=None)
    left = target - design @ coef
    return float(1.0 - np.sum(left**2) / np.sum((target - target.mean(axis=0)) ** 2))


def configuration_pairs(meas) -> tuple[np.ndarray, np.ndarray]:
    """(first, second) rows of each goal pose reached in two different joint configurations."""
    order = np.argsort(meas.extra["pose"], kind="stable")
    pose = meas.extra["pose"][order]
    same = pose[1:] == pose[:-1]
    first, second = order[:-1][same], order[1:][same]
    differ = np.abs(meas.q_deg[first] - meas.q_deg[second]).max(axis=1) > 1.0
    return first[differ], second[differ]


def repeat_pairs(meas) -> tuple[np.ndarray, np.ndarray]:
    """Rows with the same joints (to 0.1 deg): the same configuration measured twice."""
    _, inverse, counts = np.unique(np.round(meas.q_deg, 1), axis=0, return_inverse=True, return_counts=True)
    inverse = inverse.ravel()
    order = np.argsort(inverse, kind="stable")
    same = inverse[order][1:] == inverse[order][:-1]
    return order[:-1][same], order[1:][same]


def joint_spectrum(resid: np.ndarray, jac: np.ndarray, q_rad: np.ndarray) -> np.ndarray:
    """(6, MAX_ORDER): share of the residual a joint error a sin(k q_j) + b cos(k q_j) explains."""
    target = resid.reshape(-1)
    total = float(np.sum(target**2))
    out = np.zeros((6, MAX_ORDER))
    for j in range(6):
        for k in range(1, MAX_ORDER + 1):
            design = np.stack([jac[:, :, j] * np.sin(k * q_rad[:, j])[:, None], jac[:, :, j] * np.cos(k * q_rad[:, j])[:, None]], axis=-1).reshape(-1, 2)
            coef, *_ = np.linalg.lstsq(design, target, rcond=None)
            out[j, k - 1] = 1.0 - np.sum((target - design @ coef) ** 2) / total
    return out


def tracker_direction(points_mm: np.ndarray) -> np.ndarray:
    azimuth = np.arctan2(points_mm[:, 1], points_mm[:, 0])
    elevation = np.arctan2(points_mm[:, 2], np.hypot(points_mm[:, 0], points_mm[:, 1]))
    return np.column_stack([np.sin(azimuth), np.cos(azimuth), np.sin(elevation), np.cos(elevation), np.linalg.norm(points_mm, axis=1)])


def main() -> None:
    out = Path(sys.argv[1])
    root = Path(sys.argv[2]) if len(sys.argv) > 2 else Path(os.environ.get("POSTPROC_SHARED", Path(__file__).resolve().parents[2] / "shared")) / "data" / "ur10_ipa"
    out.mkdir(parents=True, exist_ok=True)
    robot = postproc.load_robot("ur10")
    meas, tool = read_series(root / "Series_B")
    model = fit(robot, tool, parse_effects(PHYSICS), meas, cv_folds=0).model
    resid = residuals(model, meas)
    first, second = configuration_pairs(meas)
    rep_a, rep_b = repeat_pairs(meas)
    common, differ = (resid[first] + resid[second]) / 2, (resid[first] - resid[second]) / 2
    repeat = np.linalg.norm(resid[rep_a] - resid[rep_b], axis=1)
    print(f"1. Series B, {PHYSICS} fitted on all {len(meas)} poses: mean {np.linalg.norm(resid, axis=1).mean():.3f} mm, RMS {rms(resid):.3f} mm")
    print(f"   {len(first)} goal poses in two configurations: common part RMS {rms(common):.3f} mm, half the difference RMS {rms(differ):.3f} mm")
    print(f"   {len(rep_a)} configurations measured twice: residual difference median {np.median(repeat):.3f} mm (p90 {np.percentile(repeat, 90):.3f})")

    dq = meas.q_deg[first] - meas.q_deg[second]
    probe = np.column_stack([meas.extra[f"probe_{a}"] for a in ("rx", "ry", "rz")])
    turn = np.abs((probe[first] - probe[second] + 180.0) % 360.0 - 180.0)
    elbow_flip = np.mean(np.sign(meas.q_deg[first, 2]) != np.sign(meas.q_deg[second, 2]))
    print("2. within a pair: joints that differ by more than 5 deg (count per joint 1..6):", (np.abs(dq) > 5).sum(axis=0).tolist(),
          f"; elbow sign flips in {elbow_flip:.0%}")
    print(f"   probe orientation to the tracker differs by at most {turn.max():.2f} deg; rows apart: {np.unique(np.abs(second - first)).tolist()}")

    tau = gravity_torque(robot, meas.q_deg)
    candidates = {
        "gravity torques (linear)": tau[first] - tau[second],
        "sign of the gravity torques (load reversal)": np.sign(tau[first]) - np.sign(tau[second]),
        "joint angles (linear)": dq,
        "workspace position (tracker azimuth, elevation, range)": tracker_direction(meas.measured_mm[first]),
    }
    q_rad = np.radians(meas.q_deg)
    harmonics = np.column_stack([f(k * q_rad[:, 1:4]) for k in (1, 2, 3, 4) for f in (np.sin, np.cos)])
    candidates["sin/cos orders 1-4 of joints 2-4"] = harmonics[first] - harmonics[second]
    print("3. share of the pair difference each candidate explains (least squares in sample: an upper bound)")
    for name, features in candidates.items():
        print(f"   {name:48s} {explained(features, differ):6.1%}  ({features.shape[1]} columns)")
    jac = jacobian(robot, meas.q_deg, tool)[:, :3, :]
    spectrum = joint_spectrum(resid, jac, q_rad)
    for j in range(6):
        k = int(np.argmax(spectrum[j]))
        print(f"   joint {j + 1} angle error at one order: largest share {spectrum[j, k]:.1%} at order {k + 1}, median over orders 1..{MAX_ORDER} {np.median(spectrum[j]):.2%}")
    print("4. share of the common part explained by")
    print(f"   the tracker direction {explained(tracker_direction(meas.measured_mm[first]), common):.1%}; "
          f"the probe orientation (sin/cos of rx, ry, rz) {explained(np.column_stack([np.sin(np.radians(probe[first])), np.cos(np.radians(probe[first]))]), common):.1%}")

    better = fit(robot, tool, parse_effects(PHYSICS + ",joint_harmonics"), meas, cv_folds=0).model
    resid_after = residuals(better, meas)
    differ_after = (resid_after[first] - resid_after[second]) / 2
    print(f"   best catalog candidate {better.effects.spec()}: half the difference RMS {rms(differ):.3f} -> {rms(differ_after):.3f} mm, "
          f"common part {rms(common):.3f} -> {rms((resid_after[first] + resid_after[second]) / 2):.3f} mm (fitted on all of B)")
    test = every_kth_group(meas.extra["point"].astype(int), 2)  # half the commanded positions, as validate --every 2
    up = meas.q_deg[:, 2] > 0
    split = [np.linalg.norm(residuals(fit(robot, tool, parse_effects(PHYSICS), meas.subset(c & ~test), cv_folds=0).model, meas.subset(c & test)), axis=1)
             for c in (up, ~up)]
    shared = np.linalg.norm(residuals(fit(robot, tool, parse_effects(PHYSICS), meas.subset(~test), cv_folds=0).model, meas.subset(test)), axis=1)
    print("5. elbow-configuration-dependent geometry: the physics fitted on half of B's commanded positions, scored on the other half:")
    print(f"   one model for both configurations mean {shared.mean():.3f} mm; one model per elbow configuration mean {np.concatenate(split).mean():.3f} mm")
    figure(out / "ur10_configurations.png", spectrum, tau[first, 2] - tau[second, 2], differ, differ_after, better.effects.spec())
    print(f"figure: {out / 'ur10_configurations.png'}")


def figure(path: Path, spectrum: np.ndarray, dtau3: np.ndarray, differ: np.ndarray, differ_after: np.ndarray, after_label: str) -> None:
    fig, (left, right) = plt.subplots(1, 2, figsize=(13, 5))
    orders = np.arange(1, spectrum.shape[1] + 1)
    for j in range(6):
        left.plot(orders, 100 * spectrum[j], lw=0.9, label=f"joint {j + 1}")
    left.set_xlabel("harmonic order k of the joint angle (cycles per revolution)")
    left.set_ylabel("share of the residual explained, %")
    left.set_title("Series B: one joint error a sin(kq) + b cos(kq) per order")
    left.legend()
    right.scatter(dtau3, 2 * np.linalg.norm(differ, axis=1), s=7, alpha=0.6, label="catalog physics (fitted on B)")
    right.scatter(dtau3, 2 * np.linalg.norm(differ_after, axis=1), s=7, alpha=0.6, label="+ joint_harmonics chosen by the fit")
    right.set_xlabel("gravity-torque change of joint 3 between the two configurations, N m")
    right.set_ylabel("residual difference between the configurations, mm")
    right.set_title("Same probe pose, elbow up vs elbow down")
    right.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    main()
