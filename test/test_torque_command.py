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
The torque_command effect in the core.

The hold rule (a command holds from the first sample at or after its stamp, stale ones dropped,
zero after the timeout, body or inertial frame) against an independent integration with the same
piecewise-constant torque; malformed commands are refused with a counted reason and never reach the
state; live (one sample at a time, sealed) equals a replay from the recorded commands bit for bit;
a scene without the effect is untouched.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from torquefree_ros.core.frames import quaternion
from torquefree_ros.core.run.simulation import Simulation
from torquefree_ros.core.scene.loader import scene_from_mapping, SceneError

# the hold drives both paths of the numerical propagators (compiled kernels, scipy/numpy reference)
pytestmark = pytest.mark.usefixtures('integrator_path')

RATE = 10.0
INERTIA = [2.0, 3.0, 4.0]
OMEGA0 = [0.3, -0.2, 0.5]


def _simulation(frame='body', timeout=0.5, accuracy=1e-12, epoch_ns=0):
    scene = scene_from_mapping(
        {
            'body': {'inertia': INERTIA},
            'initial': {'angular_velocity': OMEGA0},
            'effects': [{'torque_command': {'frame': frame, 'timeout': timeout}}],
            'accuracy': accuracy,
        }
    )
    simulation = Simulation(scene.propagator(), RATE, epoch_ns)
    ((effect, hold),) = simulation.command_holds
    hold.frame_id = 'body' if frame == 'body' else 'world'
    return simulation, hold


def _reference(torques, frame='body', count=20):
    """
    Integrate the reference motion, each torque held over its sample interval.

    Euler's equations and q' = q ⊗ (w/2), integrated by scipy's LSODA interval by interval with the
    torque ``torques[k]`` (N m, in ``frame``) held over ``[t_k, t_k+1)``.
    """
    J = np.diag(INERTIA)

    def rhs(t, y, torque):
        w, q = y[:3], y[3:] / np.linalg.norm(y[3:])
        tau = quaternion.rotate_inverse(q, torque) if frame == 'inertial' else torque
        w_dot = np.linalg.solve(J, tau - np.cross(w, J @ w))
        return np.concatenate([w_dot, 0.5 * quaternion.multiply(q, np.append(w, 0.0))])

    y = np.array([*OMEGA0, 0.0, 0.0, 0.0, 1.0])
    states = [y]
    for k in range(count - 1):
        solution = solve_ivp(
            rhs,
            (k / RATE, (k + 1) / RATE),
            y,
            method='LSODA',
            rtol=1e-12,
            atol=1e-14,
            args=(np.asarray(torques[k], float),),
        )
        y = solution.y[:, -1]
        states.append(y)
    states = np.array(states)
    return states[:, :3], states[:, 3:] / np.linalg.norm(states[:, 3:], axis=1, keepdims=True)


@pytest.mark.parametrize('frame', ['body', 'inertial'])
def test_the_hold_rule_against_an_independent_integration(frame):
    simulation, hold = _simulation(frame, timeout=0.5)
    frame_id = hold.frame_id
    # holds from t = 0.3 (k = 3) ...
    assert hold.receive(250_000_000, [0.1, 0.0, 0.0], frame_id=frame_id)[0]
    # ... replaced there by this one
    assert hold.receive(300_000_000, [0.0, 0.2, 0.0], frame_id=frame_id)[0]
    assert hold.receive(100_000_000, [5.0, 5.0, 5.0], frame_id=frame_id) == (
        False,
        'stale: stamped before the latest accepted command',
    )
    assert hold.receive(1_000_000_000, [0.0, -0.1, 0.3], frame_id=frame_id)[0]  # k = 10
    block = simulation.samples(0, 20)
    expected = np.zeros((20, 3))
    expected[3:8] = [0.0, 0.2, 0.0]  # until t_8 - 0.3 s reaches the 0.5 s timeout
    expected[10:15] = [0.0, -0.1, 0.3]
    assert [hold.in_force(k) is not None for k in range(20)] == expected.any(axis=1).tolist()
    omega, q = _reference(expected, frame)
    np.testing.assert_allclose(block.omega_B, omega, rtol=0, atol=1e-10)
    np.testing.assert_allclose(np.abs(np.sum(block.q_NB * q, axis=1)), 1.0, rtol=0, atol=1e-12)
    assert dict(hold.refused) == {'stale': 1}


def test_a_command_holds_from_the_first_sample_at_or_after_its_stamp():
    simulation, hold = _simulation(timeout=10.0, epoch_ns=1_700_000_000_000_000_000)
    stamp = [hold.stamp_ns(k) for k in range(4)]
    for when, k in ((stamp[1] - 1, 1), (stamp[1], 1), (stamp[1] + 1, 2), (stamp[0] - 10**9, 0)):
        assert hold.index_at_or_after(when) == k
    assert hold.receive(stamp[2], [0.0, 0.0, 0.1], frame_id='body')[0]
    assert [c.start for c in hold.commands] == [2]
    hold.seal(5)  # samples up to 6 computed: a command arriving now holds from interval 6 on
    assert hold.receive(stamp[3], [0.0, 0.0, 0.2], frame_id='body')[0]
    assert [c.start for c in hold.commands] == [2, 6]


@pytest.mark.parametrize(
    'torque, force, frame_id, reason',
    [
        ([float('nan'), 0.0, 0.0], [0.0] * 3, 'body', 'not finite'),
        ([0.0, float('inf'), 0.0], [0.0] * 3, 'body', 'not finite'),
        ([0.0, 0.0, 0.0], [float('nan'), 0.0, 0.0], 'body', 'not finite'),
        ([0.0, 0.0, 2e6], [0.0] * 3, 'body', 'too large'),
        ([0.0, 0.0, 0.1], [0.0] * 3, 'world', 'wrong frame'),
        ([0.0, 0.0, 0.1], [0.0] * 3, '', 'wrong frame'),
        ([0.0, 0.0, 0.1], [0.0] * 3, 'x' * 100_000, 'wrong frame'),
    ],
)
def test_malformed_commands_are_refused_counted_and_never_reach_the_state(
    torque, force, frame_id, reason
):
    simulation, hold = _simulation()
    untouched, _ = _simulation()
    accepted, text = hold.receive(0, torque, force, frame_id)
    assert not accepted and text.startswith(reason + ':') and len(text) < 300
    assert dict(hold.refused) == {reason: 1} and not hold.commands
    np.testing.assert_array_equal(
        simulation.samples(0, 8).omega_B, untouched.samples(0, 8).omega_B
    )


@pytest.mark.parametrize('rate', [0.3, 7.0, 100.0, 1000.0, 999_999.0])
def test_the_hold_stamps_samples_as_the_simulation_does(rate):
    from torquefree_ros.core.timing.grid import stamps_ns

    scene = scene_from_mapping(
        {
            'body': {'inertia': INERTIA},
            'initial': {'angular_velocity': OMEGA0},
            'effects': [{'torque_command': {}}],
        }
    )
    simulation = Simulation(scene.propagator(), rate, epoch_ns=1_700_000_000_123_456_789)
    ((_, hold),) = simulation.command_holds
    k = np.unique(np.geomspace(1, 1e9, 300).astype(np.int64))
    expected = stamps_ns(simulation.epoch_ns, k / rate)
    assert [hold.stamp_ns(int(i)) for i in k] == expected.tolist()
    assert [hold.index_at_or_after(int(s)) for s in expected] == k.tolist()


@pytest.mark.parametrize('stamp_ns', [-(2**31) * 10**9, 0, (2**31 - 1) * 10**9 + 999_999_999])
def test_stamps_at_the_ends_of_builtin_time_hold_where_the_rule_says(stamp_ns):
    simulation, hold = _simulation(epoch_ns=1_000_000_000)
    assert hold.receive(stamp_ns, [0.0, 0.0, 0.1], frame_id='body')[0]
    expected = hold.index_at_or_after(stamp_ns)
    assert hold.commands[0].start == expected
    assert hold.stamp_ns(expected) >= stamp_ns and (
        expected == 0 or hold.stamp_ns(expected - 1) < stamp_ns
    )
    assert np.all(np.isfinite(simulation.samples(0, 3).omega_B))


def test_live_one_sample_at_a_time_equals_the_replay_of_its_commands_bit_for_bit():
    rng = np.random.default_rng(7)
    live, hold = _simulation(timeout=0.35)
    rows = [live.samples(0, 1)]
    log = []  # (arrival: the stamp of the interval it first held on, stamp, torque)
    for n in range(1, 60):
        if n % 7 != 3:  # a controller answering most samples, some late, some early, some skipped
            stamp = hold.stamp_ns(n - 1 + int(rng.integers(-1, 2)))
            hold.receive(stamp, rng.normal(0.0, 0.05, 3), frame_id='body')
        for command in hold.seal(n - 1):
            log.append((hold.stamp_ns(command.start), command.stamp_ns, command.values))
        rows.append(live.samples(n, 1))
    replayed, replay_hold = _simulation(timeout=0.35)
    for arrival, stamp, torque in log:
        assert replay_hold.receive(stamp, torque, frame_id='body', arrival_ns=arrival)[0]
    block = replayed.samples(0, 60)
    assert [c.start for c in replay_hold.commands] == [
        hold.index_at_or_after(arrival) for arrival, _, _ in log
    ]
    # sealing forgets superseded ones
    assert len(hold.commands) <= 3 < replay_hold.accepted == hold.accepted
    np.testing.assert_array_equal(np.vstack([r.omega_B for r in rows]), block.omega_B)
    np.testing.assert_array_equal(np.vstack([r.q_NB for r in rows]), block.q_NB)
    assert np.ptp(block.omega_B, axis=0).max() > 0.01  # the commands did move it


def test_a_scene_without_the_effect_stays_exact_and_has_no_hold():
    scene = scene_from_mapping(
        {'body': {'inertia': INERTIA}, 'initial': {'angular_velocity': OMEGA0}}
    )
    simulation = Simulation(scene.propagator(), RATE)
    assert simulation.propagator.exact and simulation.command_holds == ()
    assert simulation.propagator.dynamics.sample_rate is None


@pytest.mark.parametrize(
    'parameters, reason',
    [
        ({'frame': 'wheel'}, r'effects\[0\]\.torque_command\.frame: '),
        ({'timeout': 0}, r'effects\[0\]\.torque_command\.timeout: must be > 0 s'),
        ({'max_torque': -1}, r'effects\[0\]\.torque_command\.max_torque: must be > 0'),
        ({'topic': '2bad'}, r'effects\[0\]\.torque_command\.topic: '),
    ],
)
def test_effect_parameters_are_checked_with_the_field_path(parameters, reason):
    with pytest.raises(SceneError, match=reason):
        scene_from_mapping(
            {
                'body': {'inertia': INERTIA},
                'initial': {'angular_velocity': OMEGA0},
                'effects': [{'torque_command': parameters}],
            }
        )
