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
The plant (torquefree_ros.Plant) under a scene's actuator faults, against the node's path.

The node's path without DDS (each effect's hold, sealed, a ``Simulation`` with the scene's faults)
is the reference: driven by the same commands, the plant gives the same samples bit for bit, with
every actuator fault kind on (wheels stuck and erring, a stuck or erring torque in either frame,
stuck magnetorquers at their last dipole or a value), windows that overlap, start at sample 0 or
between samples, and commands that stop past their timeouts; a batch whose bodies carry different
faults is each body under its own faults; a reset starts the faults' windows again; a scene file
with a fault the plant cannot apply is refused with the fault's field path.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from torquefree_ros import Plant
from torquefree_ros.core.run.simulation import Simulation
from torquefree_ros.core.scene.loader import scene_from_mapping, SceneError

RATE = 10.0
COUNT = 30


def _wheels(mode):
    wheels = [
        {'name': name, 'axis': axis, 'spin_inertia': 0.05, 'max_torque': 0.05,
         'max_speed': 400.0, 'viscous': 1e-4, 'speed': speed}
        for name, axis, speed in (('a', [1.0, 0.0, 0.0], 10.0), ('b', [0.0, 1.0, 0.0], -20.0),
                                  ('c', [0.0, 0.0, 1.0], 30.0))
    ]
    return {'reaction_wheels': {'mode': mode, 'timeout': 0.45, 'wheels': wheels}}


TORQUE_FAULTS = [
    {'torque_stuck': {'start': 0.0, 'end': 0.25}},  # from sample 0: zero, what held before
    {'torque_error': {'start': 0.75, 'end': 2.0, 'bias': [1e-3, -2e-3, 5e-4],
                      'scale': [0.5, 1.5, -1.0]}},
    {'torque_stuck': {'start': 0.5, 'end': 0.9}},  # overlaps the error: list order
    {'torque_stuck': {'start': 2.2, 'end': 2.45, 'value': [1e-3, 0.0, -1e-3]}},
]
WHEEL_FAULTS = {
    'torque': [
        {'wheel_stuck': {'wheel': 'b', 'start': 0.3, 'end': 1.1}},
        {'wheel_torque_error': {'wheel': 'a', 'start': 0.0, 'end': 1.55, 'bias': 0.01,
                                'scale': 0.7}},
        {'wheel_torque_error': {'wheel': 'c', 'start': 1.0, 'bias': -0.02, 'scale': 2.0}},
    ],
    'speed': [
        {'wheel_stuck': {'wheel': 'b', 'start': 0.3, 'end': 1.1}},
        # the speed loop's output: overlapping windows compose in list order, one across the gap
        {'wheel_torque_error': {'wheel': 'a', 'start': 0.0, 'end': 1.55, 'bias': 0.01,
                                'scale': 0.7}},
        {'wheel_torque_error': {'wheel': 'a', 'start': 1.0, 'bias': -0.02, 'scale': 2.0}},
        {'wheel_torque_error': {'wheel': 'c', 'start': 0.45, 'end': 2.05, 'scale': 0.0,
                                'bias': 0.003}},
    ],
}


def wheel_scene(mode='torque', frame='body', faults=None, omega=(0.05, -0.03, 0.02), timeout=0.35):
    return scene_from_mapping(
        {
            'body': {'inertia': [4.0, 5.0, 6.0, 0.1, -0.05, 0.02]},
            'initial': {'angular_velocity': list(omega)},
            'effects': [
                _wheels(mode),
                {'torque_command': {'frame': frame, 'timeout': timeout, 'max_torque': 1e-2}},
            ],
            'faults': TORQUE_FAULTS + WHEEL_FAULTS[mode] if faults is None else faults,
            'accuracy': 1e-10,
        }
    )


ORBIT = {'epoch': '2026-03-20T12:00:00Z', 'semi_major_axis': 6878137.0, 'eccentricity': 0.0,
         'inclination': 1.7}
RODS = [
    {'axis': [1.0, 0.0, 0.0], 'max_dipole': 0.2}, {'axis': [0.0, 1.0, 0.0], 'max_dipole': 0.2},
    {'axis': [0.0, 0.0, 1.0], 'max_dipole': 0.15}, {'axis': [1.0, 1.0, 1.0], 'max_dipole': 0.1},
]
ROD_FAULTS = [
    {'magnetorquer_stuck': {'start': 0.45, 'end': 1.2}},
    {'magnetorquer_stuck': {'start': 1.6, 'end': 2.1, 'value': [0.3, -0.1, 0.05]}},  # clipped
    {'torque_error': {'start': 0.2, 'scale': 0.5}},
]


def rod_scene(faults=ROD_FAULTS):
    return scene_from_mapping(
        {
            'body': {'inertia': [0.020, 0.021, 0.005]},
            'initial': {'angular_velocity': [0.1, -0.1, 0.1]},
            'orbit': ORBIT,
            'effects': [
                {'magnetorquers': {'rods': RODS, 'timeout': 1.2, 'max_command': 5.0}},
                {'torque_command': {'timeout': 0.35, 'max_torque': 1e-3}},
            ],
            'faults': faults,
            'accuracy': 1e-10,
        }
    )


def commands(count, seed, width, size, gap=(12, 20)):
    """Seeded commands, None in the gap (past the timeouts: off, then a fault's bias alone)."""
    values = size * np.random.default_rng(seed).standard_normal((count, width))
    return [None if gap[0] <= k < gap[1] else row for k, row in enumerate(values)]


def node_path(scene, torques, wheels=None, dipoles=None):
    """Return the Simulation's samples 1 .. len(torques), the node's path, the same commands."""
    simulation = Simulation(scene.propagator(), RATE, faults=scene.faults)
    holds = dict(simulation.command_holds)
    effects = {effect.name: effect for effect in holds}
    rows = []
    for k, torque in enumerate(torques):
        hold = effects['torque_command'].hold
        if torque is not None:
            assert hold.receive(hold.stamp_ns(k), torque)[0]
        if wheels is not None and wheels[k] is not None:
            effect = effects['reaction_wheels']
            fields = (wheels[k], []) if effect.mode == 'speed' else ([], wheels[k])
            assert effect.receive(hold.stamp_ns(k), '', effect.names, *fields)[0]
        if dipoles is not None and dipoles[k] is not None:
            effect = effects['magnetorquers']
            assert effect.receive(hold.stamp_ns(k), effect.hold.frame_id, dipoles[k])[0]
        for each in holds.values():
            each.seal(k)
        block = simulation.samples(k + 1, 1, outputs=False)
        rows.append(np.concatenate([block.omega_B[0], block.q_NB[0], block.internal[0]]))
    return np.array(rows)


def plant_path(plant, torques, wheels=None, dipoles=None):
    rows = []
    for k, torque in enumerate(torques):
        state = plant.step(
            torque,
            wheels=None if wheels is None else wheels[k],
            dipole=None if dipoles is None else dipoles[k],
        )
        rows.append(np.concatenate([state.omega_B, state.q_NB, state.internal], axis=-1))
    return np.array(rows)


@pytest.mark.parametrize('mode', ['torque', 'speed'])
@pytest.mark.parametrize('frame', ['body', 'inertial'])
def test_the_plant_applies_wheel_and_torque_faults_as_the_node_s_path_bit_for_bit(mode, frame):
    torques = commands(COUNT, 1, 3, 3e-3)
    wheels = commands(COUNT, 2, 3, 0.04 if mode == 'torque' else 60.0, gap=(5, 14))
    scene = wheel_scene(mode, frame)
    expected = node_path(scene, torques, wheels)
    got = plant_path(Plant(scene, RATE), torques, wheels)
    np.testing.assert_array_equal(got, expected)
    unfaulted = plant_path(Plant(wheel_scene(mode, frame, faults=[]), RATE), torques, wheels)
    assert np.abs(unfaulted - got).max() > 1e-3  # (the faults acted)


def test_the_plant_applies_magnetorquer_faults_as_the_node_s_path_bit_for_bit():
    """Stuck rods at the last dipole (a gap past their timeout inside) and at a clipped value."""
    torques = commands(COUNT, 3, 3, 1e-4)
    dipoles = commands(COUNT, 4, 3, 0.2, gap=(8, 16))
    scene = rod_scene()
    expected = node_path(scene, torques, dipoles=dipoles)
    got = plant_path(Plant(scene, RATE), torques, dipoles=dipoles)
    np.testing.assert_array_equal(got, expected)
    unfaulted = plant_path(Plant(rod_scene([]), RATE), torques, dipoles=dipoles)
    assert np.abs(unfaulted - got)[:, :3].max() > 1e-4  # (the faults acted)


def test_a_batch_body_is_its_own_scene_s_faults_bit_for_bit():
    """
    Three bodies: no fault, the torque faults, the wheel faults alone; each its node's path.

    Their torque timeouts differ (0.35, 1.05, 0.35 s): in the gap some bodies' commands are in
    force while the others' timed out.
    """
    faults = [[], TORQUE_FAULTS, WHEEL_FAULTS['torque']]
    omegas = [(0.05, -0.03, 0.02), (0.1, 0.02, -0.04), (-0.02, 0.06, 0.01)]
    scenes = [
        wheel_scene(faults=f, omega=w, timeout=t)
        for f, w, t in zip(faults, omegas, (0.35, 1.05, 0.35))
    ]
    torques = [commands(COUNT, 10 + b, 3, 3e-3) for b in range(3)]
    wheels = [commands(COUNT, 20 + b, 3, 0.04, gap=(5, 14)) for b in range(3)]
    batch = Plant(scenes, RATE)

    def rows(per_body, k):  # (every body's gap is the same: no command for any)
        return None if per_body[0][k] is None else np.array([each[k] for each in per_body])

    together = plant_path(
        batch, [rows(torques, k) for k in range(COUNT)], [rows(wheels, k) for k in range(COUNT)]
    )
    for body, scene in enumerate(scenes):
        expected = node_path(scene, torques[body], wheels[body])
        np.testing.assert_array_equal(together[:, body], expected, err_msg=f'body {body}')


def test_a_reset_starts_the_windows_again_and_repeats_the_run():
    torques = commands(COUNT, 1, 3, 3e-3)
    wheels = commands(COUNT, 2, 3, 0.04, gap=(5, 14))
    plant = Plant(wheel_scene(), RATE)
    first = plant_path(plant, torques, wheels)
    plant.reset()
    np.testing.assert_array_equal(plant_path(plant, torques, wheels), first)


def test_a_scene_file_with_a_bad_actuator_fault_is_refused_with_the_field_path(tmp_path):
    """The plant loads a scene file through the loader: a fault it cannot apply names its path."""
    scene = {
        'body': {'inertia': [4.0, 5.0, 6.0]},
        'initial': {'angular_velocity': [0.0, 0.0, 0.0]},
        'effects': [_wheels('hold')],
        'faults': [{'wheel_torque_error': {'wheel': 'a', 'start': 0.0, 'bias': 0.01}}],
    }
    path = tmp_path / 'bad.yaml'
    path.write_text(json.dumps(scene))
    refused = r'bad\.yaml: faults\[0\]\.wheel_torque_error: the wheel .a. is in mode hold'
    with pytest.raises(SceneError, match=refused):
        Plant([wheel_scene(), str(path)], RATE)
    scene['faults'] = [{'torque_stuck': {'start': 0.0}}]
    path.write_text(json.dumps(scene))
    with pytest.raises(SceneError, match=r'faults\[0\]\.torque_stuck: the scene has no torque_co'):
        Plant(str(path), RATE)
