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
The exact propagator against the independent high-precision reference.

The reference is torquefree_ros/bench/hard_cases.json, made by tools/make_reference.py: mpmath
Taylor-series integration at 45 digits.

Tolerance, per case and per sample: attitude error (rad) and relative rate error
<= 100 x max(floor, 1e-15), where the floor is what float64 itself allows (the change of the exact
solution when the inputs move by one rounding unit, from the reference's perturbation runs).
"""

import json

import numpy as np
import pytest
from torquefree_ros import propagate
from torquefree_ros.bench.cases import REFERENCE_FILE
from torquefree_ros.core.run.accuracy import trajectory_errors

REFERENCE = json.loads(REFERENCE_FILE.read_text())
CASES = {case['name']: case for case in REFERENCE['cases']}
FLOOR_FACTOR = 100.0
ABSOLUTE_FLOOR = 1e-15


def errors(case, propagator='analytic', **options):
    w, q = propagate(
        case['inertia'],
        case['angular_velocity'],
        case['orientation'],
        case['times'],
        propagator,
        **options,
    )
    q_ref = np.array(case['q'])
    rate_error, attitude_error = trajectory_errors(w, q, case['omega'], q_ref)
    return rate_error, attitude_error, np.sum(q * q_ref, axis=1)


def test_every_hard_case_named_in_the_issue_is_present():
    expected = {
        'near_separatrix_above_1e-6',
        'near_separatrix_below_1e-6',
        'near_separatrix_above_1e-10',
        'near_separatrix_below_1e-10',
        'separatrix_exact',
        'dzhanibekov_1e-4',
        'dzhanibekov_1e-8',
        'near_axisymmetric_1e-9',
        'oblate_unsorted',
        'prolate_unsorted',
        'flat_plate',
        'thin_rod_1e6',
        'fast_spin_1e3',
        'slow_spin_1e-9',
        'zero_rate',
        'sphere',
        'large_angle_q0',
        'unsorted_triaxial',
        'long_horizon_1e5',
    }
    assert expected <= set(CASES)


@pytest.mark.parametrize('name', sorted(CASES))
def test_analytic_is_within_100_floors_of_the_reference(name, attitude_path):
    case = CASES[name]
    rate_error, attitude_error, sign = errors(case)
    rate_tol = FLOOR_FACTOR * np.maximum(case['rate_floor'], ABSOLUTE_FLOOR)
    attitude_tol = FLOOR_FACTOR * np.maximum(case['attitude_floor'], ABSOLUTE_FLOOR)
    worst_rate = int(np.argmax(rate_error / rate_tol))
    worst_attitude = int(np.argmax(attitude_error / attitude_tol))
    assert rate_error[worst_rate] <= rate_tol[worst_rate], (
        f'rate at t = {case["times"][worst_rate]}'
    )
    assert attitude_error[worst_attitude] <= attitude_tol[worst_attitude], (
        f'attitude at t = {case["times"][worst_attitude]}'
    )
    # the same quaternion, not only the same rotation: q(t) is continuous from q0 as the ODE's is
    assert np.all(sign > 0)


def test_reference_floors_are_physical():
    """
    The floors grow where the physics is sensitive.

    They grow near the separatrix and over long horizons.
    """
    assert max(CASES['near_separatrix_above_1e-10']['rate_floor']) > 1e-9
    assert max(CASES['long_horizon_1e5']['attitude_floor']) > 1e-13  # ~ |w| t eps
    assert max(CASES['zero_rate']['attitude_floor']) < 2e-16
