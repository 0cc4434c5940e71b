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
The actuators' faults (core.faults.actuators): a wheel that stops responding, stuck magnetorquers.

References computed here, not by the code under test: a wheel's speed by the closed forms of a
wheel on a principal axis of a body at rest (``Js_eff Omega' = u - b Omega``, piecewise), the
inertial momentum ``R(q) (I_s w + sum h_i g_i)`` built from the scene's numbers by hand, a stuck
dipole's torque ``m x B_B`` with ``B`` from the environment module and scipy's rotation, the
window's samples by brute force over ``k / rate >= t``; and a faulted run against the same run
whose controller sends the faulted input itself, which must agree bit for bit.
"""

from __future__ import annotations

import copy
import json
import math

from geometry_msgs.msg import Vector3Stamped
import numpy as np
import pytest
from rclpy.node import Node
from rclpy.parameter import Parameter
from scipy.spatial.transform import Rotation
from sensor_msgs.msg import JointState
from torquefree_ros.bag import BagReader
from torquefree_ros.bag.offline import write_scene_bag
from torquefree_ros.core.checks.schema import FieldError
from torquefree_ros.core.commands.hold import CommandHold, Override
from torquefree_ros.core.faults import describe_fault
from torquefree_ros.core.run.simulation import Simulation
from torquefree_ros.core.scene.loader import faults_from_text, scene_from_mapping, SceneError
from torquefree_ros.testing import simulator

RATE = 10.0
SECOND = 1_000_000_000
EPS = np.finfo(float).eps
I_Z = 6.0  # the body's moment about z, the wheel's axis, kg m^2
JS, VISCOUS, SPEED0, U = 0.2, 0.01, 10.0, 0.05
JS_EFF = JS * (I_Z - JS) / I_Z  # a wheel against a free body about its principal axis
ONE_WHEEL = {
    'mode': 'torque',
    'timeout': 100.0,
    'wheels': [
        {'name': 'z', 'axis': [0.0, 0.0, 1.0], 'spin_inertia': JS, 'max_torque': 10.0,
         'max_speed': 1000.0, 'viscous': VISCOUS, 'speed': SPEED0},
    ],
}


def wheel_scene(faults=(), effect=ONE_WHEEL, inertia=(4.0, 5.0, I_Z), omega=(0.0, 0.0, 0.0),
                orientation=(0.0, 0.0, 0.0, 1.0)):
    return scene_from_mapping(
        {
            'body': {'inertia': list(inertia)},
            'initial': {'angular_velocity': list(omega), 'orientation': list(orientation)},
            'effects': [{'reaction_wheels': copy.deepcopy(effect)}, {'wheel_states': {}}],
            'faults': copy.deepcopy(list(faults)),
            'accuracy': 1e-12,
        },
        source='s.yaml',
    )


def run(scene, count, answer=None):
    """Return samples 0 .. count - 1 of ``scene`` at RATE, ``answer(k)`` sent at each sample."""
    simulation = Simulation(
        scene.propagator(), RATE, outputs=scene.outputs, faults=scene.faults
    )
    ((effect, hold),) = simulation.command_holds
    blocks = []
    for k in range(count):
        if answer is not None:
            names, values = answer(k)
            fields = (values, []) if effect.mode == 'speed' else ([], values)
            assert effect.receive(hold.stamp_ns(k), '', names, *fields)[0]
        blocks.append(simulation.samples(k, 1))
    return simulation, effect, blocks


def _stack(blocks, name):
    return np.concatenate([getattr(block, name) for block in blocks])


# -- a wheel that stops responding ----------------------------------------------------------------
@pytest.mark.usefixtures('integrator_path')
def test_a_stuck_wheel_coasts_by_the_free_law_in_its_window_and_obeys_its_commands_outside():
    """
    ``Js_eff Omega' = u - b Omega``: commanded ``u`` outside the window, ``u = 0`` inside.

    The window ``[1.0, 2.05)`` s covers the intervals of samples 10 .. 20 (``t_21 = 2.1`` is the
    first sample at or after 2.05). Piecewise closed forms, each from the closed form's value where
    it starts: DOP853 at rtol 1e-12 over 3 s, held to 1e-10 relative (measured: 9e-16). The body
    takes up the momentum the wheel loses, ``I_z w_z = Js (Omega_0 - Omega)`` (the z momentum is
    constant), 1e-10 relative. ``wheel_states`` reports the motor torque applied on the interval
    ending at each sample: zero on samples 11 .. 21 exactly (and on sample 0: no interval ends
    there), ``u`` elsewhere.
    """
    faults = [{'wheel_stuck': {'wheel': 'z', 'start': 1.0, 'end': 2.05}}]
    simulation, effect, blocks = run(wheel_scene(faults), 31, lambda k: (['z'], [U]))
    t = _stack(blocks, 'times')
    omega, internal = _stack(blocks, 'omega_B'), _stack(blocks, 'internal')
    speeds = effect.wheel_speeds(omega, internal[:, :2])[:, 0]
    t_a, t_b = 1.0, 2.1

    def commanded(t, start, speed):
        settled = U / VISCOUS
        return settled + (speed - settled) * np.exp(-VISCOUS * (t - start) / JS_EFF)

    at_a = commanded(t_a, 0.0, SPEED0)
    at_b = at_a * math.exp(-VISCOUS * (t_b - t_a) / JS_EFF)
    expected = np.where(
        t <= t_a,
        commanded(t, 0.0, SPEED0),
        np.where(
            t <= t_b,
            at_a * np.exp(-VISCOUS * (t - t_a) / JS_EFF),
            commanded(t, t_b, at_b),
        ),
    )
    np.testing.assert_allclose(speeds, expected, rtol=1e-10)
    np.testing.assert_allclose(omega[:, 2], JS * (SPEED0 - speeds) / I_Z, rtol=1e-10)
    efforts = np.concatenate([block.outputs[0][:, 2] for block in blocks])
    k = np.arange(31)
    assert np.array_equal(efforts, np.where((k == 0) | ((k >= 11) & (k <= 21)), 0.0, U))
    assert simulation.fault_diagnostics(10) == {
        'faults': '1', 'faults_active': 'wheel_stuck z [1, 2.05) s no motor torque'
    }
    assert simulation.fault_diagnostics(21)['faults_active'] == 'none'


PYRAMID = {
    'mode': 'torque',
    'timeout': 100.0,
    'wheels': [
        {'name': 'a', 'axis': [1.0, 1.0, 1.0], 'spin_inertia': 0.08, 'max_torque': 0.2,
         'max_speed': 600.0, 'viscous': 2e-4, 'coulomb': 3e-3, 'speed': 20.0},
        {'name': 'b', 'axis': [-1.0, 1.0, 1.0], 'spin_inertia': 0.08, 'max_torque': 0.2,
         'max_speed': 600.0, 'speed': -5.0},  # frictionless: stuck, its h stays as it is
        {'name': 'c', 'axis': [-1.0, -1.0, 1.0], 'spin_inertia': 0.08, 'max_torque': 0.2,
         'max_speed': 600.0, 'viscous': 1e-4, 'speed': 30.0},
    ],
}
PYRAMID_INERTIA = [12.0, 10.0, 8.0, 0.3, -0.2, 0.1]
PYRAMID_COMMANDS = [0.1, -0.15, 0.05]  # N m, within max_torque


def _pyramid(faults=()):
    return wheel_scene(
        faults, PYRAMID, PYRAMID_INERTIA, (0.05, -0.03, 0.02),
        Rotation.from_rotvec([0.2, -0.4, 0.3]).as_quat().tolist(),
    )


@pytest.mark.usefixtures('integrator_path')
def test_a_stuck_wheel_on_a_tumbling_body_keeps_the_inertial_momentum_and_equals_a_zero_command():
    """
    The stuck wheel's motor torque is internal: ``R(q) (I_s w + sum h_i g_i)`` stays constant.

    ``I`` from the scene's six numbers, ``I_s = I - sum Js g g^T`` with unit ``g`` by hand, scipy's
    rotation: 1e-10 of ``|H|`` (DOP853 at rtol 1e-12 over 4 s, a tumbling body; measured: 6e-16).
    The stuck wheel ``b`` is frictionless, so its absolute momentum ``h_b`` (``h' = u - f = 0``)
    keeps its value in the window to 1e-12 relative (measured: exactly) and changes outside it.
    The faulted run equals, bit for bit, the run whose controller sends ``b`` zero in the window's
    intervals (samples 12 .. 24).
    """
    faults = [{'wheel_stuck': {'wheel': 'b', 'start': 1.2, 'end': 2.5}}]
    count = 41
    _, effect, blocks = run(_pyramid(faults), count, lambda k: (['a', 'b', 'c'], PYRAMID_COMMANDS))

    def zero_in_window(k):
        return ['a', 'b', 'c'], [PYRAMID_COMMANDS[0], 0.0 if 12 <= k < 25 else -0.15,
                                 PYRAMID_COMMANDS[2]]

    _, _, reference = run(_pyramid(), count, zero_in_window)
    for name in ('omega_B', 'q_NB', 'internal'):
        assert np.array_equal(_stack(blocks, name), _stack(reference, name)), name
    omega, q, internal = (_stack(blocks, n) for n in ('omega_B', 'q_NB', 'internal'))
    xx, yy, zz, xy, xz, yz = PYRAMID_INERTIA
    inertia = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
    axes = np.array([w['axis'] for w in PYRAMID['wheels']], dtype=float)
    axes /= np.linalg.norm(axes, axis=1)[:, None]
    spin = inertia - 0.08 * axes.T @ axes
    h = internal[:, 0:6:2]
    momentum_N = Rotation.from_quat(q).apply(omega @ spin.T + h @ axes)
    size = np.linalg.norm(momentum_N[0])
    np.testing.assert_allclose(momentum_N, momentum_N[[0] * count], rtol=0, atol=1e-10 * size)
    h_b = h[:, 1]
    np.testing.assert_allclose(h_b[12:26], h_b[12], rtol=1e-12)  # samples 12 .. 25: intervals
    assert abs(h_b[11] - h_b[12]) > 1e-3 and abs(h_b[26] - h_b[25]) > 1e-3  # -0.15 N m * 0.1 s


def test_a_speed_drive_stuck_is_off_and_the_wheel_coasts():
    """Speed mode: the stuck drive's input is the drive off (NaN), so its motor torque is zero."""
    effect = {**ONE_WHEEL, 'mode': 'speed'}
    faults = [{'wheel_stuck': {'wheel': 'z', 'start': 0.5}}]
    _, wheels, blocks = run(wheel_scene(faults, effect), 16, lambda k: (['z'], [50.0]))
    efforts = np.concatenate([block.outputs[0][:, 2] for block in blocks])
    assert np.all(efforts[1:6] > 0.0) and np.array_equal(efforts[6:], np.zeros(10))
    assert np.isnan(wheels.hold.held_on(5)).all()


# -- stuck magnetorquers --------------------------------------------------------------------------
LEO = {'epoch': '2026-03-20T12:00:00Z', 'semi_major_axis': 6878137.0, 'eccentricity': 0.001,
       'inclination': 1.7, 'raan': 0.3, 'argument_of_perigee': 0.5, 'mean_anomaly': 0.2}
ROD_AXES = Rotation.from_rotvec([0.4, -0.3, 0.7]).as_matrix().T
RODS = [{'axis': a.tolist(), 'max_dipole': m} for a, m in zip(ROD_AXES, [0.2, 0.1, 0.05])]
FIRST_DIPOLE = [0.03, -0.02, 0.01]  # A m^2, inside every rod's limit: the rods apply it
SECOND_DIPOLE = [-0.01, 0.02, 0.005]


def torquer_scene(faults=(), effects=None):
    return scene_from_mapping(
        {
            'body': {'inertia': [0.03, 0.035, 0.01]},
            'initial': {'angular_velocity': [0.02, 0.05, -0.03]},
            'orbit': LEO,
            'effects': effects if effects is not None else [
                {'magnetorquers': {'rods': RODS, 'timeout': 100.0}},
                {'magnetorquer_dipole': {}},
            ],
            'faults': copy.deepcopy(list(faults)),
        },
        source='s.yaml',
    )


def _torquer_run(scene, count, answer):
    simulation = Simulation(scene.propagator(), RATE, outputs=scene.outputs, faults=scene.faults)
    ((effect, hold),) = simulation.command_holds
    hold.frame_id = 'body'
    blocks = []
    for k in range(count):
        wanted = answer(k)
        if wanted is not None:
            assert effect.receive(hold.stamp_ns(k), 'body', wanted)[0]
        blocks.append(simulation.samples(k, 1))
    return simulation, effect, blocks


def test_a_stuck_magnetorquer_holds_its_last_dipole_in_its_window_only():
    """
    ``[0.55, 1.5)`` s: intervals 6 .. 14 hold the dipole asked for on interval 5.

    They do though the controller asks for another from sample 10; ``magnetorquer_dipole`` (the
    interval ending at each sample) says the same, to rounding of the rods' split (4 eps of 0.03
    A m^2).
    """
    faults = [{'magnetorquer_stuck': {'start': 0.55, 'end': 1.5}}]

    def answer(k):
        return FIRST_DIPOLE if k == 0 else SECOND_DIPOLE if k == 10 else None

    _, effect, blocks = _torquer_run(torquer_scene(faults), 20, answer)
    expected = np.array([FIRST_DIPOLE] * 15 + [SECOND_DIPOLE] * 5)  # per interval k
    held = np.array([effect.held_slot(k / RATE) for k in range(20)])
    np.testing.assert_allclose(held, expected, rtol=0, atol=4 * EPS * 0.03)
    reported = np.concatenate([block.outputs[0] for block in blocks])
    np.testing.assert_allclose(reported[1:], expected[:-1], rtol=0, atol=4 * EPS * 0.03)


@pytest.mark.usefixtures('integrator_path')
def test_a_stuck_magnetorquer_s_torque_is_its_value_cross_b_and_the_run_equals_the_command():
    """
    ``value`` from 0.3 s: from interval 3 on the torque is ``m x B_B``.

    ``B`` the field the torque holds (``Place.evaluate``, turned by scipy), to 8 eps of ``|m|
    |B|``; before, the commanded dipole's. The faulted run equals, bit for bit, one whose
    controller asks for ``value`` from sample 3 (the rods apply the same dipole: the same motion).
    """
    stuck = [0.02, 0.01, -0.01]
    faults = [{'magnetorquer_stuck': {'start': 0.3, 'value': stuck}}]
    scene = torquer_scene(faults)
    _, effect, blocks = _torquer_run(scene, 12, lambda k: FIRST_DIPOLE if k == 0 else None)
    _, _, reference = _torquer_run(
        torquer_scene(), 12, lambda k: FIRST_DIPOLE if k == 0 else stuck if k == 3 else None
    )
    for name in ('omega_B', 'q_NB'):
        assert np.array_equal(_stack(blocks, name), _stack(reference, name)), name
    place = scene.orbit
    rng = np.random.default_rng(5)
    for t, m in ((0.25, FIRST_DIPOLE), (0.3, stuck), (0.77, stuck)):
        q = Rotation.random(random_state=rng).as_quat()
        segment = math.floor(t * RATE + 1e-9) / RATE
        field_B = Rotation.from_quat(q).inv().apply(place.evaluate(1, t, t))
        size = np.linalg.norm(m) * np.linalg.norm(field_B)
        got = effect.torque_B(t, np.zeros(3), q, np.empty(0), segment)
        np.testing.assert_allclose(got, np.cross(m, field_B), rtol=0, atol=8 * EPS * size)


# -- the window and its definition ----------------------------------------------------------------
@pytest.mark.parametrize('start, end', [(0.0, 0.3), (0.25, 0.7), (0.3, 0.30000001), (1.05, None)])
def test_the_window_starts_and_ends_at_its_samples(start, end):
    """Check the override covers the intervals of the ``k`` with ``start <= t_k < end``."""
    window = {'start': start, **({} if end is None else {'end': end})}
    value = [0.01, 0.0, 0.0]
    scene = torquer_scene([{'magnetorquer_stuck': {**window, 'value': value}}])
    simulation = Simulation(scene.propagator(), RATE, faults=scene.faults)
    ((_, hold),) = simulation.command_holds
    k = np.arange(30)
    inside = [
        first_k_at_or_after(start) <= j and (end is None or j < first_k_at_or_after(end))
        for j in k.tolist()
    ]
    stuck = [bool(np.array_equal(hold.held_on(j), value)) for j in k.tolist()]
    assert stuck == inside and any(inside)
    assert [bool(simulation.fault_diagnostics(j)['faults_active'] != 'none') for j in k] == inside


def first_k_at_or_after(t):
    """Brute force: the first k >= 0 with k / RATE >= t."""
    k = 0
    while k / RATE < t:
        k += 1
    return k


@pytest.mark.parametrize(
    'faults, effects, path',
    [
        ([{'wheel_stuck': {'wheel': 'w', 'start': 0.0}}], 'wheels',
         r'faults\[0\]\.wheel_stuck\.wheel: .w. is not a commanded wheel .*wheels: z'),
        ([{'wheel_stuck': {'start': 0.0}}], 'wheels', r'faults\[0\]\.wheel_stuck\.wheel: '),
        ([{'wheel_stuck': {'wheel': 'z', 'start': 2.0, 'end': 2.0}}], 'wheels',
         r'faults\[0\]\.wheel_stuck\.end: must be after start'),
        ([{'magnetorquer_stuck': {'start': 0.0}}], 'wheels',
         r'faults\[0\]\.magnetorquer_stuck: the scene has no magnetorquers'),
        ([{'magnetorquer_stuck': {'start': 0.0, 'value': [1.0, 0.0]}}], 'torquers',
         r'faults\[0\]\.magnetorquer_stuck\.value: '),
        ([{'wheel_stuck': {'wheel': 'z', 'start': 0.0}}], 'scheduled',
         r'faults\[0\]\.wheel_stuck: its reaction_wheels are in mode schedule'),
        ([{'wheel_stuck': {'wheel': 'z', 'start': -1.0}}], 'wheels',
         r'faults\[0\]\.wheel_stuck\.start: '),
    ],
)
def test_bad_actuator_faults_are_refused_with_the_field_path(faults, effects, path):
    with pytest.raises(SceneError, match=r'^s\.yaml: ' + path):
        if effects == 'torquers':
            torquer_scene(faults)
        elif effects == 'scheduled':
            scheduled = {k: v for k, v in ONE_WHEEL.items() if k not in ('mode', 'timeout')}
            wheel_scene(faults, scheduled)
        else:
            wheel_scene(faults)


def test_a_run_time_fault_naming_what_the_run_lacks_is_refused_and_nothing_changes():
    scene = wheel_scene()
    simulation = Simulation(scene.propagator(), RATE, outputs=scene.outputs)
    faults = faults_from_text('[{wheel_stuck: {wheel: y, start: 0}}]', scene.outputs)
    with pytest.raises(FieldError, match=r'^faults\[0\]\.wheel_stuck\.wheel: '):
        simulation.retune(3, faults)
    assert simulation.faults == ()
    (fault,) = faults_from_text('[{magnetorquer_stuck: {start: 1, value: [0, 0, 0]}}]', ())
    said = 'magnetorquer_stuck magnetorquers [1, ...) s at [0, 0, 0] A m^2'
    assert describe_fault(fault) == said


# -- at run time, on a running node ---------------------------------------------------------------
NODE_SCENE = {
    'body': {'inertia': [4.0, 5.0, I_Z]},
    'initial': {'angular_velocity': [0.0, 0.0, 0.0]},
    'effects': [{'reaction_wheels': {**ONE_WHEEL, 'timeout': 1.0}}, {'wheel_states': {}}],
    'accuracy': 1e-12,
}


class Motor(Node):
    """Answer each sample with the motor torque U for the interval after it."""

    def __init__(self, context):
        super().__init__('motor', context=context)
        self.commands = self.create_publisher(JointState, 'wheel_command', 10)
        self.create_subscription(Vector3Stamped, 'angular_velocity', self.answer, 10)

    def answer(self, sample: Vector3Stamped) -> None:
        command = JointState()
        command.header.stamp = sample.header.stamp
        command.name = ['z']
        command.effort = [U]
        self.commands.publish(command)


def test_a_wheel_fault_set_on_a_running_node_acts_from_the_next_sample(tmp_path):
    """
    Set between samples 5 and 6 (window from 0 s: it starts at the next sample out, 6).

    ``wheel_states`` reports the motor torque of the interval ending at each sample: ``U`` on
    samples 1 .. 6, zero from 7 on (interval 6 is the first the fault holds). The speeds follow
    the same run computed by the core with the fault put in force at sample 6, and
    the free law ``Omega_6 exp(-b (t - t_6) / Js_eff)`` from sample 6 on (1e-10 relative, DOP853
    at rtol 1e-12). The values ``/diagnostics`` reports name the active fault. The core's run,
    the node's and ``torquefree_bag --commands``' replay of its recording agree bit for bit.
    """
    path = tmp_path / 'wheel.yaml'
    path.write_text(json.dumps(NODE_SCENE))
    first, more = 6, 10
    recorded = tmp_path / 'live'
    with simulator(str(path), publish_rate=RATE, record_bag=str(recorded)) as sim:
        sim.add_node(Motor(sim.context))
        states = sim.tap('wheel_states', JointState)
        sim.advance(first)
        text = '[{wheel_stuck: {wheel: z, start: 0.0}}]'
        result = sim.node.set_parameters_atomically([Parameter('faults', value=text)])
        assert result.successful, result.reason
        samples = sim.advance(more)
        assert sim.node.stepping.state().missed_steps == 0
        states.wait(first + more)
        diagnostics = sim.node.sample_loop.simulation.fault_diagnostics(first)
        received = states.messages[: first + more]
        epoch = sim.samples[0].stamp_ns
    assert [s.index for s in samples] == list(range(first, first + more))
    efforts = np.array([m.effort[0] for m in received])
    assert np.array_equal(efforts[1:first + 1], [U] * first)
    assert np.array_equal(efforts[first + 1:], np.zeros(more - 1))
    speeds = np.array([m.velocity[0] for m in received])
    scene = scene_from_mapping(NODE_SCENE)
    simulation = Simulation(scene.propagator(), RATE, outputs=scene.outputs)
    ((effect, hold),) = simulation.command_holds
    offline = []
    for k in range(first + more):
        if k == first:
            simulation.retune(k, faults_from_text(text, scene.outputs))
        assert effect.receive(hold.stamp_ns(k), '', ['z'], [], [U])[0]
        offline.append(simulation.samples(k, 1).outputs[0][0, 1])
    assert np.array_equal(speeds, offline)
    t = np.arange(first, first + more) / RATE
    np.testing.assert_allclose(
        speeds[first:], speeds[first] * np.exp(-VISCOUS * (t - t[0]) / JS_EFF), rtol=1e-10
    )
    assert diagnostics == {
        'faults': '1', 'faults_active': 'wheel_stuck z [0, ...) s no motor torque'
    }
    # the recording re-simulated offline from its commands and sensor_changes: the same bytes
    replay = tmp_path / 'replay'
    write_scene_bag(scene, replay, (first + more - 1) / RATE, RATE, epoch_ns=epoch,
                    commands_bag=recorded)
    window = (epoch, epoch + (first + more - 1) * round(1e9 / RATE))

    def messages(bag, topic):
        return [m.data for m in BagReader(bag).messages([topic])
                if window[0] <= m.log_time_ns <= window[1]]

    for topic in ('/wheel_states', '/angular_velocity', '/sensor_changes'):
        live = messages(recorded, topic)
        assert live and live == messages(replay, topic), topic
    assert len(messages(recorded, '/wheel_states')) == first + more


def test_a_stuck_value_is_read_before_sealing_forgets_the_command_it_needs():
    """
    Sealing forgets superseded commands: a stuck window reads its value as they are sealed.

    The command of interval 4, ``[4, 0, 0]``, is read as interval 4 is sealed, so the window
    holds it when asked later.
    """
    hold = CommandHold(100.0, width=3)
    hold.start(RATE, 0)
    hold.override([Override(5, 9, (0, 1, 2), None)])
    for k in range(12):
        assert hold.receive(hold.stamp_ns(k), [float(k), 0.0, 0.0])[0]
        hold.seal(k)
    assert len(hold.commands) == 2  # those in force on intervals 10 and 11
    assert [hold.held_on(k)[0] for k in range(5, 9)] == [4, 4, 4, 4]
