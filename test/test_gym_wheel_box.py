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
The Gymnasium environments' action box on reaction wheels: each wheel's own bound.

Mode ``torque``: each wheel's ``max_torque``; mode ``speed``: each wheel's ``max_speed``; a wheel
given by ``preset`` gets its datasheet's. An action beyond one wheel's bound is clipped to that
wheel's alone. Test/test_gym.py has the wheels' episodes; here the wheels differ from each other.
"""

import importlib

from conftest import missing_requirement
import numpy as np
import pytest


def _gym_module(name: str):
    """Import ``name`` from gymnasium (the gym extra); skipped without it, except on CI."""
    try:
        return importlib.import_module(name)
    except ImportError as error:
        missing_requirement(f'gymnasium (the gym extra) is not installed: {error}')


gymnasium = _gym_module('gymnasium')

from torquefree_ros import Plant  # noqa: E402
from torquefree_ros.core.scene.loader import scene_from_mapping  # noqa: E402
from torquefree_ros.plant.gym import AttitudeEnv, AttitudeVectorEnv  # noqa: E402

RATE = 10.0
RWP015 = {'max_torque': 0.004, 'max_speed': 6000.0 * np.pi / 30.0}  # its datasheet: 6000 rpm


def _scene(mode):
    wheels = [
        {'axis': [1.0, 0.0, 0.0], 'spin_inertia': 0.05, 'max_torque': 0.01, 'max_speed': 100.0},
        {'axis': [0.0, 1.0, 0.0], 'spin_inertia': 0.05, 'max_torque': 0.03, 'max_speed': 300.0},
        {'axis': [0.0, 0.0, 1.0], 'preset': 'bct_rwp015'},
    ]
    return scene_from_mapping(
        {
            'body': {'inertia': [3.0, 4.0, 5.0]},
            'initial': {'angular_velocity': [0.02, -0.01, 0.01]},
            'effects': [{'reaction_wheels': {'wheels': wheels, 'mode': mode}}],
            'accuracy': 1e-10,
        }
    )


def test_a_held_array_beside_the_commanded_one_takes_no_action():
    """A held array (``mode: hold``) takes no commands: the action is the commanded array's."""
    document = {
        'body': {'inertia': [3.0, 4.0, 5.0]},
        'initial': {'angular_velocity': [0.02, -0.01, 0.01]},
        'effects': [
            {'reaction_wheels': {'mode': 'torque', 'wheels': [
                {'name': 'a', 'axis': [1.0, 0.0, 0.0], 'spin_inertia': 0.05, 'max_torque': 0.01,
                 'max_speed': 100.0}]}},
            {'reaction_wheels': {'mode': 'hold', 'topic': 'held', 'wheels': [
                {'name': 'b', 'axis': [0.0, 0.0, 1.0], 'spin_inertia': 0.05, 'max_torque': 0.02,
                 'max_speed': 300.0, 'speed': 50.0}]}},
        ],
        'accuracy': 1e-10,
    }
    scene = scene_from_mapping(document)
    env = AttitudeEnv(scene, RATE, max_steps=5)
    assert env.actuator == 'wheels'
    np.testing.assert_array_equal(env.action_space.high, [0.01])


@pytest.mark.parametrize('mode', ['torque', 'speed'])
def test_each_wheel_bounds_its_own_action(mode):
    key = 'max_speed' if mode == 'speed' else 'max_torque'
    bound = np.array([{'max_torque': 0.01, 'max_speed': 100.0}[key],
                      {'max_torque': 0.03, 'max_speed': 300.0}[key], RWP015[key]])
    scene = _scene(mode)
    env = AttitudeEnv(scene, RATE, max_steps=5)
    assert env.actuator == 'wheels'
    np.testing.assert_allclose(env.action_space.high, bound, rtol=1e-15)
    np.testing.assert_array_equal(env.action_space.low, -env.action_space.high)
    vector = AttitudeVectorEnv(scene, 2, RATE, max_steps=5)
    assert vector.single_action_space == env.action_space
    env.reset()
    plant = Plant(scene, RATE)
    # each wheel past its own bound alone: clipped to it, the others untouched
    for wheel in range(3):
        action = 0.5 * bound
        action[wheel] = -2.0 * bound[wheel]
        obs, _, _, _, info = env.step(action)
        held = action.copy()
        held[wheel] = -bound[wheel]
        np.testing.assert_array_equal(info['wheels'], held)
        assert info['clipped']
        state = plant.step(wheels=held)
        np.testing.assert_array_equal(obs[:3], state.omega_B)
    obs, _, _, _, info = env.step(0.99 * bound)
    assert not info['clipped']
