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
The exact free gyrostat's evaluation compiled by numba, when installed (one family of kernels).

The per-sample work of :meth:`.gyrostat.GyrostatAttitude._pass` (with
:class:`.elliptic.JacobiElliptic`'s ``sn, cn, dn`` and :class:`.gyrostat.AnglePanels`' Clenshaw
recurrence) as scalar code that repeats the numpy path operation for operation, in the same
order; that path stays the reference and the tests hold the two together
(test_gyrostat.py). The constants are the Python path's own, copied into one row
(:func:`table`): the decimal arithmetic and the angle's series are built once in Python, only the
evaluation is compiled.

Why: the numpy path's cost is per array operation (~120 a call), so a block of a few samples (the
node's) pays ~100 µs whatever its length; compiled, a sample costs about what the free body's does.

What differs: numpy's vectorised ``tanh`` and ``sin``/``cos`` against the C library's, in the
last bit of some samples.

Coasting wheels' angles (:meth:`.gyrostat.RateIntegrals.wheel_angles`) have a kernel of their own
here, :func:`wheel_angle_kernel`: the rates' integral series by Clenshaw's recurrence, only for the
rates some wheel's axis has a part along; it sums in another order than numpy's matrix product,
so the two agree to rounding.
"""

from __future__ import annotations

import math

import numpy as np

from ..numerics.kernels import KernelFamily

# the row's columns
RATE, INITIAL_PHASE, FORM, JACOBI = 0, 1, 2, 3  # FORM: 0 sn2, 1 cn; JACOBI: KINDS
PER_PERIOD, PERIOD, SCALE, QUARTER, HALF_QUARTER, K_PRIME = 4, 5, 6, 7, 8, 9
CUBICS = 10  # four cubics, cubic i's coefficient of power p at CUBICS + 4 i + p
WEIGHTS, Z_WEIGHTS, W3_WEIGHTS, MOMENTA = 26, 28, 30, 32  # two each
POWERS = 34  # component i, function f (sn, cn, dn) at POWERS + 3 i + f
ARC_WEIGHTS, MOMENTUM, SIGMA, REFERENCE = 40, 42, 43, 44
PERMUTATION, PERMUTATION_SIGNS = 45, 48  # three each
INVERSE_MOMENTS, PSI_RATE, PSI_OFFSET, TWO_MOMENTUM = 51, 53, 54, 55
RATE_ROWS, FRAME_CHANGE_ROWS = 56, 65  # 3x3 then 4x4, row by row
PANEL_WIDTH, PANEL_COUNT, PANEL_RANGE, PANEL_PERIOD, PERIODIC, INVERSE_WIDTH = (
    81,
    82,
    83,
    84,
    85,
    86,
)
TABLE_WIDTH = 87

#: JacobiElliptic's three evaluations
KINDS = ('trigonometric', 'hyperbolic', 'separatrix')


def table(attitude) -> tuple[np.ndarray, np.ndarray]:
    """
    Return ``(row, panels)``: a :class:`.gyrostat.GyrostatAttitude`'s constants for the kernel.

    ``panels`` is the angle's coefficient table ``(count, degree + 2)``.
    """
    motion = attitude.motion
    rates = attitude.rates
    jacobi = rates.jacobi
    row = np.zeros(TABLE_WIDTH)
    row[RATE], row[INITIAL_PHASE] = motion.rate, motion.initial_phase
    row[FORM] = 0.0 if motion.form == 'sn2' else 1.0
    if jacobi._theta is None:
        row[JACOBI] = 2.0
    else:
        theta = jacobi._theta
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
        for i, cubic in enumerate(_rows(theta.cubics)):
            row[CUBICS + 4 * i: CUBICS + 4 * i + 4] = cubic
    row[WEIGHTS: WEIGHTS + 2] = motion.weights
    row[Z_WEIGHTS: Z_WEIGHTS + 2] = motion.z_weights
    row[W3_WEIGHTS: W3_WEIGHTS + 2] = motion.w3_weights
    row[MOMENTA: MOMENTA + 2] = motion.momenta
    for i, powers in enumerate(motion.powers):
        row[POWERS + 3 * i: POWERS + 3 * i + 3] = powers
    row[ARC_WEIGHTS: ARC_WEIGHTS + 2] = motion.arc_weights
    row[MOMENTUM], row[SIGMA], row[REFERENCE] = (
        motion.momentum,
        motion.reference_sign,
        motion.reference,
    )
    for k, (index, sign) in enumerate(attitude._permutation):
        row[PERMUTATION + k], row[PERMUTATION_SIGNS + k] = index, sign
    row[INVERSE_MOMENTS: INVERSE_MOMENTS + 2] = motion.inverse_moments
    row[PSI_RATE], row[PSI_OFFSET], row[TWO_MOMENTUM] = (
        attitude.psi_rate,
        attitude._psi_offset,
        attitude._two_momentum,
    )
    for k in range(3):
        row[RATE_ROWS + 3 * k: RATE_ROWS + 3 * k + 3] = attitude._rate_rows[k]
    for k in range(4):
        row[FRAME_CHANGE_ROWS + 4 * k: FRAME_CHANGE_ROWS + 4 * k + 4] = (
            attitude._frame_change_rows[k]
        )
    panels = attitude.panels
    row[PANEL_WIDTH], row[PANEL_COUNT], row[PANEL_RANGE] = (
        panels.width,
        panels.count,
        panels.range,
    )
    row[PANEL_PERIOD] = panels.period if panels._periodic else 0.0
    row[PERIODIC] = 1.0 if panels._periodic else 0.0
    row[INVERSE_WIDTH] = panels._inverse_width
    return row, np.ascontiguousarray(panels.coefficients)


# the rate integrals' row (gyrostat.RateIntegrals)
I_RATE, I_PHASE, I_PERIOD, I_START, I_WIDTH, I_COUNT, I_RANGE, I_PERIODIC = range(8)
I_SLOPES, I_AT_START = 8, 14  # (L- , L+) per rate, then P(u0) per rate
INTEGRAL_WIDTH = 17


def integral_row(integrals) -> np.ndarray:
    """Return a :class:`.gyrostat.RateIntegrals`' constants for :func:`wheel_angle_kernel`."""
    row = np.zeros(INTEGRAL_WIDTH)
    row[I_RATE], row[I_PHASE] = integrals.rate, integrals.initial_phase
    periodic = integrals._slopes is None
    row[I_PERIOD] = integrals.period if periodic else 0.0
    row[I_START], row[I_WIDTH] = integrals.start, integrals.width
    row[I_COUNT], row[I_RANGE] = integrals.count, integrals.range
    row[I_PERIODIC] = 1.0 if periodic else 0.0
    if not periodic:
        row[I_SLOPES: I_SLOPES + 6] = np.asarray(integrals._slopes).ravel()
    row[I_AT_START: I_AT_START + 3] = integrals._at_start
    return row


def angle_kernel():
    """Return the compiled wheel angles (numba imported, the family compiled, at first use)."""
    _FAMILY.load()
    return globals()['wheel_angle_kernel']


def _rows(cubics) -> list:
    """Return the four cubics (A, B, C, D) as rows of coefficients, from the stack by power."""
    return [[float(cubics[p][i, 0]) for p in range(4)] for i in range(4)]


def kernel():
    """Return the compiled evaluation (numba imported, the family compiled, on the first call)."""
    _FAMILY.load()
    return globals()['gyrostat_kernel']


# The GIL stays held (no nogil), as the free body's kernels: a call is microseconds.
_FAMILY = KernelFamily(
    globals(),
    (
        '_horner',
        '_jacobi',
        '_angle',
        '_combine_into',
        'gyrostat_kernel',
        '_periodic_part',
        'wheel_angle_kernel',
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
    parity = 1.0 - 2.0 * (half_periods % 2.0)  # (-1)^j
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


def _angle(c, panels, u):
    """Return :class:`.gyrostat.AnglePanels`' ``P(u)``: Clenshaw's recurrence on its panel."""
    if c[PERIODIC] == 1.0:
        r = u - c[PANEL_PERIOD] * np.rint(u / c[PANEL_PERIOD])
    else:
        r = u
    a = min(abs(r), c[PANEL_RANGE])
    index = min(int(a / c[PANEL_WIDTH]), int(c[PANEL_COUNT]) - 1)
    x = (a - (index + 0.5) * c[PANEL_WIDTH]) * c[INVERSE_WIDTH]
    two_x = x + x
    last = panels.shape[1] - 1
    b1, b2 = panels[index, last], 0.0
    for k in range(last - 1, 0, -1):
        b1, b2 = two_x * b1 - b2 + panels[index, k], b1
    value = x * b1 - b2 + panels[index, 0]
    return -value if r < 0.0 else value


def _combine_into(columns, c, first, size, out):
    """Set ``out`` to ``columns @ matrix``, its rows at ``c[first:]`` (``gyrostat._combine``)."""
    for j in range(size):
        total = columns[0] * c[first + j]
        for i in range(1, len(columns)):
            total += columns[i] * c[first + size * i + j]
        out[j] = total


def gyrostat_kernel(t, c, panels, omega, q):
    """
    Fill ``omega (samples, 3)`` and ``q (samples, 4)`` at the times ``t``.

    :meth:`.gyrostat.GyrostatAttitude._pass`, sample by sample.
    """
    for i in range(t.shape[0]):
        u = c[RATE] * t[i] + c[INITIAL_PHASE]
        sn, cn, dn = _jacobi(c, u)
        if c[FORM] == 0.0:
            p, s = cn * cn, sn * sn
        else:
            sn2 = sn * sn
            p = 1.0 + cn if cn > 0.0 else sn2 / (1.0 - cn)
            s = sn2 / (1.0 + cn) if cn > 0.0 else 1.0 - cn
        inverse = 1.0 / (c[WEIGHTS] * p + c[WEIGHTS + 1] * s)
        m1 = c[MOMENTA] * inverse
        m2 = c[MOMENTA + 1] * inverse
        if c[POWERS] == 1.0:
            m1 = m1 * sn
        if c[POWERS + 1] == 1.0:
            m1 = m1 * cn
        if c[POWERS + 2] == 1.0:
            m1 = m1 * dn
        if c[POWERS + 3] == 1.0:
            m2 = m2 * sn
        if c[POWERS + 4] == 1.0:
            m2 = m2 * cn
        if c[POWERS + 5] == 1.0:
            m2 = m2 * dn
        z = (c[Z_WEIGHTS] * p + c[Z_WEIGHTS + 1] * s) * inverse
        w3 = (c[W3_WEIGHTS] * p + c[W3_WEIGHTS + 1] * s) * inverse
        reference = c[REFERENCE]
        if reference == 2.0:
            arc = (c[ARC_WEIGHTS] * p + c[ARC_WEIGHTS + 1] * s) * inverse
        elif reference == 0.0:
            arc = c[MOMENTUM] + c[SIGMA] * m1
        else:
            arc = c[MOMENTUM] + c[SIGMA] * m2
        _combine_into(
            (m1 * c[INVERSE_MOMENTS], m2 * c[INVERSE_MOMENTS + 1], w3), c, RATE_ROWS, 3, omega[i]
        )
        m_S = (m1, m2, z)
        mA1 = c[PERMUTATION_SIGNS] * m_S[int(c[PERMUTATION])]
        mA2 = c[PERMUTATION_SIGNS + 1] * m_S[int(c[PERMUTATION + 1])]
        half = 0.5 * ((c[PSI_RATE] * t[i] + _angle(c, panels, u)) + c[PSI_OFFSET])
        scale = 1.0 / math.sqrt(c[TWO_MOMENTUM] * arc)
        cos_half, sin_half = math.cos(half) * scale, math.sin(half) * scale
        _combine_into(
            (
                cos_half * mA2 + sin_half * mA1,
                sin_half * mA2 - cos_half * mA1,
                sin_half * arc,
                cos_half * arc,
            ),
            c,
            FRAME_CHANGE_ROWS,
            4,
            q[i],
        )


def _periodic_part(c, panels, f, u):
    """Return rate ``f``'s ``P(u)``: :meth:`.gyrostat.RateIntegrals.periodic_part`, one value."""
    if c[I_PERIODIC] == 1.0:
        period = c[I_PERIOD]
        r = u - period * math.floor(u / period)
        r = min(r, np.nextafter(period, 0.0))
        extra = 0.0
    else:
        low, high = c[I_START], c[I_START] + c[I_RANGE]
        r = min(max(u, low), high)
        extra = c[I_SLOPES + 2 * f] * min(u - low, 0.0) + c[I_SLOPES + 2 * f + 1] * max(
            u - high, 0.0
        )
    width = c[I_WIDTH]
    index = max(min(int((r - c[I_START]) / width), int(c[I_COUNT]) - 1), 0)
    x = (r - (c[I_START] + (index + 0.5) * width)) * (2.0 / width)
    two_x = x + x
    last = panels.shape[2] - 1
    b1, b2 = panels[f, index, last], 0.0
    for k in range(last - 1, 0, -1):
        b1, b2 = two_x * b1 - b2 + panels[f, index, k], b1
    return x * b1 - b2 + panels[f, index, 0] + extra


def wheel_angle_kernel(t, c, panels, wheels, out):
    """
    Fill ``out (samples, wheels)`` with the wheels' angles at the times ``t``.

    ``wheels``: per wheel ``(h_i / Js_i - g_i . mean, g_i in the solver frame)``;
    :meth:`.gyrostat.RateIntegrals.wheel_angles`, sample by sample.
    """
    needed = [False, False, False]
    for f in range(3):
        for j in range(wheels.shape[0]):
            if wheels[j, 1 + f] != 0.0:
                needed[f] = True
    for i in range(t.shape[0]):
        u = c[I_RATE] * t[i] + c[I_PHASE]
        # a rate no wheel's axis has a part along is not integrated (a wheel on the rotor axis
        # needs w3's alone): its term is zero either way
        r0 = r1 = r2 = 0.0
        if needed[0]:
            r0 = (_periodic_part(c, panels, 0, u) - c[I_AT_START]) / c[I_RATE]
        if needed[1]:
            r1 = (_periodic_part(c, panels, 1, u) - c[I_AT_START + 1]) / c[I_RATE]
        if needed[2]:
            r2 = (_periodic_part(c, panels, 2, u) - c[I_AT_START + 2]) / c[I_RATE]
        for j in range(wheels.shape[0]):
            out[i, j] = t[i] * wheels[j, 0] - (
                (wheels[j, 1] * r0 + wheels[j, 2] * r1) + wheels[j, 3] * r2
            )
