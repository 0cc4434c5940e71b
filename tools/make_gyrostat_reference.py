#!/usr/bin/env python3
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
Regenerate torquefree_ros/bench/gyrostat_cases.json, the free gyrostat's reference solutions.

High-precision reference solutions of the free gyrostat ``I w' + w x (I w + h) = 0`` (a rotor of
constant relative momentum ``h``, the ``rotor`` effect) for the cases of issue 43, and the float64
floor of each sample.

Independence: the reference integrates the gyrostat's equations in the principal frame and
``q' = 1/2 q ⊗ (w, 0)`` with a Taylor-series method in mpmath (40 significant digits, order 32,
step at most 0.18 of the estimated radius of convergence, so the truncation is below 1e-23 a
step; the invariants are checked to hold to 1e-20, four digits past float64's). It shares nothing
with the closed form in ``torquefree_ros.core.exact.gyrostat`` but the equations of motion. The
states next to a separatrix are found in mpmath too: on the momentum sphere of the chosen ``|m|``,
the point of a meridian whose energy is the separatrix's times ``1 + distance``, rounded to
float64; ``separatrix_distance`` is then recomputed from the rounded state.

The floor of a sample is what float64 itself allows: the change of the exact solution when an
input moves by one rounding unit (2**-53 relative). Each of the seven dynamic inputs (moments,
rates, ``h``) is perturbed in turn and integrated alongside; the responses add in quadrature, plus
the rounding of the sample time (``|w'| t u`` for the rate, ``|w| t u`` for the attitude) and of
``q0`` (``u``).

Coasting reaction wheels (cases with ``wheels``: the ``reaction_wheels`` effect, no motor torque,
no friction) are the same gyrostat with ``I_s = I - sum Js g g^T`` and ``h = sum h_i g_i``,
``h_i = Js_i (speed_i + g_i . w0)``, all formed in mpmath from the float inputs (chosen so that
float64 forms them exactly too); their angles ``theta_i' = h_i / Js_i - g_i . w`` are integrated
alongside, and their floor adds the responses to each ``h_i``'s rounding and ``|Omega| t u``.

Run: ``.venv/bin/python tools/make_gyrostat_reference.py [--jobs 2] [--only NAME ...]`` (30 CPU
minutes, of which the 1e5 s case takes 15: about 20 minutes on 2 cores; ``pip install gmpy2``
makes mpmath about 3x faster). ``--only`` recomputes the cases named and keeps the others.

``--oblique`` makes test/data/gyrostat_oblique_cases.json instead: ``h`` off every principal axis
(``rotor_vector``, principal frame), the reference of
:mod:`torquefree_ros.core.exact.gyrostat_oblique` (about 10 CPU minutes). Its states next to a
separatrix come from the saddles among the relative equilibria (``w_i = h_i / (mu - I_i)``,
``mu`` a real root of a sextic, in mpmath), at ``2T = 2T_saddle (1 + distance)`` on the saddle's
momentum sphere.
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
from pathlib import Path
import platform
import sys
import time

import mp_taylor
from mp_taylor import axis_angle as _q
from mp_taylor import changes, check_invariants, ROUNDING_UNIT, sample_grid
import mpmath as mp
import numpy as np

DIGITS = 40
ORDER = 32
STEP_FRACTION = 0.18  # of the radius of convergence: truncation ~ 0.18**32 ~ 1e-24
INVARIANT_DIGITS = 20  # T, |I w + h| and |q| hold to 1e-20 relative, or the reference is refused
OUTPUT = (
    Path(__file__).resolve().parent.parent / 'torquefree_ros' / 'bench' / 'gyrostat_cases.json'
)


def _unit(k):
    return [1.0 if i == k else 0.0 for i in range(3)]


def _separatrix_energy(inertia, rotor, h, H, saddle):
    """
    Return ``2T`` of a saddle at momentum ``H``: ``('pole', ±1)`` or ``('plane', k)``.

    Poles: ``m = ±H e_rotor``, ``2T = (±H - h)^2 / J_rotor``. Off the poles, in the plane of the
    rotor axis and transverse axis ``k``: ``m_rotor = h J_k / (J_k - J_rotor)``, the rest along
    ``k``.
    """
    J = [mp.mpf(x) for x in inertia]
    kind, which = saddle
    Jr = J[rotor]
    if kind == 'pole':
        return (which * H - h) ** 2 / Jr
    Jk = J[which]
    m_r = h * Jk / (Jk - Jr)
    return (H * H - m_r * m_r) / Jk + (m_r - h) ** 2 / Jr


def _near_separatrix(inertia, rotor, h, H, saddle, distance, meridian):
    """
    Rates with ``|m| = H`` and ``2T = 2T_sep (1 + distance)``, as float64 (principal frame).

    ``meridian``: ``(k, phi, a, b)``: ``m = H (cos t e_rotor + sin t (cos phi e_k + sin phi e_j))``
    for ``t`` in ``[a, b]``, the energy crossing the target there (bisection in mpmath).
    """
    mp.mp.dps = 50
    J = [mp.mpf(x) for x in inertia]
    h, H = mp.mpf(h), mp.mpf(H)
    target = _separatrix_energy(inertia, rotor, h, H, saddle) * (1 + mp.mpf(distance))
    k, phi, a, b = meridian
    j = 3 - rotor - k

    def momentum(t):
        m = [mp.mpf(0)] * 3
        m[rotor] = H * mp.cos(t)
        m[k] = H * mp.sin(t) * mp.cos(phi)
        m[j] = H * mp.sin(t) * mp.sin(phi)
        return m

    def gap(t):
        m = momentum(t)
        m[rotor] -= h
        return mp.fsum(m[i] ** 2 / J[i] for i in range(3)) - target

    a, b = mp.mpf(a), mp.mpf(b)
    if gap(a) * gap(b) >= 0:
        raise ValueError(f'the meridian {meridian} does not cross the energy {target}')
    for _ in range(200):  # bisection: the crossing to 50 digits
        middle = (a + b) / 2
        a, b = (a, middle) if gap(a) * gap(middle) <= 0 else (middle, b)
    t = (a + b) / 2
    m = momentum(t)
    m[rotor] -= h
    return [float(m[i] / J[i]) for i in range(3)]


def separatrix_distance(inertia, rotor, h, omega, saddle):
    """``2T / 2T_sep - 1`` at the rounded state's own ``|m|`` (mpmath)."""
    mp.mp.dps = 50
    J = [mp.mpf(x) for x in inertia]
    w = [mp.mpf(x) for x in omega]
    m = [J[i] * w[i] for i in range(3)]
    m[rotor] += mp.mpf(h)
    H = mp.sqrt(mp.fsum(x * x for x in m))
    two_T = mp.fsum(J[i] * w[i] ** 2 for i in range(3))
    return float(two_T / _separatrix_energy(inertia, rotor, mp.mpf(h), H, saddle) - 1)


# A rotor along the intermediate axis with small h: the poles ±e3 stay saddles (each its own
# separatrix, at energies (H ∓ h)^2 / J3); along the major axis: two saddles off the poles, near
# ±e_intermediate (one separatrix)
_INTERMEDIATE = ([1.0, 3.0, 2.0], 2, 0.2)  # inertia, rotor axis, h
_MAJOR = ([1.0, 2.0, 3.0], 2, 0.2)
_SEPARATRICES = {
    # name: (body, saddle, meridian (transverse axis, phi, bracket of the polar angle))
    'pole_plus': (_INTERMEDIATE, ('pole', 1), (1, 0.3, 0.45, 0.7)),
    'pole_minus': (_INTERMEDIATE, ('pole', -1), (0, 0.3, 0.85, 1.1)),
    'off_pole': (_MAJOR, ('plane', 1), (1, 0.3, 1.3, 1.55)),
}


def _separatrix_cases():
    cases = {}
    for label, ((inertia, rotor, h), saddle, meridian) in _SEPARATRICES.items():
        for exponent in (6, 10):
            for side, sign in (('above', 1), ('below', -1)):
                omega = _near_separatrix(
                    inertia, rotor, h, 1.0, saddle, sign * 10.0**-exponent, meridian
                )
                name = f'separatrix_{label}_{side}_1e-{exponent}'
                cases[name] = {
                    'inertia': inertia,
                    'angular_velocity': omega,
                    'orientation': _q([1, 2, 3], 0.4),
                    'rotor': {'momentum': h, 'axis': _unit(rotor)},
                    'horizon': 80.0 if exponent == 6 else 120.0,
                    'samples': 41 if exponent == 6 else 61,
                    'saddle': [saddle[0], saddle[1]],
                }
    return cases


# name: inertia, angular velocity, orientation, rotor (momentum, axis), horizon (s), samples
CASES = {
    'library_gyrostat': {
        'inertia': [1.0, 2.0, 3.0],
        'angular_velocity': [0.01, 1.0, 0.01],
        'orientation': [0.0, 0.0, 0.0, 1.0],
        'rotor': {'momentum': 5.0, 'axis': [0.0, 1.0, 0.0]},
        'horizon': 100.0,
        'samples': 51,
    },
    'small_h_dual_spin': {
        'inertia': [2.0, 3.0, 4.0],
        'angular_velocity': [0.4, 0.3, 0.5],
        'orientation': _q([1, -1, 2], 0.7),
        'rotor': {'momentum': 0.02, 'axis': [0.0, 0.0, 1.0]},
        'horizon': 60.0,
        'samples': 31,
    },
    'dominant_h': {
        'inertia': [1.0, 2.0, 3.0],
        'angular_velocity': [0.02, 0.3, 0.2],
        'orientation': _q([0, 1, 1], 1.1),
        'rotor': {'momentum': 100.0, 'axis': [1.0, 0.0, 0.0]},
        'horizon': 20.0,
        'samples': 41,
    },
    'negative_h_rotor_axis': {
        'inertia': [1.0, 3.0, 2.0],
        'angular_velocity': [0.5, 0.6, -0.3],
        'orientation': _q([2, 1, 0], -0.6),
        'rotor': {'momentum': -1.0, 'axis': [0.0, 0.0, 1.0]},
        'horizon': 40.0,
        'samples': 41,
    },
    'complex_roots_transverse': {
        'inertia': [3.0, 1.0, 2.0],
        'angular_velocity': [0.5, 0.6, -0.3],
        'orientation': _q([1, 0, 1], 2.0),
        'rotor': {'momentum': 0.3, 'axis': [0.0, 1.0, 0.0]},
        'horizon': 40.0,
        'samples': 41,
    },
    'real_roots_transverse': {
        'inertia': [1.0, 3.0, 2.0],
        'angular_velocity': [0.1, 1.0, 0.1],
        'orientation': _q([0, 0, 1], 0.5),
        'rotor': {'momentum': 0.05, 'axis': [0.0, 0.0, 1.0]},
        'horizon': 40.0,
        'samples': 41,
    },
    'root_at_infinity': {
        'inertia': [2.0, 3.0, 2.0],
        'angular_velocity': [0.5, 0.6, -0.3],
        'orientation': _q([1, 1, 1], 1.0),
        'rotor': {'momentum': 1.0, 'axis': [0.0, 0.0, 1.0]},
        'horizon': 40.0,
        'samples': 41,
    },
    'turning_point_start': {
        'inertia': [1.0, 3.0, 2.0],
        'angular_velocity': [0.0, 0.6, -0.3],
        'orientation': _q([1, 0, 0], 0.3),
        'rotor': {'momentum': 1.0, 'axis': [0.0, 0.0, 1.0]},
        'horizon': 40.0,
        'samples': 41,
    },
    'symmetric_rotor_on_axis': {
        'inertia': [2.0, 2.0, 1.0],
        'angular_velocity': [0.5, 0.6, -0.3],
        'orientation': _q([0, 1, 0], 0.8),
        'rotor': {'momentum': 0.3, 'axis': [0.0, 0.0, 1.0]},
        'horizon': 40.0,
        'samples': 41,
    },
    'long_horizon_1e5': {
        'inertia': [1.0, 2.0, 2.5],
        'angular_velocity': [0.01, 0.006, 0.004],
        'orientation': _q([1, 1, 0], 0.6),
        'rotor': {'momentum': 0.01, 'axis': [0.0, 0.0, 1.0]},
        'horizon': 1e5,
        'samples': 51,
    },
    # on the separatrix of the saddle +e3 exactly (m = (2, 10, 11) / 8, |m| = 15/8: every input
    # and constant a short binary or decimal fraction, so the double root is exact)
    'separatrix_exact': {
        'inertia': [1.0, 2.5, 2.0],
        'angular_velocity': [0.25, 0.5, 0.5625],
        'orientation': _q([1, 2, 3], 0.4),
        'rotor': {'momentum': 0.25, 'axis': [0.0, 0.0, 1.0]},
        'horizon': 30.0,
        'samples': 31,
        'saddle': ['pole', 1],
    },
    # the oblique rotor has no closed form here: auto's DOP853 against the reference
    'oblique_rotor': {
        'inertia': [1.0, 2.0, 3.0],
        'angular_velocity': [0.3, 0.5, -0.4],
        'orientation': _q([1, 2, 0], 0.9),
        'rotor': {'momentum': 1.5, 'axis': [0.3, -1.0, 0.2]},
        'horizon': 20.0,
        'samples': 21,
    },
    **_separatrix_cases(),
}


def _wheel(axis, spin_inertia, speed):
    return {
        'axis': axis,
        'spin_inertia': spin_inertia,
        'max_torque': 1.0,
        'max_speed': 1000.0,
        'speed': speed,
    }


# coasting reaction wheels: the scene's inertia I, its wheels; every value a short binary
# fraction, so h_i and I_s are exact in float64 as in mpmath
WHEEL_CASES = {
    'wheels_coasting_rotor_axis': {
        'inertia': [1.0, 2.0, 3.0],
        'angular_velocity': [0.3, 0.5, -0.375],
        'orientation': _q([1, 2, 3], 0.4),
        'wheels': [_wheel([0.0, 0.0, 1.0], 0.25, 20.0)],
        'horizon': 40.0,
        'samples': 41,
    },
    # a second wheel across, at rest absolutely (h = 0): its angle is -∫ w1 dt, a transverse rate
    'wheels_coasting_two_axes': {
        'inertia': [2.0, 3.0, 4.0],
        'angular_velocity': [0.5, 0.25, 0.375],
        'orientation': _q([1, -1, 2], 0.7),
        'wheels': [_wheel([0.0, 0.0, 1.0], 0.5, 10.0), _wheel([1.0, 0.0, 0.0], 0.125, -0.5)],
        'horizon': 40.0,
        'samples': 41,
    },
    # separatrix_exact's gyrostat (I_s = diag(1, 2.5, 2), h = 0.25 e3) made of a coasting wheel
    'wheels_coasting_separatrix_exact': {
        'inertia': [1.0, 2.5, 2.25],
        'angular_velocity': [0.25, 0.5, 0.5625],
        'orientation': _q([1, 2, 3], 0.4),
        'wheels': [_wheel([0.0, 0.0, 1.0], 0.25, 0.4375)],
        'horizon': 30.0,
        'samples': 31,
    },
    # the same with a wheel across at rest absolutely: its angle integrates a transverse rate,
    # which tends to zero as sech (not sech^2) along the separatrix (30 s: beyond ~100 s the
    # saddle's instability makes the floor, and this reference's own truncation, grow past 1e-6)
    'wheels_coasting_separatrix_across': {
        'inertia': [1.125, 2.5, 2.25],
        'angular_velocity': [0.25, 0.5, 0.5625],
        'orientation': _q([1, 2, 3], 0.4),
        'wheels': [_wheel([0.0, 0.0, 1.0], 0.25, 0.4375), _wheel([1.0, 0.0, 0.0], 0.125, -0.25)],
        'horizon': 30.0,
        'samples': 31,
    },
    # complex_roots_transverse's gyrostat (h = 0.3 e2, the cn form) made of a coasting wheel
    'wheels_coasting_transverse': {
        'inertia': [3.0, 1.25, 2.0],
        'angular_velocity': [0.5, 0.6, -0.3],
        'orientation': _q([1, 0, 1], 2.0),
        'wheels': [_wheel([0.0, 1.0, 0.0], 0.25, 0.6)],
        'horizon': 40.0,
        'samples': 41,
    },
}
CASES.update(WHEEL_CASES)


# -- the oblique gyrostat (h off every principal axis): test/data/gyrostat_oblique_cases.json ----
OBLIQUE_OUTPUT = (
    Path(__file__).resolve().parent.parent / 'test' / 'data' / 'gyrostat_oblique_cases.json'
)


def oblique_equilibria(inertia, h, H):
    """
    Return the relative equilibria on the sphere ``|m| = H``: ``[(m, 2T, kind)]`` (mpmath).

    ``I w + h = mu w`` (``m`` parallel to ``w``), so ``w_i = h_i / (mu - I_i)`` and
    ``mu^2 sum h_i^2 / (mu - I_i)^2 = H^2``: a sextic in ``mu`` (Volterra's equilibria; Elipe &
    Lanchares 2008). ``kind`` is 'saddle' when ``E = (m - h) . I^-1 (m - h)``'s Hessian on the
    sphere, ``2 P (I^-1 - 1/mu) P``, is indefinite, 'center' otherwise.
    """
    J = [mp.mpf(x) for x in inertia]
    h = [mp.mpf(x) for x in h]
    H = mp.mpf(H)

    def poly_mul(a, b):
        out = [mp.mpf(0)] * (len(a) + len(b) - 1)
        for i, x in enumerate(a):
            for j, y in enumerate(b):
                out[i + j] += x * y
        return out

    squares = [poly_mul([1, -J[i]], [1, -J[i]]) for i in range(3)]  # (mu - I_i)^2, highest first
    total = [mp.mpf(0)] * 7
    for i in range(3):
        others = poly_mul(squares[(i + 1) % 3], squares[(i + 2) % 3])
        term = poly_mul([h[i] ** 2, 0, 0], others)
        for k, c in enumerate(term):
            total[k + 7 - len(term)] += c
    everything = poly_mul(poly_mul(squares[0], squares[1]), squares[2])
    for k, c in enumerate(everything):
        total[k] -= H * H * c
    found = []
    for mu in mp.polyroots(total, maxsteps=200, extraprec=200):
        if abs(mp.im(mu)) > mp.mpf(10) ** -30:
            continue
        mu = mp.re(mu)
        w = [h[i] / (mu - J[i]) for i in range(3)]
        m = [mu * x for x in w]
        norm = mp.sqrt(mp.fsum(x * x for x in m))
        e = [x / norm for x in m]
        # a tangent basis at m and the Hessian of E - |m|^2 / mu restricted to it
        k = min(range(3), key=lambda i: abs(e[i]))
        t1 = [(1 if i == k else 0) - e[k] * e[i] for i in range(3)]
        n1 = mp.sqrt(mp.fsum(x * x for x in t1))
        t1 = [x / n1 for x in t1]
        t2 = [
            e[1] * t1[2] - e[2] * t1[1],
            e[2] * t1[0] - e[0] * t1[2],
            e[0] * t1[1] - e[1] * t1[0],
        ]
        g = [1 / J[i] - 1 / mu for i in range(3)]
        a = mp.fsum(g[i] * t1[i] ** 2 for i in range(3))
        b = mp.fsum(g[i] * t1[i] * t2[i] for i in range(3))
        c = mp.fsum(g[i] * t2[i] ** 2 for i in range(3))
        two_T = mp.fsum(J[i] * w[i] ** 2 for i in range(3))
        found.append((m, two_T, 'saddle' if a * c - b * b < 0 else 'center', (t1, t2, a, b, c)))
    return found


def _oblique_near_separatrix(inertia, h, H, saddle_index, distance):
    """
    Rates with ``|m| = H`` and ``2T = 2T_saddle (1 + distance)``, as float64.

    From the saddle along the great circle whose tangent is the Hessian's eigenvector of the sign
    of ``distance``, the energy crossing the target (bisection in mpmath, 50 digits).
    """
    mp.mp.dps = 50
    J = [mp.mpf(x) for x in inertia]
    hm = [mp.mpf(x) for x in h]
    saddles = [e for e in oblique_equilibria(inertia, h, H) if e[2] == 'saddle']
    saddles.sort(key=lambda e: e[1])
    m_s, two_T_s, _, (t1, t2, a, b, c) = saddles[saddle_index]
    target = two_T_s * (1 + mp.mpf(distance))
    # eigenvectors of [[a, b], [b, c]]
    mean, radius = (a + c) / 2, mp.sqrt(((a - c) / 2) ** 2 + b * b)
    value = mean + radius if distance > 0 else mean - radius
    x, y = (b, value - a) if abs(b) > abs(value - c) else (value - c, b)
    norm = mp.sqrt(x * x + y * y)
    x, y = x / norm, y / norm
    direction = [x * t1[i] + y * t2[i] for i in range(3)]
    H = mp.sqrt(mp.fsum(v * v for v in m_s))
    e = [v / H for v in m_s]

    def momentum(theta):
        return [H * (mp.cos(theta) * e[i] + mp.sin(theta) * direction[i]) for i in range(3)]

    def gap(theta):
        m = momentum(theta)
        return mp.fsum((m[i] - hm[i]) ** 2 / J[i] for i in range(3)) - target

    low, high = mp.mpf(0), mp.mpf(10) ** -6
    while gap(low) * gap(high) > 0:
        high *= 2
    for _ in range(200):
        middle = (low + high) / 2
        low, high = (low, middle) if gap(low) * gap(middle) <= 0 else (middle, high)
    m = momentum((low + high) / 2)
    return [float((m[i] - hm[i]) / J[i]) for i in range(3)]


def _oblique_near_center(inertia, h, H, angle):
    """Rates with ``|m| = H``, ``angle`` rad from the lowest-energy centre along its ``t1``."""
    mp.mp.dps = 50
    J = [mp.mpf(x) for x in inertia]
    hm = [mp.mpf(x) for x in h]
    centres = sorted((e for e in oblique_equilibria(inertia, h, H) if e[2] == 'center'),
                     key=lambda e: e[1])
    m_c, _, _, (t1, _, _, _, _) = centres[0]
    size = mp.sqrt(mp.fsum(v * v for v in m_c))
    theta = mp.mpf(angle)
    m = [mp.cos(theta) * m_c[i] + size * mp.sin(theta) * t1[i] for i in range(3)]
    return [float((m[i] - hm[i]) / J[i]) for i in range(3)]


def oblique_separatrix_distance(inertia, h, omega):
    """``2T / 2T_saddle - 1`` of the nearest saddle at the rounded state's own ``|m|``."""
    mp.mp.dps = 50
    J = [mp.mpf(x) for x in inertia]
    w = [mp.mpf(x) for x in omega]
    hm = [mp.mpf(x) for x in h]
    m = [J[i] * w[i] + hm[i] for i in range(3)]
    H = mp.sqrt(mp.fsum(x * x for x in m))
    two_T = mp.fsum(J[i] * w[i] ** 2 for i in range(3))
    ratios = [two_T / e[1] - 1 for e in oblique_equilibria(inertia, h, H) if e[2] == 'saddle']
    return float(min(ratios, key=abs))


# I = diag(1, 2, 3) at |m| = 1: h = 0.3 (1, 1, 1) / sqrt 3 leaves one saddle (four equilibria),
# h = 0.05 (1, 1, 1) / sqrt 3 two (six, next to the free body's), the second taken
_OBLIQUE_SADDLES = {
    'one_saddle': (([1.0, 2.0, 3.0], [0.3 / 3**0.5] * 3), 0, (6, 10)),
    'two_saddles': (([1.0, 2.0, 3.0], [0.05 / 3**0.5] * 3), 1, (6,)),
}


def _oblique_separatrix_cases():
    cases = {}
    for label, ((inertia, h), index, exponents) in _OBLIQUE_SADDLES.items():
        for exponent in exponents:
            for side, sign in (('above', 1), ('below', -1)):
                omega = _oblique_near_separatrix(inertia, h, 1.0, index, sign * 10.0**-exponent)
                cases[f'oblique_separatrix_{label}_{side}_1e-{exponent}'] = {
                    'inertia': inertia,
                    'angular_velocity': omega,
                    'orientation': _q([1, 2, 3], 0.4),
                    'rotor_vector': h,
                    'horizon': 40.0,
                    'samples': 21,
                    'oblique_separatrix': True,
                }
    return cases


# name: inertia, angular velocity, orientation, rotor_vector (h in the principal frame, N m s)
OBLIQUE_CASES = {
    'oblique_generic': {
        'inertia': [1.0, 2.0, 3.0],
        'angular_velocity': [0.3, 0.5, -0.4],
        'orientation': _q([1, 2, 0], 0.9),
        'rotor_vector': [0.45, -1.5, 0.3],
        'horizon': 20.0,
        'samples': 21,
    },
    'oblique_small_h': {
        'inertia': [2.0, 3.0, 4.0],
        'angular_velocity': [0.4, 0.3, 0.5],
        'orientation': _q([1, -1, 2], 0.7),
        'rotor_vector': [0.01, 0.02, -0.015],
        'horizon': 20.0,
        'samples': 21,
    },
    'oblique_dominant_h': {
        'inertia': [1.0, 2.0, 3.0],
        'angular_velocity': [0.02, 0.3, 0.2],
        'orientation': _q([0, 1, 1], 1.1),
        'rotor_vector': [20.0, 10.0, -6.0],
        'horizon': 10.0,
        'samples': 21,
    },
    'oblique_near_principal': {
        'inertia': [1.0, 3.0, 2.0],
        'angular_velocity': [0.5, 0.6, -0.3],
        'orientation': _q([2, 1, 0], -0.6),
        'rotor_vector': [1e-4, -2e-4, -1.0],
        'horizon': 20.0,
        'samples': 21,
    },
    'oblique_near_center': {
        'inertia': [1.0, 2.0, 3.0],
        'angular_velocity': _oblique_near_center([1.0, 2.0, 3.0], [0.3 / 3**0.5] * 3, 1.0, 1e-3),
        'orientation': _q([1, 1, 0], 0.6),
        'rotor_vector': [0.3 / 3**0.5] * 3,
        'horizon': 20.0,
        'samples': 21,
    },
    'oblique_long_horizon': {
        'inertia': [2.0, 3.0, 4.5],
        'angular_velocity': [0.1, -0.2, 0.15],
        'orientation': _q([0, 1, 2], -1.2),
        'rotor_vector': [0.05, 0.1, -0.08],
        'horizon': 2000.0,
        'samples': 41,
    },
    # the same motion slowed twenty times (w and h scaled by 1/20): 1e5 s is 5 000 s of it
    'oblique_long_horizon_1e5': {
        'inertia': [2.0, 3.0, 4.5],
        'angular_velocity': [0.005, -0.01, 0.0075],
        'orientation': _q([0, 1, 2], -1.2),
        'rotor_vector': [0.0025, 0.005, -0.004],
        'horizon': 1e5,
        'samples': 51,
    },
    # exactly on a separatrix (mc = 0), found in exact rational arithmetic: a saddle m_s with
    # A (m_s - h) = 3/8 m_s (h = (1 - 3/8 J) m_s), and m0 = I w0 + h the separatrix's second
    # point on a line from m_s along a direction v of the cone sum (1/J_k - 3/8) v_k^2 = 0
    # (v = (2, 3, 1) and its sign changes: the separatrix is rational from its double point).
    # The motion tends to the saddle, whose unstable rate 2r (0.3/s, 0.25/s) grows the
    # integration's 1e-24 truncation by 2e5 over 40 s. Real roots: m_s = (-2, -2, 3)
    'oblique_separatrix_exact': {
        'inertia': [2.0, 3.0, 4.0],
        'angular_velocity': [0.25, 0.25, 1.375],
        'orientation': _q([1, 2, 3], 0.4),
        'rotor_vector': [-0.5, 0.25, -1.5],
        'horizon': 40.0,
        'samples': 41,
    },
    # ... one real root: m_s = (-1, -2, 1), m0 = (1, 1, 2)
    'oblique_separatrix_exact_one_root': {
        'inertia': [2.0, 3.0, 4.0],
        'angular_velocity': [0.625, 0.25, 0.625],
        'orientation': _q([1, 2, 3], 0.4),
        'rotor_vector': [-0.25, 0.25, -0.5],
        'horizon': 40.0,
        'samples': 41,
    },
    **_oblique_separatrix_cases(),
}


def _case(name):
    """Return the case of that name, principal-axis or oblique."""
    return CASES[name] if name in CASES else OBLIQUE_CASES[name]


def _rotor_h(case, scale=1):
    """``h`` in the principal frame, in mpmath, its size times ``scale``."""
    if 'rotor_vector' in case:
        return [mp.mpf(x) * scale for x in case['rotor_vector']]
    return rotor_vector({**case['rotor'], 'momentum': mp.mpf(case['rotor']['momentum']) * scale})


class TaylorGyrostat(mp_taylor.TaylorGyrostat):
    """The shared Taylor integrator of the free gyrostat, at this script's order and step."""

    order = ORDER
    step_fraction = STEP_FRACTION


def rotor_vector(rotor):
    """``h`` in the body (principal) frame as the ``rotor`` effect makes it, in mpmath."""
    axis = [mp.mpf(x) for x in rotor['axis']]
    norm = mp.sqrt(mp.fsum(x * x for x in axis))
    return [mp.mpf(rotor['momentum']) * x / norm for x in axis]


def wheel_gyrostat(case, perturb=None):
    """
    Return ``(I_s moments, h vector, wheels for TaylorGyrostat)`` of a wheel case, in mpmath.

    ``perturb``: ``('moment', j)`` or ``('speed', i)`` moves that input by one rounding unit.
    """
    moments = [mp.mpf(x) for x in case['inertia']]
    if perturb is not None and perturb[0] == 'moment':
        moments[perturb[1]] *= 1 + mp.mpf(ROUNDING_UNIT)
    w = [mp.mpf(x) for x in case['angular_velocity']]
    h, wheels = [mp.mpf(0)] * 3, []
    for i, wheel in enumerate(case['wheels']):
        axis = [mp.mpf(x) for x in wheel['axis']]
        norm = mp.sqrt(mp.fsum(x * x for x in axis))
        g = [x / norm for x in axis]
        Js, speed = mp.mpf(wheel['spin_inertia']), mp.mpf(wheel['speed'])
        if perturb == ('speed', i):
            speed = speed * (1 + mp.mpf(ROUNDING_UNIT)) if speed else mp.mpf(ROUNDING_UNIT)
        momentum = Js * (speed + mp.fsum(g[k] * w[k] for k in range(3)))
        for k in range(3):
            if any(g[j] != 0 for j in range(3) if j != k) and g[k] != 0:
                raise ValueError('the reference takes wheels along principal axes (I_s diagonal)')
            moments[k] -= Js * g[k] * g[k]
            h[k] += momentum * g[k]
        wheels.append((g, momentum / Js))
    return moments, h, wheels


def reference_wheel_case(name):
    """Return the reference of a coasting-wheels case: rates, attitude and each wheel's angle."""
    mp.mp.dps = DIGITS
    case = CASES[name]
    omega = case['angular_velocity']
    q0, times, q0_mp, t_mp = sample_grid(case['orientation'], case['horizon'], case['samples'])
    count = len(case['wheels'])
    started = time.time()

    def run(perturb=None):
        moments, h, wheels = wheel_gyrostat(case, perturb)
        w = [mp.mpf(x) for x in omega]
        integrator = TaylorGyrostat(moments, h, wheels)
        states = integrator.integrate(w + q0_mp + [mp.mpf(0)] * count, t_mp)
        return moments, h, integrator, states

    moments, h, integrator, nominal = run()
    check_invariants(moments, h, nominal, name, INVARIANT_DIGITS)
    perturbations = [('moment', j) for j in range(3)] + [('speed', i) for i in range(count)]
    responses = []
    for perturb in perturbations:
        responses.append(changes(nominal, run(perturb)[3]))
    for j in range(3):
        if omega[j] == 0:
            continue
        w = [mp.mpf(x) for x in omega]
        w[j] *= 1 + mp.mpf(ROUNDING_UNIT)
        states = TaylorGyrostat(moments, h, wheel_gyrostat(case)[2]).integrate(
            w + q0_mp + [mp.mpf(0)] * count, t_mp
        )
        responses.append(changes(nominal, states))
    rate_floor, attitude_floor, angle_floor = [], [], []
    for k, state in enumerate(nominal):
        w = state[:3]
        speed = mp.sqrt(mp.fsum(x * x for x in w))
        series = integrator.coefficients(state)
        accel = mp.sqrt(mp.fsum(c[1] ** 2 for c in series[:3]))
        spin = max(abs(c[1]) for c in series[7:])  # |Omega_i|
        t = t_mp[k]
        rate = mp.sqrt(mp.fsum(r[k][0] ** 2 for r in responses) + (accel * t * ROUNDING_UNIT) ** 2)
        attitude = mp.sqrt(
            mp.fsum(r[k][1] ** 2 for r in responses)
            + (speed * t * ROUNDING_UNIT) ** 2
            + ROUNDING_UNIT**2
        )
        angle = mp.sqrt(mp.fsum(r[k][2] ** 2 for r in responses) + (spin * t * ROUNDING_UNIT) ** 2)
        rate_floor.append(float(rate / speed) if speed > 0 else 0.0)
        attitude_floor.append(float(attitude))
        angle_floor.append(float(angle))
    return {
        'name': name,
        'inertia': case['inertia'],
        'angular_velocity': omega,
        'orientation': q0,
        'wheels': case['wheels'],
        'gyrostat_inertia': [float(x) for x in moments],
        'gyrostat_momentum': [float(x) for x in h],
        'times': times,
        'omega': [[float(x) for x in s[:3]] for s in nominal],
        'q': [[float(x) for x in s[3:7]] for s in nominal],
        'wheel_angles': [[float(x) for x in s[7:]] for s in nominal],
        'rate_floor': rate_floor,
        'attitude_floor': attitude_floor,
        'angle_floor': angle_floor,
        'seconds': round(time.time() - started, 1),
    }


def reference_case(name):
    if 'wheels' in _case(name):
        return reference_wheel_case(name)
    mp.mp.dps = DIGITS
    case = _case(name)
    inertia, omega = case['inertia'], case['angular_velocity']
    q0, times, q0_mp, t_mp = sample_grid(case['orientation'], case['horizon'], case['samples'])
    h = _rotor_h(case)
    started = time.time()
    nominal = TaylorGyrostat(inertia, h).integrate([mp.mpf(x) for x in omega] + q0_mp, t_mp)
    check_invariants(inertia, h, nominal, name, INVARIANT_DIGITS)
    responses = []  # per perturbed input: list over samples of (rate change, attitude change)
    for index in range(7):
        moments = [mp.mpf(x) for x in inertia]
        w = [mp.mpf(x) for x in omega]
        momentum = mp.mpf(1) if 'rotor_vector' in case else mp.mpf(case['rotor']['momentum'])
        scale = 1
        if index < 6:
            target = moments if index < 3 else w
            j = index % 3
            if target[j] == 0:
                continue  # zero is exact in float64
            target[j] *= 1 + mp.mpf(ROUNDING_UNIT)
        elif momentum == 0:
            continue
        else:
            scale = 1 + mp.mpf(ROUNDING_UNIT)
        perturbed_h = _rotor_h(case, scale)
        perturbed = TaylorGyrostat(moments, perturbed_h).integrate(w + q0_mp, t_mp)
        responses.append(changes(nominal, perturbed))
    integrator = TaylorGyrostat(inertia, h)
    rate_floor, attitude_floor = [], []
    for k, state in enumerate(nominal):
        w = state[:3]
        speed = mp.sqrt(mp.fsum(x * x for x in w))
        accel = mp.sqrt(mp.fsum(series[1] ** 2 for series in integrator.coefficients(state)[:3]))
        t = t_mp[k]
        rate = mp.sqrt(mp.fsum(r[k][0] ** 2 for r in responses) + (accel * t * ROUNDING_UNIT) ** 2)
        attitude = mp.sqrt(
            mp.fsum(r[k][1] ** 2 for r in responses)
            + (speed * t * ROUNDING_UNIT) ** 2
            + ROUNDING_UNIT**2
        )
        rate_floor.append(float(rate / speed) if speed > 0 else 0.0)
        attitude_floor.append(float(attitude))
    result = {
        'name': name,
        'inertia': inertia,
        'angular_velocity': omega,
        'orientation': q0,
        **(
            {'rotor': case['rotor']}
            if 'rotor' in case
            else {'rotor_vector': case['rotor_vector']}
        ),
        'times': times,
        'omega': [[float(x) for x in s[:3]] for s in nominal],
        'q': [[float(x) for x in s[3:]] for s in nominal],
        'rate_floor': rate_floor,
        'attitude_floor': attitude_floor,
        'seconds': round(time.time() - started, 1),
    }
    if 'oblique_separatrix' in case:
        result['separatrix_distance'] = oblique_separatrix_distance(
            inertia, case['rotor_vector'], omega
        )
    if 'saddle' in case:
        rotor_axis = int(np.argmax(np.abs(case['rotor']['axis'])))
        result['saddle'] = case['saddle']
        result['separatrix_distance'] = separatrix_distance(
            inertia, rotor_axis, case['rotor']['momentum'], omega, tuple(case['saddle'])
        )
    return result


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    parser.add_argument('--jobs', type=int, default=2)
    parser.add_argument('--only', nargs='*', help='case names to recompute (others are kept)')
    parser.add_argument(
        '--oblique', action='store_true',
        help=f'the oblique-h cases, written to {OBLIQUE_OUTPUT.relative_to(OUTPUT.parents[2])}',
    )
    args = parser.parse_args(argv)
    cases, output = (OBLIQUE_CASES, OBLIQUE_OUTPUT) if args.oblique else (CASES, OUTPUT)
    names = args.only or list(cases)
    unknown = [n for n in names if n not in cases]
    if unknown:
        parser.error(f'unknown case {unknown[0]!r}; known: {", ".join(cases)}')
    existing = {}
    if output.exists():
        existing = {c['name']: c for c in json.loads(output.read_text())['cases']}
    if not args.only:
        existing = {}

    def work(name):
        case = cases[name]
        return case['horizon'] * np.linalg.norm(case['angular_velocity']) * case['samples']

    # longest first so the workers finish together
    order = sorted(names, key=lambda n: -work(n))
    with multiprocessing.Pool(args.jobs) as pool:
        for case in pool.imap_unordered(reference_case, order):
            existing[case['name']] = case
            print(f'{case["name"]:40s} {case["seconds"]:8.1f} s', flush=True)
            _write(existing, cases, output)
    print(f'wrote {output}')


def _write(existing, cases=CASES, output=OUTPUT):
    document = {
        'provenance': {
            'generator': 'tools/make_gyrostat_reference.py',
            'method': (
                f'mpmath Taylor series, {DIGITS} digits, order {ORDER}, '
                f'step {STEP_FRACTION} x radius'
            ),
            'floor': (
                'quadrature sum of responses to 2**-53 relative perturbations of each moment, '
                "rate and the rotor momentum (wheel cases: each wheel's speed), plus sample-time "
                'and q0 rounding (wheel angles: |Omega| t u)'
            ),
            'mpmath': mp.__version__,
            'python': sys.version.split()[0],
            'machine': platform.platform(),
        },
        'cases': [existing[n] for n in cases if n in existing],
    }
    output.parent.mkdir(parents=True, exist_ok=True)
    output.write_text(json.dumps(document, indent=1) + '\n')


if __name__ == '__main__':
    main()
