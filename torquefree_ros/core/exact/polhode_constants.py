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
The exact solution's constants from an initial state, for one body or for many at once.

One set of formulas for one body (plain floats: every reset builds one) or for many at once (numpy
columns: ``propagate_batch``).

Every function takes the arithmetic it runs on (:data:`.ops.FLOATS` or :data:`.ops.COLUMNS`), which
does the same IEEE operations either way: a body of a batch is bit for bit the body built alone.
See :mod:`.polhode` for the equations.
"""

from __future__ import annotations

from typing import Any, NamedTuple

from .elliptic import first_kind_from_values, sn2_integral_from_values
from ..frames import quaternion


class SolverFrame(NamedTuple):
    """The regime's frame and parameters of a non-stationary motion (values: floats or columns)."""

    axes: tuple  # solver axis i is principal axis axes[i] times signs[i] (a proper rotation)
    signs: tuple
    moments: tuple  # J1, J2, J3 (monotonic)
    rates: tuple  # the initial rate in the solver frame
    amplitudes: tuple  # a, sign(J3-J2) b, c
    mc: Any  # the complementary parameter 1 - k^2 (0 on the separatrix)
    m: Any  # k^2, computed as itself: 1 - mc loses it next to a symmetric body
    n: Any  # the characteristic of the attitude's third-kind integral (<= 0)
    rate: Any  # lambda (1/s)


def is_stationary(moments, omega) -> Any:
    """
    Tell whether Euler's equations' right-hand side is exactly zero.

    It is only for a relative equilibrium (rest, a sphere, a spin about a principal axis): the rate
    is then constant.
    """
    I, w = moments, omega
    return (
        ((I[1] - I[2]) * w[1] * w[2] == 0.0)
        & ((I[2] - I[0]) * w[2] * w[0] == 0.0)
        & ((I[0] - I[1]) * w[0] * w[1] == 0.0)
    )


def solver_frame(ops, moments, omega) -> SolverFrame:
    """
    Choose the solver frame and the regime's parameters.

    For principal ``moments`` and the rate ``omega`` in principal axes (three values each; not
    stationary).
    """
    I, w = moments, omega
    pick = ops.pick
    lo, mid, hi = ops.order(I)
    I_lo, I_mid, I_hi = pick(I, lo), pick(I, mid), pick(I, hi)
    w_lo, w_hi = pick(w, lo), pick(w, hi)
    gap_mid = I_lo * (I_lo - I_mid) * (w_lo * w_lo) + I_hi * (I_hi - I_mid) * (w_hi * w_hi)
    major = gap_mid >= 0.0  # the polhode circles the major axis, else the minor one
    axes = (ops.where(major, lo, hi), mid, ops.where(major, hi, lo))
    inversions = (axes[0] > axes[1]) * 1 + (axes[0] > axes[2]) * 1 + (axes[1] > axes[2]) * 1
    # row i of the solver frame is principal axis axes[i] times signs[i], a proper rotation;
    # rotated by pi about its axis 1 so that m3 > 0, then by pi about axis 3 so that m1(0) >= 0 (u0
    # in [-K, K])
    flip_1 = ops.where(pick(w, axes[2]) < 0.0, -1.0, 1.0)
    sign_0 = 1.0 - 2.0 * (inversions % 2)
    flip_3 = ops.where(sign_0 * pick(w, axes[0]) < 0.0, -1.0, 1.0)
    signs = (sign_0 * flip_3, flip_1 * flip_3, flip_1)
    J = (pick(I, axes[0]), I_mid, pick(I, axes[2]))
    ws = (signs[0] * pick(w, axes[0]), signs[1] * pick(w, mid), signs[2] * pick(w, axes[2]))
    d21, d31, d32 = J[1] - J[0], J[2] - J[0], J[2] - J[1]
    w1s, w2s, w3s = ws[0] * ws[0], ws[1] * ws[1], ws[2] * ws[2]
    P1 = J[1] * d21 * w2s + J[2] * d31 * w3s
    P2 = -J[0] * d21 * w1s + J[2] * d32 * w3s
    P3 = J[0] * d31 * w1s + J[1] * d32 * w2s
    mc = ops.clip(d31 * P2 / (d32 * P1), 0.0, 1.0)  # >= 0 by the choice of axis 3; clip rounding
    a = ops.sqrt(P3 / (J[0] * d31))
    b = ops.copysign(ops.sqrt(P3 / (J[1] * d32)), d32)
    c = ops.sqrt(P1 / (J[2] * d31))
    m = ops.clip(d21 * P3 / (d32 * P1), 0.0, 1.0)
    return SolverFrame(
        axes=axes,
        signs=signs,
        moments=J,
        rates=ws,
        amplitudes=(a, b, c),
        mc=mc,
        m=m,
        n=-J[2] * d21 / (J[0] * d32),
        rate=ops.sqrt(d32 * P1 / (J[0] * J[1] * J[2])),
    )


class AttitudeConstants(NamedTuple):
    """
    Everything :class:`~.polhode.PolhodeAttitude` evaluates with, for ``mc > 0``.

    Values: floats or columns; the 3x3 and 4x4 matrices as nested tuples of them.
    """

    initial_phase: Any  # u0
    momentum: Any  # |m|
    rate_matrix: tuple  # omega_F = (cn, sn, dn) @ this
    momentum_amplitudes: tuple  # m = (cn, sn, dn) * these
    direction: Any  # sign(J3 - J2)
    lever: tuple  # A, B: the angle of (m1, m2) is that of (A cn, B sn) times sign(J3 - J2)
    # psi = psi_rate t + direction (theta phase - angle of (A cn, B sn)) + psi_offset
    psi_rate: Any
    psi_offset: Any
    frame_change: tuple  # q_NF = (about_H_arc) @ this


def attitude_constants(
    ops, frame: SolverFrame, solver_from_frame, q_NF0, sn2_integral_slope
) -> AttitudeConstants:
    """
    Compute the attitude's constants.

    For ``omega_S = solver_from_frame @ omega_F`` (rows of values), the initial attitude ``q_NF0``
    (four values) and the mean slope ``S(K)/K`` of the Jacobi functions' ``S``
    (:class:`.elliptic.JacobiElliptic`).
    """
    J1, J2, J3 = frame.moments
    a, b, c = frame.amplitudes
    n = frame.n
    ws = frame.rates
    # the functions at u0, from the initial rate itself: sn0 = w2/b, cn0 = w1/a, dn0 = w3/c
    sn0, cn0, dn0 = ops.clip(ws[1] / b, -1.0, 1.0), ws[0] / a, ws[2] / c
    sn2_integral0 = sn2_integral_from_values(sn0, cn0, dn0, n, ops.elliprj)
    amplitudes = (J1 * a, J2 * b, J3 * c)
    momentum = ops.hypot(J1 * ws[0], J2 * ws[1], J3 * ws[2])
    direction = ops.copysign(1.0, b)
    A, B = amplitudes[0], ops.copysign(amplitudes[1], 1.0)
    rate = frame.rate
    gain = momentum * (J3 - J1) * n / (J1 * J3 * rate)  # psi' = |m|/J1 + gain lambda S'(u)
    u0 = first_kind_from_values(sn0, cn0, dn0, ops.elliprf)
    slope = sn2_integral_slope
    angle0 = ops.atan2(B * sn0, A * cn0)  # of (m1, m2) times sign(J3 - J2); cn0 >= 0
    m0 = (amplitudes[0] * cn0, amplitudes[1] * sn0, amplitudes[2] * dn0)
    arc_w = momentum + m0[2]
    arc_norm = ops.hypot(m0[1], m0[0], arc_w)
    q_SF = quaternion.matrix_quaternion(solver_from_frame, ops)
    q_NS0 = quaternion.multiply_values(q_NF0, quaternion.conjugate_values(q_SF))
    left = quaternion.multiply_values(
        q_NS0, (-m0[1] / arc_norm, m0[0] / arc_norm, -0.0, arc_w / arc_norm)  # conj(Q(m0))
    )
    return AttitudeConstants(
        initial_phase=u0,
        momentum=momentum,
        rate_matrix=tuple(
            [
                (amplitude * row[0], amplitude * row[1], amplitude * row[2])
                for amplitude, row in zip((a, b, c), solver_from_frame)
            ]
        ),
        momentum_amplitudes=amplitudes,
        direction=direction,
        lever=(A, B),
        # gain S(u) = gain slope u + direction (theta phase): gain weight / n = sign(J3 - J1) =
        # direction
        psi_rate=momentum / J1 + (gain * rate) * slope,
        psi_offset=direction * angle0 - gain * (sn2_integral0 - slope * u0),
        frame_change=_transpose(quaternion.product_matrix_values(left, q_SF)),
    )


def solver_from_body(ops, frame: SolverFrame, principal_axes) -> tuple:
    """
    Return the rows of ``C`` with ``omega_S = C omega_B``.

    For principal axes given as the columns of ``principal_axes`` (rows of values):
    ``C[i][j] = signs[i] principal_axes[j][axes[i]]``, exact.
    """
    pick, (row0, row1, row2) = ops.pick, principal_axes
    return tuple(
        [
            (sign * pick(row0, axis), sign * pick(row1, axis), sign * pick(row2, axis))
            for axis, sign in zip(frame.axes, frame.signs)
        ]
    )


def to_principal(omega_B, principal_axes) -> tuple:
    """
    Return ``omega_P = principal_axes^T omega_B``, summed in one fixed order.

    Values: floats or columns.
    """
    (w0, w1, w2), (a0, a1, a2) = omega_B, principal_axes
    return (
        w0 * a0[0] + w1 * a1[0] + w2 * a2[0],
        w0 * a0[1] + w1 * a1[1] + w2 * a2[1],
        w0 * a0[2] + w1 * a1[2] + w2 * a2[2],
    )


def _transpose(matrix) -> tuple:
    return tuple(zip(*matrix))
