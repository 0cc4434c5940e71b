"""The exact solution's constants from an initial state, by one set of formulas for one body (plain
floats: every reset builds one) or for many at once (numpy columns: ``propagate_batch``).

Both run the same IEEE operations in the same order: ``+ - * /`` and ``sqrt`` are correctly rounded
in Python and numpy alike, ``copysign``, ``min``/``max`` and selections are exact, scipy's Carlson
integrals are one C function per element, and ``atan2`` and ``hypot`` are Python's ``math`` functions
for both (numpy may vectorise its own). So a body of a batch is bit for bit the body built alone.
See :mod:`.polhode` for the equations.
"""

from __future__ import annotations

import math
import operator
from typing import Any, NamedTuple

import numpy as np
from scipy.special import elliprf, elliprj

from .elliptic import first_kind_from_values, sn2_integral_from_values


class _Floats:
    """Operations on one body: plain Python floats."""

    sqrt = staticmethod(math.sqrt)
    copysign = staticmethod(math.copysign)
    atan2 = staticmethod(math.atan2)

    @staticmethod
    def where(condition, if_true, if_false):
        return if_true if condition else if_false

    @staticmethod
    def clip(value, low: float, high: float):
        return min(max(value, low), high)

    pick = staticmethod(operator.getitem)  # pick(values, index)
    choose = staticmethod(operator.getitem)  # choose(tuples, index): one of several tuples
    hypot = staticmethod(math.hypot)

    @staticmethod
    def order(values):
        return sorted(range(3), key=values.__getitem__)  # stable

    @staticmethod
    def first_largest(values):
        return values.index(max(values))

    @staticmethod
    def elliprf(x, y, z):
        return float(elliprf(x, y, z))

    @staticmethod
    def elliprj(x, y, z, p):
        return float(elliprj(x, y, z, p))


class _Columns:
    """Operations on many bodies: each value a numpy array over bodies."""

    sqrt = staticmethod(np.sqrt)
    copysign = staticmethod(np.copysign)
    where = staticmethod(np.where)
    elliprf = staticmethod(elliprf)
    elliprj = staticmethod(elliprj)

    @staticmethod
    def atan2(y, x):
        return np.array([math.atan2(a, b) for a, b in zip(y.tolist(), x.tolist())])

    @staticmethod
    def clip(value, low: float, high: float):
        return np.minimum(np.maximum(value, low), high)

    @staticmethod
    def pick(values, index):
        return np.choose(index, values)

    @staticmethod
    def choose(tuples, index):
        return tuple(np.choose(index, values) for values in zip(*tuples))

    @staticmethod
    def hypot(*values):
        return np.array([math.hypot(*v) for v in zip(*(value.tolist() for value in values))])

    @staticmethod
    def order(values):
        return tuple(np.argsort(np.stack(values, axis=-1), axis=-1, kind="stable").T)

    @staticmethod
    def first_largest(values):
        return np.argmax(np.stack(values), axis=0)


FLOATS = _Floats()
COLUMNS = _Columns()


class SolverFrame(NamedTuple):
    """The regime's frame and parameters of a non-stationary motion (values: floats or columns)."""

    axes: tuple  # solver axis i is principal axis axes[i] times signs[i] (a proper rotation)
    signs: tuple
    moments: tuple  # J1, J2, J3 (monotonic)
    rates: tuple  # the initial rate in the solver frame
    amplitudes: tuple  # a, sign(J3-J2) b, c
    mc: Any  # the complementary parameter 1 - k^2 (0 on the separatrix)
    n: Any  # the characteristic of the attitude's third-kind integral (<= 0)
    rate: Any  # lambda (1/s)


def is_stationary(moments, omega) -> Any:
    """Euler's equations' right-hand side, exactly zero only for a relative equilibrium (rest, a
    sphere, a spin about a principal axis): the rate is then constant."""
    I, w = moments, omega
    return (((I[1] - I[2]) * w[1] * w[2] == 0.0) & ((I[2] - I[0]) * w[2] * w[0] == 0.0)
            & ((I[0] - I[1]) * w[0] * w[1] == 0.0))


def solver_frame(ops, moments, omega) -> SolverFrame:
    """Choose the solver frame and the regime's parameters, for principal ``moments`` and the rate
    ``omega`` in principal axes (three values each; not stationary)."""
    I, w = moments, omega
    pick = ops.pick
    lo, mid, hi = ops.order(I)
    I_lo, I_mid, I_hi = pick(I, lo), pick(I, mid), pick(I, hi)
    w_lo, w_hi = pick(w, lo), pick(w, hi)
    gap_mid = I_lo * (I_lo - I_mid) * (w_lo * w_lo) + I_hi * (I_hi - I_mid) * (w_hi * w_hi)
    major = gap_mid >= 0.0  # the polhode circles the major axis, else the minor one
    axes = (ops.where(major, lo, hi), mid, ops.where(major, hi, lo))
    inversions = (axes[0] > axes[1]) * 1 + (axes[0] > axes[2]) * 1 + (axes[1] > axes[2]) * 1
    # row i of the solver frame is principal axis axes[i] times signs[i], a proper rotation; rotated
    # by pi about its axis 1 so that m3 > 0, then by pi about axis 3 so that m1(0) >= 0 (u0 in [-K, K])
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
    return SolverFrame(axes=axes, signs=signs, moments=J, rates=ws, amplitudes=(a, b, c), mc=mc,
                       n=-J[2] * d21 / (J[0] * d32), rate=ops.sqrt(d32 * P1 / (J[0] * J[1] * J[2])))


class AttitudeConstants(NamedTuple):
    """Everything :class:`~.polhode.PolhodeAttitude` evaluates with, for ``mc > 0`` (values: floats or
    columns; the 3x3 and 4x4 matrices as nested tuples of them)."""

    initial_phase: Any  # u0
    momentum: Any  # |m|
    rate_matrix: tuple  # omega_F = (cn, sn, dn) @ this
    momentum_amplitudes: tuple  # m = (cn, sn, dn) * these
    direction: Any  # sign(J3 - J2)
    lever: tuple  # A, B: the angle of (m1, m2) is that of (A cn, B sn) times sign(J3 - J2)
    psi_rate: Any
    psi_integral_gain: Any
    psi_offset: Any
    frame_change: tuple  # q_NF = (about_H_arc) @ this


def attitude_constants(ops, frame: SolverFrame, solver_from_frame, q_NF0) -> AttitudeConstants:
    """The attitude's constants for ``omega_S = solver_from_frame @ omega_F`` (rows of values) and
    the initial attitude ``q_NF0`` (four values)."""
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
    gain = momentum * (J3 - J1) * n / (J1 * J3 * rate)
    angle0 = ops.atan2(B * sn0, A * cn0)  # of (m1, m2) times sign(J3 - J2); cn0 >= 0
    m0 = (amplitudes[0] * cn0, amplitudes[1] * sn0, amplitudes[2] * dn0)
    arc_w = momentum + m0[2]
    arc_norm = ops.hypot(m0[1], m0[0], arc_w)
    q_SF = _matrix_quaternion(ops, solver_from_frame)
    q_NS0 = _multiply(q_NF0, _conjugate(q_SF))
    left = _multiply(q_NS0, (-m0[1] / arc_norm, m0[0] / arc_norm, -0.0, arc_w / arc_norm))  # conj(Q(m0))
    return AttitudeConstants(
        initial_phase=first_kind_from_values(sn0, cn0, dn0, ops.elliprf),
        momentum=momentum,
        rate_matrix=tuple(tuple(amplitude * x for x in row) for amplitude, row in zip((a, b, c), solver_from_frame)),
        momentum_amplitudes=amplitudes,
        direction=direction,
        lever=(A, B),
        psi_rate=momentum / J1,
        psi_integral_gain=gain,
        psi_offset=direction * angle0 - gain * sn2_integral0,
        frame_change=_transpose(_product_matrix(left, q_SF)),
    )


def solver_from_body(ops, frame: SolverFrame, principal_axes) -> tuple:
    """Rows of ``C`` with ``omega_S = C omega_B`` for principal axes given as the columns of
    ``principal_axes`` (rows of values): ``C[i][j] = signs[i] principal_axes[j][axes[i]]``, exact."""
    return tuple(tuple(sign * ops.pick(row, axis) for row in principal_axes)
                 for axis, sign in zip(frame.axes, frame.signs))


def to_principal(omega_B, principal_axes) -> tuple:
    """``omega_P = principal_axes^T omega_B``, summed in one fixed order (values: floats or columns)."""
    w = omega_B
    return tuple(w[0] * principal_axes[0][j] + w[1] * principal_axes[1][j] + w[2] * principal_axes[2][j]
                 for j in range(3))


# -- fixed-order helpers, the same for floats and columns ------------------------------------------
def _conjugate(q) -> tuple:
    return (-q[0], -q[1], -q[2], q[3])


def _multiply(p, q) -> tuple:
    px, py, pz, pw = p
    qx, qy, qz, qw = q
    return (pw * qx + px * qw + py * qz - pz * qy, pw * qy - px * qz + py * qw + pz * qx,
            pw * qz + px * qy - py * qx + pz * qw, pw * qw - px * qx - py * qy - pz * qz)


def _product_matrix(left, right) -> tuple:
    """``M`` with ``M x = left ⊗ x ⊗ right`` (as :func:`.quaternion.product_matrix`): the product of
    the matrices of ``left ⊗ .`` and ``. ⊗ right``, written out in one fixed order."""
    px, py, pz, pw = left
    qx, qy, qz, qw = right
    by_right = ((qw, qz, -qy, qx), (-qz, qw, qx, qy), (qy, -qx, qw, qz), (-qx, -qy, -qz, qw))
    (r00, r01, r02, r03), (r10, r11, r12, r13), (r20, r21, r22, r23), (r30, r31, r32, r33) = by_right
    return tuple((a * r00 + b * r10 + c * r20 + d * r30, a * r01 + b * r11 + c * r21 + d * r31,
                  a * r02 + b * r12 + c * r22 + d * r32, a * r03 + b * r13 + c * r23 + d * r33)
                 for a, b, c, d in ((pw, -pz, py, px), (pz, pw, -px, py), (-py, px, pw, pz), (-px, -py, -pz, pw)))


def _transpose(matrix) -> tuple:
    return tuple(zip(*matrix))


def _matrix_quaternion(ops, m) -> tuple:
    """Unit quaternion of a proper rotation matrix (Shepperd's method, largest pivot), ``w >= 0``."""
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
