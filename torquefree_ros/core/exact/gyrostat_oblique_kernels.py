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
The oblique free gyrostat's evaluation compiled by numba, when installed (one family of kernels).

The per-sample work of :mod:`.gyrostat_oblique`'s numpy path (:class:`.ObliqueRates`'
``state`` and ``momentum_direction`` with :class:`.elliptic.JacobiElliptic`'s ``sn, cn, dn``,
:class:`.PeriodicIntegral`'s Clenshaw recurrence, in ``1 + tanh`` for a separatrix's
:class:`.WholeLineIntegral`, :class:`.ObliqueAttitude`'s quaternions) as
scalar code that repeats it operation for operation, in the same order; that path stays the
reference and the tests hold the two together (test_gyrostat_oblique_kernels.py). The constants
are the Python path's own, copied into rows (:func:`rates_row`, :func:`attitude_row`): the
decimal arithmetic and the series are built once in Python, only the evaluation is compiled.

Why: the numpy path's cost is per array operation, whatever a block's length; compiled, a
sample costs less than twice the free body's compiled sample (issue 43's bound, measured by
``tools/bench_exact.py``).

What differs: numpy's vectorised ``sin``/``cos``/``tanh``/``cosh`` against the C library's,
and the order of the three-term dot products (numpy's ``matmul`` and ``einsum`` against a plain
sum), in the last bits of some samples.

``sn, cn, dn`` are :mod:`.gyrostat_kernels`' (the principal-axis gyrostat's) repeated here, not
called there: numba rebuilds a cached function only when its own file changes
(:mod:`..numerics.kernels`).
"""

from __future__ import annotations

import math

import numpy as np

from ..numerics.kernels import KernelFamily

# the rates' row: the form, the Jacobi functions' constants (as gyrostat_kernels' row) ...
FORM, MMC, MC, RATE, TURNING_TIME, BASE_TIME, SLOPE_SCALE, Z_SCALE = range(8)
JACOBI, PER_PERIOD, PERIOD, SCALE, QUARTER, HALF_QUARTER, K_PRIME = range(8, 15)
CUBICS = 15  # four cubics, cubic i's coefficient of power p at CUBICS + 4 i + p
# ... the turning point's form: its planes, the pencil's a2, a1, a0 (coefficients of X^j Y^(deg -
# j), degrees 1, 2, 3) and the tangent ...
START, END, TANGENT = 31, 34, 37
A2, A1, A0 = 40, 42, 45
# ... the initial point's form (gyrostat_oblique.InitialForm) ...
SLOPE_WEIGHT, NUMERATOR, DENOMINATOR, TURN_QUARTIC, TURN_SLOPE = 49, 50, 53, 56, 61
INITIAL_A2, INITIAL_A1, INITIAL_A0, PLANE_AXES = 64, 66, 69, 73  # PLANE_AXES: p0 then p1
# ... and the state at the base point
MOMENTUM0, RATE0, INVERSE_MOMENTS = 79, 82, 85
RATES_WIDTH = 88

# the attitude's row (ObliqueAttitude)
H, TWO_H, PSI_RATE, ANGLE_PERIOD = 0, 1, 2, 3
FRAME_ROWS, AXES_ROWS = 4, 13  # E and the principal axes, 3x3 each, row by row
FRAME_CHANGE_ROWS = 22  # q = x @ matrix, 4x4 row by row
# on a separatrix (WholeLineIntegral; ANGLE_RATE 0 otherwise): the angle's series in sigma = 1 +
# tanh(rate (t - centre)), its slope in sigma and its value at t = 0
ANGLE_RATE, ANGLE_CENTRE, ANGLE_SLOPE, ANGLE_OFFSET = 38, 39, 40, 41
ATTITUDE_WIDTH = 42

#: gyrostat_oblique.BASE_POINT_MARGIN (a literal: compiled code keeps what it read)
BASE_POINT_MARGIN = 0.05


def rates_row(motion, jacobi, one_real_root: bool) -> np.ndarray:
    """Return an :class:`.ObliqueMotion`'s constants and its Jacobi functions' as a row."""
    row = np.zeros(RATES_WIDTH)
    row[FORM] = 1.0 if one_real_root else 0.0
    row[MMC], row[MC], row[RATE] = motion.m * motion.mc, motion.mc, motion.rate
    row[TURNING_TIME], row[BASE_TIME] = motion.turning_time, motion.base_time
    row[SLOPE_SCALE], row[Z_SCALE] = motion.slope_scale, -2.0 * motion.rate ** 3
    theta = jacobi._theta
    if theta is None:
        row[JACOBI] = 2.0
    else:
        row[JACOBI] = 0.0 if theta.trigonometric else 1.0
        row[PER_PERIOD], row[PERIOD], row[SCALE] = (
            float(jacobi._per_period),
            float(jacobi._period),
            float(theta.scale),
        )
        row[QUARTER], row[HALF_QUARTER], row[K_PRIME] = (
            float(jacobi._K),
            float(jacobi._half_K),
            float(jacobi._k_prime),
        )
        cubics = theta.cubics
        for i in range(4):
            for p in range(4):
                row[CUBICS + 4 * i + p] = float(cubics[p][i, 0])
    row[START: START + 3], row[END: END + 3] = motion.planes
    row[TANGENT: TANGENT + 3] = motion.tangent
    _, _, a2, a1, a0 = motion.pencil
    row[A2: A2 + 2], row[A1: A1 + 3], row[A0: A0 + 4] = a2, a1, a0
    form = motion.initial
    row[SLOPE_WEIGHT] = form.slope_weight
    row[NUMERATOR: NUMERATOR + 3] = form.numerator
    row[DENOMINATOR: DENOMINATOR + 3] = form.denominator
    row[TURN_QUARTIC: TURN_QUARTIC + 5] = form.turn_quartic
    row[TURN_SLOPE: TURN_SLOPE + 3] = form.turn_slope
    row[INITIAL_A2: INITIAL_A2 + 2] = form.a2
    row[INITIAL_A1: INITIAL_A1 + 3] = form.a1
    row[INITIAL_A0: INITIAL_A0 + 4] = form.a0
    row[PLANE_AXES: PLANE_AXES + 6] = np.concatenate(form.plane_axes)
    row[MOMENTUM0: MOMENTUM0 + 3] = motion.momentum0
    row[RATE0: RATE0 + 3] = motion.rate0
    row[INVERSE_MOMENTS: INVERSE_MOMENTS + 3] = motion.inverse_moments
    return row


def attitude_row(
    momentum, psi_rate, period, frame, axes, frame_change_rows, whole_line=None
) -> np.ndarray:
    """
    Return an :class:`.ObliqueAttitude`'s constants as a row (the angle's series apart).

    ``whole_line``: the angle's :class:`.WholeLineIntegral` on a separatrix (``period`` inf).
    """
    row = np.zeros(ATTITUDE_WIDTH)
    if whole_line is not None:
        period = whole_line.series.period
        row[ANGLE_RATE], row[ANGLE_CENTRE] = whole_line.rate, whole_line.centre
        row[ANGLE_SLOPE], row[ANGLE_OFFSET] = whole_line.series.mean, whole_line.offset
    row[H], row[TWO_H], row[PSI_RATE], row[ANGLE_PERIOD] = (
        momentum,
        2.0 * momentum,
        psi_rate,
        period,
    )
    row[FRAME_ROWS: FRAME_ROWS + 9] = np.asarray(frame, dtype=float).ravel()
    row[AXES_ROWS: AXES_ROWS + 9] = np.asarray(axes, dtype=float).ravel()
    row[FRAME_CHANGE_ROWS: FRAME_CHANGE_ROWS + 16] = np.ravel(frame_change_rows)
    return row


def kernels() -> dict:
    """Return the compiled kernels by name (numba imported, the family compiled, at first use)."""
    _FAMILY.load()
    return {
        name: globals()[name]
        for name in ('state_kernel', 'direction_kernel', 'attitude_kernel', 'periodic_kernel')
    }


# The GIL stays held (no nogil), as the other exact kernels: a call is microseconds.
_FAMILY = KernelFamily(
    globals(),
    (
        '_horner',
        '_jacobi',
        '_homogeneous',
        '_direction',
        '_initial_direction',
        '_turning_values',
        '_momentum_direction',
        '_state',
        '_periodic',
        'state_kernel',
        'direction_kernel',
        'attitude_kernel',
        'periodic_kernel',
    ),
)


def _horner(c, first, x):
    return ((c[first + 3] * x + c[first + 2]) * x + c[first + 1]) * x + c[first]


def _jacobi(c, u):
    """Return ``sn, cn, dn`` at ``u``: :meth:`.elliptic.JacobiElliptic.__call__` (no ``S``)."""
    kind = c[JACOBI]
    if kind == 2.0:  # the separatrix: sn = tanh, cn = dn = sech
        e = math.exp(-abs(u))
        sech = 2.0 * e / (1.0 + e * e)
        return math.tanh(u), sech, sech
    half_periods = np.rint(u * c[PER_PERIOD])
    r = u - c[PERIOD] * half_periods
    # (-1)^j: j mod 2 by floor, exact for whole floats (Python's % on floats is a libm fmod)
    parity = 1.0 - 2.0 * (half_periods - 2.0 * math.floor(0.5 * half_periods))
    k = CUBICS
    if kind == 0.0:  # _whole_half_period
        z = c[SCALE] * r
        sine, cosine = math.sin(z), math.cos(z)
        s = sine * sine
        inverse = 1.0 / _horner(c, k + 12, s)
        reduced_sn = (_horner(c, k, s) * inverse) * sine
        reduced_cn = (_horner(c, k + 4, s) * inverse) * cosine
        dn = _horner(c, k + 8, s) * inverse
        return parity * reduced_sn, parity * reduced_cn, dn
    # _two_halves
    a = abs(r)
    first = a <= c[HALF_QUARTER]
    w = a if first else c[QUARTER] - a
    y = c[SCALE] * w
    ch, th = math.cosh(y), math.tanh(y)
    x = 2.0 * (ch * ch) - 1.0
    A, B = _horner(c, k, x), _horner(c, k + 4, x)
    C, D = _horner(c, k + 8, x), _horner(c, k + 12, x)
    sh_A, ch_B = (th * ch) * A, ch * B
    inverse = 1.0 / (ch_B if first else C)
    reduced_sn = math.copysign((sh_A if first else D) * inverse, r)
    reduced_cn = (D if first else c[K_PRIME] * sh_A) * inverse
    dn = (C if first else c[K_PRIME] * ch_B) * inverse
    return parity * reduced_sn, parity * reduced_cn, dn


def _homogeneous(c, first, degree, X, Y):
    """Return ``sum c_j X^j Y^(deg - j)``: ``gyrostat_oblique._homogeneous``."""
    total = c[first + degree]
    power = Y
    for j in range(degree - 1, -1, -1):
        total = total * X + c[first + j] * power
        power = power * Y
    return total


def _direction(c, p0, p1, p2, y, a2, a1, a0):
    """Return ``v = num d + den p``: ``gyrostat_oblique._direction``, one sample."""
    if a1 * y <= 0.0:
        num, den = y - a1, 2.0 * a2
    else:
        num, den = 2.0 * a0, -a1 - y
    d = TANGENT
    return num * c[d] + den * p0, num * c[d + 1] + den * p1, num * c[d + 2] + den * p2


def _initial_direction(c, t):
    """Return ``v`` from the initial point's form: ``ObliqueRates._initial_direction``."""
    sn, cn, dn = _jacobi(c, c[RATE] * (t - c[BASE_TIME]))
    X, Y = sn * sn, cn * cn
    Z = ((c[Z_SCALE] * sn) * cn) * dn
    if c[FORM] == 1.0:
        dn2, sn4 = dn * dn, X * X
        X = X * dn2
        Y = Y * Y - c[MC] * sn4
        Z = Z * (dn2 * dn2 + c[MMC] * sn4)
    N = c[SLOPE_WEIGHT] * Z + _homogeneous(c, NUMERATOR, 2, X, Y)
    D = _homogeneous(c, DENOMINATOR, 2, X, Y)
    y = _homogeneous(c, TURN_QUARTIC, 4, X, Y) + Z * _homogeneous(c, TURN_SLOPE, 2, X, Y)
    a2 = c[INITIAL_A2] * D + c[INITIAL_A2 + 1] * N
    f = INITIAL_A1
    a1 = ((c[f] * D) * D + (c[f + 1] * D) * N) + (c[f + 2] * N) * N
    f = INITIAL_A0
    a0 = ((c[f] * D + c[f + 1] * N) * D + (c[f + 2] * N) * N) * D + ((c[f + 3] * N) * N) * N
    p = PLANE_AXES
    return _direction(
        c,
        D * c[p] + N * c[p + 3],
        D * c[p + 1] + N * c[p + 4],
        D * c[p + 2] + N * c[p + 5],
        y,
        a2,
        a1,
        a0,
    )


def _turning_values(c, t):
    """Return ``sn, cn, dn`` of the turning point's form at ``t``."""
    return _jacobi(c, c[RATE] * (t - c[TURNING_TIME]))


def _momentum_direction(c, t, sn, cn, dn):
    """
    Return ``v``: :meth:`.ObliqueRates.momentum_direction`, one sample.

    From :func:`_turning_values` at ``t``, taken apart: the kernels form them for a whole block
    first, so that the processor overlaps the long chains of the samples (a third faster).
    """
    X, Y = sn * sn, cn * cn
    y = ((c[SLOPE_SCALE] * sn) * cn) * dn
    if c[FORM] == 1.0:
        dn2, sn4 = dn * dn, X * X
        y = y * (dn2 * dn2 + c[MMC] * sn4)
        X = X * dn2
        Y = Y * Y - c[MC] * sn4
    a2 = _homogeneous(c, A2, 1, X, Y)
    a1 = _homogeneous(c, A1, 2, X, Y)
    a0 = _homogeneous(c, A0, 3, X, Y)
    v0, v1, v2 = _direction(
        c,
        Y * c[START] + X * c[END],
        Y * c[START + 1] + X * c[END + 1],
        Y * c[START + 2] + X * c[END + 2],
        y,
        a2,
        a1,
        a0,
    )
    along = abs((v0 * c[TANGENT] + v1 * c[TANGENT + 1]) + v2 * c[TANGENT + 2])
    if along * along > (1.0 - BASE_POINT_MARGIN ** 2) * ((v0 * v0 + v1 * v1) + v2 * v2):
        return _initial_direction(c, t)
    return v0, v1, v2


def _state(c, t, sn, cn, dn):
    """Return ``(w, m)`` as six values: :meth:`.ObliqueRates.state`, one sample."""
    v0, v1, v2 = _momentum_direction(c, t, sn, cn, dn)
    m = MOMENTUM0
    k = -2.0 * ((v0 * c[m] + v1 * c[m + 1]) + v2 * c[m + 2]) / ((v0 * v0 + v1 * v1) + v2 * v2)
    g0, g1, g2 = k * v0, k * v1, k * v2
    w, a = RATE0, INVERSE_MOMENTS
    return (
        c[w] + g0 * c[a],
        c[w + 1] + g1 * c[a + 1],
        c[w + 2] + g2 * c[a + 2],
        c[m] + g0,
        c[m + 1] + g1,
        c[m + 2] + g2,
    )


def _periodic(period, starts, middles, scales, table, t, f):
    """
    Return function ``f``'s ``P(t)``: :meth:`.PeriodicIntegral.__call__`, one value.

    ``middles`` and ``scales``: each panel's ``start + width / 2`` and ``2 / width``.
    """
    r = t - period * math.floor(t / period)
    # the last panel starting at or before r (searchsorted 'right', less one, clipped)
    low, high = 0, starts.shape[0]
    while low < high:
        middle = (low + high) // 2
        if starts[middle] <= r:
            low = middle + 1
        else:
            high = middle
    index = min(max(low - 1, 0), starts.shape[0] - 1)
    x = (r - middles[index]) * scales[index]
    two_x = x + x
    last = table.shape[0] - 1
    b1, b2 = table[last, index, f], 0.0
    for k in range(last - 1, 0, -1):
        b1, b2 = two_x * b1 - b2 + table[k, index, f], b1
    return x * b1 - b2 + table[0, index, f]


def state_kernel(t, c, omega, momentum):
    """Fill ``omega (samples, 3)`` and ``momentum (samples, 3)``, principal frame, at ``t``."""
    for i in range(t.shape[0]):  # sn, cn, dn first (in omega's place)
        omega[i, 0], omega[i, 1], omega[i, 2] = _turning_values(c, t[i])
    for i in range(t.shape[0]):
        w0, w1, w2, m0, m1, m2 = _state(c, t[i], omega[i, 0], omega[i, 1], omega[i, 2])
        omega[i, 0], omega[i, 1], omega[i, 2] = w0, w1, w2
        momentum[i, 0], momentum[i, 1], momentum[i, 2] = m0, m1, m2


def direction_kernel(t, c, out):
    """Fill ``out (samples, 3)`` with :meth:`.ObliqueRates.momentum_direction`'s ``v``."""
    for i in range(t.shape[0]):
        out[i, 0], out[i, 1], out[i, 2] = _turning_values(c, t[i])
    for i in range(t.shape[0]):
        out[i, 0], out[i, 1], out[i, 2] = _momentum_direction(
            c, t[i], out[i, 0], out[i, 1], out[i, 2]
        )


def periodic_kernel(t, period, starts, middles, scales, table, out):
    """Fill ``out (samples, functions)`` with :class:`.PeriodicIntegral`'s ``P(t)``."""
    for i in range(t.shape[0]):
        for f in range(table.shape[2]):
            out[i, f] = _periodic(period, starts, middles, scales, table, t[i], f)


def attitude_kernel(t, c, a, starts, middles, scales, table, omega, q):
    """
    Fill ``omega (samples, 3)`` (body frame) and ``q (samples, 4)`` at the times ``t``.

    :meth:`.ObliqueAttitude.__call__`, sample by sample; ``a`` the attitude's row, ``starts,
    middles, scales, table`` its angle's series. The angle's series and ``sn, cn, dn`` first,
    for the whole block (in ``q``'s place), then the rest (see :func:`_momentum_direction`).
    """
    for i in range(t.shape[0]):
        if a[ANGLE_RATE] > 0.0:  # WholeLineIntegral.__call__
            sigma = 1.0 + math.tanh(a[ANGLE_RATE] * (t[i] - a[ANGLE_CENTRE]))
            series = _periodic(a[ANGLE_PERIOD], starts, middles, scales, table, sigma, 0)
            q[i, 0] = (series + a[ANGLE_SLOPE] * sigma) - a[ANGLE_OFFSET]
        else:
            q[i, 0] = _periodic(a[ANGLE_PERIOD], starts, middles, scales, table, t[i], 0)
        q[i, 1], q[i, 2], q[i, 3] = _turning_values(c, t[i])
    for i in range(t.shape[0]):
        w0, w1, w2, m0, m1, m2 = _state(c, t[i], q[i, 1], q[i, 2], q[i, 3])
        e = FRAME_ROWS
        mA0 = (m0 * a[e] + m1 * a[e + 1]) + m2 * a[e + 2]
        mA1 = (m0 * a[e + 3] + m1 * a[e + 4]) + m2 * a[e + 5]
        mA2 = (m0 * a[e + 6] + m1 * a[e + 7]) + m2 * a[e + 8]
        arc = a[H] + mA2
        half = 0.5 * (a[PSI_RATE] * t[i] + q[i, 0])
        scale = 1.0 / math.sqrt(a[TWO_H] * arc)
        cos_half, sin_half = math.cos(half) * scale, math.sin(half) * scale
        x, y = cos_half * mA1 + sin_half * mA0, sin_half * mA1 - cos_half * mA0
        z, s = sin_half * arc, cos_half * arc
        f = FRAME_CHANGE_ROWS
        for j in range(4):
            q[i, j] = ((x * a[f + j] + y * a[f + 4 + j]) + z * a[f + 8 + j]) + s * a[f + 12 + j]
        b = AXES_ROWS
        omega[i, 0] = (w0 * a[b] + w1 * a[b + 1]) + w2 * a[b + 2]
        omega[i, 1] = (w0 * a[b + 3] + w1 * a[b + 4]) + w2 * a[b + 5]
        omega[i, 2] = (w0 * a[b + 6] + w1 * a[b + 7]) + w2 * a[b + 8]
