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
The actuators' noise faults and the ``topic`` of the torque faults.

``torque_noise``, ``wheel_torque_noise`` and ``dipole_noise`` add a seeded white noise to what a
command hold holds. References: the node's path (``core.run.Simulation`` with its holds sealed
sample by sample) against the plant's, which must agree bit for bit; a running node's recording
against its offline replay, byte for byte; the noise's sample mean, standard deviation, axis
correlation and a Kolmogorov-Smirnov test (scipy's, a library nobody here wrote) against
``N(0, sigma^2)``; its window's intervals by brute force over ``k / rate >= t``.
"""

from __future__ import annotations

import numpy as np
import pytest
from running_faults import (
    assert_the_replay_is_the_recording,
    GAIN,
    NODE_SCENE,
    set_while_running,
)
from scipy.stats import kstest
from torquefree_ros import Plant
from torquefree_ros.core.faults import describe_fault
from torquefree_ros.core.run.simulation import Simulation
from torquefree_ros.core.scene.loader import scene_from_mapping, SceneError

RATE = 10.0
COUNT = 30
WHEELS = [
    {'name': name, 'axis': axis, 'spin_inertia': 0.05, 'max_torque': 0.05, 'max_speed': 400.0,
     'viscous': 1e-4, 'speed': speed}
    for name, axis, speed in (('a', [1.0, 0.0, 0.0], 10.0), ('b', [0.0, 1.0, 0.0], -20.0),
                              ('c', [0.0, 0.0, 1.0], 30.0))
]
NOISES = [
    {'torque_noise': {'start': 0.25, 'end': 2.05, 'sigma': [1e-3, 2e-3, 5e-4], 'seed': 11}},
    {'torque_error': {'start': 1.0, 'end': 1.5, 'scale': 0.5}},  # before it in order: both act
    {'wheel_torque_noise': {'wheel': 'b', 'start': 0.0, 'sigma': 0.01, 'seed': 12}},
    {'wheel_torque_noise': {'wheel': 'c', 'start': 1.2, 'end': 2.0, 'sigma': 0.03}},
]
ROD_NOISES = [{'dipole_noise': {'start': 0.4, 'sigma': [0.05, 0.02, 0.1], 'seed': 3}}]


def wheel_scene(faults=NOISES, frame='body', mode='torque', commands=None):
    return scene_from_mapping(
        {
            'body': {'inertia': [4.0, 5.0, 6.0, 0.1, -0.05, 0.02]},
            'initial': {'angular_velocity': [0.05, -0.03, 0.02]},
            'effects': [
                {'reaction_wheels': {'mode': mode, 'timeout': 0.45, 'wheels': WHEELS}},
                *(commands or [{'torque_command': {'frame': frame, 'timeout': 0.35,
                                                   'max_torque': 1e-2}}]),
            ],
            'faults': list(faults),
            'accuracy': 1e-10,
        },
        source='s.yaml',
    )


def rod_scene(faults=ROD_NOISES):
    rods = [{'axis': [1.0, 0.0, 0.0], 'max_dipole': 0.2},
            {'axis': [0.0, 1.0, 0.0], 'max_dipole': 0.2},
            {'axis': [0.0, 0.0, 1.0], 'max_dipole': 0.15}]
    return scene_from_mapping(
        {
            'body': {'inertia': [0.020, 0.021, 0.005]},
            'initial': {'angular_velocity': [0.1, -0.1, 0.1]},
            'orbit': {'epoch': '2026-03-20T12:00:00Z', 'semi_major_axis': 6878137.0,
                      'eccentricity': 0.0, 'inclination': 1.7},
            'effects': [{'magnetorquers': {'rods': rods, 'timeout': 1.2, 'max_command': 5.0}}],
            'faults': list(faults),
            'accuracy': 1e-10,
        },
        source='s.yaml',
    )


def commands(seed, width, size, gap=(12, 20)):
    """Seeded commands, None in the gap (past the timeouts: the noise on ``off``)."""
    values = size * np.random.default_rng(seed).standard_normal((COUNT, width))
    return [None if gap[0] <= k < gap[1] else row for k, row in enumerate(values)]


def node_path(scene, torques=None, wheels=None, dipoles=None):
    """Return the Simulation's states of samples 1 .. COUNT, the node's path."""
    simulation = Simulation(scene.propagator(), RATE, faults=scene.faults)
    holds = dict(simulation.command_holds)
    effects = {effect.name: effect for effect in holds}
    rows = []
    for k in range(COUNT):
        stamp = next(iter(holds.values())).stamp_ns(k)
        if torques is not None and torques[k] is not None:
            assert effects['torque_command'].hold.receive(stamp, torques[k])[0]
        if wheels is not None and wheels[k] is not None:
            effect = effects['reaction_wheels']
            assert effect.receive(stamp, '', effect.names, [], wheels[k])[0]
        if dipoles is not None and dipoles[k] is not None:
            effect = effects['magnetorquers']
            assert effect.receive(stamp, effect.hold.frame_id, dipoles[k])[0]
        for hold in holds.values():
            hold.seal(k)
        block = simulation.samples(k + 1, 1, outputs=False)
        rows.append(np.concatenate([block.omega_B[0], block.q_NB[0], block.internal[0]]))
    return np.array(rows)


def plant_path(scene, torques=None, wheels=None, dipoles=None):
    plant = Plant(scene, RATE)
    rows = []
    for k in range(COUNT):
        state = plant.step(
            None if torques is None else torques[k],
            wheels=None if wheels is None else wheels[k],
            dipole=None if dipoles is None else dipoles[k],
        )
        rows.append(np.concatenate([state.omega_B, state.q_NB, state.internal]))
    return np.array(rows)


@pytest.mark.parametrize('frame', ['body', 'inertial'])
def test_the_plant_adds_the_torque_and_wheel_noise_as_the_node_s_path_bit_for_bit(frame):
    torques = commands(1, 3, 3e-3)
    wheels = commands(2, 3, 0.02, gap=(5, 14))
    scene = wheel_scene(frame=frame)
    got = plant_path(scene, torques, wheels)
    np.testing.assert_array_equal(got, node_path(scene, torques, wheels))
    quiet = plant_path(wheel_scene(faults=[], frame=frame), torques, wheels)
    assert np.abs(quiet - got).max() > 1e-4  # (the noise acted)


def test_the_plant_adds_the_dipole_noise_as_the_node_s_path_bit_for_bit():
    dipoles = commands(4, 3, 0.1, gap=(8, 16))
    got = plant_path(rod_scene(), dipoles=dipoles)
    np.testing.assert_array_equal(got, node_path(rod_scene(), dipoles=dipoles))
    quiet = plant_path(rod_scene([]), dipoles=dipoles)
    assert np.abs(quiet - got)[:, :3].max() > 1e-6  # (the noise acted)


def _held(scene, name: str, count: int) -> np.ndarray:
    """Return what the ``name`` effect's hold holds on intervals 0 .. count - 1, no command."""
    simulation = Simulation(scene.propagator(), RATE, faults=scene.faults)
    (hold,) = [hold for effect, hold in simulation.command_holds if effect.name == name]
    return np.array([hold.held_on(k) for k in range(count)])


def _first_at_or_after(t):
    """Return the least k with k / rate >= t (float64, the grid's rule written out)."""
    return next(k for k in range(10**6) if k / RATE >= t)


def test_the_torque_noise_has_its_sigma_per_axis_and_acts_on_its_window_only():
    """
    20 000 intervals of a zero torque: what holds is the noise alone.

    60 000 normals in all, 20 000 an axis: an axis's sample sd is within 3 % of its sigma (its
    own sd is 0.5 %: 6 sd), its mean within 5 sigma / sqrt(n), the axes' correlations within
    5 / sqrt(n) of 0, and the whole is normal by Kolmogorov-Smirnov (p > 1e-3: a true normal
    sample fails it once in a thousand seeds; this one is fixed).
    """
    sigma = np.array([1e-3, 2e-3, 5e-4])
    start, end, count = 0.35, 2000.35, 20_010
    scene = wheel_scene([{'torque_noise': {'start': start, 'end': end, 'sigma': sigma.tolist(),
                                           'seed': 5}}])
    held = _held(scene, 'torque_command', count)
    first, stop = _first_at_or_after(start), _first_at_or_after(end)
    assert not held[:first].any() and not held[stop:].any()
    noise = held[first:stop]
    assert noise.all()  # (every interval of the window has it)
    n = noise.shape[0]
    np.testing.assert_allclose(noise.std(axis=0), sigma, rtol=0.03)
    assert (np.abs(noise.mean(axis=0)) < 5 * sigma / np.sqrt(n)).all()
    correlation = np.corrcoef(noise.T)
    assert np.abs(correlation[np.triu_indices(3, 1)]).max() < 5 / np.sqrt(n)
    assert kstest((noise / sigma).ravel(), 'norm').pvalue > 1e-3


def test_a_wheel_s_noise_has_its_sigma_and_another_seed_draws_other_numbers():
    """The motor torque asked of wheel b (no command: zero), 1-sigma 0.01 N m; the others none."""
    count = 20_000
    faults = [{'wheel_torque_noise': {'wheel': 'b', 'start': 0.0, 'sigma': 0.01, 'seed': 1}}]
    held = _held(wheel_scene(faults), 'reaction_wheels', count)
    assert not held[:, [0, 2]].any()
    noise = held[:, 1]
    assert abs(noise.std() / 0.01 - 1) < 0.03 and abs(noise.mean()) < 5 * 0.01 / np.sqrt(count)
    assert kstest(noise / 0.01, 'norm').pvalue > 1e-3
    faults[0]['wheel_torque_noise']['seed'] = 2
    other = _held(wheel_scene(faults), 'reaction_wheels', 100)[:, 1]
    assert np.abs(np.corrcoef(other, noise[:100])[0, 1]) < 0.5 and (other != noise[:100]).all()


def test_the_torque_faults_act_on_the_torque_command_of_their_topic():
    """Two torque_command effects: a stuck torque on b's topic holds b's value alone."""
    two = [{'torque_command': {'timeout': 100.0, 'max_torque': 1.0}},
           {'torque_command': {'topic': 'thrusters', 'timeout': 100.0, 'max_torque': 1.0}}]
    faults = [{'torque_stuck': {'start': 0.2, 'value': [1.0, 2.0, 3.0], 'topic': 'thrusters'}},
              {'torque_noise': {'start': 0.0, 'sigma': 0.1, 'topic': 'torque_command'}}]
    scene = wheel_scene(faults, commands=two)
    simulation = Simulation(scene.propagator(), RATE, faults=scene.faults)
    holds = {effect.topic: hold for effect, hold in simulation.command_holds
             if effect.name == 'torque_command'}
    assert holds['thrusters'].held_on(1).tolist() == [0.0, 0.0, 0.0]
    assert holds['thrusters'].held_on(2).tolist() == [1.0, 2.0, 3.0]
    assert holds['torque_command'].held_on(2).all()  # the noise, and no stuck value
    assert describe_fault(scene.faults[0]) == (
        'torque_stuck thrusters [0.2, ...) s at [1, 2, 3] N m'
    )
    assert describe_fault(scene.faults[1]) == (
        'torque_noise torque_command [0, ...) s sigma 0.1 N m seed 0'
    )


TWO_TOPICS = [{'torque_command': {}}, {'torque_command': {'topic': 'thrusters'}}]


@pytest.mark.parametrize(
    'faults, shape, path',
    [
        ([{'torque_noise': {'start': 0.0, 'sigma': -1e-3}}], {},
         r'faults\[0\]\.torque_noise\.sigma: must be >= 0 N m'),
        ([{'torque_noise': {'start': 0.0, 'sigma': [1e-3, 1e-3]}}], {},
         r'faults\[0\]\.torque_noise\.sigma: expected 3 numbers, got 2'),
        ([{'torque_noise': {'start': 0.0, 'sigma': [1e-3, -1e-3, 0.0]}}], {},
         r'faults\[0\]\.torque_noise\.sigma: every entry must be >= 0 N m'),
        ([{'torque_noise': {'start': 0.0, 'sigma': 1e-3, 'seed': -1}}], {},
         r'faults\[0\]\.torque_noise\.seed: must lie in'),
        ([{'torque_noise': {'start': 0.0, 'sigma': 1e-3, 'seed': 1.5}}], {},
         r'faults\[0\]\.torque_noise\.seed: expected an integer'),
        ([{'torque_noise': {'start': 0.0}}], {}, r'faults\[0\]\.torque_noise\.sigma: '),
        ([{'torque_noise': {'start': 0.0, 'sigma': 1e-3, 'output': 'imu'}}], {},
         r'faults\[0\]\.torque_noise\.output: '),
        ([{'torque_noise': {'start': 0.0, 'sigma': 1e-3, 'topic': 'nope'}}], {},
         r"faults\[0\]\.torque_noise\.topic: 'nope' is not the topic of a torque_command"),
        ([{'torque_noise': {'start': 0.0, 'sigma': 1e-3}}], {'commands': TWO_TOPICS},
         r'faults\[0\]\.torque_noise: the scene has torque_command effects on 2 topics'),
        ([{'torque_stuck': {'start': 0.0}}], {'commands': TWO_TOPICS},
         r'faults\[0\]\.torque_stuck: the scene has torque_command effects on 2 topics'),
        ([{'torque_error': {'start': 0.0, 'scale': 2.0, 'topic': ''}}], {},
         r'faults\[0\]\.torque_error\.topic: expected a non-empty string'),
        ([{'wheel_torque_noise': {'wheel': 'd', 'start': 0.0, 'sigma': 1e-3}}], {},
         r'faults\[0\]\.wheel_torque_noise\.wheel: .d. is not a commanded wheel'),
        ([{'wheel_torque_noise': {'wheel': 'a', 'start': 0.0, 'sigma': [1e-3] * 3}}], {},
         r'faults\[0\]\.wheel_torque_noise\.sigma: expected a finite number N m'),
        ([{'wheel_torque_noise': {'wheel': 'a', 'start': 0.0, 'sigma': 1e-3}}],
         {'mode': 'speed'}, r'faults\[0\]\.wheel_torque_noise: the wheel .a. is in mode speed'),
        ([{'dipole_noise': {'start': 0.0, 'sigma': 0.1}}], {},
         r'faults\[0\]\.dipole_noise: the scene has no magnetorquers'),
        ([{'dipole_noise': {'start': 1.0, 'end': 1.0, 'sigma': 0.1}}], {},
         r'faults\[0\]\.dipole_noise\.end: must be after start'),
    ],
)
def test_bad_noise_and_topic_faults_are_refused_with_the_field_path(faults, shape, path):
    with pytest.raises(SceneError, match=r'^s\.yaml: ' + path):
        wheel_scene(faults, **shape)


# -- on a running node ----------------------------------------------------------------------------
def test_a_torque_noise_set_on_a_running_node_is_the_core_s_and_the_replay_s_byte_for_byte(
    tmp_path,
):
    """
    Set between samples 5 and 6: it acts from interval 6, as the core's run with it from 6.

    The node's rates equal the core's (the same commands, the noise in force from sample 6), bit
    for bit, and the plant's stepped with those commands; ``/diagnostics`` names it;
    ``torquefree_bag --commands``' replay of the recording gives the same bytes.
    """
    first, more = 6, 10
    run = set_while_running(
        tmp_path, '[{torque_noise: {start: 0.0, sigma: [2e-3, 1e-3, 3e-3], seed: 9}}]', first, more
    )
    np.testing.assert_array_equal(run.live, run.offline)
    # the plant with the noise from sample 6 (a window starting at 0.6 s) and the same torques
    plant = Plant(scene_from_mapping({**NODE_SCENE, 'faults': [
        {'torque_noise': {'start': first / RATE, 'sigma': [2e-3, 1e-3, 3e-3], 'seed': 9}}]}), RATE)
    stepped = [plant.state.omega_B] + [plant.step(-GAIN * w).omega_B for w in run.offline[:-1]]
    np.testing.assert_array_equal(np.array(stepped), run.live)
    assert run.diagnostics == {
        'faults': '1',
        'faults_active': 'torque_noise torque_command [0, ...) s sigma [0.002, 0.001, 0.003] '
        'N m seed 9',
    }
    assert_the_replay_is_the_recording(tmp_path, run)
