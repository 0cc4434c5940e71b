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
The public test kit (torquefree_ros.testing) and its pytest fixture.

Isolation under pytest-xdist, reproducible samples, advance's promise to wait for the nodes added,
clear timeouts, clean teardown.
"""

import json
import os
from pathlib import Path
import subprocess
import sys
import threading
import time

from geometry_msgs.msg import QuaternionStamped, Vector3Stamped, WrenchStamped
import numpy as np
import pytest
import rclpy
from rclpy.exceptions import InvalidHandle
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import Imu
from torquefree_ros.testing import simulator, SimulatorTimeout

RELIABLE = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)

# -- pytest -n 2: two workers at once, twice at once, no cross-talk -------------------------------
# Each inner test runs a body of its own (its own initial rate) through the plugin's fixture and
# checks that what it received is exactly its run: 300 samples, indices 0..299, every value the
# truth's.
INNER = """
import json, os, time
import numpy as np
import pytest

# KIT_SABOTAGE (to show the check can fail): every simulator in one domain and one namespace
SHARED = {}
if "KIT_SABOTAGE" in os.environ:
    SHARED = {"domain_id": int(os.environ["KIT_SABOTAGE"]), "namespace": "shared"}
SPINS = [float(s) for s in os.environ["KIT_SPINS"].split()]
SIMULATORS = [dict(angular_velocity=[0.01, spin, 0.02], timeout=5.0, **SHARED) for spin in SPINS]

@pytest.mark.parametrize(
    "torquefree_sim", SIMULATORS, indirect=True, ids=[str(spin) for spin in SPINS]
)
def test_own_samples_only(torquefree_sim):
    sim = torquefree_sim
    # a barrier: with this simulator up, wait for another worker's, so that two surely run at once
    barrier = os.environ["KIT_BARRIER"]
    open(os.path.join(barrier, str(os.getpid())), "w").close()
    sim.spin_until(lambda: set(os.listdir(barrier)) - {str(os.getpid())}, 60.0, "another worker")
    started = time.monotonic()
    sim.advance(300)
    ended = time.monotonic()
    name = f"{os.getpid()}-{sim.namespace}.json"
    with open(os.path.join(os.environ["KIT_OUT"], name), "w") as out:
        json.dump({"worker": os.environ.get("PYTEST_XDIST_WORKER"), "domain": sim.domain_id,
                   "started": started, "ended": ended}, out)
    assert [s.index for s in sim.samples] == list(range(300))
    truth = sim.truth([s.t for s in sim.samples])
    rates = np.array([s.angular_velocity for s in sim.samples])
    attitudes = np.array([s.attitude for s in sim.samples])
    assert np.array_equal(rates, truth.angular_velocity)
    assert np.array_equal(attitudes, truth.attitude)
"""


def _run_inner(directory: Path, out: Path, spins: str, **env_extra) -> subprocess.Popen:
    (directory / 'test_inner_kit.py').write_text(INNER)
    out.mkdir()
    (directory / 'barrier').mkdir(exist_ok=True)
    env = dict(
        os.environ,
        KIT_OUT=str(out),
        KIT_SPINS=spins,
        KIT_BARRIER=str(directory / 'barrier'),
        **env_extra,
    )
    env.pop('ROS_DOMAIN_ID', None)  # the kit claims its own
    return subprocess.Popen(
        [
            sys.executable,
            '-m',
            'pytest',
            '-n',
            '2',
            '-q',
            '-p',
            'no:cacheprovider',
            'test_inner_kit.py',
        ],
        cwd=directory,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )


def test_two_runs_of_two_xdist_workers_at_once_each_see_only_their_own_samples(tmp_path):
    outs = [tmp_path / 'run0', tmp_path / 'run1']
    runs = [_run_inner(tmp_path, out, '0.5 1.0 1.5 2.0') for out in outs]
    for run in runs:
        output = run.communicate(timeout=600)[0]
        assert run.returncode == 0 and '4 passed' in output, output
    simulators = [json.loads(path.read_text()) for out in outs for path in out.iterdir()]
    assert len(simulators) == 8
    assert {s['worker'] for s in simulators} == {'gw0', 'gw1'}
    overlapping = [
        (a, b)
        for i, a in enumerate(simulators)
        for b in simulators[i + 1:]
        if a['started'] < b['ended'] and b['started'] < a['ended']
    ]
    assert overlapping, 'no two simulators ran at the same time: the test did not test isolation'
    for a, b in overlapping:
        assert a['domain'] != b['domain'], (a, b)


def test_the_parallel_check_fails_when_the_simulators_share_a_domain_and_a_namespace(tmp_path):
    """
    The parallel check fails when the simulators share a domain and a namespace.

    The inner run with the isolation defeated: the two workers' samples mix, and the inner tests
    say so.
    """
    from torquefree_ros.testing.domains import claim_domain

    claim = claim_domain()  # a domain no one else uses, for both workers
    try:
        run = _run_inner(tmp_path, tmp_path / 'out', '0.5 1.0', KIT_SABOTAGE=str(claim.domain_id))
        output = run.communicate(timeout=600)[0]
    finally:
        claim.release()
    assert run.returncode == 1 and 'failed' in output, output


# -- reproducible ---------------------------------------------------------------------------------
# exact with noisy outputs; DOP853 with a damper
@pytest.mark.parametrize('scene', ['estimator', 'explorer1'])
def test_twenty_runs_give_the_same_samples_bit_for_bit_and_they_are_the_truth(scene):
    with simulator(scene=scene) as sim:
        imu = sim.tap('imu', Imu) if scene == 'estimator' else None
        runs = []
        for _ in range(20):
            sim.advance(30)
            samples = sim.samples
            # each run's stamps start later (a reset never goes back in time)
            t0 = samples[0].stamp_ns
            gyro = (
                [
                    (
                        m.header.stamp.sec * 10**9 + m.header.stamp.nanosec - t0,
                        (m.angular_velocity.x, m.angular_velocity.y, m.angular_velocity.z),
                    )
                    for m in imu.messages
                ]
                if imu
                else []
            )
            runs.append(
                (
                    [s.index for s in samples],
                    [s.stamp_ns - t0 for s in samples],
                    np.array([s.angular_velocity for s in samples]),
                    np.array([s.attitude for s in samples]),
                    gyro,
                )
            )
            truth = sim.truth([s.t for s in samples])
            assert np.array_equal(runs[-1][2], truth.angular_velocity)
            assert np.array_equal(runs[-1][3], truth.attitude)
            if imu:
                imu.messages.clear()
            sim.reset()
        first = runs[0]
        assert first[0] == list(range(30))
        for run in runs[1:]:
            assert run[0] == first[0] and run[1] == first[1] and run[4] == first[4]
            assert np.array_equal(run[2], first[2]) and np.array_equal(run[3], first[3])
        if imu:
            assert len(first[4]) == 30


def test_a_closed_loop_in_lockstep_runs_the_same_twice():
    with simulator(scene='detumble', lockstep_timeout=20.0) as sim:
        controller = sim.create_node('controller')
        publisher = controller.create_publisher(WrenchStamped, 'torque_command', RELIABLE)

        def answer(sample: Vector3Stamped):
            command = WrenchStamped()
            command.header.stamp, command.header.frame_id = sample.header.stamp, 'body'
            command.wrench.torque.x, command.wrench.torque.y, command.wrench.torque.z = (
                -0.05 * sample.vector.x,
                -0.05 * sample.vector.y,
                -0.05 * sample.vector.z,
            )
            publisher.publish(command)

        controller.create_subscription(Vector3Stamped, 'angular_velocity', answer, RELIABLE)
        first = np.array([s.angular_velocity for s in sim.advance(40)])
        sim.reset()
        second = np.array([s.angular_velocity for s in sim.advance(40)])
        assert sim.node.sample_loop.missed_steps == 0
        assert np.array_equal(first, second)
        # the controller takes momentum out: |w| falls
        assert np.linalg.norm(first[-1]) < np.linalg.norm(first[0]) * 0.99
        with pytest.raises(ValueError, match='torque commands'):
            sim.truth(0.1)


# -- advance waits for the nodes added ------------------------------------------------------------
def test_advance_returns_only_after_a_slow_subscriber_processed_every_sample():
    with simulator(scene='estimator') as sim:
        node = sim.create_node('slow')
        seen, fixes = [], []

        def slow(message):
            time.sleep(0.05)  # the subscriber's own work, slow (not a wait of the test's)
            seen.append(message.header.stamp.sec * 10**9 + message.header.stamp.nanosec)

        node.create_subscription(QuaternionStamped, 'attitude', slow, RELIABLE)
        node.create_subscription(
            Imu, 'star_tracker', lambda m: (time.sleep(0.05), fixes.append(m)), RELIABLE
        )
        samples = sim.advance(5)
        assert seen == [s.stamp_ns for s in samples]
        # the star tracker (10 Hz at 100 Hz) goes out on samples 0 and 10
        samples += sim.advance(11)
        assert seen == [s.stamp_ns for s in samples]
        assert [sim.time_of(m.header.stamp) for m in fixes] == [0.0, 0.1]


def test_advance_waits_for_callbacks_of_every_kind():
    """
    The kit's advance waits for callbacks of every kind.

    With the MessageInfo, a coroutine, a raw subscription: each has run for the sample on return.
    """
    with simulator(scene='dzhanibekov') as sim:
        node = sim.create_node('kinds')
        with_info, coroutine, raw = [], [], []

        async def on_attitude(message):
            coroutine.append(message.header.stamp.nanosec)

        node.create_subscription(
            Vector3Stamped,
            'angular_velocity',
            lambda message, info: with_info.append(info['source_timestamp']),
            RELIABLE,
        )
        node.create_subscription(QuaternionStamped, 'attitude', on_attitude, RELIABLE)
        node.create_subscription(QuaternionStamped, 'attitude', raw.append, RELIABLE, raw=True)
        sim.advance(4)
        assert (
            len(with_info) == 4
            and coroutine == [s.stamp_ns for s in sim.samples]
            and len(raw) == 4
        )
        assert all(isinstance(message, bytes) for message in raw)


# -- clear timeouts -------------------------------------------------------------------------------
def test_a_subscriber_that_cannot_match_gets_a_timeout_naming_it_and_why():
    with simulator(scene='dzhanibekov', timeout=2.0) as sim:
        node = sim.create_node('deaf')
        qos = QoSProfile(
            depth=10,
            reliability=ReliabilityPolicy.RELIABLE,
            durability=DurabilityPolicy.TRANSIENT_LOCAL,
        )
        node.create_subscription(Vector3Stamped, 'angular_velocity', lambda m: None, qos)
        with pytest.raises(SimulatorTimeout) as error:
            sim.advance(1)
        text = str(error.value)
        assert f'/{sim.namespace}/deaf' in text and f'/{sim.namespace}/angular_velocity' in text, (
            text
        )
        assert 'volatile publisher and transient local subscription' in text.lower(), text


def test_a_node_that_never_answers_gets_a_timeout_naming_the_topic():
    with simulator(scene='dzhanibekov', timeout=1.0) as sim:
        sim.create_node('mute')  # expected to publish an estimate, never does
        estimates = sim.tap('attitude_estimate', QuaternionStamped)
        sim.advance(3)
        with pytest.raises(
            SimulatorTimeout,
            match=f'/{sim.namespace}/attitude_estimate .*0 of 1 messages.*'
            'publishers on the topic: none',
        ):
            estimates.wait(1)


def test_a_controller_that_never_answers_in_lockstep_gets_a_timeout_naming_the_command_topic():
    with simulator(scene='detumble', lockstep_timeout=0.3) as sim:
        sim.advance(1)  # sample 0 needs no answer
        with pytest.raises(
            SimulatorTimeout,
            match=f"without the controller's answer to sample 0.*"
            f'/{sim.namespace}/torque_command.*lockstep=False',
        ):
            sim.advance(1)


# -- teardown -------------------------------------------------------------------------------------
def _tasks() -> int:
    """Count the process's native threads (DDS's included), not only Python's."""
    return len(os.listdir('/proc/self/task'))


def test_teardown_leaves_no_thread_context_node_or_participant_behind():
    # DDS's process-wide threads start with the first participant
    with simulator(scene='dzhanibekov') as warm:
        warm.advance(1)
    threads, tasks = set(threading.enumerate()), _tasks()
    # a participant of our own watches the graph of the domain the simulator will claim (the next
    # free one)
    with simulator(scene='estimator') as sim:
        user = sim.create_node('user')
        user.create_subscription(Imu, 'imu', lambda m: None, RELIABLE)
        sim.advance(3)
        assert _tasks() > tasks  # the participant's threads, which must go
        nodes, namespace, context = [sim.node, user, sim._kit], f'/{sim.namespace}', sim.context
        probe_context = rclpy.Context()
        rclpy.init(context=probe_context, domain_id=sim.domain_id)
        probe = rclpy.create_node('probe', context=probe_context)
        try:
            _wait_graph(
                probe,
                probe_context,
                lambda names: namespace in names,
                'the probe never saw the simulator',
            )
        except BaseException:
            probe_context.try_shutdown()
            raise
    try:
        assert set(threading.enumerate()) == threads
        assert not context.ok()
        for node in nodes:
            with pytest.raises(InvalidHandle):
                with node.handle:
                    pass
        _wait_graph(
            probe,
            probe_context,
            lambda names: namespace not in names,
            "the simulator's nodes are still in the graph",
        )
    finally:
        probe.destroy_node()
        probe_context.try_shutdown()
    assert _tasks() == tasks, 'native threads left behind: a DDS participant was not destroyed'


def _wait_graph(node, context, condition, what: str) -> None:
    """Until ``condition(namespaces of the nodes in the graph)`` holds (20 s at most)."""
    deadline = time.monotonic() + 20.0
    while not condition({ns for _, ns in node.get_node_names_and_namespaces()}):
        assert time.monotonic() < deadline, what
        _spin_briefly(node, context)


def _spin_briefly(node, context) -> None:
    """
    Let discovery traffic in: spin the node once, briefly.

    The graph updates on its own threads; a spin waits for it a little.
    """
    from rclpy.executors import SingleThreadedExecutor

    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    executor.spin_once(timeout_sec=0.1)
    executor.remove_node(node)
    executor.shutdown()


# -- the fixture's parameters, resets, mistakes ---------------------------------------------------
@pytest.mark.torquefree_sim(scene='dzhanibekov', publish_rate=50.0)
def test_the_marker_sets_the_fixture_s_parameters(torquefree_sim):
    assert torquefree_sim.publish_rate == 50.0
    assert 'dzhanibekov' in torquefree_sim.node.sample_loop.request.configuration
    assert [s.t for s in torquefree_sim.advance(2)] == [0.0, 0.02]


@pytest.mark.parametrize(
    'torquefree_sim', ['explorer1', {'scene': 'dzhanibekov', 'publish_rate': 20.0}], indirect=True
)
def test_indirect_parametrization_sets_the_fixture_s_parameters(torquefree_sim):
    configuration = torquefree_sim.node.sample_loop.request.configuration
    assert ('explorer1' in configuration) != (
        'dzhanibekov' in configuration and torquefree_sim.publish_rate == 20.0
    )


def test_reset_follows_the_service_s_rules():
    with simulator(scene='dzhanibekov') as sim:
        before = sim.advance(3)
        with pytest.raises(ValueError, match='publish_rate'):
            sim.reset(publish_rate=-1.0)
        with pytest.raises(ValueError, match='qos_depth'):  # read-only, start-up only
            sim.reset(qos_depth=20)
        assert [s.index for s in sim.advance(2)] == [3, 4]  # the run went on untouched
        summary = sim.reset(angular_velocity=[0.0, 1.0, 0.0])
        assert 'angular_velocity [0, 1, 0]' in summary
        after = sim.advance(2)
        assert [s.index for s in after] == [0, 1] and after[0].stamp_ns > before[-1].stamp_ns
        assert np.array_equal(after[0].angular_velocity, [0.0, 1.0, 0.0])


def test_a_node_in_another_namespace_is_refused_with_the_fix():
    with simulator(scene='dzhanibekov') as sim:
        node = rclpy.create_node('elsewhere', context=sim.context)
        node.create_subscription(QuaternionStamped, 'attitude', lambda m: None, RELIABLE)
        with pytest.raises(
            ValueError,
            match=f'/attitude, the simulator publishes /{sim.namespace}/attitude.*'
            'namespace=sim.namespace',
        ):
            sim.add_node(node)
        node.destroy_node()
