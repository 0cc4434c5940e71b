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
A batch's magnetometers on bodies at different places of their orbit (a campaign's orbit phase).

Each body's readings are bit for bit that body's alone (its own stream, its place's field), past
the samples its place computes ahead, with bodies sharing a place, bodies on other field models,
and a batch in any order of places.
"""

import numpy as np
from torquefree_ros import Plant
from torquefree_ros.core.scene.loader import scene_from_mapping

RATE = 1.0
SAMPLES = 140  # past two blocks of a place's samples computed ahead (64 each)


def _scene(mean_anomaly, field='igrf', seed=7):
    return scene_from_mapping(
        {
            'body': {'inertia': [0.020, 0.021, 0.005]},
            'initial': {'angular_velocity': [0.1, -0.1, 0.1]},
            'orbit': {
                'epoch': '2026-03-20T12:00:00Z',
                'semi_major_axis': 6878137.0,
                'eccentricity': 0.0,
                'inclination': 1.6999506914424771,
                'mean_anomaly': mean_anomaly,
            },
            'effects': [
                {'magnetometer': {'field': field, 'noise': 1e-7, 'bias': [1e-6, 0.0, -2e-6],
                                  'seed': seed}},
            ],
            'accuracy': 1e-10,
        }
    )


def _readings(scenes):
    plant = Plant(scenes, RATE)
    sensors = plant.sensors()
    rows = []
    for _ in range(SAMPLES):
        rows.append(np.array(sensors.read().rows['magnetometer']).reshape(len(scenes), -1))
        plant.step()
    return np.stack(rows, axis=1)  # (bodies, samples, 12)


def test_bodies_on_different_orbit_phases_read_as_each_alone():
    scenes = [
        _scene(0.0),
        _scene(2.5, seed=8),
        _scene(0.0, seed=9),  # body 0's place: one place, two bodies
        _scene(2.5, field='dipole'),  # body 1's place, another model
        _scene(4.0, field='dipole', seed=10),
    ]
    batch = _readings(scenes)
    # (the places differ: a body's field is its own, not its neighbour's)
    assert not np.array_equal(batch[0, :, :3], batch[1, :, :3])
    for body, scene in enumerate(scenes):
        np.testing.assert_array_equal(batch[body], _readings([scene])[0], err_msg=f'body {body}')
