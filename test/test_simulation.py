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
The contract's sample grid, as the node and the offline tools use it.

Modules tested: core.simulation and core.timing.
"""

import numpy as np
import pytest
from torquefree_ros import make_propagator, propagate
from torquefree_ros.core.run.simulation import Simulation
from torquefree_ros.core.timing.grid import check_rate, restart_epoch_ns, stamps_ns

INERTIA, OMEGA, Q0 = [3.0, 2.0, 1.0], [0.3, 0.2, 1.0], [0.0, 0.0, 0.0, 1.0]


def test_blocks_are_the_exact_samples_at_k_over_rate(propagator_name):
    from conftest import ACCURATE_SETTINGS

    options = ACCURATE_SETTINGS[propagator_name]
    simulation = Simulation(
        make_propagator(INERTIA, OMEGA, Q0, propagator_name, **options), 30.0, epoch_ns=5
    )
    blocks = [
        simulation.samples(first, count) for first, count in ((0, 1), (1, 7), (8, 256), (264, 3))
    ]
    k = np.arange(267)
    w_ref, q_ref = propagate(INERTIA, OMEGA, Q0, k / 30.0, propagator_name, **options)
    np.testing.assert_array_equal(np.concatenate([b.omega_B for b in blocks]), w_ref)
    np.testing.assert_array_equal(np.concatenate([b.q_NB for b in blocks]), q_ref)
    np.testing.assert_array_equal(
        np.concatenate([b.stamps_ns for b in blocks]), 5 + np.rint(k / 30.0 * 1e9).astype(np.int64)
    )


def test_stamps_are_exact_nanoseconds_on_wall_clock_epochs():
    epoch = 1_795_238_758_420_937_365  # a 2026 wall-clock time: beyond float64's integer range
    times = np.arange(100_000) / 1000.0
    stamps = stamps_ns(epoch, times)
    assert stamps.dtype == np.int64
    np.testing.assert_array_equal(np.diff(stamps), 1_000_000)  # exactly 1 ms apart
    assert stamps[0] == epoch


@pytest.mark.parametrize(
    'now, last, rate, epoch',
    [
        (100, None, 10.0, 100),  # first start: now
        (1_000, 990, 100.0, 10_000_990),  # our own clock: one period after the last stamp
        (50_000_000, 10_000_000, 100.0, 50_000_000),  # wall clock well past the last stamp: now
        (0, 2**62, 1e6, 2**62 + 1000),  # a clock switch never sends stamps backwards
    ],
)
def test_restart_epoch_never_goes_back(now, last, rate, epoch):
    assert restart_epoch_ns(now, last, rate) == epoch


@pytest.mark.parametrize(
    'rate', [0.0, -1.0, float('nan'), float('inf'), 2e6, '100', True, 5e-324, 9.9e-4]
)
def test_bad_rates_are_refused_with_the_name(rate):
    with pytest.raises(ValueError, match=r'^publish_rate: '):
        check_rate(rate, 'publish_rate')


def test_stamps_past_int32_seconds_are_refused_not_wrapped():
    simulation = Simulation(make_propagator(INERTIA, OMEGA, Q0), 1e-3, epoch_ns=0)
    simulation.samples(2_147_483, 1)  # 2147483000 s: the last whole period before 2^31 s
    with pytest.raises(ValueError, match=r'^sample 2147484: its stamp would pass 2\^31 s'):
        simulation.samples(2_147_480, 5)


def test_a_state_outside_float64_is_refused_before_a_sample_goes_out():
    with pytest.raises(ValueError, match=r'overflows float64'):
        make_propagator([1e100, 1e100, 1e100], [1e200, 0.0, 0.0], Q0)
    with pytest.raises(ValueError, match=r'inertia: entries must lie within ±1e\+100 kg m\^2'):
        make_propagator([1e308, 1e308, 1e308], [0.0, 0.0, 1.0], Q0)


def test_a_too_stiff_scene_stops_within_a_bounded_budget_with_its_reason():
    import time

    from torquefree_ros.core.scene.loader import scene_from_mapping

    scene = scene_from_mapping(
        {
            'body': {'inertia': [0.4, 4.6, 4.95]},
            'initial': {'angular_velocity': [6, 0.05, 0]},
            'effects': [{'damper': {'inertia': 0.05, 'damping': 1e9}}],
        }
    )
    started = time.process_time()
    with pytest.raises(RuntimeError, match=r'too stiff for an explicit integrator'):
        with np.errstate(invalid='ignore', over='ignore'):  # the collapsing steps' own arithmetic
            Simulation(scene.propagator(), 100.0).samples(0, 2)
    assert time.process_time() - started < 1.0  # caught within a few steps, not after 1e10 of them


@pytest.mark.parametrize('method', ['rk4', 'lie_rk4', 'dop853'])
def test_a_step_budget_per_sample_bounds_the_work_before_it_is_done(method):
    """
    A step budget per sample bounds the work before it is done.

    The node's bound (``max_steps_per_sample``): a sample needing more steps than it allows is
    refused, a fixed step before any work, an adaptive one as soon as it is over; samples within it
    are unchanged; the estimate of the accuracy stays bounded work too (it says what it skipped).
    """
    import time

    from torquefree_ros.core.propagators import MAX_STEPS_PER_SAMPLE, StepBudgetExceeded
    from torquefree_ros.core.scene.loader import load_scene

    scene = load_scene('gyrostat')
    free, bounded = scene.propagator(method), scene.propagator(method)
    bounded.max_steps_per_sample = 100 if method != 'dop853' else 3
    times = np.array([0.0, 0.05, 0.1])  # 50 steps of 1 ms apart; dop853 takes 1-2 steps there
    np.testing.assert_array_equal(bounded(times)[0], free(times)[0])
    started = time.process_time()
    with pytest.raises(
        StepBudgetExceeded,
        match=rf'{method}: reaching t = 1000 s needs more than '
        rf'{bounded.max_steps_per_sample} steps from the sample before',
    ):
        bounded([0.0, 1000.0])
    assert time.process_time() - started < 0.5
    # offline and the API refuse what the node refuses (the same bound) unless a caller lifts it
    assert free.max_steps_per_sample == MAX_STEPS_PER_SAMPLE


def test_an_accuracy_estimate_over_its_step_bound_says_so():
    from torquefree_ros.core.scene.loader import scene_from_mapping

    # a stiff damper: dop853 at 1e-12 takes ~10^4 steps over the estimate's two turns
    scene = scene_from_mapping(
        {
            'body': {'inertia': [0.4, 4.6, 4.95]},
            'initial': {'angular_velocity': [6, 0.05, 0]},
            'effects': [{'damper': {'inertia': 0.05, 'damping': 1e3}}],
            'accuracy': 1e-12,
        }
    )
    accuracy = Simulation(scene.propagator(), 100.0).accuracy
    assert accuracy.startswith(
        'not estimated (dop853 needs more than 5,000 steps over the first'
    ), accuracy


def test_summary_names_the_state_and_invariants_are_exact():
    simulation = Simulation(make_propagator(INERTIA, OMEGA, Q0), 100.0, epoch_ns=1_500_000_000)
    summary = simulation.summary()
    for part in (
        'inertia [3, 2, 1] kg m^2',
        'w0 [0.3, 0.2, 1] rad/s',
        'q0 [0, 0, 0, 1]',
        'T 0.675 J',
        '|H| 1.40356688',
        'minor axis polhode, polhode period',
        'propagator analytic',
        '100 Hz',
        'first stamp 1.500000000 s',
    ):
        assert part in summary, part
    block = simulation.samples(1000, 200)  # 10 to 12 s into the motion
    for omega in block.omega_B:
        invariants = simulation.invariants(omega)
        assert abs(invariants.energy_drift) <= 4e-16 * 8  # a few rounding units of T
        assert abs(invariants.momentum_drift) <= 4e-16 * 8
