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
Regenerate torquefree_ros/bench/hard_cases.json, the reference solutions of the hard cases.

High-precision reference solutions of the torque-free rigid body for the hard cases, and the
float64 floor of each sample.

Independence: the reference integrates Euler's equations in the principal frame and
``q' = 1/2 q ⊗ (w, 0)`` with a Taylor-series method in mpmath (``tools/mp_taylor.py``, 45
significant digits, order 40, step at most a fifth of the estimated radius of convergence so the
truncation is below 1e-27). It shares nothing with the closed form in
``torquefree_ros.core.exact.polhode`` but the equations of motion.

The floor of a sample is what float64 itself allows: the change of the exact solution when an input
moves by one rounding unit (2**-53 relative). Each of the six dynamic inputs (moments, rates) is
perturbed in turn and integrated alongside; the responses add in quadrature, plus the rounding of
the sample time (``|w'| t u`` for the rate, ``|w| t u`` for the attitude) and of ``q0`` (``u``).

Run: ``.venv/bin/python tools/make_reference.py [--jobs 2] [--only NAME ...]`` (about 10 minutes
on 2 cores; ``pip install gmpy2`` makes mpmath about 3x faster). ``--check`` recomputes the cases
(``--only``: those named) and compares them with the file, digit for digit, writing nothing.
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
from pathlib import Path
import platform
import sys
import time

from mp_taylor import axis_angle as _q
from mp_taylor import changes, check_cases, check_invariants, ROUNDING_UNIT, sample_grid
from mp_taylor import separatrix_sides, TaylorGyrostat
import mpmath as mp
import numpy as np

DIGITS = 45
ORDER = 40
STEP_FRACTION = 0.2  # of the radius of convergence: truncation ~ 0.2**40 ~ 1e-28
INVARIANT_DIGITS = 25  # T, |H| and |q| hold to 1e-25 relative, or the reference is refused
OUTPUT = Path(__file__).resolve().parent.parent / 'torquefree_ros' / 'bench' / 'hard_cases.json'


def _near_separatrix(inertia, distance):
    """Rates with H^2/2T = I_mid (1 + distance), |w| about 1 (inertia ascending)."""
    I1, I2, I3 = inertia
    # w = (x, 1, z) with the energy-momentum gap sum_i I_i (I_i - I2) w_i^2 = 2 T I2 * distance
    z = 0.3
    # solve I1 (I1 - I2) x^2 + I3 (I3 - I2) z^2 = distance * I2 * (I1 x^2 + I2 + I3 z^2)
    a = I1 * (I1 - I2) - distance * I2 * I1
    b = I3 * (I3 - I2) * z * z - distance * I2 * (I2 + I3 * z * z)
    return [float(np.sqrt(-b / a)), 1.0, z]


# near the separatrix of I = (1, 2, 2.5), 1e-6 and 1e-10 above and below it: (orientation,
# horizon, samples) by exponent
_NEAR_SEPARATRIX = {6: (_q([1, 2, 3], 0.4), 80.0, 41), 10: (_q([0, 1, 0], 1.0), 120.0, 61)}

# name: inertia, angular velocity, orientation, horizon (s), samples
CASES = {
    **{
        f'near_separatrix_{side}': (
            [1.0, 2.0, 2.5],
            _near_separatrix([1.0, 2.0, 2.5], distance),
            *_NEAR_SEPARATRIX[exponent],
        )
        for exponent in _NEAR_SEPARATRIX
        for side, distance in separatrix_sides(exponent)
    },
    'separatrix_exact': ([3.0, 4.0, 6.0], [2.0, 0.5, 1.0], [0.0, 0.0, 0.0, 1.0], 30.0, 31),
    'dzhanibekov_1e-4': ([1.0, 2.0, 3.0], [1e-4, 1.0, 1e-4], [0.0, 0.0, 0.0, 1.0], 40.0, 41),
    'dzhanibekov_1e-8': ([1.0, 2.0, 3.0], [1e-8, 1.0, 1e-8], [0.0, 0.0, 0.0, 1.0], 60.0, 61),
    'near_axisymmetric_1e-9': (
        [1.0, 1.0 + 1e-9, 1.7],
        [0.4, -0.3, 1.1],
        _q([1, -1, 0], 0.3),
        30.0,
        31,
    ),
    'oblate_unsorted': ([1.0, 2.0, 1.0], [0.5, 1.2, -0.3], _q([0, 0, 1], 2.0), 30.0, 31),
    'prolate_unsorted': ([2.0, 1.0, 2.0], [0.2, 2.0, 0.4], _q([1, 1, 1], -1.0), 30.0, 31),
    'flat_plate': ([1.5, 2.5, 4.0], [0.7, 0.5, 0.6], _q([2, -1, 1], 0.8), 30.0, 31),
    'thin_rod_1e6': ([1.0, 1.0e6, 1.0000005e6], [3.0, 1e-3, 2e-3], _q([0, 0, 1], 0.5), 20.0, 41),
    'fast_spin_1e3': ([1.0, 2.0, 3.0], [600.0, 300.0, 700.0], _q([1, 0, 0], 0.2), 0.05, 26),
    'slow_spin_1e-9': ([1.0, 2.0, 3.0], [6e-10, 3e-10, 7e-10], _q([1, 0, 0], 0.2), 3e10, 31),
    'zero_rate': ([1.0, 2.0, 3.0], [0.0, 0.0, 0.0], _q([1, 2, 2], 1.2), 10.0, 11),
    'sphere': ([2.0, 2.0, 2.0], [0.3, -0.4, 1.2], _q([3, 1, 0], 0.7), 20.0, 21),
    'large_angle_q0': ([1.0, 2.0, 3.0], [0.4, 0.8, -0.5], _q([1, -2, 0.5], 3.1), 30.0, 31),
    'unsorted_triaxial': ([3.0, 1.0, 2.0], [0.8, 0.3, 0.5], _q([0, 1, 1], 1.5), 30.0, 31),
    'long_horizon_1e5': ([1.0, 2.0, 2.5], [0.01, 0.006, 0.004], _q([1, 1, 0], 0.6), 1e5, 51),
}


class TaylorRigidBody(TaylorGyrostat):
    """The shared Taylor integrator with no rotor (``h = 0``), at this script's order and step."""

    order = ORDER
    step_fraction = STEP_FRACTION


def reference_case(name):
    mp.mp.dps = DIGITS
    inertia, omega, orientation, horizon, count = CASES[name]
    # the propagators normalise q0 as given; so does the reference, at full precision
    q0, times, q0_mp, t_mp = sample_grid(orientation, horizon, count)
    started = time.time()
    nominal = TaylorRigidBody(inertia).integrate([mp.mpf(x) for x in omega] + q0_mp, t_mp)
    check_invariants(inertia, (0, 0, 0), nominal, name, INVARIANT_DIGITS)
    responses = []  # per perturbed input: list over samples of (rate change, attitude change)
    for index in range(6):
        moments = [mp.mpf(x) for x in inertia]
        w = [mp.mpf(x) for x in omega]
        target = moments if index < 3 else w
        j = index % 3
        if target[j] == 0:
            continue  # zero is exact in float64
        target[j] *= 1 + mp.mpf(ROUNDING_UNIT)
        perturbed = TaylorRigidBody(moments).integrate(w + q0_mp, t_mp)
        responses.append(changes(nominal, perturbed))
    gains = TaylorRigidBody(inertia).gains
    rate_floor, attitude_floor = [], []
    for k, state in enumerate(nominal):
        w = state[:3]
        speed = mp.sqrt(mp.fsum(x * x for x in w))
        accel = mp.sqrt(
            mp.fsum(
                x * x
                for x in (gains[0] * w[1] * w[2], gains[1] * w[2] * w[0], gains[2] * w[0] * w[1])
            )
        )
        t = t_mp[k]
        rate = mp.sqrt(mp.fsum(r[k][0] ** 2 for r in responses) + (accel * t * ROUNDING_UNIT) ** 2)
        attitude = mp.sqrt(
            mp.fsum(r[k][1] ** 2 for r in responses)
            + (speed * t * ROUNDING_UNIT) ** 2
            + ROUNDING_UNIT**2
        )
        rate_floor.append(float(rate / speed) if speed > 0 else 0.0)
        attitude_floor.append(float(attitude))
    return {
        'name': name,
        'inertia': inertia,
        'angular_velocity': omega,
        'orientation': q0,
        'times': times,
        'omega': [[float(x) for x in s[:3]] for s in nominal],
        'q': [[float(x) for x in s[3:]] for s in nominal],
        'rate_floor': rate_floor,
        'attitude_floor': attitude_floor,
        'seconds': round(time.time() - started, 1),
    }


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    parser.add_argument('--jobs', type=int, default=2)
    parser.add_argument('--only', nargs='*', help='case names to recompute (others are kept)')
    parser.add_argument(
        '--check',
        action='store_true',
        help='compare the cases recomputed with the file, digit for digit; write nothing',
    )
    args = parser.parse_args(argv)
    names = args.only or list(CASES)
    unknown = [n for n in names if n not in CASES]
    if unknown:
        parser.error(f'unknown case {unknown[0]!r}; known: {", ".join(CASES)}')
    if args.check:
        return 1 if check_cases(OUTPUT, reference_case, names, args.jobs) else 0
    existing = {}
    if args.only and OUTPUT.exists():
        existing = {c['name']: c for c in json.loads(OUTPUT.read_text())['cases']}
    # longest first so the two workers finish together
    order = sorted(names, key=lambda n: -CASES[n][3] * np.linalg.norm(CASES[n][1]) * CASES[n][4])
    with multiprocessing.Pool(args.jobs) as pool:
        for case in pool.imap_unordered(reference_case, order):
            existing[case['name']] = case
            print(f'{case["name"]:32s} {case["seconds"]:8.1f} s', flush=True)
    document = {
        'provenance': {
            'generator': 'tools/make_reference.py',
            'method': (
                f'mpmath Taylor series, {DIGITS} digits, order {ORDER}, '
                f'step {STEP_FRACTION} x radius'
            ),
            'floor': (
                'quadrature sum of responses to 2**-53 relative perturbations of each moment and '
                'rate, plus sample-time and q0 rounding'
            ),
            'mpmath': mp.__version__,
            'python': sys.version.split()[0],
            'machine': platform.platform(),
        },
        'cases': [existing[n] for n in CASES if n in existing],
    }
    OUTPUT.parent.mkdir(parents=True, exist_ok=True)
    OUTPUT.write_text(json.dumps(document, indent=1) + '\n')
    print(f'wrote {OUTPUT}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
