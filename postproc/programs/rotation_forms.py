"""How languages write a target's orientation: one table of notations.

A toolpath's ``orientation_kind`` names its form. The form reads the orientation numbers the
text gives (``values[:, 3:3 + width]``, in the language's own units) into rotations and writes
rotations back as numbers of the same notation, near the numbers already there (a rotation
has several spellings in most notations: the one closest to what the program wrote is the
one a reader expects, and keeps a compensated program's numbers small changes). Parsing,
writing back and subdividing all go through this table, so a new language adds one entry
here and nothing elsewhere.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from postproc.errors import InputError
from postproc.robot.frames import abc_to_matrix, abc_to_quat_wxyz, matrix_to_abc, matrix_to_quat_wxyz, quat_wxyz_to_matrix

Numbers = np.ndarray  # (N, width) orientation numbers as the text gives them


@dataclass(frozen=True)
class RotationForm:
    """One notation. ``to_matrix`` is None where the numbers do not fix a rotation (a tool
    axis leaves the spin about it free); ``to_quat`` / ``from_quat`` are exact or faster
    variants of the matrix functions where a notation has them."""

    name: str
    width: int  # how many numbers, from values[:, 3]
    description: str
    to_matrix: Callable[[Numbers], np.ndarray] | None  # (N, width) -> (N, 3, 3)
    from_matrix: Callable[[np.ndarray, Numbers], Numbers] | None  # ((N, 3, 3), near (N, width), NaN rows: none) -> (N, width)
    to_quat: Callable[[Numbers], np.ndarray] | None = None  # (N, width) -> (N, 4) w, x, y, z
    from_quat: Callable[[np.ndarray, Numbers], Numbers] | None = None  # ((N, 4), near) -> (N, width)

    def quaternions(self, numbers: Numbers) -> np.ndarray:
        """(N, 4) unit quaternions of the rows that give all their numbers, NaN elsewhere."""
        numbers = np.asarray(numbers, dtype=float)[:, : self.width]
        out = np.full((len(numbers), 4), np.nan)
        given = ~np.isnan(numbers).any(axis=1) if self.width else np.zeros(len(numbers), bool)
        if self.to_matrix is None or not given.any():
            return out
        if self.to_quat is not None:
            out[given] = self.to_quat(numbers[given])
        else:
            out[given] = matrix_to_quat_wxyz(self.to_matrix(numbers[given]))
        return out

    def numbers(self, quat: np.ndarray, near: Numbers | None = None) -> Numbers:
        """(N, width) numbers of the rotations ``quat`` (N, 4), each spelled nearest ``near``."""
        quat = np.asarray(quat, dtype=float)
        near = _near(near, len(quat), self.width)
        if self.from_quat is not None:
            return self.from_quat(quat, near)
        return self.from_matrix(quat_wxyz_to_matrix(quat), near)

    def numbers_from_matrix(self, rot: np.ndarray, near: Numbers | None = None) -> Numbers:
        """(N, width) numbers of the rotations ``rot`` (N, 3, 3), each spelled nearest ``near``."""
        rot = np.asarray(rot, dtype=float)
        near = _near(near, len(rot), self.width)
        if self.from_matrix is not None:
            return self.from_matrix(rot, near)
        return self.from_quat(matrix_to_quat_wxyz(rot), near)


def _near(near: Numbers | None, n: int, width: int) -> Numbers:
    if near is None:
        return np.full((n, width), np.nan)
    return np.asarray(near, dtype=float)[:, :width]


def wrap_near(angles_deg: np.ndarray, near_deg: np.ndarray) -> np.ndarray:
    """``angles_deg`` moved by whole turns to within 180 degrees of ``near_deg`` (kept where near is NaN)."""
    moved = near_deg + (angles_deg - near_deg + 180.0) % 360.0 - 180.0
    return np.where(np.isnan(near_deg), angles_deg, moved)


# ----------------------------------------------------------------- the notations

def _quat_to_quat(numbers: Numbers) -> np.ndarray:
    norm = np.linalg.norm(numbers, axis=1, keepdims=True)
    return np.where(norm > 0, numbers / np.where(norm > 0, norm, 1), np.nan)


def _quat_from_quat(quat: np.ndarray, near: Numbers) -> Numbers:
    """The quaternion as given (exactly), its sign flipped where the one near points the other way."""
    flip = np.einsum("ij,ij->i", quat, np.nan_to_num(near)) < 0
    return np.where(flip[:, None], -quat, quat)


def _abc_from_matrix(rot: np.ndarray, near: Numbers) -> Numbers:
    """KUKA A, B, C; of the two triples of one rotation (B and 180 - B) the one nearest ``near``,
    each angle by whole turns nearest it; the canonical triple (B in [-90, 90]) without one."""
    abc = matrix_to_abc(rot)
    other = np.column_stack([abc[:, 0] + 180.0, 180.0 - abc[:, 1], abc[:, 2] + 180.0])
    candidates = [wrap_near(c, near) for c in (abc, other)]
    pick = np.abs(candidates[1] - near).sum(axis=1) < np.abs(candidates[0] - near).sum(axis=1)  # False where near is NaN
    return np.where(pick[:, None], candidates[1], candidates[0])


def _rotvec_to_quat(numbers: Numbers) -> np.ndarray:
    """Unit quaternions w, x, y, z of rotation vectors (radians): cos(a/2), sin(a/2) * axis.
    Written out rather than scipy's Rotation: scipy.spatial costs every command 0.3 s to import."""
    angle = np.linalg.norm(numbers, axis=1, keepdims=True)
    # sin(a/2)/a, by its series near a = 0 (1/2 - a^2/48) where the quotient loses digits
    factor = np.where(angle > 1e-6, np.sin(angle / 2) / np.where(angle > 1e-6, angle, 1.0), 0.5 - angle**2 / 48.0)
    return np.concatenate([np.cos(angle / 2), numbers * factor], axis=1)


def _matrix_to_rotvec(rot: np.ndarray) -> np.ndarray:
    """Rotation vectors (radians, angle in [0, pi]) of rotation matrices, through the quaternion (w >= 0)."""
    quat = matrix_to_quat_wxyz(rot)
    sin_half = np.linalg.norm(quat[:, 1:], axis=1, keepdims=True)
    angle = 2.0 * np.arctan2(sin_half, quat[:, :1])
    factor = np.where(sin_half > 1e-12, angle / np.where(sin_half > 1e-12, sin_half, 1.0), 2.0)
    return quat[:, 1:] * factor


def _rotvec_from_matrix(rot: np.ndarray, near: Numbers) -> Numbers:
    """Rotation vector (radians); of its spellings (the angle plus whole turns about the same
    axis, all one rotation to the controller) the one nearest ``near``, the shortest without."""
    plain = np.full((len(rot), 3), np.nan)
    some = ~np.isnan(rot).any(axis=(1, 2))  # rows without a rotation stay NaN
    if some.any():
        plain[some] = _matrix_to_rotvec(rot[some])
    angle = np.linalg.norm(plain, axis=1, keepdims=True)
    given = np.nan_to_num(near)
    # A (near) zero rotation has no axis of its own: the old numbers' axis spells it.
    near_norm = np.linalg.norm(given, axis=1, keepdims=True)
    axis = np.where(angle > 1e-12, plain / np.where(angle > 1e-12, angle, 1.0), given / np.where(near_norm > 0, near_norm, 1.0))
    turns = np.array([-2.0, -1.0, 0.0, 1.0, 2.0])
    candidates = axis[:, None, :] * (angle[:, None, :] + 2.0 * np.pi * turns[None, :, None])
    best = candidates[np.arange(len(rot)), np.argmin(np.linalg.norm(candidates - given[:, None, :], axis=2), axis=1)]
    return np.where(np.isnan(near).any(axis=1, keepdims=True), plain, best)


def _wpr_to_quat(numbers: Numbers) -> np.ndarray:
    return abc_to_quat_wxyz(numbers[:, ::-1])  # W P R about the fixed X Y Z: Rz(R) Ry(P) Rx(W), KUKA's A B C reversed


def _wpr_from_matrix(rot: np.ndarray, near: Numbers) -> Numbers:
    return _abc_from_matrix(rot, near[:, ::-1])[:, ::-1]


def _rxyz_to_matrix(numbers: Numbers) -> np.ndarray:
    """Stäubli Rx, Ry, Rz (degrees, about the moving x, y', z''): R = Rx Ry Rz, the transpose of
    KUKA's Rz(A) Ry(B) Rx(C) at A = -Rz, B = -Ry, C = -Rx."""
    return np.swapaxes(abc_to_matrix(-np.asarray(numbers, dtype=float)[:, ::-1]), -1, -2)


def _rxyz_to_quat(numbers: Numbers) -> np.ndarray:
    q = abc_to_quat_wxyz(-np.asarray(numbers, dtype=float)[:, ::-1])
    q[:, 1:] *= -1.0  # the transpose's quaternion is the conjugate
    return q


def _rxyz_from_matrix(rot: np.ndarray, near: Numbers) -> Numbers:
    """Rx, Ry, Rz of ``rot``, the triple nearest ``near`` (through KUKA's, of the transpose)."""
    near = np.asarray(near, dtype=float)
    return -_abc_from_matrix(np.swapaxes(rot, -1, -2), -near[:, ::-1])[:, ::-1] + 0.0  # + 0.0: no '-0'


def _axis_from_matrix(rot: np.ndarray, near: Numbers) -> Numbers:
    return rot[:, :, 2].copy()


FORMS: dict[str, RotationForm] = {
    form.name: form
    for form in (
        RotationForm("quat", 4, "quaternion q1..q4 = w, x, y, z (ABB RAPID)", quat_wxyz_to_matrix,
                     lambda rot, near: _quat_from_quat(matrix_to_quat_wxyz(rot), near), _quat_to_quat, _quat_from_quat),
        RotationForm("abc", 3, "A, B, C degrees: R = Rz(A) Ry(B) Rx(C) (KUKA)", abc_to_matrix, _abc_from_matrix, abc_to_quat_wxyz),
        RotationForm("wpr", 3, "W, P, R degrees about the fixed X, Y, Z: R = Rz(R) Ry(P) Rx(W) (Fanuc)",
                     lambda wpr: abc_to_matrix(wpr[:, ::-1]), _wpr_from_matrix, _wpr_to_quat),
        RotationForm("rxyz", 3, "Rx, Ry, Rz degrees about the moving axes: R = Rx Ry Rz (Stäubli VAL3)", _rxyz_to_matrix, _rxyz_from_matrix, _rxyz_to_quat),
        RotationForm("axis", 3, "tool axis i, j, k (G-code five-axis): the spin about it is free", None, _axis_from_matrix),
        RotationForm("rotvec", 3, "rotation vector rx, ry, rz, radians: axis times angle (Universal Robots URScript)",
                     lambda numbers: quat_wxyz_to_matrix(_rotvec_to_quat(numbers)), _rotvec_from_matrix, _rotvec_to_quat),
        RotationForm("none", 0, "no orientation (three-axis G-code)", None, lambda rot, near: np.zeros((len(rot), 0))),
    )
}


def form(name: str) -> RotationForm:
    """The notation called ``name`` (a toolpath's ``orientation_kind``)."""
    try:
        return FORMS[name]
    except KeyError:
        raise InputError(f"orientation notation '{name}' is not one of {', '.join(FORMS)}") from None


__all__ = ["FORMS", "RotationForm", "form", "wrap_near"]
