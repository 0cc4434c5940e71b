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
The plant's sensors (``Plant.sensors()``), read at its samples one body or a batch at a time.

The reference is the node's and ``torquefree_bag``'s own path, ``core.run.Simulation``: its
outputs of the plant's states computed as one offline block (``Simulation.with_outputs``: the
streams' block path, the fault injector, the rate picking), which shares none of the batched
arithmetic under test (``core.effects.sensor_batch``). Rows are compared bit for bit (the
contract: live, offline, plant and campaign runs give the same sensor data), so no tolerance.
"""

from __future__ import annotations

import copy

import numpy as np
import pytest
from torquefree_ros import Plant
from torquefree_ros.core.effects.sensor_batch import AHEAD
from torquefree_ros.core.run.simulation import SampleBlock, Simulation
from torquefree_ros.core.scene.loader import scene_from_mapping
from torquefree_ros.core.timing.grid import stamps_ns

RATE = 10.0
ORBIT = {
    'epoch': '2026-03-20T12:00:00Z',
    'semi_major_axis': 6878137.0,
    'eccentricity': 0.001,
    'inclination': 1.7,
    'raan': 0.3,
    'argument_of_perigee': 0.5,
    'mean_anomaly': 5.0,
}
GYRO = {
    'angle_random_walk': 0.17,
    'rate_random_walk': 16.0,
    'bias_instability': 10.0,
    'bias_correlation_time': 5.0,
    'turn_on_bias': 30.0,
    'scale_factor': [100.0, -200.0, 50.0],
    'misalignment': [[0.0, 30.0, -20.0], [10.0, 0.0, 40.0], [-25.0, 5.0, 0.0]],
    'saturation': 50.0,
    'quantization': 0.002,
    'latency_samples': 2,
    'seed': 11,
}
TRACKER = {
    'cross_boresight_noise': 5.0,
    'about_boresight_noise': 40.0,
    'max_rate': 100.0,
    'sun_exclusion': 60.0,
    'earth_exclusion': 20.0,
    'latency_samples': 1,
    'seed': 12,
}
MAGNETOMETER = {
    'noise': 40e-9,
    'bias': [1e-7, -5e-8, 2e-8],
    'scale_factor': [200.0, -100.0, 50.0],
    'misalignment': [[0.0, 30.0, -20.0], [10.0, 0.0, 40.0], [-25.0, 5.0, 0.0]],
    'saturation': 6e-5,
    'quantization': 1e-8,
    'seed': 13,
}
SUN = {
    'noise': 0.05,
    'bias': [0.3, -0.2, 0.1],
    'misalignment': [600.0, -300.0, 900.0],
    'field_of_view': 70.0,
    'quantization': 0.02,
    'boresight': [1.0, 0.0, 1.0],
    'seed': 14,
}
SENSORS = [{'imu': GYRO}, {'star_tracker': TRACKER}, {'magnetometer': MAGNETOMETER},
           {'sun_sensor': SUN}]
STEPS = 40  # 4 s at 10 Hz: the tumble takes the boresights in and out of the exclusions


def _scene(sensors=SENSORS, faults=(), omega=(0.6, -0.9, 0.7), orbit=True, seed_offset=0):
    sensors = copy.deepcopy(list(sensors))
    for entry in sensors:
        (values,) = entry.values()
        if 'seed' in values:
            values['seed'] += seed_offset
    data = {
        'body': {'inertia': [0.03, 0.035, 0.01]},
        'initial': {'angular_velocity': list(omega)},
        'effects': [{'torque_command': {'max_torque': 1.0}}] + sensors,
        'faults': copy.deepcopy(list(faults)),
        'accuracy': 1e-10,
    }
    if orbit:
        data['orbit'] = dict(ORBIT)
    return scene_from_mapping(data)


def _without(values, *keys):
    return {key: value for key, value in values.items() if key not in keys}


def _torques(count, bodies):
    return 1e-3 * np.random.default_rng(5).standard_normal((count, bodies, 3))


def _lockstep(scenes, steps=STEPS, torques=None):
    """
    Step a plant of ``scenes`` (a list: a batch; else one body) and read its sensors each sample.

    ``torques``: ``(steps, bodies, 3)`` (default: seeded). Return the states (samples first) and
    the readings.
    """
    plant = Plant(scenes, RATE)
    sensors = plant.sensors()
    if torques is None:
        torques = _torques(steps, len(scenes) if isinstance(scenes, list) else 1)
    states, readings = [plant.state], [sensors.read()]
    for k in range(1, steps):
        torque = torques[k] if plant.batch else torques[k][0]
        states.append(plant.step(torque))
        readings.append(sensors.read())
    return states, readings


def _offline(scene, states, body=None):
    """Return the ``Simulation``'s block of the plant's ``states`` (of ``body`` in a batch)."""
    pick = (lambda a: a) if body is None else (lambda a: a[body])
    times = np.arange(len(states)) / RATE
    block = SampleBlock(
        0,
        times,
        stamps_ns(0, times),
        np.array([pick(s.omega_B) for s in states]),
        np.array([pick(s.q_NB) for s in states]),
        np.array([pick(s.internal) for s in states]),
    )
    simulation = Simulation(scene.propagator(), RATE, outputs=scene.outputs, faults=scene.faults)
    return simulation.with_outputs(block)


def _assert_as_offline(scene, states, readings, body=None):
    """Assert that the readings of ``body`` are the offline rows bit for bit where they go out."""
    block = _offline(scene, states, body)
    count = len(states)
    for position, output in enumerate(scene.outputs):
        rows = np.array([r.rows[output.topic] for r in readings])
        sent = np.array([r.published[output.topic] for r in readings])
        if body is not None:
            rows, sent = rows[:, body], sent[:, body]
        picked = block.output_positions[position]
        expected = np.arange(count) if picked is None else picked
        assert np.flatnonzero(sent).tolist() == expected.tolist(), output.topic
        np.testing.assert_array_equal(rows[sent], block.outputs[position], err_msg=output.topic)
        assert np.isnan(rows[~sent]).all(), output.topic


def test_each_sensor_of_one_body_reads_the_offline_rows_bit_for_bit():
    scene = _scene()
    states, readings = _lockstep(scene)
    _assert_as_offline(scene, states, readings)
    tracker = np.array([r.rows['star_tracker'] for r in readings])
    gyro = np.array([r.rows['imu'] for r in readings])
    sun = np.array([r.rows['sun_sensor'] for r in readings])
    # the cases the comparison must have met to mean something: the gyro's latency (its first 2
    # samples carry no estimate), the tracker with and without a solution, the Sun seen and not
    assert (gyro[:2, 16] == -1.0).all() and (gyro[2:, 16] > 0.0).all()
    lost = tracker[1:, 4] == -1.0
    assert lost.any() and not lost.all()
    seen = np.any(sun != 0.0, axis=1)
    assert seen.any() and not seen.all()


def test_a_batch_body_reads_as_offline_and_as_that_body_alone():
    scenes = [
        _scene(omega=(0.6, -0.9, 0.7), seed_offset=0),
        # each term left out by some body and kept by others: the batch's masks
        _scene(sensors=[{'imu': _without(GYRO, 'misalignment', 'quantization', 'turn_on_bias',
                                         'bias_instability', 'bias_correlation_time')}]
               + SENSORS[1:], omega=(-0.3, 0.5, 1.1), seed_offset=100),
        # without quantization, which would hide a difference of an ulp in most samples
        _scene(sensors=[{'imu': {**_without(GYRO, 'quantization'), 'latency_samples': 0}},
                        {'star_tracker': _without(TRACKER, 'sun_exclusion')},
                        {'magnetometer': {**_without(MAGNETOMETER, 'quantization'),
                                          'field': 'dipole'}},
                        {'sun_sensor': {'noise': 0.1, 'seed': 3}}],
               omega=(0.2, 0.1, -0.8)),
        _scene(omega=(0.1, 0.4, -0.9)),  # body 0's seeds: its draws are shared, not drawn twice
    ]
    torques = _torques(20, len(scenes))
    states, batch = _lockstep(scenes, 20, torques)
    for body, scene in enumerate(scenes):
        _assert_as_offline(scene, states, batch, body)
        _, alone = _lockstep(scene, 20, torques[:, body: body + 1])
        for together, single in zip(batch, alone):
            for topic, rows in single.rows.items():
                np.testing.assert_array_equal(together.rows[topic][body], rows, err_msg=topic)
                assert together.published[topic][body] == single.published[topic]


def test_the_draws_drawn_ahead_go_on_past_their_first_chunk():
    # the batch draws each generator's normals AHEAD samples a call: samples past the first call
    sensors = [{'imu': GYRO}, {'star_tracker': {'cross_boresight_noise': 5.0, 'seed': 4}}]
    scenes = [_scene(sensors=sensors, orbit=False), _scene(sensors=sensors, orbit=False,
                                                           seed_offset=1)]
    states, readings = _lockstep(scenes, steps=AHEAD + 6)
    for body, scene in enumerate(scenes):
        _assert_as_offline(scene, states, readings, body)


def test_faults_act_on_the_readings_as_offline():
    faults = [
        {'stuck': {'output': 'imu', 'start': 0.5, 'end': 1.2}},
        {'bias': {'output': 'magnetometer', 'start': 0.3, 'step': [1e-6, -2e-6, 3e-6]}},
        {'spikes': {'output': 'star_tracker', 'start': 0.0, 'magnitude': 1e-3,
                    'probability': 0.5}},
        {'dropout': {'output': 'sun_sensor', 'start': 0.75, 'end': 1.55}},
        {'stuck': {'output': 'magnetometer', 'start': 2.0, 'value': [1e-5, 2e-5, 3e-5]}},
        {'noise': {'output': 'imu', 'start': 2.5, 'sigma': 1e-3}},
    ]
    scenes = [_scene(faults=faults), _scene(seed_offset=7)]  # the second body has no faults
    states, readings = _lockstep(scenes, steps=30)
    for body, scene in enumerate(scenes):
        _assert_as_offline(scene, states, readings, body)
    gyro = np.array([r.rows['imu'][0] for r in readings])
    # held: the row of the sample before the window (4) on samples 5 .. 11
    np.testing.assert_array_equal(gyro[5:12], np.tile(gyro[4], (7, 1)))
    assert not any(r.published['sun_sensor'][0] for r in readings[8:16])
    assert all(r.published['sun_sensor'][1] for r in readings)


def test_an_output_with_its_own_rate_reads_on_its_samples_only():
    sensors = [{'imu': {**GYRO, 'rate': 2.5}}, {'magnetometer': {**MAGNETOMETER, 'rate': 5.0}},
               {'tf': {}}]
    scene = _scene(sensors=sensors)
    states, readings = _lockstep(scene, steps=21)
    _assert_as_offline(scene, states, readings)
    assert [k for k, r in enumerate(readings) if r.published['imu']] == [0, 4, 8, 12, 16, 20]
    assert [k for k, r in enumerate(readings) if r.published['magnetometer']] == list(
        range(0, 21, 2)
    )
    assert all(r.published['/tf'] for r in readings)


def test_reading_again_repeats_and_reset_starts_over():
    plant = Plant(_scene(), RATE)
    sensors = plant.sensors()
    first = sensors.read()
    plant.step([0.0, 0.0, 0.0])
    second = sensors.read()
    again = sensors.read()
    for topic in second.rows:
        np.testing.assert_array_equal(again.rows[topic], second.rows[topic])
    plant.reset()
    restarted = sensors.read()
    for topic in first.rows:
        np.testing.assert_array_equal(restarted.rows[topic], first.rows[topic])


def test_a_skipped_sample_is_refused():
    plant = Plant(_scene(), RATE)
    sensors = plant.sensors()
    sensors.read()
    plant.run(0.3)
    with pytest.raises(RuntimeError, match='at sample 3 and the sensors next read sample 1'):
        sensors.read()
    fresh = Plant(_scene(), RATE)
    fresh.step([0.0, 0.0, 0.0])
    with pytest.raises(RuntimeError, match='in order from 0'):
        fresh.sensors().read()


def test_a_batch_with_other_outputs_is_refused_with_the_scene_s_index():
    scenes = [_scene(), _scene(sensors=SENSORS[:2])]
    with pytest.raises(ValueError, match=r"scene\[1\]: its outputs .* differ from scene\[0\]'s"):
        Plant(scenes, RATE).sensors()
    rated = [_scene(), _scene(sensors=[{'imu': {**GYRO, 'rate': 5.0}}] + SENSORS[1:])]
    with pytest.raises(ValueError, match=r'scene\[1\].*imu on imu every 2'):
        Plant(rated, RATE).sensors()
    with pytest.raises(ValueError, match=r'scene: imu\.rate: 3 Hz must divide rate 10 Hz'):
        Plant(_scene(sensors=[{'imu': {**GYRO, 'rate': 3.0}}]), RATE).sensors()
