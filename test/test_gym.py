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
The Gymnasium environments over the plant (torquefree_ros.plant.gym, the optional 'gym' extra).

gymnasium's own check_env passes without a warning; a rate-damping controller ends the detumble
episode within the steps its sampled-data energy bound allows; an episode is the Plant's samples
bit for bit; seeded resets repeat; each body of the vector environment is the single environment
bit for bit, across autoresets; bad actions get clear errors and change nothing.
"""

from dataclasses import replace
import importlib
import math
import subprocess
import sys
import warnings

from conftest import missing_requirement
import numpy as np
import pytest


def _gym_module(name: str):
    """
    Import ``name`` from gymnasium (the gym extra).

    Without it the module is skipped, except on CI (the CI environment variable set), where
    requirements-test.txt installs it: a skip there would pass without testing anything.
    """
    try:
        return importlib.import_module(name)
    except ImportError as error:
        missing_requirement(f'gymnasium (the gym extra) is not installed: {error}')


gymnasium = _gym_module('gymnasium')
check_env = _gym_module('gymnasium.utils.env_checker').check_env
seeding = _gym_module('gymnasium.utils.seeding')
AutoresetMode = _gym_module('gymnasium.vector').AutoresetMode

from torquefree_ros import load_scene, Plant, propagate, RigidBody  # noqa: E402
from torquefree_ros.core.scene.loader import scene_from_mapping  # noqa: E402
from torquefree_ros.plant.gym import (  # noqa: E402
    AttitudeEnv,
    AttitudeVectorEnv,
    DetumbleReward,
    ENV_ID,
)

RATE = 10.0
MAX_TORQUE = 0.01  # detumble.yaml's torque_command.max_torque


def _observation(state):
    return np.concatenate([state.omega_B, state.q_NB, state.internal, state.wheel_speeds])


def _damper_scene(frame='inertial'):
    """Build a scene with an effect state (a damper's rate) and inertial-frame commands."""
    return scene_from_mapping(
        {
            'body': {'inertia': [0.4, 4.6, 4.95]},
            'initial': {'angular_velocity': [6.0, 0.05, 0.0]},
            'effects': [
                {'damper': {'inertia': 0.05, 'damping': 0.01}},
                {'torque_command': {'frame': frame, 'timeout': 0.35, 'max_torque': 0.5}},
            ],
            'accuracy': 1e-10,
        }
    )


def test_importing_the_package_does_not_import_gymnasium():
    code = (
        "import sys, torquefree_ros; assert 'gymnasium' not in sys.modules, 'gymnasium imported'"
    )
    subprocess.run([sys.executable, '-c', code], check=True)


@pytest.mark.parametrize('randomize', [False, True])
def test_check_env_passes_without_warnings(randomize):
    env = AttitudeEnv('detumble', 10.0, randomize=randomize)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter('always')
        check_env(env)
    assert [str(w.message) for w in caught] == []
    assert env.action_space == gymnasium.spaces.Box(-MAX_TORQUE, MAX_TORQUE, (3,), np.float64)
    assert env.observation_space.shape == (7,) and env.observation_space.dtype == np.float64
    assert env.spec.id == ENV_ID and env.frame == 'body'


def test_gymnasium_make_and_make_vec_build_the_environments():
    env = gymnasium.make(ENV_ID, scene='detumble', rate=RATE, max_steps=5)
    assert isinstance(env.unwrapped, AttitudeEnv)
    obs, info = env.reset(seed=1)
    np.testing.assert_array_equal(obs, [0.10, -0.12, 0.14, 0.0, 0.0, 0.0, 1.0])
    assert info == {'t': 0.0}
    envs = gymnasium.make_vec(
        ENV_ID, num_envs=3, vectorization_mode='vector_entry_point', scene='detumble'
    )
    assert isinstance(envs.unwrapped, AttitudeVectorEnv)
    assert envs.metadata['autoreset_mode'] is AutoresetMode.NEXT_STEP
    obs, info = envs.reset(seed=1)
    assert obs.shape == (3, 7) and envs.action_space.shape == (3, 3)
    assert envs.observation_space.shape == (3, 7)


def test_a_proportional_controller_detumbles_within_the_sampled_data_bound():
    """
    A proportional controller detumbles within the steps its sampled-data energy bound allows.

    The action a = -K w is held over h = 1 / rate. E = w.I w (twice the kinetic energy) changes
    only by the torque, dE/dt = 2 w(t).tau = -2K w(t).w_k on [t_k, t_k+1). With w(t) = w_k + e(t)
    and |w'| <= K|w_k| / I_min + G |w|^2 (G = max|I_j - I_k| / I_i / sqrt(3), the gyroscopic term),
    E not increasing keeps |w| <= W = sqrt(E_0 / I_min), and Gronwall gives
    |e(t)| <= c |w_k| (t - t_k), c = (K / I_min + G W) exp(G W h). So E_k+1 - E_k lies within
    -2K h |w_k|^2 (1 -/+ c h / 2), and with E / I_max <= |w|^2 <= E / I_min:
    rho_lo E_k <= E_k+1 <= rho_hi E_k, rho_hi = 1 - 2K h (1 - c h/2) / I_max,
    rho_lo = 1 - 2K h (1 + c h/2) / I_min. The episode ends (|w_n| < tol) by
    n_hi = ceil(ln(E_0 / (I_min tol^2)) / -ln rho_hi) and not before
    n_lo = ln(E_0 / (I_max tol^2)) / -ln rho_lo. K W <= max_torque: the box never clips.
    """
    env = AttitudeEnv('detumble', RATE, max_steps=400)
    scene = env.scene
    body = RigidBody.from_inertia(scene.inertia)
    np.testing.assert_array_equal(body.principal_axes, np.eye(3))
    moments = np.asarray(scene.inertia, dtype=float)
    I_min, I_max, h, tol = moments.min(), moments.max(), 1.0 / RATE, env.omega_tol
    w0 = np.asarray(scene.angular_velocity)
    E0 = w0 @ (moments * w0)
    W = math.sqrt(E0 / I_min)
    K = 0.04
    assert K * W <= MAX_TORQUE  # unsaturated: the torque limit is never reached
    G = max(
        abs(moments[1] - moments[2]) / moments[0],
        abs(moments[2] - moments[0]) / moments[1],
        abs(moments[0] - moments[1]) / moments[2],
    ) / math.sqrt(3.0)
    c = (K / I_min + G * W) * math.exp(G * W * h)
    assert c * h < 1.0  # the increments are small: E does not increase within a step
    rho_hi = 1.0 - 2.0 * K * h * (1.0 - 0.5 * c * h) / I_max
    rho_lo = 1.0 - 2.0 * K * h * (1.0 + 0.5 * c * h) / I_min
    n_hi = math.ceil(math.log(E0 / (I_min * tol**2)) / -math.log(rho_hi))
    n_lo = math.log(E0 / (I_max * tol**2)) / -math.log(rho_lo)
    assert 90 < n_lo < n_hi < 170  # the bound is not vacuous: about 9.6 s to 16.3 s

    obs, _ = env.reset(seed=0)
    energy, total, terminated, n = E0, 0.0, False, 0
    while not terminated:
        obs, reward, terminated, truncated, info = env.step(-K * obs[:3])
        n += 1
        assert not truncated and not info['clipped']
        E = obs[:3] @ (moments * obs[:3])
        assert rho_lo * energy <= E <= rho_hi * energy, n
        energy, total = E, total + reward
    assert n_lo <= n <= n_hi
    assert np.linalg.norm(obs[:3]) < tol <= np.linalg.norm(env.plant.scenes[0].angular_velocity)
    # the documented reward, -h sum(|w_k+1|^2 / |w_0|^2 + 0.1 K^2 |w_k|^2 / max_torque^2), within
    # the same bounds: |w_k|^2 in [rho_lo^k E_0 / I_max, rho_hi^k E_0 / I_min]
    k = np.arange(n + 1)
    low, high = rho_lo**k * E0 / I_max, rho_hi**k * E0 / I_min
    weight = 0.1 * K**2 / MAX_TORQUE**2
    assert -h * (high[1:].sum() / (w0 @ w0) + weight * high[:-1].sum()) <= total
    assert total <= -h * (low[1:].sum() / (w0 @ w0) + weight * low[:-1].sum())
    # left alone (no torque), r_k = -h |w_k+1|^2 / |w_0|^2: the exact torque-free solution's rates
    # (the analytic propagator, not the plant's integrator) give the cost of 10 s
    env.reset()
    idle = sum(env.step(np.zeros(3))[1] for _ in range(100))
    exact, _ = propagate(scene.inertia, w0, scene.orientation, np.arange(1, 101) * h)
    # the plant's DOP853 at the scene's accuracy (1e-10) against the exact rates over 10 s: 10x
    # the accuracy is room (3e-16 observed)
    assert idle == pytest.approx(-h * np.sum(exact * exact) / (w0 @ w0), rel=1e-9, abs=0.0)
    # about one unit a second: |w|^2 stays within [E_0 / I_max, E_0 / I_min] (E = 2T is constant)
    assert -100 * h * E0 / (I_min * (w0 @ w0)) <= idle <= -100 * h * E0 / (I_max * (w0 @ w0))


def test_an_episode_is_the_plants_samples_bit_for_bit():
    """
    An episode is the Plant's samples bit for bit, and its reward the documented one.

    The same torques, clipped to the box as the environment documents, through a Plant of the
    scene; the reward is the documented detumble reward.
    """
    for scene, limit in (
        ('detumble', MAX_TORQUE),
        (_damper_scene(), 0.5),
        (_damper_scene('body'), 0.5),
    ):
        env = AttitudeEnv(scene, RATE, max_steps=30)
        plant = Plant(scene, RATE)
        obs, info = env.reset(seed=3)
        np.testing.assert_array_equal(obs, _observation(plant.state))
        rng = np.random.default_rng(11)
        omega_ref = np.linalg.norm(plant.scenes[0].angular_velocity)
        clipped_any = False
        for k in range(30):
            action = 1.5 * limit * rng.uniform(-1.0, 1.0, 3)  # some components outside the box
            obs, reward, terminated, truncated, info = env.step(action)
            torque = np.clip(action, -limit, limit)
            state = plant.step(torque)
            np.testing.assert_array_equal(obs, _observation(state))
            np.testing.assert_array_equal(info['torque'], torque)
            assert info['clipped'] == bool(np.any(torque != action))
            assert info['t'] == plant.t == (k + 1) / RATE
            expected = (
                -(np.sum(state.omega_B**2) / omega_ref**2 + 0.1 * np.sum(torque**2) / limit**2)
                / RATE
            )
            assert reward == pytest.approx(expected, rel=1e-14)
            assert truncated == (k == 29) and not terminated
            clipped_any |= info['clipped']
        assert clipped_any
        assert obs.shape == env.observation_space.shape
        with pytest.raises(RuntimeError, match='truncated at max_steps = 30; call reset'):
            env.step(np.zeros(3))
    assert env.frame == 'body' and AttitudeEnv(_damper_scene(), RATE).frame == 'inertial'


def test_the_observation_bounds_hold_at_full_torque():
    """
    The observation bounds hold at the largest spin-up the box allows.

    The largest spin-up the box allows (|tau| = sqrt(3) max_torque along w) stays within the rates'
    bound over an episode from the most dispersed start.
    """
    env = AttitudeEnv('detumble', RATE, max_steps=200, randomize=True, spread=0.25)
    obs, _ = env.reset(seed=0)
    for _ in range(200):
        assert obs in env.observation_space
        obs, *_ = env.step(MAX_TORQUE * np.sign(obs[:3]))
    assert obs in env.observation_space
    # the bound is not vacuous
    assert np.linalg.norm(obs[:3]) > 0.3 * env.observation_space.high[0]
    # no bound known
    assert np.isinf(AttitudeEnv(_damper_scene(), RATE).observation_space.high[[0, 7]]).all()


def test_seeded_resets_repeat_and_draw_the_documented_rate():
    scene = load_scene('detumble')
    omega = np.asarray(scene.angular_velocity)
    env = AttitudeEnv('detumble', RATE, max_steps=20)

    def episode(seed=None, options=None):
        obs, _ = env.reset(seed=seed, options=options)
        rows, action = [obs], np.array([0.004, -0.002, 0.001])
        for _ in range(10):
            rows.append(env.step(action)[0])
        return np.array(rows)

    first = episode(7, {'randomize': True})
    np.testing.assert_array_equal(first, episode(7, {'randomize': True}))
    drawn = omega + 0.25 * np.linalg.norm(omega) * seeding.np_random(7)[0].uniform(-1.0, 1.0, 3)
    np.testing.assert_array_equal(first[0, :3], drawn)
    assert not np.array_equal(first[0], episode(8, {'randomize': True})[0])
    # without randomize the scene's own state, whatever the seed
    np.testing.assert_array_equal(episode(7)[0], [0.10, -0.12, 0.14, 0.0, 0.0, 0.0, 1.0])
    np.testing.assert_array_equal(episode(7), episode(9))
    # a sequence of unseeded resets after a seeded one repeats too
    again = AttitudeEnv('detumble', RATE, max_steps=20, randomize=True)
    runs = []
    for _ in range(2):
        again.reset(seed=5)
        runs.append([again.reset()[0] for _ in range(3)])
    np.testing.assert_array_equal(runs[0], runs[1])
    assert len({tuple(r) for r in runs[0]}) == 3


def test_the_vector_bodies_are_the_single_environments_bit_for_bit():
    """
    Each body of the vector environment is the single environment, bit for bit.

    Four bodies of three inertias, dispersed starts, a noisy proportional controller: bodies end
    their episodes at different steps (terminated or truncated), autoreset on the next step into
    new cohorts; each is, step by step and across its episodes, the single environment reset with
    seed + i.
    """
    base = load_scene('detumble')
    scenes = [
        base,
        replace(base, inertia=(0.10, 0.12, 0.09)),
        base,
        replace(base, inertia=(0.2, 0.15, 0.1)),
    ]
    options = {'max_steps': 40, 'omega_tol': 0.05, 'randomize': True, 'spread': 0.6}
    vector = AttitudeVectorEnv(scenes, rate=RATE, **options)
    singles = [AttitudeEnv(scene, RATE, **options) for scene in scenes]
    n = len(scenes)
    assert vector.num_envs == n and vector.single_action_space == singles[0].action_space
    obs, info = vector.reset(seed=100)
    for i, env in enumerate(singles):
        np.testing.assert_array_equal(obs[i], env.reset(seed=100 + i)[0])
    np.testing.assert_array_equal(info['t'], np.zeros(n))
    rng = np.random.default_rng(5)
    ended = np.zeros(n, dtype=bool)
    endings, cohorts = {'terminated': set(), 'truncated': set()}, set()
    for step in range(150):
        actions = -0.04 * obs[:, :3] + 0.006 * rng.standard_normal((n, 3))
        obs, rewards, terminated, truncated, info = vector.step(actions)
        cohorts.add(vector.cohorts)
        for i, env in enumerate(singles):
            if ended[i]:  # next-step autoreset
                expected_obs, _ = env.reset()
                assert (rewards[i], terminated[i], truncated[i], info['_torque'][i]) == (
                    0.0,
                    False,
                    False,
                    False,
                )
                assert info['t'][i] == 0.0
            else:
                expected_obs, reward, term, trunc, single_info = env.step(actions[i])
                assert (rewards[i], terminated[i], truncated[i]) == (reward, term, trunc)
                np.testing.assert_array_equal(info['torque'][i], single_info['torque'])
                assert (
                    info['t'][i] == single_info['t']
                    and info['clipped'][i] == single_info['clipped']
                )
                if term:
                    endings['terminated'].add(step)
                if trunc:
                    endings['truncated'].add(step)
            np.testing.assert_array_equal(obs[i], expected_obs)
        ended = terminated | truncated
    # bodies ended apart, both ways
    assert len(endings['terminated']) >= 2 and endings['truncated']
    assert max(cohorts) > 1


def test_the_vector_reset_mask_and_one_cohort_when_episodes_align():
    vector = AttitudeVectorEnv('detumble', num_envs=5, rate=RATE, max_steps=3)
    obs, info = vector.reset(seed=0)
    assert obs.shape == (5, 7) and vector.cohorts == 1 and info['_t'].all()
    for _ in range(8):  # no termination, a fixed length: the bodies stay one batched plant
        obs, rewards, terminated, truncated, info = vector.step(np.zeros((5, 3)))
        assert vector.cohorts == 1
    moved = vector.step(np.full((5, 3), 0.005))[0]
    mask = np.array([True, False, False, True, False])
    obs, info = vector.reset(options={'reset_mask': mask})
    np.testing.assert_array_equal(
        obs[mask], np.tile([0.10, -0.12, 0.14, 0.0, 0.0, 0.0, 1.0], (2, 1))
    )
    np.testing.assert_array_equal(obs[~mask], moved[~mask])
    np.testing.assert_array_equal(info['_t'], mask)
    assert vector.cohorts == 2


@pytest.mark.parametrize(
    'action, reason',
    [
        ([np.nan, 0.0, 0.0], r'action: not finite: \[nan, 0.0, 0.0\]'),
        ([0.0, np.inf, 0.0], 'action: not finite'),
        ([0.0, 0.0], r'action: expected shape \(3,\), got \(2,\)'),
        (np.zeros((1, 3)), r'action: expected shape \(3,\), got \(1, 3\)'),
        ('abc', r'action: expected numbers of shape \(3,\)'),
        (None, r'action: expected shape \(3,\), got \(\)'),
    ],
)
def test_a_bad_action_raises_and_changes_nothing(action, reason):
    env = AttitudeEnv('detumble', RATE)
    env.reset()
    env.step([0.001, 0.0, 0.0])
    before, k = env.plant.state, env.plant.k
    with pytest.raises(ValueError, match=reason):
        env.step(action)
    assert env.plant.k == k
    for now, then in zip(env.plant.state, before):
        np.testing.assert_array_equal(now, then)


def test_bad_vector_actions_scenes_and_order_get_clear_errors():
    vector = AttitudeVectorEnv('detumble', num_envs=3, rate=RATE)
    with pytest.raises(RuntimeError, match='call reset'):
        vector.step(np.zeros((3, 3)))
    obs, _ = vector.reset(seed=0)
    actions = np.zeros((3, 3))
    actions[2, 1] = np.nan
    with pytest.raises(ValueError, match=r'action: not finite \(body 2\)'):
        vector.step(actions)
    with pytest.raises(ValueError, match=r'action: expected shape \(3, 3\), got \(3,\)'):
        vector.step(np.zeros(3))
    # nothing moved before
    np.testing.assert_array_equal(vector.step(np.zeros((3, 3)))[4]['t'], np.full(3, 0.1))
    with pytest.raises(RuntimeError, match='call reset'):
        AttitudeEnv('detumble', RATE).step(np.zeros(3))
    with pytest.raises(ValueError, match='takes no torque .* an attitude environment needs one'):
        AttitudeEnv('explorer1', 1.0)
    with pytest.raises(ValueError, match='takes no torque'):
        AttitudeVectorEnv('explorer1', num_envs=2, rate=1.0)
    base = load_scene('detumble')
    stronger = replace(
        base, effects=(type(base.effects[0])(**{**base.effects[0].values, 'max_torque': 0.02}),)
    )
    with pytest.raises(
        ValueError, match=r"scene\[1\]: its max_torque 0.02 N m differs from scene\[0\]'s 0.01"
    ):
        AttitudeVectorEnv([base, stronger], rate=RATE)
    with pytest.raises(ValueError, match=r"options: unknown \['angle'\]"):
        AttitudeEnv('detumble', RATE).reset(options={'angle': 1.0})
    with pytest.raises(ValueError, match='max_steps: expected a positive integer'):
        AttitudeEnv('detumble', RATE, max_steps=0)


def test_the_default_reward_is_the_same_arithmetic_for_one_body_and_rows():
    reward = DetumbleReward(np.array([0.2, 0.3]), 0.01, 0.1)
    rows = np.array([[0.1, -0.2, 0.05], [0.01, 0.02, -0.3]])
    torques = np.array([[0.001, 0.0, -0.002], [0.01, 0.01, 0.0]])
    batched = reward(None, torques, type('S', (), {'omega_B': rows})())
    for i in range(2):
        alone = DetumbleReward(float([0.2, 0.3][i]), 0.01, 0.1)(
            None, torques[i], type('S', (), {'omega_B': rows[i]})()
        )
        assert batched[i] == alone


# -- reaction wheels ------------------------------------------------------------------------------
WHEEL_MAX_TORQUE, WHEEL_MAX_SPEED = 0.05, 200.0


def _wheel_scene(mode):
    axes = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 1.0, 1.0]]
    wheels = [
        {
            'axis': axis,
            'spin_inertia': 0.05,
            'max_torque': WHEEL_MAX_TORQUE,
            'max_speed': WHEEL_MAX_SPEED,
            'coulomb': 1e-3,
            'speed': 20.0 * i,
        }
        for i, axis in enumerate(axes)
    ]
    return scene_from_mapping(
        {
            'body': {'inertia': [3.0, 4.0, 5.0]},
            'initial': {'angular_velocity': [0.1, -0.1, 0.05]},
            'effects': [{'reaction_wheels': {'wheels': wheels, 'mode': mode}}],
            'accuracy': 1e-10,
        }
    )


@pytest.mark.parametrize('mode', ['torque', 'speed'])
def test_a_wheel_scene_acts_with_the_wheels_and_observes_their_speeds(mode):
    """
    The action is the wheels' inputs, the observation ends with their speeds: the plant's, exactly.

    check_env passes; every bound is finite (the energy the motors can add), so it warns of none,
    but for speed set-points, whose box is not [-1, 1] (it recommends normalising). An episode at
    the box's corners (its most energetic) stays in the observation space.
    """
    scene = _wheel_scene(mode)
    env = AttitudeEnv(scene, RATE, max_steps=150, randomize=True)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter('always')
        check_env(env)
    expected = ['we recommend using a symmetric and normalized'] if mode == 'speed' else []
    assert len(caught) == len(expected) and all(
        text in str(w.message) for w, text in zip(caught, expected)
    )
    bound = WHEEL_MAX_SPEED if mode == 'speed' else WHEEL_MAX_TORQUE
    assert env.action_space == gymnasium.spaces.Box(-bound, bound, (4,), np.float64)
    assert env.observation_space.shape == (7 + 8 + 4,) and env.frame == 'wheels'
    assert np.isfinite(env.observation_space.high).all()
    plant = Plant(scene, RATE)
    obs, _ = env.reset(seed=5, options={'randomize': False})
    np.testing.assert_array_equal(obs, _observation(plant.state))
    rng = np.random.default_rng(2)
    for k in range(150):
        action = bound * np.sign(rng.uniform(-1.0, 1.0, 4)) * (1.5 if k % 10 == 0 else 1.0)
        obs, reward, _, truncated, info = env.step(action)
        inputs = np.clip(action, -bound, bound)
        state = plant.step(wheels=inputs)
        np.testing.assert_array_equal(obs, _observation(state))
        np.testing.assert_array_equal(info['wheels'], inputs)
        assert info['clipped'] == (k % 10 == 0)
        assert obs in env.observation_space
        omega_ref = np.linalg.norm(scene.angular_velocity)
        cost = np.sum(state.omega_B**2) / omega_ref**2 + 0.1 * np.sum((inputs / bound) ** 2)
        assert reward == pytest.approx(-cost / RATE, rel=1e-14)
    assert truncated
    # the vector environment: each body the single one, bit for bit
    vector = AttitudeVectorEnv(scene, 2, RATE, max_steps=150)
    observations, _ = vector.reset(seed=5)
    single = AttitudeEnv(scene, RATE, max_steps=150)
    np.testing.assert_array_equal(observations[1], single.reset(seed=6)[0])
    for _ in range(20):
        actions = bound * rng.uniform(-1.0, 1.0, (2, 4))
        observations, *_, info = vector.step(actions)
        np.testing.assert_array_equal(observations[1], single.step(actions[1])[0])
    np.testing.assert_array_equal(info['wheels'], actions)
