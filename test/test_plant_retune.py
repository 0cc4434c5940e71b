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
A sensor's noise changed on a running plant (``PlantSensors.retune``), against the node's path.

References, neither sharing the plant's batched sensor arithmetic, so rows agree bit for bit and
no tolerance: the node's own run, ``core.run.Simulation`` in lock-step with the same torques (its
command hold sealed sample by sample), its sensors changed at the same sample by the node's
``sensor_noise`` call (``noise_from_text`` then ``Simulation.retune``); and the offline path
(``Simulation.with_outputs``) over the plant's own states with the rebuilt sensors from sample 0,
which a retune's rows must be from its sample on ("as if it had had the new values from the
start", ``core.faults.retune``).

With latencies, a rebuilt sensor's delay line holds the measurements of the samples before the
change, whose states are the run's own: the node's commanded run keeps them
(``core.run.simulation.RecentStates``: its propagator asked for past times would integrate them
again under the command now in force, and go on from there), the plant keeps the states it read.
"""

from __future__ import annotations

import numpy as np
import pytest
from torquefree_ros import Plant
from torquefree_ros.core.checks.schema import FieldError
from torquefree_ros.core.run.simulation import RecentStates, SampleBlock, Simulation
from torquefree_ros.core.scene.loader import noise_from_text, scene_from_mapping
from torquefree_ros.core.timing.grid import stamps_ns

RATE = 10.0
STEPS = 30
RETUNE_AT = 13  # the first sample read with the new parameters
ORBIT = {'epoch': '2026-03-20T12:00:00Z', 'semi_major_axis': 6878137.0,
         'eccentricity': 0.001, 'inclination': 1.7, 'raan': 0.3,
         'argument_of_perigee': 0.5, 'mean_anomaly': 5.0}
CHANGES = {
    'imu': {'angle_random_walk': 0.9, 'rate_random_walk': 40.0, 'bias_instability': 30.0},
    'star_tracker': {'cross_boresight_noise': 30.0},
    'magnetometer': {'noise': 4e-7},
}


def _scene(seed=1, latency=True):
    return scene_from_mapping({
        'body': {'inertia': [0.03, 0.035, 0.01]},
        'initial': {'angular_velocity': [0.3, -0.2, 0.25]},
        'orbit': ORBIT,
        'effects': [
            {'torque_command': {'max_torque': 1.0, 'timeout': 100.0}},
            # latencies: the rebuilt sensors' delay lines start from the run's past states
            {'imu': {'angle_random_walk': 0.17, 'rate_random_walk': 16.0,
                     'bias_instability': 10.0, 'bias_correlation_time': 5.0,
                     'scale_factor': [100.0, -200.0, 50.0],
                     'latency_samples': 2 if latency else 0, 'seed': seed}},
            {'star_tracker': {'cross_boresight_noise': 5.0, 'about_boresight_noise': 40.0,
                              'latency_samples': 1 if latency else 0, 'seed': seed + 1,
                              'rate': RATE / 2}},
            {'magnetometer': {'noise': 4e-8, 'seed': seed + 2}},
        ],
        'accuracy': 1e-10,
    })


def _torques(bodies):
    return 1e-4 * np.random.default_rng(3).standard_normal((STEPS, bodies, 3))


def _node_rows(scene, torques, changes=None):
    """Return each output's rows of the node's lock-step run, its sensors changed at RETUNE_AT."""
    return _node_run(scene, torques, changes)[0]


def _node_run(scene, torques, changes=None):
    """Return the node's lock-step run's rows per output and its states (rates, attitudes)."""
    simulation = Simulation(scene.propagator(), RATE, outputs=scene.outputs)
    ((_, hold),) = simulation.command_holds
    blocks = [simulation.samples(0, 1)]
    for k in range(STEPS - 1):
        assert hold.receive(hold.stamp_ns(k), torques[k])[0]
        hold.seal(k)
        if changes is not None and k + 1 == RETUNE_AT:
            rebuilt = noise_from_text(str(changes), simulation.outputs)
            topics = [output.topic for output in simulation.outputs]
            simulation.retune(RETUNE_AT, outputs={
                topics.index(topic): output for topic, output in rebuilt.items()})
        blocks.append(simulation.samples(k + 1, 1))
    rows = [np.concatenate([block.outputs[p] for block in blocks])
            for p in range(len(scene.outputs))]
    return rows, np.concatenate([np.hstack([b.omega_B, b.q_NB]) for b in blocks])


def _plant_rows(scenes, torques, retunes):
    """
    Return each topic's published rows per body and the states: ``retunes`` at RETUNE_AT.

    ``retunes``: the retune calls' arguments.
    """
    plant = Plant(scenes, RATE)
    sensors = plant.sensors()
    states, readings = [plant.state], [sensors.read()]
    for k in range(STEPS - 1):
        states.append(plant.step(torques[k]))
        if k + 1 == RETUNE_AT:
            for args, kwargs in retunes:
                sensors.retune(*args, **kwargs)
        readings.append(sensors.read())
    rows = {}
    for topic in sensors.topics:
        stacked = np.array([r.rows[topic] for r in readings]).reshape(STEPS, len(scenes), -1)
        sent = np.array([r.published[topic] for r in readings]).reshape(STEPS, len(scenes))
        rows[topic] = [stacked[sent[:, b], b] for b in range(len(scenes))]
    return rows, states


def _offline_rows(outputs, states):
    """Return each output's rows of the offline path over one body's ``states``, from sample 0."""
    times = np.arange(len(states)) / RATE
    block = SampleBlock(0, times, stamps_ns(0, times),
                        *(np.array([getattr(s, name) for s in states]).reshape(len(states), -1)
                          for name in ('omega_B', 'q_NB', 'internal')))
    scene = _scene()
    return Simulation(scene.propagator(), RATE, outputs=outputs).with_outputs(block).outputs


def _first(output, sample):
    """Return an output's first row read at or after run sample ``sample`` (its own grid)."""
    return -(-sample // (2 if output.name == 'star_tracker' else 1))


RETUNES = [((topic,), changes) for topic, changes in CHANGES.items()]


@pytest.mark.parametrize('latency', [False, True], ids=['no latency', 'latencies'])
def test_a_retuned_plant_reads_the_node_s_rows_with_the_same_change_bit_for_bit(latency):
    """And the node's run goes on along its own states: a retune changes no state."""
    scene = _scene(latency=latency)
    torques = _torques(1)
    node, states = _node_run(scene, torques[:, 0], CHANGES)
    plain, plain_states = _node_run(scene, torques[:, 0])
    np.testing.assert_array_equal(states, plain_states)
    plant, _ = _plant_rows([scene], torques, RETUNES)
    for position, output in enumerate(scene.outputs):
        np.testing.assert_array_equal(plant[output.topic][0], node[position],
                                      err_msg=output.topic)
        # the change acted, and from its sample on only
        changed = np.flatnonzero(np.any(node[position] != plain[position], axis=1))
        assert changed.size and changed[0] == _first(output, RETUNE_AT), output.topic


def test_a_retuned_sensor_with_a_latency_reads_the_rebuilt_sensor_s_rows_from_its_sample():
    """From the change on, the rows of the rebuilt sensors run offline from sample 0."""
    scene = _scene()
    torques = _torques(1)
    plant, states = _plant_rows([scene], torques, RETUNES)
    rebuilt = noise_from_text(str(CHANGES), scene.outputs)
    offline = _offline_rows(tuple(rebuilt[o.topic] for o in scene.outputs), states)
    before = _offline_rows(scene.outputs, states)
    for position, output in enumerate(scene.outputs):
        rows, first = plant[output.topic][0], _first(output, RETUNE_AT)
        np.testing.assert_array_equal(rows[:first], before[position][:first], output.topic)
        np.testing.assert_array_equal(rows[first:], offline[position][first:], output.topic)
        # the delay line's rows after the change are the rebuilt sensor's, not the old one's
        assert np.all(np.any(rows[first:] != before[position][first:], axis=1)), output.topic


def test_a_retune_of_one_body_of_a_batch_leaves_the_others_as_they_were():
    scenes = [_scene(seed=1, latency=False), _scene(seed=20, latency=False),
              _scene(seed=40, latency=False)]
    torques = _torques(3)
    plant, _ = _plant_rows(scenes, torques, [(('imu',), {'body': 1, **CHANGES['imu']})])
    for body, scene in enumerate(scenes):
        node = _node_rows(scene, torques[:, body],
                          {'imu': CHANGES['imu']} if body == 1 else None)
        for position, output in enumerate(scene.outputs):
            np.testing.assert_array_equal(plant[output.topic][body], node[position],
                                          err_msg=f'{output.topic} body {body}')


@pytest.mark.parametrize(
    'args, kwargs, message',
    [
        (('imu',), {'angle_random_walk': -1.0}, r'^sensor_noise\.imu\.angle_random_walk: '),
        (('imu',), {'latency_samples': 3}, r'^sensor_noise\.imu\.latency_samples: '),
        (('gyro',), {'noise': 1.0}, r'^sensor_noise\.gyro: not the topic of a sensor'),
        (('magnetometer',), {'noise': 'loud'}, r'^sensor_noise\.magnetometer\.noise: '),
    ],
)
def test_a_bad_retune_is_refused_with_the_node_s_field_path_and_changes_nothing(
    args, kwargs, message
):
    scene = _scene()
    plant = Plant(scene, RATE)
    sensors = plant.sensors()
    first = sensors.read()
    with pytest.raises(FieldError, match=message):
        sensors.retune(*args, **kwargs)
    plant.step([0.0, 0.0, 0.0])
    second = sensors.read()
    again = Plant(scene, RATE)
    reference = again.sensors()
    reference.read()
    again.step([0.0, 0.0, 0.0])
    expected = reference.read()
    for topic in sensors.topics:
        np.testing.assert_array_equal(second.rows[topic], expected.rows[topic])
    assert first.k == 0


def test_a_batch_s_retune_names_the_body_s_scene():
    plant = Plant([_scene(), _scene(seed=5)], RATE)
    with pytest.raises(FieldError, match=r'^scene\[0\]\.sensor_noise\.imu\.angle_random_walk: '):
        plant.sensors().retune('imu', angle_random_walk=-1.0)


def test_a_commanded_run_keeps_its_last_block_and_the_delay_lines_span_before_it():
    """Blocks of 1, then 5, then 1 sample, a span of 3: the states of samples k - 3 .. kept."""
    recent = RecentStates(3)
    states = np.arange(20.0)[:, None] * np.ones((1, 3)), np.ones((20, 4)), np.zeros((20, 0))
    for first, count in ((0, 1), (1, 1), (2, 5), (7, 1), (8, 4)):
        recent.add(first, *(a[first: first + count] for a in states))
    assert recent.first == 5 and len(recent.omega) == 7  # 5 .. 11: 8 .. 11 and 3 before
    omega, _, _ = recent.at(RATE, 12, 'imu').states(np.array([5, 9, 11]) / RATE)
    np.testing.assert_array_equal(omega[:, 0], [5.0, 9.0, 11.0])
    with pytest.raises(ValueError, match=r'^imu: the states of samples 4 \.\. 4 .* 5 \.\. 11 are'):
        recent.at(RATE, 12, 'imu').states(np.array([4]) / RATE)
