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
The Gymnasium environments with a dipole action (a scene's magnetorquers) and B_B observed.

A B-dot policy through the environment detumbles ``bdot_detumble`` as the example controller does,
bit for bit the same law on ``Plant.step(dipole=...)``; the observed field is the environment's
field turned by the plant's attitude (numpy's IGRF and a rotation matrix); the box is the rods'
reach and clips; the vector environment's bodies are the single one; bad actions, actuators and
scenes get clear errors.
"""

import importlib
import math

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
from torquefree_ros.core.environment import magnetic  # noqa: E402
from torquefree_ros.core.frames import quaternion  # noqa: E402
from torquefree_ros.core.scene.library import library_scenes  # noqa: E402
from torquefree_ros.core.scene.loader import scene_from_mapping  # noqa: E402
from torquefree_ros.plant.gym import AttitudeEnv, AttitudeVectorEnv  # noqa: E402
import yaml  # noqa: E402

RATE = 1.0  # Hz: the example controller's (examples/test_bdot_detumble_controller.py)
SPAN = 3600  # samples: an hour, about two thirds of an orbit
WINDOW = 300  # samples: the mean rate over each window falls window after window
GAIN = 1.0e5  # A m^2 s/T: the example's k
MAX_DIPOLE = 0.2  # A m^2: bdot_detumble.yaml's rods
GM, SEMI_MAJOR_AXIS = 3.986004418e14, 6878137.0  # the scene's orbit
MEAN_MOTION = math.sqrt(GM / SEMI_MAJOR_AXIS**3)  # 1.107e-3 rad/s


class Bdot:
    """``m = -k dB_B/dt`` by the finite difference of two samples, scaled down as a whole."""

    def __init__(self):
        self.last = None

    def __call__(self, field_B: np.ndarray) -> np.ndarray:
        last, self.last = self.last, np.array(field_B)
        if last is None:
            return np.zeros(3)
        m = -GAIN * (field_B - last) * RATE
        largest = float(np.max(np.abs(m)))
        return m * (MAX_DIPOLE / largest) if largest > MAX_DIPOLE else m


def _field_B(scene, t: float, q_NB) -> np.ndarray:
    """Return the field the magnetometer reads exactly: IGRF-14 at the orbit's place, body axes."""
    place, times = scene.orbit, np.array([t])
    field_N = place.field_N(times, place.state(times)[0], 'igrf')[0]
    return np.array(
        quaternion.rotate_values(quaternion.conjugate_values(q_NB.tolist()), field_N.tolist())
    )


def _bdot_mapping(**rods):
    """Return ``bdot_detumble.yaml`` as a mapping, its magnetorquers' parameters updated."""
    mapping = yaml.safe_load(library_scenes()['bdot_detumble'].read_text())
    mapping['effects'][0]['magnetorquers'].update(rods)
    return mapping


def test_b_dot_through_the_environment_is_the_plants_detumble_bit_for_bit():
    """
    B-dot on the observed B_B detumbles 10 deg/s to the field's turning rate, as on the plant.

    The same law on ``Plant.step(dipole=...)`` with the field computed beside it gives the same
    floats: the observation (state and B_B), the dipole held and the reward. The detumble is the
    example controller's (examples/test_bdot_detumble_controller.py, the theory there): the mean
    rate of each 300 s window below the one before, the last within n and 4 n (measured 3.2 n,
    0.204 deg/s, as the example through the node).
    """
    env = AttitudeEnv('bdot_detumble', RATE, max_steps=SPAN, omega_tol=0.0)
    plant = Plant('bdot_detumble', RATE)
    obs, info = env.reset(seed=0)
    assert env.actuator == 'dipole' and env.frame == 'body' and info == {'t': 0.0}
    state = plant.state
    field = _field_B(plant.scenes[0], 0.0, state.q_NB)
    np.testing.assert_array_equal(obs, np.concatenate([state.omega_B, state.q_NB, field]))
    policy, reference = Bdot(), Bdot()
    omega_ref = math.radians(10.0)
    rates = [np.linalg.norm(obs[:3])]
    for k in range(SPAN):
        action = policy(obs[7:10])
        obs, reward, terminated, truncated, info = env.step(action)
        dipole = reference(field)
        state = plant.step(dipole=dipole)
        field = _field_B(plant.scenes[0], plant.t, state.q_NB)
        np.testing.assert_array_equal(obs, np.concatenate([state.omega_B, state.q_NB, field]))
        # the law scales to 0.2 A m^2, which may round an ulp above the box: clipped to it
        held = np.clip(dipole, -MAX_DIPOLE, MAX_DIPOLE)
        np.testing.assert_array_equal(info['dipole'], held)
        assert info['clipped'] == bool(np.any(held != dipole)) and info['t'] == plant.t
        # the documented reward: -h (|w|^2 / w_ref^2 + 0.1 sum (m_j / 0.2)^2), to rounding
        cost = np.sum(state.omega_B**2) / omega_ref**2 + 0.1 * np.sum((held / MAX_DIPOLE) ** 2)
        assert reward == pytest.approx(-cost / RATE, rel=1e-14)
        assert not terminated and truncated == (k + 1 == SPAN)
        rates.append(np.linalg.norm(obs[:3]))
    means = np.array(rates[:SPAN]).reshape(-1, WINDOW).mean(axis=1)
    assert rates[0] == pytest.approx(omega_ref, rel=1e-12)
    assert np.all(np.diff(means) < 0.0), np.degrees(means)
    assert MEAN_MOTION <= means[-1] <= 4.0 * MEAN_MOTION, means[-1] / MEAN_MOTION


def test_the_observed_field_is_igrf_turned_by_the_attitude():
    """
    B_B is R(q)^T B_N: numpy's IGRF-14 at the orbit's position, a rotation matrix from q.

    An independent path: the orbit's numpy two-body state and ``magnetic.igrf_inertial`` (the
    series in numpy, where the environment runs its compiled kernels), and the textbook matrix of
    a unit quaternion. Within 1e-13 of |B|: the two evaluations of a degree-13 series differ by
    rounding (the kernels are held to numpy to a few ulp), measured 1.3e-15 of |B|. The rotation
    keeps the norm to rounding.
    """
    env = AttitudeEnv('bdot_detumble', RATE, max_steps=40)
    obs, _ = env.reset(seed=3)
    place = env.scene.orbit
    rng = np.random.default_rng(7)
    for _ in range(40):
        t = env.plant.t
        position, _ = place.orbit.state(np.array([place.offset + t]))
        field_N = magnetic.igrf_inertial(position, place.instants(np.array([t])), 'orbit')[0]
        x, y, z, w = obs[3:7]
        rotation = np.array(
            [
                [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
            ]
        )
        size = np.linalg.norm(field_N)
        assert 1e-5 < size < 1e-4  # LEO: tens of microtesla
        np.testing.assert_allclose(obs[7:10], rotation.T @ field_N, rtol=0, atol=1e-13 * size)
        assert np.linalg.norm(obs[7:10]) == pytest.approx(size, rel=1e-13)
        obs, *_ = env.step(rng.uniform(-0.3, 0.3, 3))


def test_the_box_is_the_rods_reach_and_a_larger_action_is_clipped():
    """
    The box: per axis the rods' largest component, capped by max_command; beyond it, clipped.

    A rod per axis: its own ``max_dipole``. Rods turned 45 deg about z: x and y reach ``(0.3 +
    0.1) / sqrt(2)`` each. A ``max_command`` below the reach caps it (the plant refuses beyond).
    An action outside the box holds the clipped dipole, reported, and moves the body as the plant
    moves under that dipole, bit for bit.
    """
    env = AttitudeEnv('bdot_detumble', RATE, max_steps=5)
    assert env.action_space == gymnasium.spaces.Box(-0.2, 0.2, (3,), np.float64)
    assert env.observation_space.shape == (10,)
    s = math.sqrt(0.5)
    turned = scene_from_mapping(
        _bdot_mapping(
            rods=[
                {'axis': [s, s, 0.0], 'max_dipole': 0.3},
                {'axis': [-s, s, 0.0], 'max_dipole': 0.1},
                {'axis': [0.0, 0.0, 1.0], 'max_dipole': 0.2},
            ]
        )
    )
    reach = AttitudeEnv(turned, RATE).action_space.high
    np.testing.assert_allclose(reach, [0.4 * s, 0.4 * s, 0.2], rtol=1e-15)
    capped = scene_from_mapping(_bdot_mapping(max_command=0.15))
    np.testing.assert_array_equal(AttitudeEnv(capped, RATE).action_space.high, 0.15)
    env.reset()
    plant = Plant('bdot_detumble', RATE)
    for action in ([0.5, -0.1, -1.0], [0.05, 0.2, -0.2], [-0.21, 0.0, 0.0]):
        obs, _, _, _, info = env.step(action)
        held = np.clip(action, -0.2, 0.2)
        state = plant.step(dipole=held)
        np.testing.assert_array_equal(obs[:7], np.concatenate([state.omega_B, state.q_NB]))
        np.testing.assert_array_equal(info['dipole'], held)
        assert info['clipped'] == bool(np.any(held != np.asarray(action)))


def test_the_vector_bodies_are_the_single_dipole_environments_bit_for_bit():
    """Each body of the vector environment is the single one under its actions, across resets."""
    vector = AttitudeVectorEnv('bdot_detumble', 2, RATE, max_steps=8, randomize=True)
    assert vector.single_action_space == gymnasium.spaces.Box(-0.2, 0.2, (3,), np.float64)
    assert vector.single_observation_space.shape == (10,)
    observations, _ = vector.reset(seed=11)
    singles = [AttitudeEnv('bdot_detumble', RATE, max_steps=8, randomize=True) for _ in range(2)]
    for i, single in enumerate(singles):
        np.testing.assert_array_equal(observations[i], single.reset(seed=11 + i)[0])
    rng = np.random.default_rng(5)
    for k in range(12):  # the autoreset on step 9: each body begins again
        actions = rng.uniform(-0.3, 0.3, (2, 3))
        observations, rewards, _, truncated, info = vector.step(actions)
        for i, single in enumerate(singles):
            if k == 8:
                expected, _ = single.reset()
                assert rewards[i] == 0.0 and not info['_dipole'][i]
            else:
                expected, reward, _, ended, _ = single.step(actions[i])
                assert rewards[i] == reward and truncated[i] == ended
            np.testing.assert_array_equal(observations[i], expected)


def test_bad_actions_actuators_and_scenes_get_clear_errors():
    env = AttitudeEnv('bdot_detumble', RATE)
    env.reset()
    env.step([0.1, 0.0, 0.0])
    before, k = env.plant.state, env.plant.k
    for action, reason in (
        ([np.nan, 0.0, 0.0], r'action: not finite: \[nan, 0.0, 0.0\]'),
        ([0.0, 0.0], r'action: expected shape \(3,\), got \(2,\)'),
        ('abc', r'action: expected numbers of shape \(3,\)'),
    ):
        with pytest.raises(ValueError, match=reason):
            env.step(action)
    assert env.plant.k == k  # nothing moved
    for now, then in zip(env.plant.state, before):
        np.testing.assert_array_equal(now, then)
    with pytest.raises(ValueError, match=r'actuator: .* takes no wheels \(it takes dipole\)'):
        AttitudeEnv('bdot_detumble', RATE, actuator='wheels')
    with pytest.raises(ValueError, match="actuator: expected one of 'wheels', 'dipole', 'torque'"):
        AttitudeEnv('bdot_detumble', RATE, actuator='magnet')
    with pytest.raises(ValueError, match=r"options: unknown \['field'\]"):
        env.reset(options={'field': 'dipole'})
    # a torque_command beside the rods: the dipole by default, the torque when asked
    mapping = _bdot_mapping()
    mapping['effects'].append({'torque_command': {'max_torque': 0.001}})
    both = scene_from_mapping(mapping)
    assert AttitudeEnv(both, RATE).actuator == 'dipole'
    torque = AttitudeEnv(both, RATE, actuator='torque')
    assert torque.observation_space.shape == (7,) and torque.max_torque == 0.001
    # the bodies of a vector environment share one box
    weaker = scene_from_mapping(
        _bdot_mapping(rods=[{'axis': axis, 'max_dipole': 0.1} for axis in np.eye(3).tolist()])
    )
    with pytest.raises(
        ValueError, match=r'scene\[1\]: its dipole bounds \[0.1, 0.1, 0.1\] differs from'
    ):
        AttitudeVectorEnv(['bdot_detumble', weaker], rate=RATE)
