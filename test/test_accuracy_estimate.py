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
The accuracy a propagator's settings deliver, as the reset summary and /diagnostics state it.

Checked against independent references (the mpmath solution, a much tighter integration).
"""

import numpy as np
import pytest
from torquefree_ros.bench.cases import load_cases
from torquefree_ros.core.effects import parse_effect
from torquefree_ros.core.propagators import make_propagator
from torquefree_ros.core.run.accuracy import (
    estimate_accuracy,
    estimate_horizon,
    ESTIMATE_TURNS,
    trajectory_errors,
)
from torquefree_ros.core.run.simulation import Simulation

FLAT_PLATE = load_cases(['flat_plate'])[0]
DAMPER = (parse_effect({'damper': {'inertia': 0.1, 'damping': 0.05}}, 'effects[0]'),)


def test_the_exact_propagator_says_so():
    p = make_propagator(FLAT_PLATE.inertia, FLAT_PLATE.angular_velocity, FLAT_PLATE.orientation)
    assert estimate_accuracy(p).describe() == 'exact (closed form: float64 rounding of the inputs)'


@pytest.mark.parametrize(
    'name, options',
    [
        ('rk4', {'step': 0.05}),
        ('lie_rk4', {'step': 0.05}),
        ('dop853', {'rtol': 1e-7, 'atol': 1e-9}),
    ],
)
def test_torque_free_estimate_matches_the_error_against_the_mpmath_reference(name, options):
    case = FLAT_PLATE
    p = make_propagator(case.inertia, case.angular_velocity, case.orientation, name, **options)
    estimate = estimate_accuracy(p)
    turns = estimate.horizon_s * np.linalg.norm(case.angular_velocity) / (2 * np.pi)
    assert (
        turns == pytest.approx(ESTIMATE_TURNS, rel=1e-12)
        and estimate.reference == 'the exact solution'
    )
    within = case.times <= estimate.horizon_s  # the reference's samples, 1 s apart
    fresh = make_propagator(case.inertia, case.angular_velocity, case.orientation, name, **options)
    rate, attitude = trajectory_errors(
        *fresh(case.times[within]), case.omega[within], case.q[within]
    )
    # other samples of the same smoothly growing error: the largest of each within 2x
    assert attitude.max() / 2.0 <= estimate.attitude_rad <= 2.0 * attitude.max()
    assert rate.max() / 2.0 <= estimate.rate_rel <= 2.0 * rate.max()
    assert f'attitude error ~{estimate.attitude_rad:.1e} rad' in estimate.describe()


@pytest.mark.parametrize(
    'name, options, factor',
    [
        ('rk4', {'step': 0.02}, 1.5),
        ('lie_rk4', {'step': 0.02}, 1.5),
        ('dop853', {'rtol': 1e-7, 'atol': 1e-9}, 3.0),
    ],
)
def test_estimate_with_effects_matches_a_much_tighter_integration(name, options, factor):
    start = ([3.0, 2.0, 1.0], [0.3, 0.2, 1.0], [0.0, 0.0, 0.0, 1.0])
    p = make_propagator(*start, name, effects=DAMPER, **options)
    estimate = estimate_accuracy(p)
    horizon = min(estimate_horizon(start[1]), 2000 * options.get('step', np.inf))
    assert estimate.horizon_s == horizon
    times = np.linspace(0.0, horizon, 21)
    reference = make_propagator(*start, 'dop853', effects=DAMPER, rtol=1e-13, atol=1e-15)(times)
    rate, attitude = trajectory_errors(
        *make_propagator(*start, name, effects=DAMPER, **options)(times), *reference
    )
    assert attitude.max() / factor <= estimate.attitude_rad <= factor * attitude.max()
    assert rate.max() / factor <= estimate.rate_rel <= factor * rate.max()


def test_the_estimate_does_not_advance_the_running_propagator():
    p = make_propagator(
        FLAT_PLATE.inertia, FLAT_PLATE.angular_velocity, FLAT_PLATE.orientation, 'rk4', step=0.01
    )
    before = p(np.array([0.5]))
    simulation = Simulation(p, 100.0)
    assert 'accuracy: attitude error ~' in simulation.summary()
    assert simulation.accuracy in simulation.summary()
    np.testing.assert_array_equal(p(np.array([0.5]))[1], before[1])


@pytest.mark.parametrize('speed', [1e3, 1e-3])
def test_the_estimate_follows_the_motion_for_the_same_turns_at_any_spin_rate(speed):
    """
    The estimate covers the same number of turns at any spin rate.

    A fast spin is not integrated for thousands of turns at reset, and a slow one is not judged on
    a sliver of its motion.
    """
    start = (
        [3.0, 2.0, 1.0],
        speed * np.array([0.3, 0.2, 1.0]) / np.linalg.norm([0.3, 0.2, 1.0]),
        [0.0, 0.0, 0.0, 1.0],
    )
    options = {'rtol': 1e-7, 'atol': 1e-9 * speed}
    estimate = estimate_accuracy(make_propagator(*start, 'dop853', **options))
    assert estimate.horizon_s == pytest.approx(ESTIMATE_TURNS * 2 * np.pi / speed, rel=1e-12)
    # against the exact solution on a grid of its own over those turns
    times = np.linspace(0.0, estimate.horizon_s, 57)
    rate, attitude = trajectory_errors(
        *make_propagator(*start, 'dop853', **options)(times),
        *make_propagator(*start, 'analytic')(times),
    )
    assert attitude.max() > 1e-10  # the motion of two turns, not of a sliver
    # DOP853's error varies from step to step, so two grids see its peaks differently (as below)
    assert attitude.max() / 3.0 <= estimate.attitude_rad <= 3.0 * attitude.max()
