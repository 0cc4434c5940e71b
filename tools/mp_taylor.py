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
The mpmath Taylor-series integrator of the reference scripts, and the pieces of their cases.

``tools/make_reference.py`` (the rigid body) and ``tools/make_gyrostat_reference.py`` (the free
gyrostat, coasting reaction wheels) integrate the same equations in the principal frame:
``I w' + w x (I w + h) = 0`` (``h = 0``: the rigid body), ``q' = 1/2 q ⊗ (w, 0)`` (Hamilton,
scalar last) and, per coasting wheel, its angle ``theta' = h_i / Js_i - g . w``. Each script sets
the working precision (``mp.mp.dps``) and subclasses ``TaylorGyrostat`` with its series order and
step fraction. Float inputs enter mpmath exactly; nothing here rounds to float64 but the returns
named so. ``check_cases`` recomputes some cases and compares them with a script's committed file
without writing it.
"""

from __future__ import annotations

import json
import multiprocessing
from pathlib import Path

import mpmath as mp
import numpy as np

ROUNDING_UNIT = 2.0**-53


def axis_angle(axis, angle) -> list[float]:
    """Return the float64 quaternion (x, y, z, w) of a turn by ``angle`` about ``axis``."""
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    return [*(axis * np.sin(angle / 2)), float(np.cos(angle / 2))]


def separatrix_sides(exponent):
    """
    Return the two sides of a separatrix at ``10**-exponent``: ``[(name, distance)]``.

    ``('above_1e-6', 1e-6)`` then ``('below_1e-6', -1e-6)`` for ``exponent`` 6: the cases' names
    end so, the distance the relative energy gap to the separatrix.
    """
    distance = 10.0**-exponent
    return [(f'above_1e-{exponent}', distance), (f'below_1e-{exponent}', -distance)]


def sample_grid(orientation, horizon, samples):
    """
    Return ``(q0, times, q0 in mpmath, times in mpmath)`` of a case.

    ``q0`` is the orientation normalised in float64, as the propagators take it; its mpmath copy
    is normalised again at full precision; ``times`` are ``samples`` evenly spaced from 0 to
    ``horizon`` in float64, entered exactly in mpmath. Call with the working precision set.
    """
    q0 = list(np.asarray(orientation) / np.linalg.norm(orientation))
    times = [float(x) for x in np.linspace(0.0, horizon, samples)]
    q_norm = mp.sqrt(mp.fsum(mp.mpf(x) ** 2 for x in q0))
    return q0, times, [mp.mpf(x) / q_norm for x in q0], [mp.mpf(x) for x in times]


class TaylorGyrostat:
    """
    Taylor-series integrator of the free gyrostat in the principal frame, in mpmath.

    A subclass sets ``order`` (the series' last power) and ``step_fraction`` (a step is at most
    this fraction of the radius of convergence estimated from the last coefficients: the
    truncation is about ``step_fraction ** order``). The state is w1..w3, qx, qy, qz, qw, then one
    angle per coasting wheel.
    """

    order: int
    step_fraction: float

    def __init__(self, inertia, h=(0, 0, 0), wheels=()):
        # wheels: (g, h_i / Js_i) per coasting wheel, whose angle theta_i' = h_i / Js_i - g . w
        # follows the attitude in the state
        self.wheels = tuple(wheels)
        I1, I2, I3 = (mp.mpf(x) for x in inertia)
        self.gains = ((I2 - I3) / I1, (I3 - I1) / I2, (I1 - I2) / I3)
        h1, h2, h3 = (mp.mpf(x) for x in h)
        # I_i w_i' = (m x w)_i = (I_j - I_k) w_j w_k + h_j w_k - h_k w_j (zero terms add exactly)
        self.linear = ((h2 / I1, h3 / I1), (h3 / I2, h1 / I2), (h1 / I3, h2 / I3))

    def coefficients(self, state):
        """
        Return the Taylor coefficients of each state component about t0.

        One list of length ``order + 1`` per component.
        """
        order = self.order
        c = [[value] + [mp.mpf(0)] * order for value in state]
        g1, g2, g3 = self.gains
        (a1, b1), (a2, b2), (a3, b3) = self.linear
        half = mp.mpf(1) / 2

        def product(a, b, k):
            return mp.fsum(a[i] * b[k - i] for i in range(k + 1))

        w1, w2, w3, qx, qy, qz, qw = c[:7]
        angles = c[7:]
        for k in range(order):
            for theta, (g, spin) in zip(angles, self.wheels):
                theta[k + 1] = (
                    (spin if k == 0 else 0) - (g[0] * w1[k] + g[1] * w2[k] + g[2] * w3[k])
                ) / (k + 1)
            scale = 1 / mp.mpf(k + 1)
            w1[k + 1] = (g1 * product(w2, w3, k) + a1 * w3[k] - b1 * w2[k]) * scale
            w2[k + 1] = (g2 * product(w3, w1, k) + a2 * w1[k] - b2 * w3[k]) * scale
            w3[k + 1] = (g3 * product(w1, w2, k) + a3 * w2[k] - b3 * w1[k]) * scale
            # q ⊗ (w, 0), Hamilton, scalar last
            qx[k + 1] = (
                half * scale * (product(qw, w1, k) + product(qy, w3, k) - product(qz, w2, k))
            )
            qy[k + 1] = (
                half * scale * (product(qw, w2, k) - product(qx, w3, k) + product(qz, w1, k))
            )
            qz[k + 1] = (
                half * scale * (product(qw, w3, k) + product(qx, w2, k) - product(qy, w1, k))
            )
            qw[k + 1] = (
                -half * scale * (product(qx, w1, k) + product(qy, w2, k) + product(qz, w3, k))
            )
        return c

    def radius(self, coefficients):
        """Radius of convergence estimated from the last coefficients (Cauchy-Hadamard)."""
        estimates = []
        for k in (self.order - 1, self.order):
            size = max(abs(series[k]) for series in coefficients)
            if size > 0:
                estimates.append(size ** (-mp.mpf(1) / k))
        return min(estimates) if estimates else mp.inf

    def integrate(self, state, times):
        """Return the state at each of the sorted ``times`` (mpf) from ``state`` at t = 0."""
        t = mp.mpf(0)
        out = []
        for target in times:
            while t < target:
                c = self.coefficients(state)
                h = min(target - t, self.step_fraction * self.radius(c))
                state = [mp.polyval(series[::-1], h) for series in c]
                t = target if h == target - t else t + h
            out.append(list(state))
        return out


def check_invariants(inertia, h, states, name, digits):
    """
    Raise unless T, ``|I w + h|`` and ``|q|`` hold to ``10**-digits`` relative.

    Only then is the integration trusted.
    """
    moments = [mp.mpf(x) for x in inertia]
    h = [mp.mpf(x) for x in h]

    def invariants(s):
        energy = mp.fsum(moments[i] * s[i] ** 2 for i in range(3))
        momentum = mp.fsum((moments[i] * s[i] + h[i]) ** 2 for i in range(3))
        return energy, momentum, mp.fsum(x * x for x in s[3:7])

    first = invariants(states[0])
    for s in states:
        for a, b in zip(invariants(s), first):
            if abs(a - b) > mp.mpf(10) ** -digits * max(abs(b), mp.mpf(10) ** -300):
                raise RuntimeError(
                    f'{name}: invariant drift {mp.nstr(abs(a - b) / b, 3)} in the reference'
                )


def changes(nominal, perturbed):
    """Per sample: (|dw|, the rotation angle between the attitudes, the largest |d theta|)."""
    out = []
    for a, b in zip(nominal, perturbed):
        dw = mp.sqrt(mp.fsum((a[i] - b[i]) ** 2 for i in range(3)))
        # rotation angle of conj(qa) ⊗ qb from its vector and scalar parts: exact for tiny
        # angles and independent of |q| (1 - (qa.qb)^2 is swamped by |q0|^2 - 1 ~ 1e-16)
        (ax, ay, az, aw), (bx, by, bz, bw) = a[3:7], b[3:7]
        vector = [
            aw * bx - ax * bw - ay * bz + az * by,
            aw * by + ax * bz - ay * bw - az * bx,
            aw * bz - ax * by + ay * bx - az * bw,
        ]
        scalar = aw * bw + ax * bx + ay * by + az * bz
        angle = 2 * mp.atan2(mp.sqrt(mp.fsum(v * v for v in vector)), abs(scalar))
        theta = max((abs(x - y) for x, y in zip(a[7:], b[7:])), default=mp.mpf(0))
        out.append((dw, angle, theta))
    return out


def check_cases(path: Path, compute, names, jobs: int) -> int:
    """
    Recompute the cases ``names`` and compare each with its entry in the file ``path``.

    Digit for digit: each field's JSON text, as the script writes it, but the run time
    (``seconds``). Prints a line a case; returns how many differ or are missing. Writes nothing.
    """
    committed = {case['name']: case for case in json.loads(Path(path).read_text())['cases']}
    failures = 0
    with multiprocessing.Pool(jobs) as pool:
        for case in pool.imap_unordered(compute, names):
            name = case['name']
            if name not in committed:
                print(f'{name:40s} not in {path}', flush=True)
                failures += 1
                continue
            fields = sorted(
                key
                for key in (case.keys() | committed[name].keys()) - {'seconds'}
                if json.dumps(case.get(key)) != json.dumps(committed[name].get(key))
            )
            failures += bool(fields)
            verdict = f'differs in {", ".join(fields)}' if fields else 'the same, digit for digit'
            print(f'{name:40s} {verdict} ({case["seconds"]} s)', flush=True)
    return failures
