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
The dipole environments observing the magnetometer's reading, and their finite bounds (issue 41).

The reference for ``observed_field="magnetometer"`` is the plant's own sensors
(``Plant.sensors()``, held bit for bit to the node's and the bag's rows in
``test_plant_sensors``) on a plant stepped with the same dipoles: the observation is that row,
bit for bit. The bounds are held to what the environment observes over episodes that push the
rods to their limits, and to Gymnasium's own checker.
"""

import importlib
import warnings

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
check_env = _gym_module('gymnasium.utils.env_checker').check_env

from torquefree_ros import Plant  # noqa: E402
from torquefree_ros.core.scene.library import library_scenes  # noqa: E402
from torquefree_ros.core.scene.loader import scene_from_mapping  # noqa: E402
from torquefree_ros.plant.gym import AttitudeEnv, AttitudeVectorEnv  # noqa: E402
import yaml  # noqa: E402

RATE = 1.0  # Hz
NT = 1e-9
#: a magnetometer with every error term: noise, bias, scale factor, misalignment, saturation, LSB
SENSOR = {
    'noise': 80 * NT,
    'bias': [150 * NT, -220 * NT, 60 * NT],
    'scale_factor': [300.0, -150.0, 90.0],
    'misalignment': [[0.0, 40.0, -25.0], [30.0, 0.0, 10.0], [-15.0, 20.0, 0.0]],
    'saturation': 80000 * NT,
    'quantization': 5 * NT,
    'seed': 23,
}


def _bdot(magnetometer=None, faults=None):
    """Return ``bdot_detumble`` with its magnetometer's parameters (and faults) replaced."""
    mapping = yaml.safe_load(library_scenes()['bdot_detumble'].read_text())
    if magnetometer is not None:
        (index,) = [i for i, e in enumerate(mapping['effects']) if 'magnetometer' in e]
        mapping['effects'][index] = {'magnetometer': magnetometer}
    if faults is not None:
        mapping['faults'] = faults
    return scene_from_mapping(mapping)


def _magnetometer_row(plant: Plant, sensors) -> np.ndarray:
    return sensors.read().rows['magnetometer'][..., 0:3]


def test_the_observed_field_is_the_magnetometer_s_row_bit_for_bit():
    scene = _bdot(SENSOR)
    env = AttitudeEnv(scene, RATE, max_steps=80, observed_field='magnetometer')
    truth = AttitudeEnv(scene, RATE, max_steps=80)
    plant = Plant(scene, RATE)
    sensors = plant.sensors()
    obs, _ = env.reset(seed=1)
    truth_obs, _ = truth.reset(seed=1)
    np.testing.assert_array_equal(obs[7:10], _magnetometer_row(plant, sensors))
    rng = np.random.default_rng(9)
    for _ in range(80):
        action = rng.uniform(-0.25, 0.25, 3)
        obs, reward, _, _, info = env.step(action)
        truth_obs, truth_reward, *_ = truth.step(action)
        state = plant.step(dipole=info['dipole'])
        np.testing.assert_array_equal(obs[:7], np.concatenate([state.omega_B, state.q_NB]))
        np.testing.assert_array_equal(obs[7:10], _magnetometer_row(plant, sensors))
        # the reading only: the motion and the reward are the truth environment's
        np.testing.assert_array_equal(obs[:7], truth_obs[:7])
        assert reward == truth_reward
        # the sensor's errors are in: 80 nT of noise, biases of 60-220 nT on ~40 uT
        assert 1e-8 < np.abs(obs[7:10] - truth_obs[7:10]).max() < 2e-6


def test_the_default_observes_the_truth_and_an_exact_magnetometer_reads_it_to_rounding():
    """With no errors the reading is the truth's field: the same model, place and rotation."""
    exact = AttitudeEnv('bdot_detumble', RATE, observed_field='magnetometer')
    truth = AttitudeEnv('bdot_detumble', RATE)
    assert truth.magnetometer is None and exact.magnetometer == 'magnetometer'
    for a, b in zip(exact.reset(seed=0), truth.reset(seed=0)):
        np.testing.assert_array_equal(a, b)
    for _ in range(20):
        a, *_ = exact.step([0.1, -0.2, 0.05])
        b, *_ = truth.step([0.1, -0.2, 0.05])
        np.testing.assert_array_equal(a, b)


def test_the_vector_bodies_read_their_own_magnetometers_as_the_single_environments():
    scenes = [_bdot(SENSOR), _bdot({**SENSOR, 'seed': 24})]
    vector = AttitudeVectorEnv(scenes, rate=RATE, max_steps=6, observed_field='magnetometer')
    singles = [AttitudeEnv(s, RATE, max_steps=6, observed_field='magnetometer') for s in scenes]
    observations, _ = vector.reset(seed=4)
    for i, single in enumerate(singles):
        np.testing.assert_array_equal(observations[i], single.reset(seed=4 + i)[0])
    assert not np.array_equal(observations[0, 7:10], observations[1, 7:10])  # own seeds
    rng = np.random.default_rng(2)
    for k in range(9):  # the autoreset on step 7: a new cohort, its sensors from sample 0
        actions = rng.uniform(-0.2, 0.2, (2, 3))
        observations, *_ = vector.step(actions)
        for i, single in enumerate(singles):
            expected = single.reset()[0] if k == 6 else single.step(actions[i])[0]
            np.testing.assert_array_equal(observations[i], expected)


@pytest.mark.parametrize('observed_field', ['truth', 'magnetometer'])
def test_check_env_passes_without_warnings_on_a_magnetorquer_scene(observed_field):
    scene = _bdot(SENSOR)
    env = AttitudeEnv(scene, 10.0, observed_field=observed_field)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter('always')
        check_env(env)
    assert [str(w.message) for w in caught] == []
    assert np.isfinite(env.observation_space.high).all()


def test_the_bounds_hold_what_the_rods_at_their_limits_do_in_an_episode():
    """
    Keep a body spun up by the rods at their limits inside the rate and field bounds.

    The rods at +-max_dipole each, the torque along the rate: the rates, B_B and the readings
    stay inside their bounds. The bounds are not vacuous: the field's within a factor 3 of the
    largest |B_B| seen in LEO (a bound of the model's size anywhere on the orbit: 1.9x IGRF's
    largest at 500 km), the reading's its saturation.
    """
    scene = _bdot(SENSOR)
    env = AttitudeEnv(scene, RATE, max_steps=600, randomize=True, observed_field='magnetometer')
    truth = AttitudeEnv(scene, RATE, max_steps=600, randomize=True)
    space, truth_space = env.observation_space, truth.observation_space
    np.testing.assert_allclose(space.high[7:10], 80000 * NT, rtol=2e-6)  # the saturation
    obs, _ = env.reset(seed=5)
    truth_obs, _ = truth.reset(seed=5)
    first, largest = truth_obs, 0.0
    for _ in range(600):
        push = 0.2 * np.sign(np.cross(truth_obs[7:10], truth_obs[:3]))  # (m x B) . w > 0
        obs, *_ = env.step(push)
        truth_obs, *_ = truth.step(push)
        assert space.contains(obs) and truth_space.contains(truth_obs)
        largest = max(largest, float(np.linalg.norm(truth_obs[7:10])))
    assert truth_space.high[7] < 3.0 * largest
    assert np.linalg.norm(truth_obs[:3]) > 1.5 * np.linalg.norm(first[:3])  # spun up


def test_bad_observed_fields_are_refused_with_the_reason():
    with pytest.raises(ValueError, match=r"observed_field: expected one of 'truth', 'magneto"):
        AttitudeEnv('bdot_detumble', RATE, observed_field='sensor')
    mapping = yaml.safe_load(library_scenes()['bdot_detumble'].read_text())
    mapping['effects'] = [e for e in mapping['effects'] if 'magnetometer' not in e]
    with pytest.raises(ValueError, match=r'observed_field: scene \(.*\) has no magnetometer'):
        AttitudeEnv(scene_from_mapping(mapping), RATE, observed_field='magnetometer')
    mapping = yaml.safe_load(library_scenes()['bdot_detumble'].read_text())
    mapping['effects'].append({'torque_command': {'max_torque': 0.001}})
    with pytest.raises(ValueError, match=r'observed_field: .* dipole action only, .* torque'):
        AttitudeEnv(
            scene_from_mapping(mapping), RATE, actuator='torque', observed_field='magnetometer'
        )


def test_sensor_faults_or_noise_without_saturation_leave_the_reading_unbounded():
    noisy = AttitudeEnv(_bdot({'noise': 50 * NT}), RATE, observed_field='magnetometer')
    assert np.isinf(noisy.observation_space.high[7:10]).all()
    exact = AttitudeEnv(_bdot({'bias': [1e-6, 0.0, 0.0]}), RATE, observed_field='magnetometer')
    truth = AttitudeEnv('bdot_detumble', RATE)
    np.testing.assert_allclose(
        exact.observation_space.high[7:10] - truth.observation_space.high[7:10],
        [1e-6, 0.0, 0.0], rtol=0, atol=1e-9,
    )
    faulted = _bdot(SENSOR, faults=[{'bias': {'output': 'magnetometer', 'start': 1.0,
                                              'end': 2.0, 'step': [1e-5, 0.0, 0.0]}}])
    env = AttitudeEnv(faulted, RATE, observed_field='magnetometer')
    assert np.isinf(env.observation_space.high[7:10]).all()
    assert np.isfinite(env.observation_space.high[0:3]).all()  # the rods' torque: as before


def test_a_magnetorquer_fault_leaves_the_rates_unbounded():
    # a stuck rod's value or the dipole's noise may pass the rods' max_dipole
    faulted = _bdot(faults=[{'dipole_noise': {'start': 1.0, 'sigma': 0.01}}])
    space = AttitudeEnv(faulted, RATE).observation_space
    assert np.isinf(space.high[0:3]).all() and np.isfinite(space.high[7:10]).all()
