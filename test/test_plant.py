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
The plant (torquefree_ros.Plant), stepped in process.

It follows the node's command rules bit for bit (the same hold, the same integrator), a batch body
is bit for bit the body alone, a rate-damping loop meets its sampled-data closed form, and a
refused torque changes nothing.
"""

import numpy as np
import pytest
from torquefree_ros import load_scene, Plant
from torquefree_ros.core.run.simulation import Simulation
from torquefree_ros.core.scene.loader import scene_from_mapping

RATE = 10.0


def _plant_scene(
    inertia=(0.4, 4.6, 4.95), omega=(6.0, 0.05, 0.0), frame='body', damper=True, **command
):
    effects = [{'torque_command': {'frame': frame, 'timeout': 0.35, 'max_torque': 0.5, **command}}]
    if damper:
        effects.insert(0, {'damper': {'inertia': 0.05, 'damping': 0.01}})
    return scene_from_mapping(
        {
            'body': {'inertia': list(inertia)},
            'initial': {'angular_velocity': list(omega)},
            'effects': effects,
            'accuracy': 1e-10,
        }
    )


def _commands(count, seed=0):
    rng = np.random.default_rng(seed)
    torques = 0.1 * rng.standard_normal((count, 3))
    # no new command for a while: the last one holds until its timeout, then zero
    torques[5:9] = np.nan
    return torques


def _assert_steps_as_the_node(scene, count):
    """
    Assert that the plant steps as the node does, bit for bit.

    The node's path without DDS: each command offered to the run's hold at its sample, the interval
    sealed, the sample computed by the Simulation; the plant gives the same samples, bit for bit.
    """
    simulation = Simulation(scene.propagator(), RATE)
    ((_, hold),) = simulation.command_holds
    plant = Plant(scene, RATE)
    for k, torque in enumerate(_commands(count)):
        given = None if np.isnan(torque[0]) else torque
        if given is not None:
            assert hold.receive(hold.stamp_ns(k), given)[0]
        hold.seal(k)
        block = simulation.samples(k + 1, 1)
        state = plant.step(given)
        assert plant.k == k + 1
        np.testing.assert_array_equal(state.omega_B, block.omega_B[0])
        np.testing.assert_array_equal(state.q_NB, block.q_NB[0])
        np.testing.assert_array_equal(state.internal, block.internal[0])


@pytest.mark.parametrize('frame', ['body', 'inertial'])
def test_stepping_follows_the_node_rules_bit_for_bit(frame):
    _assert_steps_as_the_node(_plant_scene(frame=frame), 20)


def test_running_without_commands_is_the_scene_propagator_bit_for_bit():
    plant = Plant('explorer1', 1.0)
    run = plant.run(60.0)
    omega, q, x = load_scene('explorer1').propagator().states(np.arange(1, 61) / 1.0)
    np.testing.assert_array_equal(run.omega_B, omega)
    np.testing.assert_array_equal(run.q_NB, q)
    np.testing.assert_array_equal(run.internal, x)
    assert plant.k == 60 and plant.t == 60.0


def test_a_batch_body_is_bit_for_bit_the_body_alone():
    rng = np.random.default_rng(7)
    scenes = [
        _plant_scene(
            inertia=(2.0, 4.6, 4.95) * (1 + 0.02 * rng.standard_normal(3)),
            omega=(6.0, 0.05, 0.0) + 0.1 * rng.standard_normal(3),
        )
        for _ in range(12)
    ]
    batch = Plant(scenes, RATE)
    alone = [Plant(scene, RATE) for scene in scenes]
    torques = 0.05 * rng.standard_normal((15, 12, 3))
    for step in torques:
        states = batch.step(step)
        for b, plant in enumerate(alone):
            state = plant.step(step[b])
            np.testing.assert_array_equal(states.omega_B[b], state.omega_B)
            np.testing.assert_array_equal(states.q_NB[b], state.q_NB)
            np.testing.assert_array_equal(states.internal[b], state.internal)
    assert batch.state.omega_B.shape == (12, 3) and batch.state.q_NB.shape == (12, 4)


def test_a_rate_damping_loop_on_a_sphere_meets_its_sampled_data_closed_form():
    """
    A rate-damping loop on a sphere meets its sampled-data closed form.

    tau_k = -K w_k held over each period h: w' = tau / J is constant on the interval, so
    w_k+1 = (1 - K h / J) w_k exactly (DOP853 integrates a linear w to rounding), the continuous
    w0 exp(-K t / J) in the limit h -> 0.
    """
    J, K = 2.0, 0.5
    scene = scene_from_mapping(
        {
            'body': {'inertia': [J, J, J]},
            'initial': {'angular_velocity': [0.4, -0.3, 0.5]},
            'effects': [{'torque_command': {'max_torque': 10.0}}],
            'accuracy': 1e-12,
        }
    )
    plant = Plant(scene, RATE)
    omega = [plant.state.omega_B]
    for _ in range(100):
        omega.append(plant.step(-K * omega[-1]).omega_B)
    factor = 1.0 - K / (RATE * J)
    expected = np.outer(factor ** np.arange(101), [0.4, -0.3, 0.5])
    np.testing.assert_allclose(omega, expected, rtol=1e-12, atol=1e-15)
    # and within the sampling's first-order error of the continuous law
    continuous = np.outer(np.exp(-K * np.arange(101) / RATE / J), [0.4, -0.3, 0.5])
    assert np.abs(np.array(omega) - continuous).max() < 0.5 * (K / (RATE * J)) ** 2 * 100 * 0.5


# -- against independent references ---------------------------------------------------------------
EXPLORER1_INERTIA = np.array([0.4, 4.6, 4.95])  # kg m^2, the body of explorer1.yaml
DAMPER_J = 0.05  # kg m^2: explorer1's damper rotor


def _inertial_momentum(state) -> np.ndarray:
    """
    Return the total angular momentum of body and damper in the inertial frame.

    ``R(q) (I w + J nu)`` (the damper's state ``nu`` is its rotor's absolute rate, body frame),
    rotated by scipy's Rotation, not by the package's quaternions.
    """
    from scipy.spatial.transform import Rotation

    body_frame = state.omega_B * EXPLORER1_INERTIA + DAMPER_J * state.internal
    return Rotation.from_quat(state.q_NB).apply(body_frame)


def _explorer1_with_commands(timeout=1.0, accuracy=1e-10):
    return scene_from_mapping(
        {
            'body': {'inertia': EXPLORER1_INERTIA.tolist()},
            'initial': {'angular_velocity': [6.0, 0.05, 0.0]},
            'effects': [
                {'damper': {'inertia': DAMPER_J, 'damping': 0.01}},
                {'torque_command': {'frame': 'inertial', 'timeout': timeout, 'max_torque': 0.5}},
            ],
            'accuracy': accuracy,
        }
    )


def test_the_plant_conserves_the_inertial_momentum_of_body_and_damper():
    """
    Without commands the plant conserves body plus damper's momentum in the inertial frame.

    Over 600 s explorer1 goes from its spin about the minor axis to its flat spin (the energy falls
    by 90 %), so the body's own momentum changes by order 1 while the total must not: the damper's
    torque is internal.
    """
    accuracy = 1e-10
    plant = Plant(_explorer1_with_commands(accuracy=accuracy), 1.0)
    initial = _inertial_momentum(plant.state)
    run = plant.run(600.0)
    energy = 0.5 * (
        np.einsum('ij,j,ij->i', run.omega_B, EXPLORER1_INERTIA, run.omega_B)
        + DAMPER_J * np.einsum('ij,ij->i', run.internal, run.internal)
    )
    assert energy[-1] < 0.1 * energy[0]  # the damper did its work: a real test of the sum
    drift = np.abs(_inertial_momentum(run) - initial).max() / np.linalg.norm(initial)
    # DOP853 holds each step's local error under the accuracy (relative); the drift of an
    # invariant sums such errors over the run's steps: about 7x the accuracy here, so 100x is
    # room for rounding elsewhere, and still 1e7 times under the body's own change
    assert drift < 100 * accuracy, drift


def _held_rule(k: int, stamp_k: int | None, timeout_ns: int, rate: float) -> bool:
    """
    Return whether the command given at sample ``stamp_k`` holds over ``[t_k, t_k+1)``.

    hold.py's rule, written out: zero from the sample where ``now - stamp >= timeout`` (stamps in
    integer nanoseconds, ``t_k = k / rate``).
    """
    if stamp_k is None:
        return False
    return round(k * 1e9 / rate) - round(stamp_k * 1e9 / rate) < timeout_ns


def test_inertial_commands_change_the_inertial_momentum_by_their_impulses():
    """
    Inertial-frame commands change body plus damper's inertial momentum by their impulses.

    ``dH_N/dt = tau_N``, constant over each interval: ``H_N(t_k+1) = H_N(t_k) + tau_k h``, with the
    held torque zero once the command timed out (gaps of several samples here).
    """
    rate, timeout = 10.0, 0.35
    plant = Plant(_explorer1_with_commands(timeout=timeout), rate)
    torques = 0.05 * np.random.default_rng(3).standard_normal((60, 3))
    torques[10:20] = np.nan  # no new command: the last one holds 4 intervals (0.3 < 0.35), then 0
    torques[30:33] = np.nan
    expected = [_inertial_momentum(plant.state)]
    momentum = [expected[0]]
    in_force, stamp_k = None, None
    for k, torque in enumerate(torques):
        given = None if np.isnan(torque[0]) else torque
        if given is not None:
            in_force, stamp_k = given, k
        held = _held_rule(k, stamp_k, round(timeout * 1e9), rate)
        expected.append(expected[-1] + (in_force if held else 0.0) / rate)
        momentum.append(_inertial_momentum(plant.step(given)))
    momentum, expected = np.array(momentum), np.array(expected)
    assert np.abs(expected - expected[0]).max() > 0.01  # the impulses are far above the tolerance
    # the integrator's drift over 6 s at accuracy 1e-10 (3e-11 observed), with room
    np.testing.assert_allclose(momentum, expected, rtol=0, atol=1e-9)


@pytest.mark.parametrize(
    'timeout, held_intervals',
    [
        (0.3, 3),  # the timeout on a sample: now - stamp == timeout there, zero from that sample
        (0.35, 4),  # between samples: held over the interval it falls in
    ],
)
def test_a_held_body_torque_on_a_sphere_follows_its_closed_form_up_to_the_timeout(
    timeout, held_intervals
):
    """
    A body torque held on a sphere gives ``w(t) = w0 + tau t / J`` until the timeout, then stays.

    A sphere has ``w x J w = 0`` and a body-frame torque is constant in the body frame, so ``w``
    is linear in ``t`` while the command holds (DOP853 integrates it to rounding). The command is
    given at sample 2 and none after it: it holds on the intervals whose start is less than
    ``timeout`` after its stamp, the last one included, and is zero from the sample where
    ``now - stamp >= timeout`` (hold.py's ``timed_out``).
    """
    from torquefree_ros.core.commands.hold import timed_out

    J, rate, given_at = 2.0, 10.0, 2
    omega0, torque = np.array([0.4, -0.3, 0.5]), np.array([0.1, -0.2, 0.05])
    scene = scene_from_mapping(
        {
            'body': {'inertia': [J, J, J]},
            'initial': {'angular_velocity': omega0.tolist()},
            'effects': [{'torque_command': {'timeout': timeout, 'max_torque': 1.0}}],
            'accuracy': 1e-12,
        }
    )
    # the boundary sample, by the rule in integer nanoseconds and by hold.py's function
    timeout_ns, stamp = round(timeout * 1e9), round(given_at * 1e9 / rate)
    boundary = given_at + held_intervals
    assert not _held_rule(boundary, given_at, timeout_ns, rate)
    assert _held_rule(boundary - 1, given_at, timeout_ns, rate)
    assert timed_out(round(boundary * 1e9 / rate), stamp, timeout_ns)
    assert not timed_out(round((boundary - 1) * 1e9 / rate), stamp, timeout_ns)
    plant = Plant(scene, rate)
    omega = [plant.state.omega_B]
    for k in range(boundary + 5):
        omega.append(plant.step(torque if k == given_at else None).omega_B)
    held_time = np.clip(np.arange(len(omega)) - given_at, 0, held_intervals) / rate
    expected = omega0 + np.outer(held_time, torque / J)
    # a linear w integrated to rounding: a few rounding units of |w| ~ 0.5 rad/s
    np.testing.assert_allclose(omega, expected, rtol=0, atol=1e-14)
    # held on the last interval before the timeout, zero from the boundary sample on
    step = np.diff(omega, axis=0)
    np.testing.assert_allclose(step[boundary - 1], torque / (J * rate), rtol=0, atol=1e-14)
    np.testing.assert_array_equal(step[boundary:], 0.0)


@pytest.mark.parametrize(
    'torque, reason',
    [
        ([np.nan, 0.0, 0.0], 'torque: not finite'),
        ([0.0, 0.0], r'torque: expected shape \(3,\)'),
        ([0.6, 0.0, 0.0], 'torque: a component exceeds max_torque 0.5 N m'),
        ('abc', 'torque: expected numbers of shape'),
    ],
)
def test_a_refused_torque_raises_and_changes_nothing(torque, reason):
    plant = Plant(_plant_scene(), RATE)
    plant.step([0.1, 0.0, 0.0])
    before, k = plant.state, plant.k
    with pytest.raises(ValueError, match=reason):
        plant.step(torque)
    assert plant.k == k
    for now, then in zip(plant.state, before):
        np.testing.assert_array_equal(now, then)
    # and the command in force is still the one given before
    again = Plant(_plant_scene(), RATE)
    again.step([0.1, 0.0, 0.0])
    np.testing.assert_array_equal(plant.step().omega_B, again.step().omega_B)


def test_a_scene_without_torque_command_takes_no_torque():
    plant = Plant('explorer1', 1.0)
    assert not plant.takes_torque
    with pytest.raises(ValueError, match='the scene takes no torque'):
        plant.step([0.0, 0.0, 0.01])
    assert plant.k == 0


def test_a_batch_of_different_kinds_is_refused_with_the_reason():
    with pytest.raises(
        ValueError,
        match=r"scene\[1\]: its motion effects \(torque_command\) differ from scene\[0\]'s "
        r'\(damper, torque_command\)',
    ):
        Plant([_plant_scene(), _plant_scene(damper=False)], RATE)


def test_reset_starts_again_from_sample_0():
    plant = Plant(_plant_scene(), RATE)
    first = [plant.step([0.1, 0.0, 0.0]).omega_B for _ in range(3)]
    plant.reset()
    assert plant.k == 0
    again = [plant.step([0.1, 0.0, 0.0]).omega_B for _ in range(3)]
    np.testing.assert_array_equal(first, again)


def _schedule_scene(frame='inertial', shift=0.0, commanded=False, starts=(0.35, 1.0, 1.7)):
    """
    Build a damper body under a torque schedule.

    Its switches fall between samples and on one (``shift`` moves them); with a torque_command too
    when ``commanded``.
    """
    schedule = [{'start': 0.0, 'torque': [0.01, 0.0, -0.02]}]
    schedule += [
        {'start': start + shift, 'torque': [0.02 * (-1) ** i, 0.01 * i, 0.005]}
        for i, start in enumerate(starts)
    ]
    effects = [
        {'damper': {'inertia': 0.05, 'damping': 0.01}},
        {'external_torque': {'schedule': schedule, 'frame': frame}},
    ]
    if commanded:
        effects.append({'torque_command': {'frame': 'body', 'timeout': 0.35, 'max_torque': 0.5}})
    return scene_from_mapping(
        {
            'body': {'inertia': [0.4, 4.6, 4.95]},
            'initial': {'angular_velocity': [6.0, 0.05, 0.0]},
            'effects': effects,
            'accuracy': 1e-10,
        }
    )


@pytest.mark.parametrize('frame', ['inertial', 'body'])
def test_a_torque_schedule_runs_bit_for_bit_as_the_scene_propagator(frame):
    scene = _schedule_scene(frame)
    # the switches at 0.35 and 1.7 fall between samples, 1.0 on one
    run = Plant(scene, RATE).run(2.5)
    omega, q, x = scene.propagator().states(np.arange(1, 26) / RATE)
    np.testing.assert_array_equal(run.omega_B, omega)
    np.testing.assert_array_equal(run.q_NB, q)
    np.testing.assert_array_equal(run.internal, x)
    # the schedule acts: without it the motion differs
    plain = Plant(_plant_scene(), RATE).run(2.5)
    assert np.abs(plain.omega_B - run.omega_B).max() > 1e-4


def test_a_schedule_and_commands_step_as_the_node_rules_bit_for_bit():
    _assert_steps_as_the_node(_schedule_scene(commanded=True), 25)


def test_a_batch_of_bodies_with_their_own_schedules_is_each_body_alone():
    scenes = [
        _schedule_scene(shift=0.013 * i, starts=(0.35, 1.0, 1.7)[: 1 + i % 3]) for i in range(6)
    ]
    batch = Plant(scenes, RATE).run(2.5)
    for b, scene in enumerate(scenes):
        alone = Plant(scene, RATE).run(2.5)
        np.testing.assert_array_equal(batch.omega_B[b], alone.omega_B)
        np.testing.assert_array_equal(batch.q_NB[b], alone.q_NB)


# -- reaction wheels ------------------------------------------------------------------------------
def _wheel_scene(mode='torque', spin_inertia=0.05, torque=False, omega=(0.2, -0.1, 0.3)):
    axes = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 1.0, 1.0]]
    wheels = [
        {
            'axis': axis,
            'spin_inertia': spin_inertia,
            'max_torque': 0.05,
            'max_speed': 200.0,
            'viscous': 1e-4,
            'coulomb': 1e-3,
            'speed': 10.0 * i,
        }
        for i, axis in enumerate(axes)
    ]
    effects = [{'reaction_wheels': {'wheels': wheels, 'mode': mode, 'timeout': 0.35}}]
    if torque:
        effects.append({'torque_command': {'timeout': 0.35, 'max_torque': 0.5}})
    return scene_from_mapping(
        {
            'body': {'inertia': [3.0, 4.0, 5.0]},
            'initial': {'angular_velocity': list(omega)},
            'effects': effects,
            'accuracy': 1e-10,
        }
    )


def _wheel_inputs(count, mode, seed=1):
    rng = np.random.default_rng(seed)
    inputs = 0.08 * rng.standard_normal((count, 4))  # (some beyond 0.05 N m: clipped)
    if mode == 'speed':
        inputs = 60.0 * rng.standard_normal((count, 4))
    inputs[5:10] = np.nan  # no new command: the one in force until its timeout, then off
    return inputs


@pytest.mark.parametrize('mode', ['torque', 'speed'])
def test_wheel_commands_step_as_the_node_does_bit_for_bit(mode):
    """
    The node's path without DDS (the hold, sealed, a Simulation) and the plant, under wheels.

    Wheel inputs (motor torques or speed set-points) with a gap past the timeout (the motors off,
    a speed drive coasting), beside a torque_command: the same samples, bit for bit, and
    ``state.wheel_speeds`` the speeds of the effect's own state.
    """
    scene = _wheel_scene(mode, torque=True)
    simulation = Simulation(scene.propagator(), RATE)
    holds = dict(simulation.command_holds)
    (wheels,) = [e for e in holds if e.name == 'reaction_wheels']
    (torque_hold,) = [h for e, h in holds.items() if e.name == 'torque_command']
    plant = Plant(scene, RATE)
    assert plant.takes_wheels and plant.wheel_effect.mode == mode
    # the scene's initial speeds, through h = Js (Omega + g . w) and back: to rounding
    np.testing.assert_allclose(plant.state.wheel_speeds, [0, 10, 20, 30], rtol=1e-15, atol=1e-15)
    torques = _commands(30)
    for k, inputs in enumerate(_wheel_inputs(30, mode)):
        given = None if np.isnan(inputs[0]) else inputs
        torque = None if np.isnan(torques[k][0]) else torques[k]
        if given is not None:
            velocity, effort = (given, []) if mode == 'speed' else ([], given)
            assert wheels.receive(torque_hold.stamp_ns(k), '', wheels.names, velocity, effort)[0]
        if torque is not None:
            assert torque_hold.receive(torque_hold.stamp_ns(k), torque)[0]
        for hold in holds.values():
            hold.seal(k)
        block = simulation.samples(k + 1, 1)
        state = plant.step(torque, wheels=given)
        np.testing.assert_array_equal(state.omega_B, block.omega_B[0])
        np.testing.assert_array_equal(state.q_NB, block.q_NB[0])
        np.testing.assert_array_equal(state.internal, block.internal[0])
        np.testing.assert_array_equal(
            state.wheel_speeds, wheels.wheel_speeds(block.omega_B, block.internal)[0]
        )
    assert np.ptp(plant.state.wheel_speeds) > 1.0  # (the wheels moved)


def test_a_batch_of_wheel_bodies_is_bit_for_bit_each_alone():
    rng = np.random.default_rng(3)
    scenes = [
        _wheel_scene('speed', spin_inertia=0.05 * (1 + 0.1 * rng.random()), omega=omega)
        for omega in 0.2 * rng.standard_normal((5, 3))
    ]
    batch = Plant(scenes, RATE)
    alone = [Plant(scene, RATE) for scene in scenes]
    inputs = 50.0 * rng.standard_normal((12, 5, 4))
    for step in inputs:
        states = batch.step(wheels=step)
        for b, plant in enumerate(alone):
            state = plant.step(wheels=step[b])
            for got, expected in zip(states, state):
                np.testing.assert_array_equal(got[b], expected)
    assert batch.state.wheel_speeds.shape == (5, 4)
    run = batch.run(0.5)
    assert run.wheel_speeds.shape == (5, 5, 4) and run.internal.shape == (5, 5, 8)


@pytest.mark.parametrize(
    'wheels, reason',
    [
        ([np.nan, 0.0, 0.0, 0.0], 'wheels: not finite'),
        ([0.0, 0.0, 0.0], r'wheels: expected shape \(4,\) \(one motor torque \(N m\) per wheel'),
        ('abc', 'wheels: expected numbers of shape'),
    ],
)
def test_a_refused_wheel_input_raises_and_changes_nothing(wheels, reason):
    plant = Plant(_wheel_scene(torque=True), RATE)
    plant.step(wheels=[0.01, 0.0, 0.0, 0.0])
    before, k = plant.state, plant.k
    with pytest.raises(ValueError, match=reason):
        plant.step([0.1, 0.0, 0.0], wheels=wheels)  # (the torque is not taken either)
    assert plant.k == k
    for now, then in zip(plant.state, before):
        np.testing.assert_array_equal(now, then)
    again = Plant(_wheel_scene(torque=True), RATE)
    again.step(wheels=[0.01, 0.0, 0.0, 0.0])
    np.testing.assert_array_equal(plant.step().omega_B, again.step().omega_B)
    with pytest.raises(ValueError, match='wheels: the scene takes no wheel commands'):
        Plant(_plant_scene(), RATE).step(wheels=[0.0] * 4)
