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
Closing the loop through the node.

An in-process PD (rate-damping) controller detumbles a body in lock-step as the closed loop
predicts; two runs are bit-identical; the same controller stepping the plant in process and the
recorded commands re-simulated offline give the very same samples; without lock-step the hold times
out to zero and /diagnostics warns; malformed commands are counted there; a scene without the
effect has no subscription.
"""

from __future__ import annotations

import math

from conftest import PROCESS_TIMEOUT
import numpy as np
import pytest

SPHERE = (
    2.0  # kg m^2: w x Jw = 0, so the held torque -K w_k gives w_k+1 = (1 - K h / J) w_k exactly
)
GAIN = 0.5  # N m s
RATE = 20.0
OMEGA0 = [0.4, -0.3, 0.5]


# outputs beside the closed loop: every sample (markers, a noisy gyro) and every other (a star
# tracker at half the rate); the node publishes them after the rates (SampleLoop._step)
OUTPUTS = (
    '  - markers: {}\n'
    '  - imu: {gyro_noise_density: 1.0e-4, seed: 42}\n'
    f'  - star_tracker: {{cross_boresight_noise: 5.0, seed: 7, rate: {RATE / 2}}}\n'
)


def _scene(tmp_path, inertia=(SPHERE, SPHERE, SPHERE), extra='', outputs=''):
    path = tmp_path / 'plant.yaml'
    path.write_text(
        f'body: {{inertia: {list(inertia)}}}\ninitial: {{angular_velocity: {OMEGA0}}}\n'
        f'effects:\n  - torque_command: {{timeout: 0.5{extra}}}\n{outputs}accuracy: 1.0e-12\n'
    )
    return path


def _raw_messages(bag, start_ns: int, end_ns: int) -> dict:
    """Return topic -> the CDR bytes of its messages logged in ``[start_ns, end_ns]``."""
    from rosbags.highlevel import AnyReader

    messages: dict = {}
    with AnyReader([bag]) as reader:
        for connection, timestamp, raw in reader.messages():
            if start_ns <= timestamp <= end_ns:
                messages.setdefault(connection.topic, []).append(bytes(raw))
    return messages


class RateDamper:
    """
    The controller under test: answers each angular_velocity sample with ``-K w``.

    The answer is stamped with the sample's stamp, in the body frame. The node must take commands
    already (its start-up scene).
    """

    def __init__(self, harness, gain=GAIN, reliability='reliable'):
        from geometry_msgs.msg import Vector3Stamped, WrenchStamped
        from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy

        qos = QoSProfile(
            history=HistoryPolicy.KEEP_LAST, depth=1000, reliability=ReliabilityPolicy.RELIABLE
        )
        commands = QoSProfile(
            history=HistoryPolicy.KEEP_LAST,
            depth=1000,
            reliability=ReliabilityPolicy[reliability.upper()],
        )
        self.gain, self.message = gain, WrenchStamped
        self.publisher = harness.client.create_publisher(WrenchStamped, 'torque_command', commands)
        harness.client.create_subscription(Vector3Stamped, 'angular_velocity', self.answer, qos)
        harness.spin_until(
            lambda: self.publisher.get_subscription_count() > 0, what="the node's command input"
        )

    def answer(self, sample) -> None:
        command = self.message()
        command.header.stamp, command.header.frame_id = sample.header.stamp, 'body'
        v = sample.vector
        command.wrench.torque.x, command.wrench.torque.y, command.wrench.torque.z = (
            -self.gain * v.x,
            -self.gain * v.y,
            -self.gain * v.z,
        )
        self.publisher.publish(command)


def _run(harness, scene, count):
    """Reset into ``scene`` and collect its first ``count`` samples; returns (epoch, w, q)."""
    from sim_harness import reset_epoch_ns

    assert harness.set_parameters(scene=str(scene))[0].successful
    response = harness.reset()
    assert response.success, response.message
    epoch = reset_epoch_ns(response)
    period = round(1e9 / RATE)
    stamps = [epoch + k * period for k in range(count)]
    harness.spin_until(
        lambda: all(s in harness.omega and s in harness.q for s in stamps),
        timeout=60.0,
        what=f'{count} closed-loop samples',
    )
    return (
        epoch,
        np.array([harness.omega[s] for s in stamps]),
        np.array([harness.q[s] for s in stamps]),
    )


def test_lockstep_detumbles_as_predicted_reproducibly_and_replays_offline_bit_for_bit(tmp_path):
    from bag_checks import read_with_rosbags, stamp_ns
    from sim_harness import connected_harness
    from torquefree_ros import load_scene, Plant
    from torquefree_ros.cli.bag import main as bag_main

    scene = _scene(tmp_path, outputs=OUTPUTS)
    recorded = tmp_path / 'live'
    count = 120
    with connected_harness(
        publish_rate=RATE,
        real_time_factor=0.0,
        lockstep=True,
        lockstep_timeout=20.0,
        record_bag=str(recorded),
        scene=str(scene),
    ) as harness:
        RateDamper(harness)
        namespace = harness.node.get_namespace()
        epoch, omega, q = _run(harness, scene, count)
        _, omega_again, q_again = _run(harness, scene, count)
        loop = harness.node.sample_loop
        assert loop.request.lockstep and loop.missed_steps == 0
    # the closed loop's prediction: |w_k| = |w_0| (1 - K h / J)^k, along w_0
    factor = 1.0 - GAIN / (RATE * SPHERE)
    k = np.arange(count)
    np.testing.assert_allclose(omega, np.outer(factor**k, OMEGA0), rtol=1e-12, atol=0)
    assert np.linalg.norm(omega[-1]) < 0.25 * np.linalg.norm(OMEGA0)
    # the same controller, the same samples, bit for bit
    np.testing.assert_array_equal(omega_again, omega)
    np.testing.assert_array_equal(q_again, q)
    # and in process: the same controller stepping the plant gives the node's samples, bit for bit
    plant = Plant(load_scene(scene), RATE)
    np.testing.assert_array_equal(plant.state.omega_B, omega[0])
    for j in range(1, count):
        state = plant.step(
            [-GAIN * omega[j - 1][0], -GAIN * omega[j - 1][1], -GAIN * omega[j - 1][2]]
        )
        np.testing.assert_array_equal(state.omega_B, omega[j])
        np.testing.assert_array_equal(state.q_NB, q[j])

    # the bag holds the commands; re-simulated offline from them, the first run comes out bit for
    # bit. A command is logged at the stamp of the sample it holds from, so the first run's are
    # those logged in its window [epoch, epoch + (count - 1) period]. The loop may run a few
    # samples past `count` before the reset (logged later); an answer to the start-up run may
    # arrive after the reset and be accepted, then superseded by this run's answer to sample 0
    # (logged at epoch, stamped before it); and a command is logged once the next sample seals it,
    # so the one holding from sample count - 1 may or may not be in the bag.
    messages, _ = read_with_rosbags(recorded)
    period = round(1e9 / RATE)
    window_end = epoch + (count - 1) * period
    commands = [
        (log, m)
        for log, m in messages[f'{namespace}/torque_command']
        if epoch <= log <= window_end
    ]
    # this run's own: the answer to sample k holds from sample k (lock-step: it came before k + 1)
    own = [(log, stamp_ns(m.header)) for log, m in commands if stamp_ns(m.header) >= epoch]
    assert len(own) in (count - 1, count) and own == [
        (epoch + j * period,) * 2 for j in range(len(own))
    ]
    assert {m.header.frame_id for _, m in commands} == {'body'}
    replay = tmp_path / 'replay'
    assert (
        bag_main(
            [
                str(scene),
                '--commands',
                str(recorded),
                '--namespace',
                namespace,
                '--rate',
                str(RATE),
                '--duration',
                str((count - 1) / RATE),
                '--start-time',
                f'{epoch / 1e9:.9f}',
                '--output',
                str(replay),
            ]
        )
        == 0
    )
    replayed, _ = read_with_rosbags(replay)
    w = replayed[f'{namespace}/angular_velocity']
    assert [stamp_ns(m.header) for _, m in w] == [
        epoch + round(j * 1e9 / RATE) for j in range(count)
    ]
    np.testing.assert_array_equal([[m.vector.x, m.vector.y, m.vector.z] for _, m in w], omega)
    attitude = replayed[f'{namespace}/attitude']
    np.testing.assert_array_equal(
        [[m.quaternion.x, m.quaternion.y, m.quaternion.z, m.quaternion.w] for _, m in attitude], q
    )
    # every sample topic, outputs included, in the very same bytes
    live_bytes = _raw_messages(recorded, epoch, window_end)
    replayed_bytes = _raw_messages(replay, epoch, window_end)
    samples = {f'{namespace}/{name}' for name in ('angular_velocity', 'attitude', 'markers')}
    samples |= {f'{namespace}/{name}' for name in ('imu', 'star_tracker')}
    assert samples <= set(replayed_bytes)
    assert len(replayed_bytes[f'{namespace}/star_tracker']) == count // 2
    for topic in samples:
        assert live_bytes[topic] == replayed_bytes[topic], topic
    # the replay logs every command that holds within its samples where the node logged it
    replayed_commands = replayed[f'{namespace}/torque_command']
    assert [(log, stamp_ns(m.header)) for log, m in replayed_commands] == [
        (log, stamp_ns(m.header)) for log, m in commands
    ]
    assert [
        [m.wrench.torque.x, m.wrench.torque.y, m.wrench.torque.z] for _, m in replayed_commands
    ] == [[m.wrench.torque.x, m.wrench.torque.y, m.wrench.torque.z] for _, m in commands]


@pytest.mark.parametrize('reliability', ['best_effort', 'reliable'])
def test_a_best_effort_and_a_reliable_controller_both_drive_the_lockstep_loop(
    tmp_path, reliability
):
    """
    The command input matches either publisher, and the loop runs as predicted.

    A best-effort one is common at high rates and on micro-ROS; the input matches even one that
    appears after the subscription.
    """
    from sim_harness import connected_harness

    scene = _scene(tmp_path)
    count = 40
    with connected_harness(
        publish_rate=RATE,
        real_time_factor=0.0,
        lockstep=True,
        lockstep_timeout=20.0,
        scene=str(scene),
    ) as harness:
        # waits until the node's input matches it
        damper = RateDamper(harness, reliability=reliability)
        assert damper.publisher.qos_profile.reliability.name.lower() == reliability
        _, omega, _ = _run(harness, scene, count)
        # every sample waited for its answer and had it
        assert harness.node.sample_loop.missed_steps == 0
    factor = 1.0 - GAIN / (RATE * SPHERE)
    # the closed loop's prediction, as in the replay test (rounding of 40 products: 1e-12)
    np.testing.assert_allclose(
        omega, np.outer(factor ** np.arange(count), OMEGA0), rtol=1e-12, atol=0
    )


def test_a_triaxial_body_loses_energy_every_sample_within_the_closed_loop_bounds(tmp_path):
    from sim_harness import connected_harness
    from torquefree_ros.core.body.rigid_body import RigidBody

    scene = _scene(tmp_path, inertia=(1.0, 2.0, 3.0))
    with connected_harness(
        publish_rate=RATE,
        real_time_factor=0.0,
        lockstep=True,
        lockstep_timeout=20.0,
        scene=str(scene),
    ) as harness:
        RateDamper(harness)
        _, omega, _ = _run(harness, scene, 80)
    energy = RigidBody.from_inertia([1.0, 2.0, 3.0]).kinetic_energy(omega)
    assert np.all(np.diff(energy) < 0.0)  # dT/dt = w . tau = -K |w|^2 < 0
    # 2T / J_max <= |w|^2 <= 2T / J_min: T falls between exp(-2K t / J_min) and exp(-2K t / J_max)
    # (1 % for the hold lagging the continuous law)
    t = np.arange(80) / RATE
    ratio = energy / energy[0]
    assert np.all(ratio <= 1.01 * np.exp(-2.0 * GAIN * t / 3.0))
    assert np.all(ratio >= 0.99 * np.exp(-2.0 * GAIN * t / 1.0))
    assert ratio[-1] < 0.25


def test_without_lockstep_the_hold_times_out_and_diagnostics_say_why(tmp_path):
    from geometry_msgs.msg import WrenchStamped
    from sim_harness import connected_harness

    with connected_harness(publish_rate=50.0) as harness:
        publisher = harness.client.create_publisher(WrenchStamped, 'torque_command', 10)
        assert harness.set_parameters(scene=str(_scene(tmp_path)))[0].successful
        response = harness.reset()
        assert response.success, response.message
        harness.spin_until(
            lambda: publisher.get_subscription_count() > 0, what="the node's command input"
        )
        bad = WrenchStamped()
        bad.header.frame_id = 'body'
        bad.wrench.torque.x = math.nan
        publisher.publish(bad)
        good = WrenchStamped()
        good.header.frame_id = 'body'
        good.header.stamp = harness.node.get_clock().now().to_msg()
        good.wrench.torque.z = 0.01
        good.wrench.force.x = 1.0  # ignored, and said so
        publisher.publish(good)
        topic = 'torque_command'

        def status():
            for array in reversed(harness.diagnostics):
                values = {v.key: v.value for v in array.status[0].values}
                if values.get(f'{topic}.accepted') == '1':
                    return array.status[0], values
            return None, {}

        harness.spin_until(
            lambda: status()[0] is not None and 'no command for 0.5 s' in status()[0].message,
            timeout=20.0,
            what='the timeout warning',
        )
        level, values = status()
        assert level.level == level.WARN
        assert values[f'{topic}.refused'] == 'not finite 1'
        assert values[f'{topic}.torque'] == 'zero (no command in force)'
        assert values[f'{topic}.force'].startswith('ignored')
        hold = harness.node.sample_loop.simulation.command_holds[0][1]
        assert [c.values.tolist() for c in hold.commands] == [[0.0, 0.0, 0.01]]


def test_a_scene_without_the_effect_has_no_command_subscription(tmp_path):
    from sim_harness import connected_harness

    with connected_harness(publish_rate=50.0) as harness:

        def subscribed():
            return {
                name
                for name, _ in harness.node.get_subscriber_names_and_types_by_node(
                    harness.node.get_name(), harness.node.get_namespace()
                )
            }

        assert not any(name.endswith('/torque_command') for name in subscribed())
        assert harness.set_parameters(scene=str(_scene(tmp_path)))[0].successful
        assert harness.reset().success
        assert f'{harness.node.get_namespace()}/torque_command' in subscribed()
        assert harness.set_parameters(scene='default')[0].successful
        assert harness.reset().success
        assert not any(name.endswith('/torque_command') for name in subscribed())


def test_lockstep_without_answers_goes_on_at_each_timeout_and_counts_the_missed_steps(tmp_path):
    import time

    from sim_harness import connected_harness

    timeout = 0.1
    with connected_harness(
        publish_rate=RATE,
        real_time_factor=0.0,
        lockstep=True,
        lockstep_timeout=timeout,
        scene=str(_scene(tmp_path)),
    ) as harness:
        loop = harness.node.sample_loop
        harness.spin_until(lambda: loop.published >= 2, what='samples without a controller')
        first, started = loop.published, time.monotonic()
        harness.spin_until(
            lambda: loop.published >= first + 4, what='4 more samples without a controller'
        )
        elapsed, published = time.monotonic() - started, loop.published
        # every sample after the first waited the whole timeout for an answer that never came
        assert elapsed >= 3 * timeout
        assert loop.missed_steps >= published - 1


def test_lockstep_is_read_only():
    from sim_harness import connected_harness

    with connected_harness(publish_rate=50.0) as harness:
        (result,) = harness.set_parameters(lockstep=True)
        assert not result.successful and 'read-only' in result.reason


def _wait_for_a_sample(process, namespace: str) -> None:
    """
    Wait until the node process publishes a sample (it records each sample it publishes).

    A client of its own in the session's domain (conftest.py); the node's namespace keeps other
    tests' nodes out.
    """
    import time

    from geometry_msgs.msg import Vector3Stamped
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.signals import SignalHandlerOptions

    context = rclpy.Context()
    rclpy.init(context=context, signal_handler_options=SignalHandlerOptions.NO)
    try:
        node = rclpy.create_node('closing_watch', namespace=namespace, context=context)
        executor = SingleThreadedExecutor(context=context)
        executor.add_node(node)
        received = []
        node.create_subscription(Vector3Stamped, 'angular_velocity', received.append, 10)
        deadline = time.monotonic() + PROCESS_TIMEOUT  # only bounds a hang
        while not received:
            assert process.poll() is None, process.communicate()
            assert time.monotonic() < deadline, 'no sample from the node in time'
            executor.spin_once(timeout_sec=0.1)
        executor.shutdown()
        node.destroy_node()
    finally:
        context.try_shutdown()


def _threads(pid: int) -> set:
    import os

    return set(os.listdir(f'/proc/{pid}/task'))


def _pending(pid: int, signum: int) -> bool:
    """Return whether signal ``signum`` waits to be taken by a thread of process ``pid``."""
    with open(f'/proc/{pid}/status') as status:
        masks = [
            int(line.split()[1], 16)
            for line in status
            if line.startswith(('SigPnd:', 'ShdPnd:'))  # the main thread's own, the process's
        ]
    return any(mask >> (signum - 1) & 1 for mask in masks)


def _stop(pid: int) -> None:
    """SIGSTOP ``pid`` and wait until every thread of it has stopped (state T in proc(5))."""
    import os
    import signal
    import time

    os.kill(pid, signal.SIGSTOP)
    while True:
        with open(f'/proc/{pid}/stat') as stat:
            state = stat.read().rsplit(')', 1)[1].split()[0]
        assert state != 'Z', 'the node process ended while the test was stopping it'
        if state in 'Tt':
            return
        time.sleep(0.001)


@pytest.mark.parametrize('lockstep', [True, False], ids=['lockstep', 'paced'])
def test_a_second_ctrl_c_while_closing_still_closes_the_bag_and_exits_cleanly(tmp_path, lockstep):
    """
    A second Ctrl-C while the node is closing still lets it close its bag and exit cleanly.

    Decided by events, not times: the first SIGINT goes out once the node publishes (and records)
    samples; the second while the node is closing. Closing begins (``process.shut_down``, its
    signals already ignored) by stopping the executor's thread: the first of the running node's
    threads to end (none ends before it; a run has no other). Once a thread has taken the first
    signal, the test checks for that with the process stopped (SIGSTOP), and sends the second
    SIGINT before it continues, so the signal reaches a process that is closing, never one that
    has exited.
    """
    import os
    from pathlib import Path
    import signal
    import subprocess
    import sys
    import time

    from bag_checks import metadata

    bag = tmp_path / 'closing'
    namespace = '/closing_test'
    process = subprocess.Popen(
        [
            sys.executable,
            '-m',
            'torquefree_ros.cli.sim',
            '--ros-args',
            '-r',
            f'__ns:={namespace}',
            '-p',
            'scene:=detumble',
            '-p',
            f'lockstep:={str(lockstep).lower()}',
            '-p',
            'real_time_factor:=0.0',
            '-p',
            f'record_bag:={bag}',
        ],
        cwd=Path(__file__).resolve().parents[1],
        env=dict(os.environ, PYTHONUNBUFFERED='1'),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        for line in process.stderr:
            if 'start: ' in line:
                break
        _wait_for_a_sample(process, namespace)
        running = _threads(process.pid)
        process.send_signal(signal.SIGINT)
        deadline = time.monotonic() + PROCESS_TIMEOUT  # only bounds a hang
        # not stopped before a thread took it: a signal pending across a stop is taken, when the
        # process continues, by whichever thread runs first, and only the main thread's wait is
        # interrupted by it (the kernel gives it to the main thread, which sleeps, when running)
        while _pending(process.pid, signal.SIGINT):
            assert time.monotonic() < deadline, 'the first SIGINT was not taken in time'
            time.sleep(0.001)
        while True:
            _stop(process.pid)
            closing = not running <= _threads(process.pid)
            if closing:
                process.send_signal(signal.SIGINT)  # pending until it continues, closing
            os.kill(process.pid, signal.SIGCONT)
            if closing:
                break
            assert time.monotonic() < deadline, 'the node did not begin closing in time'
            time.sleep(0.01)  # the process runs between two looks
        _, stderr = process.communicate(timeout=PROCESS_TIMEOUT)
    finally:
        process.kill()
    assert process.returncode == 0, stderr
    assert 'terminate called' not in stderr and 'Traceback' not in stderr, stderr
    # closed: metadata.yaml written, the summary in place
    assert metadata(bag)['message_count'] > 0


def test_outputs_failing_after_the_rates_went_out_stop_the_run_until_a_reset(
    tmp_path, monkeypatch
):
    from sim_harness import connected_harness
    from torquefree_ros.core.run.simulation import Simulation

    with_outputs = Simulation.with_outputs

    def failing_at_sample_5(simulation, block):
        if block.first == 5:
            raise ValueError('rows out of range')
        return with_outputs(simulation, block)

    monkeypatch.setattr(Simulation, 'with_outputs', failing_at_sample_5)
    scene = _scene(tmp_path, outputs='  - markers: {}\n')
    with connected_harness(
        publish_rate=RATE,
        real_time_factor=0.0,
        lockstep=True,
        lockstep_timeout=0.5,  # the start-up run's first samples go unanswered
        scene=str(scene),
    ) as harness:
        RateDamper(harness)
        loop = harness.node.sample_loop
        harness.spin_until(lambda: loop.failure, what='the failure')
        # sample 5's rates went out before its markers failed; the run stops there, whole
        # samples 0-4 published and counted
        assert loop.failure == 'cannot compute the outputs of sample 5: rows out of range'
        assert loop.published == 5 and loop.last.index == 4
        monkeypatch.undo()
        assert harness.reset().success
        harness.spin_until(lambda: loop.published >= 5 + 20, what='samples after the reset')
        assert not loop.failure


# -- reaction wheels: wheel_command in, wheel_states out ------------------------------------------
WHEEL_RATE = 20.0
WHEEL_NAMES = ['rw_x', 'rw_y', 'rw_z', 'rw_s']
WHEEL_AXES = np.array([[1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0], [1.0, 1.0, 1.0]])
WHEEL_AXES /= np.linalg.norm(WHEEL_AXES, axis=1, keepdims=True)
WHEEL_JS, WHEEL_MAX_TORQUE = 0.02, 0.05
WHEEL_INERTIA = [4.0, 5.0, 6.0, 0.1, -0.05, 0.08]
WHEEL_SPEEDS = [50.0, -30.0, 0.0, 10.0]
WHEEL_GAIN = 2.0  # N m s: -K w asks more than the wheels' 0.05 N m at first (clipped)


def _wheel_scene(tmp_path, mode='torque', extra=''):
    wheels = ''.join(
        f'        - {{name: {name}, axis: {axis.tolist()}, spin_inertia: {WHEEL_JS}, '
        f'max_torque: {WHEEL_MAX_TORQUE}, max_speed: 300.0, viscous: 1.0e-5, coulomb: 1.0e-4, '
        f'speed: {speed}}}\n'
        for name, axis, speed in zip(WHEEL_NAMES, WHEEL_AXES, WHEEL_SPEEDS)
    )
    path = tmp_path / f'wheels_{mode}.yaml'
    path.write_text(
        f'body: {{inertia: {WHEEL_INERTIA}}}\n'
        'initial: {angular_velocity: [0.05, -0.04, 0.03]}\n'
        'effects:\n'
        f'  - reaction_wheels:\n      mode: {mode}\n      timeout: 0.5\n      wheels:\n{wheels}'
        f'  - wheel_states: {{}}\n  - markers: {{}}\n{extra}'
        'accuracy: 1.0e-10\n'
    )
    return path


# wheel torques whose reaction on the body is a body torque tau: -G^T u = tau, least norm
WHEEL_FROM_BODY = -WHEEL_AXES @ np.linalg.inv(WHEEL_AXES.T @ WHEEL_AXES)


def test_wheel_commands_in_lockstep_replay_offline_bit_for_bit_and_refusals_are_counted(tmp_path):
    """
    A rate damper on four wheels, through wheel_command: physics, the plant, the offline replay.

    Each sample is answered with the least-norm wheel torques for the body torque ``-K w``
    (clipped by the wheels at first); every 7th answer names two wheels only (the others keep
    their values); sample 10 also gets six malformed commands, counted in /diagnostics and never
    reaching the state: the replay of the recorded commands gives every sample topic's bytes.
    wheel_states, read by rclpy: its velocities keep the inertial momentum ``R(q) (I w + sum Js
    Omega g)`` constant (no external torque) to 1e-9 of |H| (the integration's accuracy, 1e-10 a
    sample, over 60 samples); its efforts are the commands of the interval before each sample,
    clipped to max_torque, exactly; its positions the trapezoidal integral of the velocities to
    1e-5 rad over 3 s (the trapezoid's error, h^3 / 12 of the speeds' curvature a step: measured
    1.2e-6 rad). The plant stepped with the same inputs gives the node's samples bit for bit.
    """
    from bag_checks import read_with_rosbags, stamp_ns
    from diagnostic_msgs.msg import DiagnosticArray
    from geometry_msgs.msg import Vector3Stamped
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import JointState
    from torquefree_ros import load_scene, Plant
    from torquefree_ros.cli.bag import main as bag_main
    from torquefree_ros.core.frames import quaternion
    from torquefree_ros.testing import simulator

    reliable = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)
    scene, recorded, count = _wheel_scene(tmp_path), tmp_path / 'live', 60
    held = {}  # sample k -> the wheel torques the controller asked to hold from it (merged)
    bad = [  # (names, velocity, effort)
        (['rw_x', 'rw_q'], [], [0.0, 0.0]),
        (['rw_x', 'rw_y'], [], [0.0]),
        (['rw_x'], [], []),
        (['rw_x'], [], [math.nan]),
        (['rw_x'], [1.0], [0.0]),
        (['rw_x'], [1.0], []),
    ]
    with simulator(
        scene=str(scene), publish_rate=WHEEL_RATE, record_bag=str(recorded), lockstep_timeout=20
    ) as sim:
        controller = sim.create_node('wheel_damper')
        publisher = controller.create_publisher(JointState, 'wheel_command', reliable)

        def send(stamp, names, velocity, effort):
            command = JointState()
            command.header.stamp, command.name = stamp, names
            command.velocity, command.effort = velocity, effort
            publisher.publish(command)

        def answer(sample):
            k = round(sim.time_of(sample.header.stamp) * WHEEL_RATE)
            w = np.array([sample.vector.x, sample.vector.y, sample.vector.z])
            wheels = (WHEEL_FROM_BODY @ (-WHEEL_GAIN * w)).tolist()
            if k == 10:
                for message in bad:
                    send(sample.header.stamp, *message)
            if k % 7 == 3:  # two wheels only
                send(sample.header.stamp, ['rw_z', 'rw_x'], [], [wheels[2], wheels[0]])
                held[k] = [wheels[0], held[k - 1][1], wheels[2], held[k - 1][3]]
            else:
                send(sample.header.stamp, WHEEL_NAMES, [], wheels)
                held[k] = wheels

        controller.create_subscription(Vector3Stamped, 'angular_velocity', answer, reliable)
        states = sim.tap('wheel_states', JointState)
        samples = sim.advance(count)
        states.wait(count)
        diagnostics = sim.tap('/diagnostics', DiagnosticArray)
        diagnostics.wait(1)
        state = sim.node.stepping.state()
        assert state.missed_steps == 0
        epoch = samples[0].stamp_ns
    values = {v.key: v.value for v in diagnostics.messages[-1].status[0].values}
    assert values['wheel_command.refused'] == (
        'both fields 1, not finite 1, unknown name 1, wrong length 2, wrong mode 1'
    )
    assert float(values['wheels.rw_x.torque_limited_time']) > 0.0
    assert 0.0 < float(values['wheels.rw_x.speed_fraction']) < 1.0
    assert float(values['wheels.momentum']) > 0.0
    # wheel_states against the physics
    messages = states.messages[:count]
    assert [stamp_ns(m.header) for m in messages] == [s.stamp_ns for s in samples]
    assert {m.header.frame_id for m in messages} == {'body'}
    assert all(list(m.name) == WHEEL_NAMES for m in messages)
    speeds = np.array([m.velocity for m in messages])
    omega = np.array([s.angular_velocity for s in samples])
    q = np.array([s.attitude for s in samples])
    tensor = np.array([[4.0, 0.1, -0.05], [0.1, 5.0, 0.08], [-0.05, 0.08, 6.0]])
    H_N = quaternion.rotate(q, omega @ tensor + (WHEEL_JS * speeds) @ WHEEL_AXES)
    np.testing.assert_allclose(
        H_N, np.broadcast_to(H_N[0], H_N.shape), rtol=0, atol=1e-9 * np.linalg.norm(H_N[0])
    )
    efforts = np.array([m.effort for m in messages])
    asked = np.array([[0.0] * 4] + [held[k] for k in range(count - 1)])
    np.testing.assert_array_equal(
        efforts, np.clip(asked, -WHEEL_MAX_TORQUE, WHEEL_MAX_TORQUE)
    )
    assert (np.abs(asked) > WHEEL_MAX_TORQUE).any()  # (clipping shown)
    positions = np.array([m.position for m in messages])
    trapezoid = np.concatenate(
        [np.zeros((1, 4)), np.cumsum(0.5 * (speeds[1:] + speeds[:-1]) / WHEEL_RATE, axis=0)]
    )
    np.testing.assert_allclose(positions, trapezoid, rtol=0, atol=1e-5)
    assert np.abs(positions[-1]).max() > 100.0  # (the angles did grow)
    # the same wheel inputs stepping the plant in process: the node's samples, bit for bit
    plant = Plant(load_scene(scene), WHEEL_RATE)
    for k in range(1, count):
        state = plant.step(wheels=held[k - 1])
        np.testing.assert_array_equal(state.omega_B, omega[k])
        np.testing.assert_array_equal(state.q_NB, q[k])
        np.testing.assert_array_equal(state.wheel_speeds, speeds[k])
        np.testing.assert_array_equal(state.internal[1::2], positions[k])
    # the recorded commands (merged, accepted) replayed offline: every sample topic's bytes
    replay = tmp_path / 'replay'
    assert (
        bag_main(
            [
                str(scene),
                '--commands',
                str(recorded),
                '--rate',
                str(WHEEL_RATE),
                '--duration',
                str((count - 1) / WHEEL_RATE),
                '--start-time',
                f'{epoch / 1e9:.9f}',
                '--output',
                str(replay),
            ]
        )
        == 0
    )
    window_end = epoch + round((count - 1) * 1e9 / WHEEL_RATE)
    live_bytes = _raw_messages(recorded, epoch, window_end)
    replayed_bytes = _raw_messages(replay, epoch, window_end)
    for topic in ('angular_velocity', 'attitude', 'wheel_states', 'markers', 'wheel_command'):
        assert live_bytes[f'/{topic}'] == replayed_bytes[f'/{topic}'], topic
    assert len(live_bytes['/wheel_states']) == count
    # each command that held, recorded whole: every wheel named
    commands, _ = read_with_rosbags(recorded)
    assert all(list(m.name) == WHEEL_NAMES for _, m in commands['/wheel_command'])


def test_lockstep_waits_for_the_wheels_answer_too():
    """
    A scene taking torque and wheel commands: an answer on torque_command alone is not enough.

    The kit's timeout names the topic still unanswered.
    """
    import tempfile
    from pathlib import Path

    from geometry_msgs.msg import Vector3Stamped, WrenchStamped
    from torquefree_ros.testing import simulator, SimulatorTimeout

    with tempfile.TemporaryDirectory() as directory:
        scene = _wheel_scene(
            Path(directory), 'speed', '  - torque_command: {timeout: 0.5}\n'
        )
        with simulator(scene=str(scene), lockstep_timeout=0.3) as sim:
            controller = sim.create_node('torque_only')
            publisher = controller.create_publisher(WrenchStamped, 'torque_command', 10)

            def answer(sample):
                command = WrenchStamped()
                command.header.stamp, command.header.frame_id = sample.header.stamp, 'body'
                publisher.publish(command)

            controller.create_subscription(Vector3Stamped, 'angular_velocity', answer, 10)
            sim.advance(1)  # sample 0 needs no answer
            with pytest.raises(SimulatorTimeout, match=r'on /wheel_command \(the answer'):
                sim.advance(1)
