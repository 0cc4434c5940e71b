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
Reaction wheels held at constant speed (``mode: hold``): the ``rotor``'s gyrostat, exactly.

References: the ``rotor`` effect with the same ``h = sum Js_i Omega_i g_i`` (the body's states bit
for bit, on both integrator paths); the gyrostat's Euler equation on a principal axis (the drive's
torque ``Js g . w'`` in closed form) and central differences of the rotor's rates (an oblique
array under an inertial torque); the inertial momentum ``R(q) (I w + h)``; the node's path
(``Simulation``) for the plant.
"""

from __future__ import annotations

import numpy as np
import pytest
from torquefree_ros import Plant
from torquefree_ros.core.checks.schema import FieldError
from torquefree_ros.core.frames import quaternion
from torquefree_ros.core.run.simulation import Simulation
from torquefree_ros.core.scene.loader import scene_from_mapping, SceneError

INERTIA = [1.0, 2.0, 3.0]  # kg m^2, locked: the wheels' spin included
FULL_INERTIA = [4.0, 5.0, 6.0, 0.1, -0.05, 0.02]  # with products: every h is oblique
W0 = [0.3, 0.5, -0.4]  # rad/s
RATE = 10.0  # Hz
Z_WHEEL = {'name': 'z', 'axis': [0.0, 0.0, 1.0], 'spin_inertia': 0.2, 'max_torque': 0.5,
           'max_speed': 100.0, 'speed': 20.0}  # h = 4 N m s along z
# three wheels on the body axes: h = (1, 2, 2) N m s, |h| = 3, which a rotor of momentum 3 about
# (1, 2, 2) reproduces bit for bit (asserted)
TRIAD = [
    {'name': name, 'axis': axis, 'spin_inertia': 0.5, 'max_torque': 0.5, 'max_speed': 100.0,
     'speed': speed}
    for name, axis, speed in (('x', [1.0, 0.0, 0.0], 2.0), ('y', [0.0, 1.0, 0.0], 4.0),
                              ('z', [0.0, 0.0, 1.0], 4.0))
]
INERTIAL_TORQUE = {'external_torque': {'frame': 'inertial', 'schedule': [
    {'start': 0.0, 'torque': [0.02, -0.01, 0.005]},
    {'start': 1.25, 'torque': [-0.01, 0.03, 0.0]},  # between samples: a breakpoint of its own
]}}


def scene(wheels, inertia=INERTIA, more=(), faults=(), **array):
    return scene_from_mapping(
        {
            'body': {'inertia': inertia},
            'initial': {'angular_velocity': W0},
            'effects': [
                {'reaction_wheels': {'mode': 'hold', 'wheels': wheels, **array}},
                {'wheel_states': {}},
                *more,
            ],
            'faults': list(faults),
        }
    )


def rotor_scene(h, inertia=INERTIA, more=()):
    h = np.array(h, dtype=float)
    return scene_from_mapping(
        {
            'body': {'inertia': inertia},
            'initial': {'angular_velocity': W0},
            'effects': [
                {'rotor': {'momentum': float(np.linalg.norm(h)), 'axis': h.tolist()}},
                *more,
            ],
        }
    )


def held_effect(propagator):
    (effect,) = [e for e in propagator.effects if e.name == 'reaction_wheels']
    return effect


def run(s, count, propagator='dop853', **options):
    simulation = Simulation(s.propagator(propagator, **options), RATE, outputs=s.outputs)
    return simulation, simulation.samples(0, count)


@pytest.mark.parametrize(
    'wheels, inertia, h, more',
    [
        ([Z_WHEEL], INERTIA, [0.0, 0.0, 4.0], ()),
        (TRIAD, FULL_INERTIA, [1.0, 2.0, 2.0], (INERTIAL_TORQUE,)),
    ],
    ids=['one wheel on a principal axis', 'oblique triad under an inertial torque'],
)
@pytest.mark.parametrize('method', ['dop853', 'rk4'])
def test_a_held_array_is_the_rotor_bit_for_bit(integrator_path, method, wheels, inertia, h, more):
    """Same h, same locked inertia: the body's rates and attitude are the rotor's, bit for bit."""
    options = {'rtol': 1e-10, 'atol': 1e-12} if method == 'dop853' else {'step': 0.01}
    held = scene(wheels, inertia, more).propagator(method, **options)
    rotor = rotor_scene(h, inertia, more).propagator(method, **options)
    (rotor_effect,) = [e for e in rotor.effects if e.name == 'rotor']
    assert held_effect(held).held_momentum_B().tolist() == rotor_effect.h_B.tolist() == h
    assert held.dynamics.state_size == 0 and np.array_equal(held.dynamics.tensor,
                                                            rotor.dynamics.tensor)
    times = np.arange(31) / RATE
    omega, q, internal = held.states(times)
    omega_rotor, q_rotor, _ = rotor.states(times)
    np.testing.assert_array_equal(omega, omega_rotor)
    np.testing.assert_array_equal(q, q_rotor)
    assert internal.shape == (31, 0)
    assert np.abs(omega - omega[0]).max() > 0.1  # (the body tumbles: a test that can fail)


def test_the_held_drive_torque_is_js_g_dot_w_prime_on_a_principal_axis():
    """
    ``u = Js (I1 - I2) w1 w2 / I3 + f(Omega)``: the gyrostat's Euler equation about z.

    With ``h`` along z, ``(I w + h) x w`` has z component ``(I1 - I2) w1 w2``; viscous 1e-4 N m s
    and Coulomb 2e-3 N m at 20 rad/s add ``f = 4e-3`` N m. Same sampled rates on both sides:
    agreement to the rounding of ``w'``'s few operations (1e-15 N m on torques of 1e-2).
    """
    wheel = {**Z_WHEEL, 'viscous': 1e-4, 'coulomb': 2e-3}
    _, block = run(scene([wheel]), 41, rtol=1e-12, atol=1e-14)
    position, velocity, effort = block.outputs[0].T
    w1, w2 = block.omega_B[:, 0], block.omega_B[:, 1]
    expected = 0.2 * (INERTIA[0] - INERTIA[1]) * w1 * w2 / INERTIA[2] + (1e-4 * 20.0 + 2e-3)
    np.testing.assert_allclose(effort, expected, rtol=0, atol=1e-15)
    assert np.ptp(effort) > 1e-2  # (it moves with the tumbling body)
    np.testing.assert_array_equal(velocity, 20.0)
    np.testing.assert_array_equal(position, 20.0 * block.times)


def test_the_held_drive_torque_of_an_oblique_array_matches_the_rotor_s_rate_differences():
    """
    ``u_i = Js_i g_i . w'`` against central differences of the rotor's own rates.

    The rotor (DOP853 at rtol 1e-13) sampled at ``t +- 1e-4`` s: the difference's error is
    ``dt^2 |w'''| / 6`` ~ 1e-9 rad/s^2 here, plus ~1e-12 / 1e-4 of the integrator's; 1e-7 N m
    bounds both times Js. The inertial torque's breakpoint at 1.25 s is between samples, and the
    samples near it use the piece before them.
    """
    _, block = run(scene(TRIAD, FULL_INERTIA, (INERTIAL_TORQUE,)), 31, rtol=1e-13, atol=1e-15)
    effort = block.outputs[0][:, 6:9]
    rotor = rotor_scene([1.0, 2.0, 2.0], FULL_INERTIA, (INERTIAL_TORQUE,)).propagator(
        'dop853', rtol=1e-13, atol=1e-15
    )
    dt = 1e-4
    inner = block.times[1:]  # (t = 0: a one-sided start)
    after, _, _ = rotor.states(inner + dt)
    before, _, _ = rotor.states(inner - dt)
    w_dot = (after - before) / (2.0 * dt)
    expected = 0.5 * w_dot  # Js g_i . w', the g_i the body axes
    np.testing.assert_allclose(effort[1:], expected, rtol=0, atol=1e-7)
    assert np.abs(effort).max() > 1e-2


def test_the_inertial_momentum_of_a_held_array_is_conserved():
    """``R(q) (I w + h)`` within 1e-10 of its start over 20 s at rtol 1e-12 (integration)."""
    s = scene(TRIAD, FULL_INERTIA)
    propagator = s.propagator('dop853', rtol=1e-12, atol=1e-14)
    times = np.linspace(0.0, 20.0, 201)
    omega, q, internal = propagator.states(times)
    momentum_B = propagator.momentum_B(omega, internal)
    # I w0 + h at the start (to the rounding of the product: 1e-15)
    np.testing.assert_allclose(
        momentum_B[0], _tensor(FULL_INERTIA) @ W0 + [1.0, 2.0, 2.0], rtol=0, atol=1e-14
    )
    inertial = quaternion.rotate(q, momentum_B)
    assert np.abs(inertial - inertial[0]).max() < 1e-10 * np.linalg.norm(inertial[0])
    assert np.abs(momentum_B - momentum_B[0]).max() > 0.1  # (it turns in the body)


def _tensor(six):
    xx, yy, zz, xy, xz, yz = six
    return np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])


def test_a_held_array_refuses_every_command_and_counts_it():
    s = scene([Z_WHEEL])
    simulation, _ = run(s, 2)
    assert simulation.command_holds == ()  # (nothing to wait for in lock-step)
    effect = held_effect(simulation.propagator)
    assert effect.holds_speeds() and not effect.takes_commands
    for velocity, effort in (([1.0], []), ([], [0.1]), ([], [])):
        accepted, reason = effect.receive(0, '', ['z'], velocity, effort)
        assert not accepted and reason.startswith('wrong mode: wheels in hold mode')
    values, _ = simulation.monitor_diagnostics()
    assert values['wheel_command.refused'] == 'wrong mode 3'
    assert values['wheel_command.accepted'] == '0'
    # another run of the scene starts its own count
    assert Simulation(s.propagator(), RATE).monitor_diagnostics()[0] == {}
    fresh = held_effect(s.propagator())
    assert not fresh.refused


def test_the_node_path_publishes_the_held_speeds_and_angles():
    """wheel_states as the node publishes it: ``Omega t``, ``Omega``, and the limits' counts."""
    wheels = [{**Z_WHEEL, 'max_torque': 1e-6}, {**TRIAD[0], 'coulomb': 1e-3, 'max_torque': 2.0}]
    simulation, block = run(scene(wheels), 21)
    rows = block.outputs[0]
    np.testing.assert_array_equal(rows[:, 0:2], np.outer(block.times, [20.0, 2.0]))
    np.testing.assert_array_equal(rows[:, 2:4], np.broadcast_to([20.0, 2.0], (21, 2)))
    values, _ = simulation.monitor_diagnostics()
    # wheel z's drive needs 1.9e-3 to 5.1e-2 N m at the samples (its effort), far over 1e-6 on
    # every interval; wheel x's, 0.5 g_x . w' + 1e-3 Coulomb, stays within its 2 N m
    assert np.abs(rows[:, 4]).min() > 1e-3 and np.abs(rows[:, 5]).max() < 1.5
    assert values['wheels.z.torque_limited_time'] == '2'  # 20 intervals of 0.1 s
    assert values['wheels.x.torque_limited_time'] == '0'
    assert values['wheels.z.speed'] == '20' and values['wheels.momentum_B'] == '1 0 4'


def test_a_held_drive_whose_friction_exceeds_max_torque_is_torque_limited_all_along():
    """
    A body spinning about the wheel's axis: ``w' = 0``, so the drive's torque is ``f`` exactly.

    Coulomb 2e-3 N m against max_torque 1e-3: every interval after the first sample counts.
    """
    wheel = {**Z_WHEEL, 'coulomb': 2e-3, 'max_torque': 1e-3}
    s = scene_from_mapping({
        'body': {'inertia': INERTIA},
        'initial': {'angular_velocity': [0.0, 0.0, 0.7]},
        'effects': [{'reaction_wheels': {'mode': 'hold', 'wheels': [wheel]}},
                    {'wheel_states': {}}],
    })
    simulation, block = run(s, 5)
    simulation.samples(5, 6)  # a second block: its first interval ends the first block's last
    np.testing.assert_array_equal(block.outputs[0][:, 2], 2e-3)
    assert simulation.monitor_diagnostics()[0]['wheels.z.torque_limited_time'] == '1'


def test_the_plant_steps_a_held_array_as_the_node_s_path():
    s = scene(TRIAD, FULL_INERTIA, (INERTIAL_TORQUE,))
    plant = Plant(s, RATE)
    assert not plant.takes_wheels
    with pytest.raises(ValueError, match='wheels: the scene takes no wheel commands'):
        plant.step(wheels=[1.0, 2.0, 3.0])
    sensors = plant.sensors()
    simulation = Simulation(s.propagator('dop853', rtol=1e-10, atol=1e-12), RATE,
                            outputs=s.outputs)
    reference = simulation.samples(0, 16)
    rows, published = [sensors.read().rows['wheel_states']], []
    for _ in range(15):
        state = plant.step()
        published.append(np.concatenate([state.omega_B, state.q_NB]))
        rows.append(sensors.read().rows['wheel_states'])
        np.testing.assert_array_equal(state.wheel_speeds, [2.0, 4.0, 4.0])
        assert state.internal.shape == (0,)
    expected = np.column_stack([reference.omega_B, reference.q_NB])[1:]
    np.testing.assert_array_equal(np.array(published), expected)
    np.testing.assert_array_equal(np.array(rows), reference.outputs[0])


@pytest.mark.parametrize(
    'change, path',
    [
        ({'torque': [0.1]}, r'effects\[0\]\.reaction_wheels\.torque: mode hold: an ideal drive'),
        ({'schedule': [{'start': 0.0, 'torque': [0.1]}]},
         r'effects\[0\]\.reaction_wheels\.schedule: mode hold'),
        ({'wheels': [{**Z_WHEEL, 'speed': 101.0}]},
         r'effects\[0\]\.reaction_wheels\.wheels\[0\]\.speed: \|101\| rad/s is beyond max_speed'),
        ({'mode': 'held'}, r'effects\[0\]\.reaction_wheels\.mode: .*hold'),
    ],
)
def test_bad_held_arrays_are_refused_with_the_field_path(change, path):
    array = {'mode': 'hold', 'wheels': [Z_WHEEL], **change}
    with pytest.raises((SceneError, FieldError), match=path):
        scene_from_mapping({'body': {'inertia': INERTIA}, 'initial': {'angular_velocity': W0},
                            'effects': [{'reaction_wheels': array}]})


@pytest.mark.parametrize('fault', [
    {'wheel_stuck': {'wheel': 'z', 'start': 1.0}},
    {'wheel_torque_error': {'wheel': 'z', 'start': 0.0, 'end': 2.0, 'scale': 0.5}},
])
def test_a_drive_fault_on_a_held_wheel_is_refused_at_load_with_its_path(fault):
    """A stuck or erring held drive changes the speed: no state carries it, so it is refused."""
    (kind,) = fault
    with pytest.raises(SceneError, match=rf"faults\[0\]\.{kind}: the wheel 'z' is in mode hold"):
        scene([Z_WHEEL], faults=[fault])


@pytest.mark.parametrize(
    'wheels, inertia, h',
    [([Z_WHEEL], INERTIA, [0.0, 0.0, 4.0]), (TRIAD, FULL_INERTIA, [1.0, 2.0, 2.0])],
    ids=['one wheel on a principal axis', 'oblique triad'],
)
def test_auto_solves_a_held_array_exactly_as_the_rotor(wheels, inertia, h):
    """
    A held array alone is the free gyrostat: ``auto`` takes the exact ``gyrostat``.

    Bit for bit the rotor's exact solution (same ``h``, same locked inertia); within 5e-13 of
    DOP853 at rtol 1e-14 over 60 s, the integrator's own error (measured: 7.4e-14 rad/s and
    2.0e-13 rad; ten times that at rtol 1e-13, as an integrator's error shrinks); each wheel's
    angle is ``speed t`` exactly.
    """
    held = scene(wheels, inertia).propagator()
    rotor = rotor_scene(h, inertia, ()).propagator()
    assert held.name == rotor.name == 'gyrostat'
    times = np.linspace(0.0, 60.0, 601)
    omega, q, internal = held.states(times)
    omega_rotor, q_rotor, _ = rotor.states(times)
    np.testing.assert_array_equal(omega, omega_rotor)
    np.testing.assert_array_equal(q, q_rotor)
    assert internal.shape == (601, 0)
    integrated = scene(wheels, inertia).propagator('dop853', rtol=1e-14, atol=1e-16)
    omega_dop, q_dop, _ = integrated.states(times)
    assert np.abs(omega - omega_dop).max() < 5e-13
    assert quaternion.angle_between(q, q_dop).max() < 5e-13
    effect = held_effect(held)
    speeds = np.array([wheel['speed'] for wheel in wheels])
    np.testing.assert_array_equal(effect.wheel_angles(internal, times), np.outer(times, speeds))


def test_the_exact_gyrostat_s_view_of_a_held_array():
    """What the gyrostat propagator reads: held, its constant ``h``, and no coasting."""
    effect = held_effect(scene(TRIAD).propagator())
    assert effect.holds_speeds()
    assert effect.held_momentum_B().tolist() == [1.0, 2.0, 2.0]
    assert effect.coasting_problem().startswith('reaction wheels held at constant speed')
    speed_mode = held_effect(scene(TRIAD, mode='speed').propagator())
    assert not speed_mode.holds_speeds()


def test_the_node_s_command_inputs_refuse_and_count_a_held_array_s_commands():
    """Without DDS: the subscription's topic, and a JointState taken on it, refused and counted."""
    from types import SimpleNamespace

    from torquefree_ros.ros.commands import command_effects, CommandInputs, refusing_effects

    propagator = scene([Z_WHEEL]).propagator()
    effect = held_effect(propagator)
    request = SimpleNamespace(propagator=propagator)
    assert refusing_effects(request) == {'wheel_command': effect}
    assert command_effects(request) == {'wheel_command': effect}  # (subscribed)
    warnings = []
    inputs = CommandInputs.__new__(CommandInputs)  # (its subscriptions' thread is not needed)
    logger = SimpleNamespace(warning=warnings.append)
    inputs._node = SimpleNamespace(get_logger=lambda: logger)
    inputs._holds, inputs._logged = (lambda: ()), set()
    inputs._refusing = refusing_effects(request)
    for _ in range(2):
        inputs._receive('wheel_command', (0, '', ['z'], (), (0.1,)))
    assert effect.refused == {'wrong mode': 2}
    assert len(warnings) == 1 and 'wrong mode: wheels in hold mode' in warnings[0]
    # a topic a commanded array takes is that array's
    shared = scene_from_mapping({
        'body': {'inertia': INERTIA},
        'initial': {'angular_velocity': W0},
        'effects': [{'reaction_wheels': {'mode': 'hold', 'wheels': [Z_WHEEL]}},
                    {'reaction_wheels': {'mode': 'torque', 'wheels': [{**TRIAD[0]}]}}],
    }).propagator()
    (commanded,) = [e for e in shared.effects if e.mode == 'torque']
    assert refusing_effects(SimpleNamespace(propagator=shared)) == {}
    assert command_effects(SimpleNamespace(propagator=shared)) == {'wheel_command': commanded}
