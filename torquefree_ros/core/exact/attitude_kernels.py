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
The exact solution compiled by numba, when it is installed (the ``fast`` extra).

A body's constants from its initial state, and the attitude's per-sample evaluation, as scalar code
that repeats what the Python/numpy path computes (:mod:`.polhode_constants` and
:class:`.elliptic.JacobiElliptic`'s constants in Python floats, :class:`.polhode.PolhodeAttitude`
with numpy arrays) operation for operation, in the same order. That path stays the reference; the
tests hold the two together (test_attitude_kernels.py).

Why: a build is ~150 Python float operations and ~10 scipy calls, and numpy's cost is per array
operation whatever its length, ~80 of them a call, so a block of a few hundred samples (the
node's) pays more for operations than for arithmetic (figures: docs/bench/exact.md).

What differs: the Euclidean norms (Python's ``math.hypot`` of three or four values is its own
near-correctly-rounded algorithm, here a scaled sum of squares, within an ulp or two) and ``tanh``
(numpy has its own vectorised one, here the C library's): the last bit of a few constants and of
some samples. Carlson's ``R_F`` and ``R_J`` are scipy's own C functions
(``scipy.special.cython_special``), the ones ``scipy.special.elliprf``/``elliprj`` call.

A body's constants are one row of a table (``TABLE_WIDTH`` floats, the layout below); many bodies
are rows of one table and fill ``(bodies, samples, 3 | 4)`` outputs.
``TORQUEFREE_ROS_KERNELS=numpy`` in the environment turns the kernels off (the numpy path then
runs, as without numba).
"""

from __future__ import annotations

import math

import numpy as np

from ..numerics.kernels import KernelFamily


# the table's columns: common to both kinds of series ...
RATE, INITIAL_PHASE, PER_PERIOD, PERIOD, SCALE = 0, 1, 2, 3, 4
MOMENTUM, TWO_MOMENTUM, AMPLITUDES, LEVER = 5, 6, 7, 10  # amplitudes 3, lever 2
HALF_DIRECTION, HALF_PSI_RATE, HALF_PSI_OFFSET = 12, 13, 14
RATE_ROWS, FRAME_CHANGE_ROWS = 15, 24  # 3x3 then 4x4, row by row
# ... then by kind: trigonometric (m <= 1/2) the phase's base and six cubics, hyperbolic the
# quarter period, its half, k', kappa and eight cubics (cubic i's coefficient of power p at
# CUBICS + 4i + p), the separatrix sqrt(-n)
BASE, TRIGONOMETRIC_CUBICS = 40, 41
QUARTER, HALF_QUARTER, K_PRIME, KAPPA, HYPERBOLIC_CUBICS = 40, 41, 42, 43, 44
ROOT = 40
TABLE_WIDTH = HYPERBOLIC_CUBICS + 4 * 8

#: the kinds of motion with a kernel; build_row returns an index into these, or STATIONARY
KINDS = ('trigonometric', 'hyperbolic', 'separatrix')
STATIONARY = -1
# JacobiElliptic.TRIGONOMETRIC_MC (a literal: compiled code keeps what it read)
TRIGONOMETRIC_MC = 0.5


def kernel(kind: str):
    """
    Return the compiled kernel for ``kind``.

    ``kind`` is ``"trigonometric"`` (``m <= 1/2``), ``"hyperbolic"`` or ``"separatrix"`` (numba
    imported, and the functions below compiled on their first call, the first time one is asked
    for).
    """
    _compile()
    return globals()[kind + '_kernel']


#: a body's initial state as build_row reads it: principal moments (3), principal axes (3x3, row by
#: row, the axes as columns), the rate in the body frame (3) and the attitude q_NB (4)
STATE_WIDTH = 19


def build_tables(moments, principal_axes, omega_B, q_NB):
    """
    Build the tables of bodies' constants: ``(kinds, table)``.

    The bodies are given by their principal ``moments (N, 3)``, ``principal_axes (N, 3, 3)``
    (columns), rates ``omega_B (N, 3)`` and attitudes ``q_NB (N, 4)``, or one body's without the
    leading axis (:func:`build_row`). ``kinds[i]`` is an index into :data:`KINDS`, or -1 for a
    stationary motion (whose row is not filled). The states go in as one new (N, STATE_WIDTH)
    array: one compiled signature whatever the inputs' flags (a read-only array is another numba
    type, another compilation).
    """
    _compile()
    axes = principal_axes.reshape(principal_axes.shape[:-2] + (9,))
    states = np.concatenate((moments, axes, omega_B, q_NB), axis=-1, dtype=float).reshape(
        (-1, STATE_WIDTH)
    )
    table = np.zeros((states.shape[0], TABLE_WIDTH))  # (columns a kind does not use stay 0)
    return _build_rows(states, table), table


def _build_rows(states, table):
    kinds = np.empty(states.shape[0], dtype=np.int64)
    for i in range(states.shape[0]):
        kinds[i] = build_row(states[i], table[i])
    return kinds


def _link_scipy(numba) -> None:
    """Declare scipy's Carlson ``R_F`` and ``R_J`` (C functions) to the compiled code."""
    import llvmlite.binding
    from numba.extending import get_cython_function_address

    # scipy's elliprf/elliprj for doubles (fused variant 1), called by symbol name: the compiled
    # code then refers to no address of this process and numba's cache can keep it
    double = numba.float64
    for name, signature in (
        ('rf', double(double, double, double, numba.intc)),
        ('rj', double(double, double, double, double, numba.intc)),
    ):
        symbol = f'torquefree_ros_ellip{name}'
        llvmlite.binding.add_symbol(
            symbol,
            get_cython_function_address(
                'scipy.special.cython_special', f'__pyx_fuse_1ellip{name}'
            ),
        )
        globals()[f'carlson_{name}'] = numba.types.ExternalFunction(symbol, signature)


# The GIL stays held (no nogil): a kernel call is microseconds, and releasing it let the node's
# executor thread take the GIL for up to the interpreter's switch interval.
_FAMILY = KernelFamily(
    globals(),
    (
        '_rf',
        '_rj',
        '_norm',
        '_multiply',
        '_matrix_quaternion',
        '_product_matrix_transposed',
        '_set_cubic',
        '_trigonometric_phase',
        '_hyperbolic_phase',
        '_theta_constants',
        'build_row',
        '_build_rows',
        '_horner',
        '_reduce',
        '_phase_minus_angle',
        '_finish',
        'trigonometric_kernel',
        'hyperbolic_kernel',
        'separatrix_kernel',
    ),
    prepare=_link_scipy,
)
_compile = _FAMILY.load


def _horner(c, first, x):
    return ((c[first + 3] * x + c[first + 2]) * x + c[first + 1]) * x + c[first]


def _reduce(c, t):
    """``(j, r)`` with ``u = rate t + u0 = r + 2K j``: :meth:`.elliptic.JacobiElliptic._reduce`."""
    u = c[RATE] * t + c[INITIAL_PHASE]
    half_periods = np.rint(u * c[PER_PERIOD])
    return half_periods, u - c[PERIOD] * half_periods


def _phase_minus_angle(c, re, im, reduced_sn, reduced_cn, half_periods):
    """:meth:`.elliptic.JacobiValues.phase_minus_angle` at the lever, without the linear term."""
    x, y = c[LEVER] * reduced_cn, c[LEVER + 1] * reduced_sn
    return math.atan2(im * x - re * y, re * x + im * y) - np.pi * half_periods


def _finish(c, t, sn, cn, dn, difference, omega, q):
    """Do what :meth:`.polhode.PolhodeAttitude._pass` does with the Jacobi values of one sample."""
    half = (c[HALF_PSI_RATE] * t + c[HALF_DIRECTION] * difference) + c[HALF_PSI_OFFSET]
    for k in range(3):
        omega[k] = (cn * c[RATE_ROWS + k] + sn * c[RATE_ROWS + 3 + k]) + dn * c[RATE_ROWS + 6 + k]
    m0, m1 = c[AMPLITUDES] * cn, c[AMPLITUDES + 1] * sn
    arc_w = c[MOMENTUM] + c[AMPLITUDES + 2] * dn
    scale = 1.0 / math.sqrt(c[TWO_MOMENTUM] * arc_w)
    cos_half, sin_half = math.cos(half) * scale, math.sin(half) * scale
    a0, a1 = cos_half * m1 + sin_half * m0, sin_half * m1 - cos_half * m0
    a2, a3 = sin_half * arc_w, cos_half * arc_w
    f = FRAME_CHANGE_ROWS
    for k in range(4):
        q[k] = ((a0 * c[f + k] + a1 * c[f + 4 + k]) + a2 * c[f + 8 + k]) + a3 * c[f + 12 + k]


def trigonometric_kernel(t, constants, omega, q):
    """
    Evaluate bodies of the trigonometric kind (``m <= 1/2``).

    :meth:`.elliptic.JacobiElliptic._whole_half_period` with the phase, then the attitude;
    ``omega (bodies, samples, 3)`` and ``q (bodies, samples, 4)`` are filled.
    """
    for body in range(constants.shape[0]):
        c = constants[body]
        k = TRIGONOMETRIC_CUBICS
        for i in range(t.shape[0]):
            half_periods, r = _reduce(c, t[i])
            z = c[SCALE] * r
            sine, cosine = math.sin(z), math.cos(z)
            s = sine * sine
            inverse = 1.0 / _horner(c, k + 12, s)
            reduced_sn = (_horner(c, k, s) * inverse) * sine
            reduced_cn = (_horner(c, k + 4, s) * inverse) * cosine
            dn = _horner(c, k + 8, s) * inverse
            parity = 1.0 - 2.0 * (half_periods % 2.0)  # (-1)^j
            re = c[BASE] + s * _horner(c, k + 16, s)
            im = (sine * cosine) * _horner(c, k + 20, s)
            difference = _phase_minus_angle(c, re, im, reduced_sn, reduced_cn, half_periods)
            _finish(
                c,
                t[i],
                parity * reduced_sn,
                parity * reduced_cn,
                dn,
                difference,
                omega[body, i],
                q[body, i],
            )


def hyperbolic_kernel(t, constants, omega, q):
    """
    Evaluate bodies of the hyperbolic kind (``m > 1/2``).

    :meth:`.elliptic.JacobiElliptic._two_halves` with the phase, then the attitude.
    """
    for body in range(constants.shape[0]):
        c = constants[body]
        k = HYPERBOLIC_CUBICS
        for i in range(t.shape[0]):
            half_periods, r = _reduce(c, t[i])
            a = abs(r)
            first = a <= c[HALF_QUARTER]
            w = a if first else c[QUARTER] - a
            y = c[SCALE] * w
            ch, th = math.cosh(y), math.tanh(y)
            ch2 = ch * ch
            x = 2.0 * ch2 - 1.0
            A, B, C, D = (
                _horner(c, k, x),
                _horner(c, k + 4, x),
                _horner(c, k + 8, x),
                _horner(c, k + 12, x),
            )
            sh_A, ch_B = (th * ch) * A, ch * B
            inverse = 1.0 / (ch_B if first else C)
            reduced_sn = math.copysign((sh_A if first else D) * inverse, r)
            reduced_cn = (D if first else c[K_PRIME] * sh_A) * inverse
            dn = (C if first else c[K_PRIME] * ch_B) * inverse
            parity = 1.0 - 2.0 * (half_periods % 2.0)  # (-1)^j
            if first:
                re, im = _horner(c, k + 16, x), math.copysign(th, r) * _horner(c, k + 20, x)
                linear = -c[KAPPA] * math.copysign(w, r)
            else:
                re, im = (
                    _horner(c, k + 24, x),
                    math.copysign(th, r) * (ch2 * _horner(c, k + 28, x)),
                )
                linear = c[KAPPA] * math.copysign(w, r)
            difference = (
                _phase_minus_angle(c, re, im, reduced_sn, reduced_cn, half_periods) + linear
            )
            _finish(
                c,
                t[i],
                parity * reduced_sn,
                parity * reduced_cn,
                dn,
                difference,
                omega[body, i],
                q[body, i],
            )


def separatrix_kernel(t, constants, omega, q):
    """
    Evaluate bodies on the separatrix (``m = 1``).

    :meth:`.elliptic.JacobiElliptic._separatrix` with the phase (``sn = tanh``, ``cn = dn = sech``,
    the phase ``atan2(sqrt(-n) tanh, 1)``), then the attitude.
    """
    for body in range(constants.shape[0]):
        c = constants[body]
        for i in range(t.shape[0]):
            u = c[RATE] * t[i] + c[INITIAL_PHASE]
            e = math.exp(-abs(u))
            sech = 2.0 * e / (1.0 + e * e)
            tanh = math.tanh(u)
            difference = _phase_minus_angle(c, 1.0, c[ROOT] * tanh, tanh, sech, 0.0)
            _finish(c, t[i], tanh, sech, sech, difference, omega[body, i], q[body, i])


# -- one body's table from its initial state ------------------------------------------------------
# scipy's C functions, set by _compile: double f(double x, double y, double z[, double p], int)
carlson_rf = carlson_rj = None


def _rf(x, y, z):
    return carlson_rf(x, y, z, 0)


def _rj(x, y, z, p):
    return carlson_rj(x, y, z, p, 0)


def _norm(values):
    """
    Return the Euclidean norm, computed so that no square overflows or underflows.

    The values are scaled by the largest magnitude.
    """
    largest = 0.0
    for v in values:
        largest = max(largest, abs(v))
    if largest == 0.0 or not math.isfinite(largest):
        return largest
    total = 0.0
    for v in values:
        scaled = v / largest
        total += scaled * scaled
    return largest * math.sqrt(total)


def build_row(state, row):
    """
    Fill ``row`` (``TABLE_WIDTH`` floats) for one body from its initial ``state``; return its kind.

    ``state`` is laid out as :data:`STATE_WIDTH` says.
    """
    I, P, omega_B, q_NB = state[0:3], state[3:12].reshape((3, 3)), state[12:15], state[15:19]
    w = np.empty(3)  # the rate in principal axes (polhode_constants.to_principal)
    for k in range(3):
        w[k] = omega_B[0] * P[0, k] + omega_B[1] * P[1, k] + omega_B[2] * P[2, k]
    if (
        ((I[1] - I[2]) * w[1] * w[2] == 0.0)
        and ((I[2] - I[0]) * w[2] * w[0] == 0.0)
        and ((I[0] - I[1]) * w[0] * w[1] == 0.0)
    ):
        return STATIONARY

    # -- polhode_constants.solver_frame -----------------------------------------------------------
    lo, mid, hi = 0, 1, 2  # a stable argsort of three
    if I[mid] < I[lo]:
        lo, mid = mid, lo
    if I[hi] < I[mid]:
        mid, hi = hi, mid
        if I[mid] < I[lo]:
            lo, mid = mid, lo
    gap_mid = I[lo] * (I[lo] - I[mid]) * (w[lo] * w[lo]) + I[hi] * (I[hi] - I[mid]) * (
        w[hi] * w[hi]
    )
    major = gap_mid >= 0.0
    axes = (lo if major else hi, mid, hi if major else lo)
    inversions = (axes[0] > axes[1]) * 1 + (axes[0] > axes[2]) * 1 + (axes[1] > axes[2]) * 1
    flip_1 = -1.0 if w[axes[2]] < 0.0 else 1.0
    sign_0 = 1.0 - 2.0 * (inversions % 2)
    flip_3 = -1.0 if sign_0 * w[axes[0]] < 0.0 else 1.0
    signs = (sign_0 * flip_3, flip_1 * flip_3, flip_1)
    J1, J2, J3 = I[axes[0]], I[mid], I[axes[2]]
    w1, w2, w3 = signs[0] * w[axes[0]], signs[1] * w[mid], signs[2] * w[axes[2]]
    d21, d31, d32 = J2 - J1, J3 - J1, J3 - J2
    w1s, w2s, w3s = w1 * w1, w2 * w2, w3 * w3
    P1 = J2 * d21 * w2s + J3 * d31 * w3s
    P2 = -J1 * d21 * w1s + J3 * d32 * w3s
    P3 = J1 * d31 * w1s + J2 * d32 * w2s
    mc = min(max(d31 * P2 / (d32 * P1), 0.0), 1.0)
    a = math.sqrt(P3 / (J1 * d31))
    b = math.copysign(math.sqrt(P3 / (J2 * d32)), d32)
    c = math.sqrt(P1 / (J3 * d31))
    m = min(max(d21 * P3 / (d32 * P1), 0.0), 1.0)
    n = -J3 * d21 / (J1 * d32)
    rate = math.sqrt(d32 * P1 / (J1 * J2 * J3))

    # -- elliptic.JacobiElliptic's constants (the theta series' and phase's into the row) ---------
    if mc > 0.0:
        K = _rf(0.0, mc, 1.0)
        slope = (_rj(0.0, mc, 1.0, 1.0 - n) / 3.0) / K
        Kc = _rf(0.0, m, 1.0)
        trigonometric = mc >= TRIGONOMETRIC_MC
        _theta_constants(K, Kc, m, n, trigonometric, math.sqrt(mc), row)
        kind = 0 if trigonometric else 1  # KINDS
    else:
        slope = 1.0 / (1.0 - n)
        row[PER_PERIOD] = row[PERIOD] = row[SCALE] = 0.0
        row[ROOT] = math.sqrt(-n)
        kind = 2

    # -- polhode_constants.attitude_constants -----------------------------------------------------
    # solver_from_body: row i is principal axis axes[i] times signs[i]
    solver_from_frame = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            solver_from_frame[i, j] = signs[i] * P[j, axes[i]]
    sn0, cn0, dn0 = min(max(w2 / b, -1.0), 1.0), w1 / a, w3 / c
    s2 = sn0 * sn0
    sn2_integral0 = sn0 * s2 * _rj(cn0 * cn0, dn0 * dn0, 1.0, 1.0 - n * s2) / 3.0
    amplitudes = (J1 * a, J2 * b, J3 * c)
    momentum = _norm((J1 * w1, J2 * w2, J3 * w3))
    direction = math.copysign(1.0, b)
    A, B = amplitudes[0], math.copysign(amplitudes[1], 1.0)
    gain = momentum * (J3 - J1) * n / (J1 * J3 * rate)
    u0 = sn0 * _rf(cn0 * cn0, dn0 * dn0, 1.0)
    angle0 = math.atan2(B * sn0, A * cn0)
    m0 = (amplitudes[0] * cn0, amplitudes[1] * sn0, amplitudes[2] * dn0)
    arc_w = momentum + m0[2]
    arc_norm = _norm((m0[1], m0[0], arc_w))
    q_SF = _matrix_quaternion(solver_from_frame)
    q_NS0 = _multiply(q_NB, (-q_SF[0], -q_SF[1], -q_SF[2], q_SF[3]))
    left = _multiply(q_NS0, (-m0[1] / arc_norm, m0[0] / arc_norm, -0.0, arc_w / arc_norm))
    psi_rate = momentum / J1 + (gain * rate) * slope
    psi_offset = direction * angle0 - gain * (sn2_integral0 - slope * u0)

    # -- the row (the layout at the top) ----------------------------------------------------------
    row[RATE], row[INITIAL_PHASE], row[MOMENTUM], row[TWO_MOMENTUM] = (
        rate,
        u0,
        momentum,
        2.0 * momentum,
    )
    for k in range(3):
        row[AMPLITUDES + k] = amplitudes[k]
        row[RATE_ROWS + k] = a * solver_from_frame[0, k]
        row[RATE_ROWS + 3 + k] = b * solver_from_frame[1, k]
        row[RATE_ROWS + 6 + k] = c * solver_from_frame[2, k]
    row[LEVER], row[LEVER + 1] = A, B
    row[HALF_DIRECTION], row[HALF_PSI_RATE], row[HALF_PSI_OFFSET] = (
        0.5 * direction,
        0.5 * psi_rate,
        0.5 * psi_offset,
    )
    _product_matrix_transposed(left, q_SF, row)
    return kind


def _multiply(p, q):
    """quaternion.multiply_values."""
    px, py, pz, pw = p[0], p[1], p[2], p[3]
    qx, qy, qz, qw = q
    return (
        pw * qx + px * qw + py * qz - pz * qy,
        pw * qy - px * qz + py * qw + pz * qx,
        pw * qz + px * qy - py * qx + pz * qw,
        pw * qw - px * qx - py * qy - pz * qz,
    )


def _matrix_quaternion(m):
    """quaternion.matrix_quaternion: Shepperd's method, the first largest pivot, ``w >= 0``."""
    trace = m[0, 0] + m[1, 1] + m[2, 2]
    pivot, largest = 0, m[0, 0]
    for i, value in enumerate((m[1, 1], m[2, 2], trace)):
        if value > largest:
            pivot, largest = i + 1, value
    if pivot == 0:
        q = (1.0 + 2.0 * m[0, 0] - trace, m[1, 0] + m[0, 1], m[2, 0] + m[0, 2], m[2, 1] - m[1, 2])
    elif pivot == 1:
        q = (m[0, 1] + m[1, 0], 1.0 + 2.0 * m[1, 1] - trace, m[2, 1] + m[1, 2], m[0, 2] - m[2, 0])
    elif pivot == 2:
        q = (m[0, 2] + m[2, 0], m[1, 2] + m[2, 1], 1.0 + 2.0 * m[2, 2] - trace, m[1, 0] - m[0, 1])
    else:
        q = (m[2, 1] - m[1, 2], m[0, 2] - m[2, 0], m[1, 0] - m[0, 1], 1.0 + trace)
    norm = _norm(q)
    norm = norm if q[3] >= 0.0 else -norm
    return (q[0] / norm, q[1] / norm, q[2] / norm, q[3] / norm)


def _product_matrix_transposed(left, right, row):
    """quaternion.product_matrix_values(left, right), transposed, into the row's frame change."""
    px, py, pz, pw = left
    qx, qy, qz, qw = right
    r = ((qw, qz, -qy, qx), (-qz, qw, qx, qy), (qy, -qx, qw, qz), (-qx, -qy, -qz, qw))
    by_left = ((pw, -pz, py, px), (pz, pw, -px, py), (-py, px, pw, pz), (-px, -py, -pz, pw))
    for i in range(4):
        a, b, c, d = by_left[i]
        for j in range(4):  # element (i, j) of the product matrix is (j, i) of the frame change
            row[FRAME_CHANGE_ROWS + 4 * j + i] = (
                a * r[0][j] + b * r[1][j] + c * r[2][j] + d * r[3][j]
            )


def _theta_constants(K, Kc, m, n, trigonometric, k_prime, row):
    """elliptic._ThetaPhase and _ThetaSeries for one parameter, into the row."""
    # _third_kind_shift
    moving = n < 0.0
    d = m - n if moving else 1.0
    b = math.sqrt(-n / d) * _rf(
        m / d if moving else 1.0, m * (1.0 - n) / d if moving else 1.0, 1.0
    )
    bc = _rf(-n / (1.0 - n), (m - n) / (1.0 - n), 1.0) / math.sqrt(1.0 - n)
    ratio = Kc / K if trigonometric else K / Kc
    q = math.exp(-math.pi * ratio)
    q2 = q * q
    q4 = q2 * q2
    q6, q9, q12 = q4 * q2, q4 * q4 * q, q4 * q4 * q4
    t2 = ((1.0 + q2) + q6) + q12
    t3 = 1.0 + 2.0 * ((q + q4) + q9)
    t4 = 1.0 + 2.0 * ((q4 - q) - q9)
    row[PER_PERIOD], row[PERIOD] = 0.5 / K, 2.0 * K
    row[SCALE] = (0.5 * math.pi) / (K if trigonometric else Kc)
    if trigonometric:
        first = TRIGONOMETRIC_CUBICS
        _set_cubic(
            row,
            first,
            t3 / t2,
            ((1.0 - 3.0 * q2) + 5.0 * q6) - 7.0 * q12,
            (4.0 * q2 - 20.0 * q6) + 56.0 * q12,
            16.0 * q6 - 112.0 * q12,
            64.0 * q12,
        )
        _set_cubic(
            row,
            first + 4,
            t4 / t2,
            t2,
            (-4.0 * q2 - 12.0 * q6) - 24.0 * q12,
            16.0 * q6 + 80.0 * q12,
            -64.0 * q12,
        )
        _set_cubic(
            row,
            first + 8,
            t4 / t3,
            t3,
            (-4.0 * q - 16.0 * q4) - 36.0 * q9,
            16.0 * q4 + 96.0 * q9,
            -64.0 * q9,
        )
        _set_cubic(
            row,
            first + 12,
            1.0,
            t4,
            (4.0 * q - 16.0 * q4) + 36.0 * q9,
            16.0 * q4 - 96.0 * q9,
            64.0 * q9,
        )
        row[BASE] = _trigonometric_phase(K, Kc, b, bc, row, first + 16)
    else:
        first = HYPERBOLIC_CUBICS
        _set_cubic(
            row,
            first,
            t3 / t4,
            ((1.0 - q2) - q6) + q12,
            (2.0 * q6 - 2.0 * q2) + 4.0 * q12,
            4.0 * q6 - 4.0 * q12,
            -8.0 * q12,
        )
        _set_cubic(
            row,
            first + 4,
            1.0,
            ((1.0 - q2) - q6) + q12,
            (2.0 * q2 - 2.0 * q6) - 4.0 * q12,
            4.0 * q6 - 4.0 * q12,
            8.0 * q12,
        )
        _set_cubic(row, first + 8, t2 / t3, 1.0 - 2.0 * q4, 2.0 * q - 6.0 * q9, 4.0 * q4, 8.0 * q9)
        _set_cubic(
            row, first + 12, t2 / t4, 1.0 - 2.0 * q4, 6.0 * q9 - 2.0 * q, 4.0 * q4, -8.0 * q9
        )
        _hyperbolic_phase(K, Kc, b, bc, row, first + 16)
        row[QUARTER], row[HALF_QUARTER], row[K_PRIME] = K, 0.5 * K, k_prime
        row[KAPPA] = (math.pi * b) / (2.0 * K * Kc)


def _set_cubic(row, at, factor, c0, c1, c2, c3):
    row[at], row[at + 1], row[at + 2], row[at + 3] = (
        factor * c0,
        factor * c1,
        factor * c2,
        factor * c3,
    )


def _trigonometric_phase(K, Kc, b, bc, row, at):
    """elliptic._ThetaPhase._trigonometric: the two cubics into the row; returns theta4(i beta)."""
    L = math.pi / K
    q, rho, sigma = math.exp(-L * Kc), math.exp(-L * bc), math.exp(-L * (Kc + b))
    q2 = q * q
    q6 = q2 * q2 * q2
    spread = (1.0, q2, q6, q6 * q6)
    up = (
        rho,
        rho * rho * spread[1],
        rho * rho * rho * spread[2],
        (rho * rho) * (rho * rho) * spread[3],
    )
    down = (
        sigma,
        sigma * sigma * spread[1],
        sigma * sigma * sigma * spread[2],
        (sigma * sigma) * (sigma * sigma) * spread[3],
    )
    C1, C2, C3, C4 = (
        0.5 * (up[0] + down[0]),
        0.5 * (up[1] + down[1]),
        0.5 * (up[2] + down[2]),
        0.5 * (up[3] + down[3]),
    )
    x = L * b
    sh = math.sinh(min(max(x, 0.0), 1.0))
    sh2 = sh * sh
    sinh2 = 2.0 * sh * math.sqrt(1.0 + sh2)
    small = (sh, sinh2, sh * (3.0 + 4.0 * sh2), 2.0 * sinh2 * (1.0 + 2.0 * sh2))
    q_squares = (q, q2 * q2, q6 * q2 * q, (q6 * q2) * (q6 * q2))
    S = [0.0, 0.0, 0.0, 0.0]
    for j in range(4):
        S[j] = q_squares[j] * small[j] if (j + 1) * x < 1.0 else 0.5 * (up[j] - down[j])
    S1, S2, S3, S4 = S[0], S[1], S[2], S[3]
    base = -math.expm1(-L * bc)
    q_even = 1.0
    for _ in range(6):
        q_before, q_even = q_even, q_even * q2
        base = base * ((1.0 - q_even) * (1.0 - sigma * q_before) * (1.0 - rho * q_even))
    _set_cubic(
        row,
        at,
        1.0,
        4.0 * (((C1 - 4.0 * C2) + 9.0 * C3) - 16.0 * C4),
        4.0 * ((4.0 * C2 - 24.0 * C3) + 80.0 * C4),
        4.0 * (16.0 * C3 - 128.0 * C4),
        256.0 * C4,
    )
    _set_cubic(
        row,
        at + 4,
        1.0,
        4.0 * (((S1 - 2.0 * S2) + 3.0 * S3) - 4.0 * S4),
        4.0 * ((4.0 * S2 - 16.0 * S3) + 40.0 * S4),
        4.0 * (16.0 * S3 - 96.0 * S4),
        256.0 * S4,
    )
    return base


def _hyperbolic_phase(K, Kc, b, bc, row, at):
    """elliptic._ThetaPhase._hyperbolic: the four cubics into the row."""
    q = math.exp(-math.pi * (K / Kc))
    q2 = q * q
    q4 = q2 * q2
    q6, q9, q12 = q4 * q2, q4 * q4 * q, q4 * q4 * q4
    direct = b <= bc
    angle = (0.5 * math.pi / Kc) * (b if direct else bc)
    sin_angle, cos_angle = math.sin(angle), math.cos(angle)
    sg, cg = (sin_angle, cos_angle) if direct else (cos_angle, sin_angle)
    v = sg * sg
    c0, c1 = cg, cg * (1.0 - 4.0 * v)
    c2, c3 = (
        cg * ((1.0 - 12.0 * v) + 16.0 * v * v),
        cg * (((1.0 - 24.0 * v) + 80.0 * v * v) - 64.0 * v * v * v),
    )
    s0, s1 = sg, sg * (3.0 - 4.0 * v)
    s2, s3 = (
        sg * ((5.0 - 20.0 * v) + 16.0 * v * v),
        sg * (((7.0 - 56.0 * v) + 112.0 * v * v) - 64.0 * v * v * v),
    )
    cos2 = 1.0 - 2.0 * v
    sin2 = 2.0 * sg * cg
    cos4, sin4 = 2.0 * cos2 * cos2 - 1.0, 2.0 * sin2 * cos2
    cos6, sin6 = cos2 * (4.0 * cos2 * cos2 - 3.0), sin2 * (3.0 - 4.0 * sin2 * sin2)
    _set_cubic(
        row,
        at,
        1.0,
        ((c0 - q2 * c1) - q6 * c2) + q12 * c3,
        (2.0 * q2 * c1 - 2.0 * q6 * c2) - 4.0 * q12 * c3,
        4.0 * q6 * c2 - 4.0 * q12 * c3,
        8.0 * q12 * c3,
    )
    _set_cubic(
        row,
        at + 4,
        1.0,
        ((s0 + q2 * s1) - q6 * s2) - q12 * s3,
        (2.0 * q2 * s1 + 2.0 * q6 * s2) - 4.0 * q12 * s3,
        4.0 * q6 * s2 + 4.0 * q12 * s3,
        8.0 * q12 * s3,
    )
    _set_cubic(
        row,
        at + 8,
        1.0,
        1.0 - 2.0 * q4 * cos4,
        2.0 * q * cos2 - 6.0 * q9 * cos6,
        4.0 * q4 * cos4,
        8.0 * q9 * cos6,
    )
    _set_cubic(
        row,
        at + 12,
        1.0,
        4.0 * q9 * sin6 - 4.0 * q * sin2,
        -8.0 * q4 * sin4,
        -16.0 * q9 * sin6,
        0.0 * q,
    )
