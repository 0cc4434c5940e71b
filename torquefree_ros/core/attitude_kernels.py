"""The exact attitude's per-sample evaluation compiled by numba, when it is installed (the ``fast``
extra): the same formulas, in the same order of IEEE operations, as :class:`.polhode.PolhodeAttitude`
and :class:`.elliptic.JacobiElliptic` evaluate with numpy arrays (their numpy path is the reference;
the tests hold the two together), written as one loop over samples.

Why: numpy's cost is ~0.5 µs per array operation whatever its length, and a sample takes ~80 of them,
so a call of a few hundred samples (the node's block) pays more for operations than for arithmetic.
Compiled, a call costs ~2 µs and a sample ~0.1 µs at any block size.

A body's constants are one row of a table (``TABLE_WIDTH`` floats, the layout below); many bodies are
rows of one table and fill ``(bodies, samples, 3 | 4)`` outputs. ``TORQUEFREE_ROS_KERNELS=numpy`` in the
environment turns the kernels off (the numpy path then runs, as without numba).
"""

from __future__ import annotations

import functools
import importlib.util
import math
import os

import numpy as np

#: numba is installed (imported only when a kernel is first asked for: it adds ~0.2 s to an import)
AVAILABLE = importlib.util.find_spec("numba") is not None
#: whether the exact attitude evaluates through these kernels (read when a propagator is built)
ENABLED = AVAILABLE and os.environ.get("TORQUEFREE_ROS_KERNELS", "numba") != "numpy"

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


def table(jacobi, rate, constants) -> np.ndarray:
    """The constants' table ``(bodies, TABLE_WIDTH)`` of a :class:`.polhode.PolhodeAttitude`: the same
    values its numpy path evaluates with (``jacobi`` off the separatrix; values floats for one body,
    arrays ``(N,)`` over bodies)."""
    c, theta = constants, jacobi._theta
    K = jacobi.quarter_period
    periodic = (0.5 / K, 2.0 * K, theta.scale) if theta is not None else (0.0, 0.0, 0.0)
    values = [rate, c.initial_phase, *periodic, c.momentum, 2.0 * c.momentum,
              *c.momentum_amplitudes, *c.lever, 0.5 * c.direction, 0.5 * c.psi_rate, 0.5 * c.psi_offset,
              *(v for row in c.rate_matrix for v in row), *(v for row in c.frame_change for v in row)]
    if theta is None:
        values += [math.sqrt(-jacobi.n)]
    else:
        values += [theta.phase.base] if theta.trigonometric else [K, 0.5 * K, jacobi.k_prime, theta.phase.kappa]
        values += [v for cubic in theta.rows + list(theta.phase.cubics) for v in cubic]
    if not isinstance(rate, np.ndarray):  # one body
        return np.array([values + [0.0] * (TABLE_WIDTH - len(values))])
    columns = np.zeros((TABLE_WIDTH, rate.size))
    columns[:len(values)] = np.array([np.broadcast_to(v, rate.shape) for v in values])
    return np.ascontiguousarray(columns.T)


def kernel(kind: str):
    """The compiled kernel for ``kind``, ``"trigonometric"`` (``m <= 1/2``), ``"hyperbolic"`` or
    ``"separatrix"`` (numba imported, and the functions below compiled on their first call, the first
    time one is asked for)."""
    _compile()
    return globals()[kind + "_kernel"]


@functools.cache
def _compile() -> None:
    """Replace the functions below by numba's compiled ones, callees first (a compiled function calls
    what its module's globals hold when it compiles). Kept in numba's cache next to this file, or in the
    user's cache directory when the install is read-only; error_model="numpy": a division by zero gives
    inf, as numpy's does."""
    import numba

    def jit(function):
        try:
            return numba.njit(cache=True, nogil=True, error_model="numpy")(function)
        except RuntimeError:  # no writable cache anywhere: compile in every process
            return numba.njit(nogil=True, error_model="numpy")(function)

    for name in ("_horner", "_phase_minus_angle", "_finish", "trigonometric_kernel", "hyperbolic_kernel",
                 "separatrix_kernel"):
        globals()[name] = jit(globals()[name])


def _horner(c, first, x):
    return ((c[first + 3] * x + c[first + 2]) * x + c[first + 1]) * x + c[first]


def _phase_minus_angle(c, re, im, reduced_sn, reduced_cn, half_periods):
    """:meth:`.elliptic.JacobiValues.phase_minus_angle` at the lever, without the linear term."""
    x, y = c[LEVER] * reduced_cn, c[LEVER + 1] * reduced_sn
    return math.atan2(im * x - re * y, re * x + im * y) - np.pi * half_periods


def _finish(c, t, sn, cn, dn, difference, omega, q):
    """What :meth:`.polhode.PolhodeAttitude._pass` does with the Jacobi values of one sample."""
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
    """``m <= 1/2``: :meth:`.elliptic.JacobiElliptic._whole_half_period` with the phase, then the
    attitude; ``omega (bodies, samples, 3)`` and ``q (bodies, samples, 4)`` are filled."""
    for body in range(constants.shape[0]):
        c = constants[body]
        k = TRIGONOMETRIC_CUBICS
        for i in range(t.shape[0]):
            u = c[RATE] * t[i] + c[INITIAL_PHASE]
            half_periods = np.rint(u * c[PER_PERIOD])
            z = c[SCALE] * (u - c[PERIOD] * half_periods)
            sine, cosine = math.sin(z), math.cos(z)
            s = sine * sine
            inverse = 1.0 / _horner(c, k + 12, s)
            reduced_sn = (_horner(c, k, s) * inverse) * sine
            reduced_cn = (_horner(c, k + 4, s) * inverse) * cosine
            dn = _horner(c, k + 8, s) * inverse
            parity = 1.0 - 2.0 * (half_periods % 2.0)
            re = c[BASE] + s * _horner(c, k + 16, s)
            im = (sine * cosine) * _horner(c, k + 20, s)
            difference = _phase_minus_angle(c, re, im, reduced_sn, reduced_cn, half_periods)
            _finish(c, t[i], parity * reduced_sn, parity * reduced_cn, dn, difference, omega[body, i], q[body, i])


def hyperbolic_kernel(t, constants, omega, q):
    """``m > 1/2``: :meth:`.elliptic.JacobiElliptic._two_halves` with the phase, then the attitude."""
    for body in range(constants.shape[0]):
        c = constants[body]
        k = HYPERBOLIC_CUBICS
        for i in range(t.shape[0]):
            u = c[RATE] * t[i] + c[INITIAL_PHASE]
            half_periods = np.rint(u * c[PER_PERIOD])
            r = u - c[PERIOD] * half_periods
            a = abs(r)
            first = a <= c[HALF_QUARTER]
            w = a if first else c[QUARTER] - a
            y = c[SCALE] * w
            ch, th = math.cosh(y), math.tanh(y)
            ch2 = ch * ch
            x = 2.0 * ch2 - 1.0
            A, B, C, D = _horner(c, k, x), _horner(c, k + 4, x), _horner(c, k + 8, x), _horner(c, k + 12, x)
            sh_A, ch_B = (th * ch) * A, ch * B
            inverse = 1.0 / (ch_B if first else C)
            reduced_sn = math.copysign((sh_A if first else D) * inverse, r)
            reduced_cn = (D if first else c[K_PRIME] * sh_A) * inverse
            dn = (C if first else c[K_PRIME] * ch_B) * inverse
            parity = 1.0 - 2.0 * (half_periods % 2.0)
            if first:
                re, im = _horner(c, k + 16, x), math.copysign(th, r) * _horner(c, k + 20, x)
                linear = -c[KAPPA] * math.copysign(w, r)
            else:
                re, im = _horner(c, k + 24, x), math.copysign(th, r) * (ch2 * _horner(c, k + 28, x))
                linear = c[KAPPA] * math.copysign(w, r)
            difference = _phase_minus_angle(c, re, im, reduced_sn, reduced_cn, half_periods) + linear
            _finish(c, t[i], parity * reduced_sn, parity * reduced_cn, dn, difference, omega[body, i], q[body, i])


def separatrix_kernel(t, constants, omega, q):
    """``m = 1``: :meth:`.elliptic.JacobiElliptic._separatrix` with the phase (``sn = tanh``,
    ``cn = dn = sech``, the phase ``atan2(sqrt(-n) tanh, 1)``), then the attitude."""
    for body in range(constants.shape[0]):
        c = constants[body]
        for i in range(t.shape[0]):
            u = c[RATE] * t[i] + c[INITIAL_PHASE]
            e = math.exp(-abs(u))
            sech = 2.0 * e / (1.0 + e * e)
            tanh = math.tanh(u)
            difference = _phase_minus_angle(c, 1.0, c[ROOT] * tanh, tanh, sech, 0.0)
            _finish(c, t[i], tanh, sech, sech, difference, omega[body, i], q[body, i])
