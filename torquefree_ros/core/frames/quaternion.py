# Copyright 2026 torquefree_ros maintainers
#
# Licensed under the Apache License, Version 2.0 (the "License");
# you may not use this file except in compliance with the License.
# You may obtain a copy of the License at
#
#     http://www.apache.org/licenses/LICENSE-2.0
#
# Unless required by applicable law or agreed to in writing, software
# distributed under the License is distributed on an "AS IS" BASIS,
# WITHOUT WARRANTIES OR CONDITIONS OF ANY KIND, either express or implied.
# See the License for the specific language governing permissions and
# limitations under the License.

"""
Attitude conventions, in one place.

Quaternions are stored ``(x, y, z, w)`` (scalar last, as geometry_msgs), use the Hamilton product,
and ``q_NB`` is the orientation of the body frame B in the inertial frame N: ``R(q_NB)`` maps
body-frame coordinates to inertial ones (REP 103). Kinematics with the body-frame rate
``omega_BN_B``: ``dq_NB/dt = 1/2 q_NB ⊗ (omega_BN_B, 0)``.

All functions broadcast over leading axes. A single quaternion or vector (1-D arrays) takes a plain
float path: the integrators call these once per stage, where numpy's per-call cost on 3- and
4-element arrays (10 µs for ``np.cross``) would be most of a step.
"""

from __future__ import annotations

import math

import numpy as np

from ..numerics.ops import FLOATS

_CONJUGATE = np.array([-1.0, -1.0, -1.0, 1.0])


def _single(*arrays: np.ndarray) -> bool:
    return all(a.ndim == 1 for a in arrays)


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Return ``a x b`` of 3-vectors (``np.cross``, with the float path for one pair)."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    if not _single(a, b):
        return np.cross(a, b)
    a1, a2, a3 = a.tolist()
    b1, b2, b3 = b.tolist()
    return np.array([a2 * b3 - a3 * b2, a3 * b1 - a1 * b3, a1 * b2 - a2 * b1])


def multiply(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Hamilton product ``p ⊗ q`` of ``(x, y, z, w)`` quaternions."""
    p = np.asarray(p, dtype=float)
    q = np.asarray(q, dtype=float)
    if _single(p, q):
        return np.array(multiply_values(p.tolist(), q.tolist()))
    px, py, pz, pw = np.moveaxis(p, -1, 0)
    qx, qy, qz, qw = np.moveaxis(q, -1, 0)
    return np.stack(
        [
            pw * qx + px * qw + py * qz - pz * qy,
            pw * qy - px * qz + py * qw + pz * qx,
            pw * qz + px * qy - py * qx + pz * qw,
            pw * qw - px * qx - py * qy - pz * qz,
        ],
        axis=-1,
    )


def multiply_values(p, q) -> tuple:
    """
    Return ``p ⊗ q`` of two quaternions given as four values each, floats or arrays.

    The same operations as :func:`multiply`, for code that builds constants from a handful of
    numbers.
    """
    px, py, pz, pw = p
    qx, qy, qz, qw = q
    return (
        pw * qx + px * qw + py * qz - pz * qy,
        pw * qy - px * qz + py * qw + pz * qx,
        pw * qz + px * qy - py * qx + pz * qw,
        pw * qw - px * qx - py * qy - pz * qz,
    )


def conjugate_values(q) -> tuple:
    """Return the conjugate of a quaternion given as four values."""
    return (-q[0], -q[1], -q[2], q[3])


def product_matrix(left: np.ndarray, right: np.ndarray) -> np.ndarray:
    """
    Return the 4x4 matrix ``M`` with ``M x = left ⊗ x ⊗ right`` for any ``x``.

    ``left`` and ``right`` are one quaternion each: a fixed frame change on both sides of many
    quaternions is then one matrix product, ``X @ M.T``.
    """
    return np.array(
        product_matrix_values(
            np.asarray(left, dtype=float).tolist(), np.asarray(right, dtype=float).tolist()
        )
    )


def product_matrix_values(left, right) -> tuple:
    """
    Compute :func:`product_matrix` with each quaternion as four values (floats or arrays).

    The product of the matrices of ``left ⊗ .`` and ``. ⊗ right``, summed in one fixed order; rows
    of values.
    """
    px, py, pz, pw = left
    qx, qy, qz, qw = right
    # rows: the Hamilton product's components as linear forms in x, for left ⊗ x and for x ⊗ right
    by_left = ((pw, -pz, py, px), (pz, pw, -px, py), (-py, px, pw, pz), (-px, -py, -pz, pw))
    (r00, r01, r02, r03), (r10, r11, r12, r13), (r20, r21, r22, r23), (r30, r31, r32, r33) = (
        (qw, qz, -qy, qx),
        (-qz, qw, qx, qy),
        (qy, -qx, qw, qz),
        (-qx, -qy, -qz, qw),
    )
    return tuple(
        [
            (
                a * r00 + b * r10 + c * r20 + d * r30,
                a * r01 + b * r11 + c * r21 + d * r31,
                a * r02 + b * r12 + c * r22 + d * r32,
                a * r03 + b * r13 + c * r23 + d * r33,
            )
            for a, b, c, d in by_left
        ]
    )


def conjugate(q: np.ndarray) -> np.ndarray:
    """Inverse rotation of a unit quaternion."""
    return np.asarray(q, dtype=float) * _CONJUGATE


def to_matrix(q: np.ndarray) -> np.ndarray:
    """Rotation matrix ``R(q)`` (maps body coordinates to inertial ones); ``q`` must be unit."""
    x, y, z, w = np.moveaxis(np.asarray(q, dtype=float), -1, 0)
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], -1),
            np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], -1),
            np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], -1),
        ],
        axis=-2,
    )


def from_matrix(matrix) -> np.ndarray:
    """
    Return the unit quaternion, ``w >= 0``, of a proper rotation matrix.

    Shepperd's method, largest pivot.
    """
    return np.array(matrix_quaternion(np.asarray(matrix, dtype=float).tolist()))


def matrix_quaternion(m, ops=FLOATS) -> tuple:
    """
    Compute :func:`from_matrix` of a matrix given as rows of values.

    The values are floats (``ops`` :data:`.ops.FLOATS`) or arrays over bodies
    (:data:`.ops.COLUMNS`).
    """
    trace = m[0][0] + m[1][1] + m[2][2]
    pivot = ops.first_largest([m[0][0], m[1][1], m[2][2], trace])
    # the four candidates, one per pivot; each is the quaternion times a positive number
    candidates = [
        (1.0 + 2.0 * m[0][0] - trace, m[1][0] + m[0][1], m[2][0] + m[0][2], m[2][1] - m[1][2]),
        (m[0][1] + m[1][0], 1.0 + 2.0 * m[1][1] - trace, m[2][1] + m[1][2], m[0][2] - m[2][0]),
        (m[0][2] + m[2][0], m[1][2] + m[2][1], 1.0 + 2.0 * m[2][2] - trace, m[1][0] - m[0][1]),
        (m[2][1] - m[1][2], m[0][2] - m[2][0], m[1][0] - m[0][1], 1.0 + trace),
    ]
    q = ops.choose(candidates, pivot)
    norm = ops.hypot(*q)
    norm = ops.where(q[3] >= 0.0, norm, -norm)
    return (q[0] / norm, q[1] / norm, q[2] / norm, q[3] / norm)


def rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``R(q) v``: a body-frame vector expressed in the inertial frame; ``q`` must be unit."""
    q = np.asarray(q, dtype=float)
    v = np.asarray(v, dtype=float)
    if not _single(q, v):
        return np.einsum('...ij,...j->...i', to_matrix(q), v)
    return np.array(rotate_values(q.tolist(), v.tolist()))


def rotate_values(q, v) -> tuple:
    """
    Return ``R(q) v`` of a quaternion and a vector given as values, floats or arrays.

    The same operations as :func:`rotate` of one pair: ``v + 2 w (u x v) + 2 u x (u x v)``, u the
    vector part, w the scalar.
    """
    ux, uy, uz, w = q
    vx, vy, vz = v
    tx, ty, tz = 2.0 * (uy * vz - uz * vy), 2.0 * (uz * vx - ux * vz), 2.0 * (ux * vy - uy * vx)
    return (
        vx + w * tx + uy * tz - uz * ty,
        vy + w * ty + uz * tx - ux * tz,
        vz + w * tz + ux * ty - uy * tx,
    )


def rotate_inverse(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``R(q)^T v``: an inertial vector in body coordinates (``rotate`` by the conjugate)."""
    return rotate(conjugate(q), v)


def exp_rotation(rotation_vector: np.ndarray) -> np.ndarray:
    """
    Return the unit quaternion of the rotation by ``|v|`` rad about ``v``.

    The map ``v -> exp(v/2)``.
    """
    v = np.asarray(rotation_vector, dtype=float)
    # sin(|v|/2)/|v| without dividing by zero: its series is exact to rounding below 1e-4.
    if v.ndim == 1:
        x, y, z = v.tolist()
        angle = math.sqrt(x * x + y * y + z * z)
        scale = 0.5 - angle * angle / 48.0 if angle < 1e-4 else math.sin(0.5 * angle) / angle
        return np.array([x * scale, y * scale, z * scale, math.cos(0.5 * angle)])
    angle = np.linalg.norm(v, axis=-1, keepdims=True)
    half = 0.5 * angle
    small = angle < 1e-4
    scale = np.where(small, 0.5 - angle * angle / 48.0, np.sin(half) / np.where(small, 1.0, angle))
    return np.concatenate([v * scale, np.cos(half)], axis=-1)


def angle_between(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """
    Rotation angle (rad, in [0, pi]) of ``p* ⊗ q``; the same for ``q`` and ``-q``.

    ``atan2`` of the vector and scalar parts keeps full relative precision for tiny angles,
    where ``2 acos(|p·q|)`` would not.
    """
    d = multiply(conjugate(p), q)
    return 2.0 * np.arctan2(np.linalg.norm(d[..., :3], axis=-1), np.abs(d[..., 3]))
