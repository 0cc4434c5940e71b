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
Faults of a commanded torque and a wheel's torque error, on the node's path and the plant's.

``torque_stuck``, ``torque_error`` (``torque_command``) and ``wheel_torque_error``. References
computed here, not by the code under test: a sphere at rest under held body torques, whose rate is
the sum of the impulses (``I w' = tau``: no gyroscopic term), the torque of each interval written
out by hand; a frictionless wheel on a principal axis of a body at rest, whose speed is linear
under a constant motor torque (``Js_eff Omega' = u``), its slope changed exactly by the fault's
scale and bias and bounded by the wheel's ``max_torque`` after them; a faulted run against the
run whose controller sends the faulted torque itself, which must agree bit for bit; and a
running node's recording against its offline replay, byte for byte.
"""

from __future__ import annotations

import numpy as np
import pytest
from running_faults import assert_the_replay_is_the_recording, set_while_running
from torquefree_ros import Plant
from torquefree_ros.bag import BagReader, BagWriter
from torquefree_ros.bag.cdr import decode_joint_state, decode_stamped_doubles
from torquefree_ros.bag.offline import write_scene_bag
from torquefree_ros.bag.samples import encode_command
from torquefree_ros.core.checks.schema import FieldError
from torquefree_ros.core.commands.hold import CommandHold, Override
from torquefree_ros.core.run.simulation import Simulation
from torquefree_ros.core.scene.loader import faults_from_text, scene_from_mapping, SceneError

RATE = 10.0
SPHERE = 5.0  # kg m^2: I w' = tau exactly (w x I w = 0)
I_Z, JS = 6.0, 0.2  # the body's moment about the wheel's axis z, the wheel's spin inertia
JS_EFF = JS * (I_Z - JS) / I_Z  # a wheel against a free body about its principal axis
U, MAX_TORQUE, SPEED0 = 0.05, 0.1, 10.0  # N m, N m, rad/s


def torque_scene(faults=(), inertia=(SPHERE, SPHERE, SPHERE), omega=(0.0, 0.0, 0.0),
                 frame='body', timeout=0.55):
    return scene_from_mapping(
        {
            'body': {'inertia': list(inertia)},
            'initial': {'angular_velocity': list(omega)},
            'effects': [{'torque_command': {'frame': frame, 'timeout': timeout,
                                            'max_torque': 0.1}}],
            'faults': list(faults),
            'accuracy': 1e-12,
        },
        source='s.yaml',
    )


def wheel_scene(faults=(), mode='torque', bandwidth=10.0):
    wheel = {'name': 'z', 'axis': [0.0, 0.0, 1.0], 'spin_inertia': JS, 'max_torque': MAX_TORQUE,
             'max_speed': 1000.0, 'speed': SPEED0}
    wheels = {'mode': mode, 'timeout': 100.0, 'wheels': [wheel], 'speed_bandwidth': bandwidth}
    return scene_from_mapping(
        {
            'body': {'inertia': [4.0, 5.0, I_Z]},
            'initial': {'angular_velocity': [0.0, 0.0, 0.0]},
            'effects': [{'reaction_wheels': wheels}, {'wheel_states': {}}],
            'faults': list(faults),
            'accuracy': 1e-12,
        },
        source='s.yaml',
    )


def torque_run(scene, torques):
    """Return the Simulation and its samples 0 .. len(torques), ``torques[k]`` sent at sample k."""
    simulation = Simulation(scene.propagator(), RATE, faults=scene.faults)
    ((_, hold),) = simulation.command_holds
    omega = [simulation.samples(0, 1).omega_B[0]]
    for k, torque in enumerate(torques):
        if torque is not None:
            assert hold.receive(hold.stamp_ns(k), torque)[0]
        hold.seal(k)
        omega.append(simulation.samples(k + 1, 1).omega_B[0])
    return simulation, np.array(omega)


# -- a commanded torque ---------------------------------------------------------------------------
TORQUES = [[1e-3 * (k + 1), -2e-3, 5e-4 * (-1) ** k] for k in range(14)] + [None] * 8 + [
    [-3e-3, 1e-3, 2e-3]
] * 8  # a gap past the 0.55 s timeout (intervals 19 .. 21: zero torque), then a constant


def by_hand(k):
    """Return the torque the faults below leave on interval ``k``, written out from their text."""
    commanded = (
        np.array(TORQUES[k]) if TORQUES[k] is not None
        else np.array(TORQUES[13]) if k < 19 else np.zeros(3)  # 13 stamped 1.3 s: out at 1.85 s
    )
    if 3 <= k < 8:  # torque_error [0.25, 0.8): scale per axis, bias
        return commanded * np.array([0.5, 2.0, -1.0]) + np.array([1e-3, 0.0, -2e-3])
    if 8 <= k < 12:  # torque_stuck [0.8, 1.2): what held on interval 7, the error's result
        return by_hand(7)
    if 19 <= k < 24:  # torque_error [1.9, 2.4), scale 0: the bias alone, timed out or not
        return np.array([0.0, 4e-4, 0.0])
    return commanded


FAULTS = [
    {'torque_error': {'start': 0.25, 'end': 0.8, 'scale': [0.5, 2.0, -1.0],
                      'bias': [1e-3, 0.0, -2e-3]}},
    {'torque_stuck': {'start': 0.8, 'end': 1.2}},
    {'torque_error': {'start': 1.9, 'end': 2.4, 'scale': 0.0, 'bias': [0.0, 4e-4, 0.0]}},
]


@pytest.mark.usefixtures('integrator_path')
def test_a_sphere_s_rate_is_the_sum_of_the_faulted_torques_written_out_by_hand():
    """
    ``w_k = sum_{j < k} tau_j / (I rate)``: the torque of each interval as the faults leave it.

    DOP853 at rtol 1e-12 is exact on a linear rate up to rounding: 1e-12 of the largest rate.
    The windows' intervals are those of ``k`` with ``start <= k / rate < end``; the stuck
    window holds what held on the interval before it (the error's result), and a bias acts on
    the zero torque of a timed-out command too.
    """
    _, omega = torque_run(torque_scene(FAULTS), TORQUES)
    impulses = np.array([by_hand(k) for k in range(len(TORQUES))]) / (SPHERE * RATE)
    expected = np.vstack([np.zeros(3), np.cumsum(impulses, axis=0)])
    size = np.abs(expected).max()
    np.testing.assert_allclose(omega, expected, rtol=0, atol=1e-12 * size)


def test_a_faulted_torque_equals_the_controller_sending_it_bit_for_bit():
    """A tumbling body, both frames: the faulted run is the one commanded with by_hand's."""
    for frame in ('body', 'inertial'):
        shape = {'inertia': (4.0, 5.0, 6.0), 'omega': (0.3, -0.2, 0.25), 'frame': frame,
                 'timeout': 100.0}
        torques = TORQUES[:14]
        _, faulted = torque_run(torque_scene(FAULTS, **shape), torques)
        sent = [by_hand(k).tolist() for k in range(14)]
        _, reference = torque_run(torque_scene(**shape), sent)
        np.testing.assert_array_equal(faulted, reference)


@pytest.mark.parametrize('frame', ['body', 'inertial'])
def test_the_plant_applies_torque_faults_as_the_node_s_path_bit_for_bit(frame):
    """Plant.step with the same torques: the same samples as the Simulation, bit for bit."""
    shape = {'inertia': (4.0, 5.0, 6.0), 'omega': (0.3, -0.2, 0.25), 'frame': frame}
    _, omega = torque_run(torque_scene(FAULTS, **shape), TORQUES)
    plant = Plant(torque_scene(FAULTS, **shape), RATE)
    stepped = [plant.state.omega_B] + [plant.step(torque).omega_B for torque in TORQUES]
    np.testing.assert_array_equal(np.array(stepped), omega)
    free = Plant(torque_scene(**shape), RATE)
    for torque in TORQUES:
        free.step(torque)
    assert np.abs(free.state.omega_B - plant.state.omega_B).max() > 1e-4  # (the faults acted)


# -- a wheel's torque error -----------------------------------------------------------------------
WHEEL_FAULTS = [
    {'wheel_torque_error': {'wheel': 'z', 'start': 1.0, 'end': 2.0, 'scale': 0.6, 'bias': 0.01}},
    {'wheel_torque_error': {'wheel': 'z', 'start': 2.5, 'end': 3.0, 'scale': 3.0}},
]


def motor_torque(k):
    """Return the motor torque of interval ``k``: U, the fault's ``scale U + bias``, clipped."""
    if 10 <= k < 20:
        return 0.6 * U + 0.01  # 0.04 N m
    if 25 <= k < 30:
        return min(3.0 * U, MAX_TORQUE)  # 0.15 asked: the wheel's limit, 0.1, after the fault
    return U


def test_a_wheel_torque_error_changes_the_speed_s_slope_by_exactly_its_scale_and_bias(
    integrator_path,
):
    """
    ``Omega(t) = Omega_0 + sum u_k / (Js_eff rate)``: linear under each interval's motor torque.

    ``u`` is 0.05 N m outside the windows, ``0.6 u + 0.01`` in ``[1, 2)`` s and ``min(3 u,
    max_torque)`` in ``[2.5, 3)`` s: the limit bounds what the fault asks. DOP853 at rtol 1e-12 is
    exact on a linear speed up to rounding: 1e-12 of the largest speed, so each interval's slope
    ``(Omega_k+1 - Omega_k) rate`` is its ``u / Js_eff`` to 2e-11 of ``Omega``'s size times the
    rate. The body takes up what the wheel gains: ``I_z w_z = Js (Omega_0 - Omega)``, and
    ``wheel_states`` reports each interval's ``u`` exactly (the same operations). The plant
    meets the same closed form, and equals the node's compiled path bit for bit.
    """
    count = 40
    scene = wheel_scene(WHEEL_FAULTS)
    simulation = Simulation(scene.propagator(), RATE, outputs=scene.outputs, faults=scene.faults)
    ((effect, hold),) = simulation.command_holds
    blocks = [simulation.samples(0, 1)]
    for k in range(count):
        assert effect.receive(hold.stamp_ns(k), '', ['z'], [], [U])[0]
        hold.seal(k)
        blocks.append(simulation.samples(k + 1, 1))
    omega = np.concatenate([b.omega_B for b in blocks])
    internal = np.concatenate([b.internal for b in blocks])
    speeds = effect.wheel_speeds(omega, internal)[:, 0]
    u = np.array([motor_torque(k) for k in range(count)])
    expected = SPEED0 + np.concatenate([[0.0], np.cumsum(u / (JS_EFF * RATE))])
    np.testing.assert_allclose(speeds, expected, rtol=1e-12)
    slopes = np.diff(speeds) * RATE
    np.testing.assert_allclose(
        slopes, u / JS_EFF, rtol=0, atol=2e-11 * np.abs(speeds).max() * RATE
    )
    # the slope in the first window differs from the commanded one by (scale - 1) U + bias
    change = (0.6 - 1.0) * U + 0.01
    assert abs((slopes[15] - slopes[5]) - change / JS_EFF) < 2e-11 * speeds.max() * RATE
    np.testing.assert_allclose(omega[:, 2], JS * (SPEED0 - speeds) / I_Z, rtol=1e-10, atol=1e-15)
    # wheel_states: the motor torque of the interval ending at each sample, fault and limit applied
    efforts = np.concatenate([b.outputs[0][:, 2] for b in blocks])
    assert efforts[1:].tolist() == u.tolist()
    plant = Plant(wheel_scene(WHEEL_FAULTS), RATE)
    stepped = [plant.state.wheel_speeds]
    stepped += [plant.step(wheels=[U]).wheel_speeds for _ in range(count)]
    stepped = np.array(stepped)[:, 0]
    np.testing.assert_allclose(stepped, expected, rtol=1e-12)
    if integrator_path == 'compiled':  # (the plant runs the kernels; the reference is scipy's)
        np.testing.assert_array_equal(stepped, speeds)


# -- a speed drive's torque error -----------------------------------------------------------------
BANDWIDTH, SET_POINT = 1e-3, 30.0  # rad/s: K = Js BANDWIDTH = 2e-4 N m s, under max_torque
SPEED_FAULTS = [
    {'wheel_torque_error': {'wheel': 'z', 'start': 1.0, 'end': 2.0, 'scale': 0.6, 'bias': 0.01}},
    {'wheel_torque_error': {'wheel': 'z', 'start': 2.5, 'end': 3.0, 'scale': 3.0}},
    {'wheel_torque_error': {'wheel': 'z', 'start': 2.5, 'end': 2.8, 'scale': 0.5, 'bias': -0.004}},
]


def loop_error(k):
    """Return ``(scale, bias)`` of interval ``k`` from the faults' text (list order composed)."""
    if 10 <= k < 20:
        return 0.6, 0.01
    if 25 <= k < 28:
        return 0.5 * 3.0, -0.004  # 0.5 (3 u) - 0.004
    if 28 <= k < 30:
        return 3.0, 0.0
    return 1.0, 0.0


def test_a_speed_drive_s_torque_error_scales_and_offsets_its_loop_s_output(integrator_path):
    """
    ``Js_eff Omega' = s K (Omega_ref - Omega) + b``: an exponential in closed form per interval.

    ``Omega(t) = Omega_inf + (Omega_k - Omega_inf) exp(-s K (t - t_k) / Js_eff)``, ``Omega_inf =
    Omega_ref + b / (s K)``, interval after interval (a frictionless wheel on the principal axis
    of a body at rest; every asked torque within ``max_torque``). DOP853 at rtol 1e-12: 1e-10
    relative. ``wheel_states``' effort is ``s K (Omega_ref - Omega_k) + b`` of the interval ending
    at each sample (the same operations: 1e-15 relative); the plant equals the node's compiled
    path bit for bit.
    """
    count = 40
    scene = wheel_scene(SPEED_FAULTS, mode='speed', bandwidth=BANDWIDTH)
    simulation = Simulation(scene.propagator(), RATE, outputs=scene.outputs, faults=scene.faults)
    ((effect, hold),) = simulation.command_holds
    blocks = [simulation.samples(0, 1)]
    for k in range(count):
        assert effect.receive(hold.stamp_ns(k), '', ['z'], [SET_POINT], [])[0]
        hold.seal(k)
        blocks.append(simulation.samples(k + 1, 1))
    omega = np.concatenate([b.omega_B for b in blocks])
    speeds = effect.wheel_speeds(omega, np.concatenate([b.internal for b in blocks]))[:, 0]
    gain = JS * BANDWIDTH
    expected = [SPEED0]
    for k in range(count):
        scale, bias = loop_error(k)
        settled = SET_POINT + bias / (scale * gain)
        decay = np.exp(-scale * gain / (JS_EFF * RATE))
        expected.append(settled + (expected[-1] - settled) * decay)
    np.testing.assert_allclose(speeds, expected, rtol=1e-10)
    errors = np.array([loop_error(k) for k in range(count)])
    asked = errors[:, 0] * (gain * (SET_POINT - speeds[1:])) + errors[:, 1]
    assert np.abs(asked).max() < MAX_TORQUE and np.ptp(asked) > 1e-2  # (unclipped; it acts)
    efforts = np.concatenate([b.outputs[0][:, 2] for b in blocks])
    np.testing.assert_allclose(efforts[1:], asked, rtol=1e-15, atol=0)
    plant = Plant(wheel_scene(SPEED_FAULTS, mode='speed', bandwidth=BANDWIDTH), RATE)
    stepped = [plant.state.wheel_speeds]
    stepped += [plant.step(wheels=[SET_POINT]).wheel_speeds for _ in range(count)]
    stepped = np.array(stepped)[:, 0]
    np.testing.assert_allclose(stepped, expected, rtol=1e-10)
    if integrator_path == 'compiled':  # (the plant runs the kernels; the reference is scipy's)
        np.testing.assert_array_equal(stepped, speeds)


def test_a_speed_drive_s_torque_error_replays_bit_for_bit(tmp_path):
    """
    ``torquefree_bag --commands``' replay of the node's recorded set-points: the same samples.

    The node's path without DDS (the effect's hold, sealed sample by sample) records each
    command that holds as the node's recorder does (``encode_command``, logged at the stamp of
    the sample it holds from); ``write_scene_bag`` re-simulates the scene, its faults included,
    from that recording: its ``wheel_states`` and rates equal the node path's bit for bit.
    """
    count = 30
    scene = wheel_scene(SPEED_FAULTS, mode='speed', bandwidth=BANDWIDTH)
    simulation = Simulation(scene.propagator(), RATE, outputs=scene.outputs, faults=scene.faults)
    ((effect, hold),) = simulation.command_holds
    blocks, commands = [simulation.samples(0, 1)], tmp_path / 'commands'
    with BagWriter(commands) as writer:
        channel = writer.add_topic('/wheel_command', 'sensor_msgs/msg/JointState')
        for k in range(count):
            set_point = SET_POINT + 5.0 * np.sin(k)  # a new one each sample
            assert effect.receive(hold.stamp_ns(k), '', ['z'], [set_point], [])[0]
            for command in hold.seal(k):
                data = encode_command(command, effect)
                writer.write(channel, hold.stamp_ns(command.start), data)
            blocks.append(simulation.samples(k + 1, 1))
    replay = tmp_path / 'replay'
    write_scene_bag(scene, replay, count / RATE, RATE, commands_bag=commands)
    messages = list(BagReader(replay).messages(['/wheel_states', '/angular_velocity']))
    states = [decode_joint_state(m.data) for m in messages if m.topic == '/wheel_states']
    rates = [m.data for m in messages if m.topic == '/angular_velocity']
    assert len(states) == len(rates) == count + 1
    replayed = np.array([[*position, *velocity, *effort]
                         for _, _, _, position, velocity, effort in states])
    np.testing.assert_array_equal(replayed, np.concatenate([b.outputs[0] for b in blocks]))
    omega = np.concatenate([b.omega_B for b in blocks])
    np.testing.assert_array_equal(
        np.array([decode_stamped_doubles(data, 3)[2] for data in rates]), omega
    )
    unfaulted = wheel_scene(mode='speed', bandwidth=BANDWIDTH)
    write_scene_bag(unfaulted, tmp_path / 'free', count / RATE, RATE, commands_bag=commands)
    free = [decode_joint_state(m.data)[4][0]
            for m in BagReader(tmp_path / 'free').messages(['/wheel_states'])]
    assert np.abs(np.array(free) - replayed[:, 1]).max() > 1e-3  # (the faults acted)


# -- the rule on a hold ---------------------------------------------------------------------------
def test_overrides_on_one_interval_apply_in_list_order():
    """
    An error after a stuck value acts on the value; a stuck value after an error replaces it.

    By hand: ``[1, 2, 3]`` held; error ``x 2 + 1`` on component 0; stuck ``[9, ., 7]``.
    """
    hold = CommandHold(100.0, width=3)
    hold.start(RATE, 0)
    assert hold.receive(hold.stamp_ns(0), [1.0, 2.0, 3.0])[0]
    error = Override(2, 4, (0,), None, (2.0,), (1.0,))
    stuck = Override(3, 5, (0, 2), (9.0, 7.0))
    hold.override([error, stuck])
    assert [hold.held_on(k).tolist() for k in range(6)] == [
        [1, 2, 3], [1, 2, 3], [3, 2, 3], [9, 2, 7], [9, 2, 7], [1, 2, 3]
    ]
    hold.override([stuck, error])
    assert hold.held_on(3).tolist() == [19, 2, 7]


# -- bad definitions ------------------------------------------------------------------------------
@pytest.mark.parametrize(
    'faults, scene, path',
    [
        ([{'torque_error': {'start': 0.0}}], 'torque',
         r"faults\[0\]\.torque_error: give 'bias' \(N m\), 'scale' or both"),
        ([{'torque_error': {'start': 0.0, 'scale': [1.0, 2.0]}}], 'torque',
         r'faults\[0\]\.torque_error\.scale: expected 3 numbers, got 2'),
        ([{'torque_error': {'start': 0.0, 'bias': [0.0, float('nan'), 0.0]}}], 'torque',
         r'faults\[0\]\.torque_error\.bias: every entry must be finite'),
        ([{'torque_error': {'start': 1.0, 'end': 0.5, 'scale': 2.0}}], 'torque',
         r'faults\[0\]\.torque_error\.end: must be after start'),
        ([{'torque_stuck': {'start': 0.0, 'value': [1.0]}}], 'torque',
         r'faults\[0\]\.torque_stuck\.value: expected 3 numbers'),
        ([{'torque_stuck': {'start': 0.0}}], 'wheels',
         r'faults\[0\]\.torque_stuck: the scene has no torque_command'),
        ([{'wheel_torque_error': {'wheel': 'z', 'start': 0.0, 'bias': 'x'}}], 'wheels',
         r'faults\[0\]\.wheel_torque_error\.bias: expected a finite number N m'),
        ([{'wheel_torque_error': {'wheel': 'y', 'start': 0.0, 'scale': 2.0}}], 'wheels',
         r'faults\[0\]\.wheel_torque_error\.wheel: .y. is not a commanded wheel'),
        ([{'wheel_torque_error': {'wheel': 'z', 'start': 0.0, 'scale': 2.0}}], 'hold',
         r'faults\[0\]\.wheel_torque_error: the wheel .z. is in mode hold'),
        ([{'wheel_torque_error': {'wheel': 'z', 'start': 0.0, 'scale': [2.0]}}], 'wheels',
         r'faults\[0\]\.wheel_torque_error\.scale: expected a finite number'),
    ],
)
def test_bad_command_faults_are_refused_with_the_field_path(faults, scene, path):
    with pytest.raises(SceneError, match=r'^s\.yaml: ' + path):
        if scene == 'torque':
            torque_scene(faults)
        else:
            wheel_scene(faults, scene if scene in ('speed', 'hold') else 'torque')


def test_a_run_time_torque_fault_is_checked_and_shown_in_the_diagnostics():
    scene = torque_scene()
    simulation = Simulation(scene.propagator(), RATE)
    bad = faults_from_text('[{wheel_torque_error: {wheel: z, start: 0, bias: 1}}]', ())
    with pytest.raises(FieldError, match=r'^faults\[0\]\.wheel_torque_error: the scene has no '):
        simulation.retune(3, bad)
    assert simulation.faults == ()
    text = ('[{torque_error: {start: 0.5, end: 1, scale: 0.5, bias: [0, 0, 1e-3]}}, '
            '{torque_stuck: {start: 0.7, value: [0, 0, 0]}}]')
    simulation.retune(3, faults_from_text(text, ()))
    assert simulation.fault_diagnostics(2)['faults_active'] == 'none'
    assert simulation.fault_diagnostics(7) == {
        'faults': '2',
        'faults_active': 'torque_error torque_command [0.5, 1) s scale [0.5, 0.5, 0.5] bias '
        '[0, 0, 0.001] N m; torque_stuck torque_command [0.7, ...) s at [0, 0, 0] N m',
    }
    wheel = faults_from_text('[{wheel_torque_error: {wheel: z, start: 0, scale: 0.5}}]', ())
    scene = wheel_scene()
    simulation = Simulation(scene.propagator(), RATE, faults=wheel)
    assert simulation.fault_diagnostics(0)['faults_active'] == (
        'wheel_torque_error z [0, ...) s scale 0.5 bias 0 N m'
    )


# -- on a running node ----------------------------------------------------------------------------
def test_a_torque_error_set_on_a_running_node_replays_byte_for_byte(tmp_path):
    """
    Set between samples 5 and 6: it acts from interval 6, as the core's run with it from 6.

    The node's rates equal the core's (the same commands, the fault put in force at sample 6),
    bit for bit; ``/diagnostics``' values name it; ``torquefree_bag --commands``' replay of the
    recording gives the same bytes.
    """
    run = set_while_running(
        tmp_path, '[{torque_error: {start: 0.0, scale: 0.5, bias: [1e-3, 0, -1e-3]}}]', 6, 10
    )
    np.testing.assert_array_equal(run.live, run.offline)
    assert run.diagnostics == {
        'faults': '1',
        'faults_active': 'torque_error torque_command [0, ...) s scale [0.5, 0.5, 0.5] bias '
        '[0.001, 0, -0.001] N m',
    }
    assert_the_replay_is_the_recording(tmp_path, run)
