"""Rotations in the project's conventions (docs/conventions.md, docs/system.md §2), in numpy.

Mirrors math/rotation.h: frame rotations R1/R2/R3, the paper's 2-1-3 Euler
sequence C = R3(psi) R1(phi) R2(theta), the small-angle matrix and the
rotation-vector exp/log (active rotations).
"""

from __future__ import annotations

import numpy as np


def r1(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, s], [0.0, -s, c]])


def r2(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0.0, -s], [0.0, 1.0, 0.0], [s, 0.0, c]])


def r3(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])


def euler213_to_matrix(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """C = R3(yaw) R1(roll) R2(pitch), angles in radians."""
    return r3(yaw) @ r1(roll) @ r2(pitch)


def euler213_deg_to_matrix(angles_deg) -> np.ndarray:
    """(roll, pitch, yaw) in degrees -> C."""
    roll, pitch, yaw = np.deg2rad(np.asarray(angles_deg, dtype=float))
    return euler213_to_matrix(roll, pitch, yaw)


def matrix_to_euler213(c: np.ndarray) -> tuple[float, float, float]:
    """Inverse of euler213_to_matrix: (roll, pitch, yaw) in radians.

    At the gimbal lock (roll = +-90 deg) pitch is set to 0 and yaw carries the rotation.
    """
    c = np.asarray(c, dtype=float)
    cos_roll = np.hypot(c[2, 0], c[2, 2])
    roll = np.arctan2(-c[2, 1], cos_roll)
    if cos_roll < 1e-12:
        return float(roll), 0.0, float(np.arctan2(-c[1, 0], c[0, 0]))
    return float(roll), float(np.arctan2(c[2, 0], c[2, 2])), float(np.arctan2(c[0, 1], c[1, 1]))


def matrix_to_euler213_deg(c: np.ndarray) -> np.ndarray:
    return np.rad2deg(np.array(matrix_to_euler213(c)))


def small_angle(a) -> np.ndarray:
    """Eq. A2: I - skew(a) = [[1, g, -b], [-g, 1, a], [b, -a, 1]]."""
    al, be, ga = a
    return np.array([[1.0, ga, -be], [-ga, 1.0, al], [be, -al, 1.0]])


def skew(v) -> np.ndarray:
    x, y, z = v
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def rot_exp(w) -> np.ndarray:
    """Active rotation by |w| about w/|w| (Rodrigues)."""
    w = np.asarray(w, dtype=float)
    th = np.linalg.norm(w)
    k = skew(w)
    if th < 1e-8:
        return np.eye(3) + k + 0.5 * k @ k
    return np.eye(3) + np.sin(th) / th * k + (1.0 - np.cos(th)) / th**2 * k @ k


def rot_log(r: np.ndarray) -> np.ndarray:
    """Rotation vector w with |w| <= pi and rot_exp(w) = r."""
    from scipy.spatial.transform import Rotation

    return Rotation.from_matrix(np.asarray(r, dtype=float)).as_rotvec()


def rx(a: float) -> np.ndarray:
    """Active rotation about x (the turntable's auxiliary axis): R1(-a)."""
    return r1(-a)


def rz(a: float) -> np.ndarray:
    """Active rotation about z (the turntable's main axis): R3(-a)."""
    return r3(-a)


def random_rotations(rng: np.random.Generator, n: int) -> np.ndarray:
    """n uniformly distributed rotation matrices (from unit quaternions)."""
    q = rng.normal(size=(n, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    w, x, y, z = q.T
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], axis=-1),
            np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], axis=-1),
            np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], axis=-1),
        ],
        axis=1,
    )
