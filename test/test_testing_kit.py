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
namespaces, clear timeouts, clean teardown.
"""

import json
import os
from pathlib import Path
import subprocess
import sys
import tempfile
import threading
import time

from geometry_msgs.msg import QuaternionStamped, Vector3Stamped, WrenchStamped
import numpy as np
import pytest
import rclpy
from rclpy.exceptions import InvalidHandle
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import Imu
from torquefree_ros.testing import simulator, SimulatorTimeout, stamp_ns

RELIABLE = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)
#: a wait that must succeed may take this long (s): generous, the machine is shared and busy
GENEROUS = 20.0

# -- pytest -n 2: two workers at once, twice at once, no cross-talk -------------------------------
# Each inner test runs a body of its own (its own initial rate) through the plugin's fixture and
# checks that what it received is exactly its run: COUNT samples, indices 0..COUNT-1, every value
# the truth's.
INNER = """
import json, os, time
import numpy as np
import pytest

# KIT_SABOTAGE (to show the check can fail): every simulator in one domain (each in the root
# namespace, the default); its waits are expected to fail, so they may be short: with the two
# streams mixed, a wait can also go on succeeding slowly, sample after sample
SHARED = {}
if "KIT_SABOTAGE" in os.environ:
    SHARED = {"domain_id": int(os.environ["KIT_SABOTAGE"]), "timeout": 5.0}
SPINS = [float(s) for s in os.environ["KIT_SPINS"].split()]
SIMULATORS = [dict(angular_velocity=[0.01, spin, 0.02], **SHARED) for spin in SPINS]
# 3 s of samples at the default 100 Hz: beyond the barrier, long enough for the runs to overlap
COUNT = 300

@pytest.mark.parametrize(
    "torquefree_sim", SIMULATORS, indirect=True, ids=[str(spin) for spin in SPINS]
)
def test_own_samples_only(torquefree_sim, request):
    sim = torquefree_sim
    # a barrier: with this simulator up, wait for another worker's, so that two surely run at once
    barrier = os.environ["KIT_BARRIER"]
    open(os.path.join(barrier, str(os.getpid())), "w").close()
    sim.spin_until(lambda: set(os.listdir(barrier)) - {str(os.getpid())}, 60.0, "another worker")
    started = time.monotonic()
    sim.advance(COUNT)
    ended = time.monotonic()
    name = f"{os.getpid()}-{request.node.callspec.id}.json"
    with open(os.path.join(os.environ["KIT_OUT"], name), "w") as out:
        json.dump({"worker": os.environ.get("PYTEST_XDIST_WORKER"), "domain": sim.domain_id,
                   "started": started, "ended": ended}, out)
    assert [s.index for s in sim.samples] == list(range(COUNT))
    truth = sim.truth([s.t for s in sim.samples])
    rates = np.array([s.angular_velocity for s in sim.samples])
    attitudes = np.array([s.attitude for s in sim.samples])
    assert np.array_equal(rates, truth.angular_velocity)
    assert np.array_equal(attitudes, truth.attitude)
"""
WORKERS = 2  # pytest -n 2: its workers are gw0 and gw1


def _run_inner(directory: Path, out: Path, spins: list, **env_extra) -> subprocess.Popen:
    (directory / 'test_inner_kit.py').write_text(INNER)
    out.mkdir()
    (directory / 'barrier').mkdir(exist_ok=True)
    env = dict(
        os.environ,
        KIT_OUT=str(out),
        KIT_SPINS=' '.join(str(spin) for spin in spins),
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
            str(WORKERS),
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
    outs, spins = [tmp_path / 'run0', tmp_path / 'run1'], [0.5, 1.0, 1.5, 2.0]
    runs = [_run_inner(tmp_path, out, spins) for out in outs]
    try:
        for run in runs:
            output = run.communicate(timeout=600)[0]
            assert run.returncode == 0 and f'{len(spins)} passed' in output, output
    finally:  # (nothing of a failed run goes on beside the next tests)
        for run in runs:
            run.kill()
    simulators = [json.loads(path.read_text()) for out in outs for path in out.iterdir()]
    assert len(simulators) == len(outs) * len(spins)  # one simulator per inner test
    assert {s['worker'] for s in simulators} == {f'gw{i}' for i in range(WORKERS)}
    overlapping = [
        (a, b)
        for i, a in enumerate(simulators)
        for b in simulators[i + 1:]
        if a['started'] < b['ended'] and b['started'] < a['ended']
    ]
    assert overlapping, 'no two simulators ran at the same time: the test did not test isolation'
    for a, b in overlapping:
        assert a['domain'] != b['domain'], (a, b)


def test_the_parallel_check_fails_when_the_simulators_share_a_domain(tmp_path):
    """
    The parallel check fails when the simulators share a domain.

    The inner run with the isolation defeated: the two workers' samples mix, and the inner tests
    say so.
    """
    from torquefree_ros.testing.domains import claim_domain

    claim = claim_domain()  # a domain no one else uses, for both workers
    run = None
    try:
        run = _run_inner(tmp_path, tmp_path / 'out', [0.5, 1.0], KIT_SABOTAGE=str(claim.domain_id))
        output = run.communicate(timeout=600)[0]
    finally:
        if run is not None:
            run.kill()  # (before the domain is free again)
        claim.release()
    assert run.returncode == 1 and 'failed' in output, output


# -- reproducible ---------------------------------------------------------------------------------
# Resets enough to catch state carried from one run into the next (seeded noise, an integrator's
# state, a block computed ahead), each run short: about a second in all
RUNS, SAMPLES = 20, 30


# exact with noisy outputs; DOP853 with a damper
@pytest.mark.parametrize('scene', ['estimator', 'explorer1'])
def test_twenty_runs_give_the_same_samples_bit_for_bit_and_they_are_the_truth(scene):
    with simulator(scene=scene) as sim:
        imu = sim.tap('imu', Imu) if scene == 'estimator' else None
        runs = []
        for _ in range(RUNS):
            sim.advance(SAMPLES)
            samples = sim.samples
            # each run's stamps start later (a reset never goes back in time)
            t0 = samples[0].stamp_ns
            gyro = (
                [
                    (
                        stamp_ns(m.header.stamp) - t0,
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
        assert first[0] == list(range(SAMPLES))
        for run in runs[1:]:
            assert run[0] == first[0] and run[1] == first[1] and run[4] == first[4]
            assert np.array_equal(run[2], first[2]) and np.array_equal(run[3], first[3])
        if imu:
            assert len(first[4]) == SAMPLES  # the estimator scene's imu has no rate of its own


def test_a_closed_loop_in_lockstep_runs_the_same_twice():
    # lockstep_timeout: the controller's answers must all come in time (GENEROUS)
    with simulator(scene='detumble', lockstep_timeout=GENEROUS) as sim:
        controller = sim.create_node('controller')
        publisher = controller.create_publisher(WrenchStamped, 'torque_command', RELIABLE)
        # K w0 is at most 0.007 N m a component (w0 [0.10, -0.12, 0.14] rad/s), under the scene's
        # max_torque 0.01 N m, beyond which a command is refused: every answer holds as sent
        gain = 0.05  # N m s

        def answer(sample: Vector3Stamped):
            command = WrenchStamped()
            command.header.stamp, command.header.frame_id = sample.header.stamp, 'body'
            command.wrench.torque.x, command.wrench.torque.y, command.wrench.torque.z = (
                -gain * sample.vector.x,
                -gain * sample.vector.y,
                -gain * sample.vector.z,
            )
            publisher.publish(command)

        controller.create_subscription(Vector3Stamped, 'angular_velocity', answer, RELIABLE)
        count = 40
        first = np.array([s.angular_velocity for s in sim.advance(count)])
        sim.reset()
        second = np.array([s.angular_velocity for s in sim.advance(count)])
        state = sim.node.stepping.state()
        assert state.missed_steps == 0
        assert np.array_equal(first, second)
        # the controller takes momentum out. With tau = -K w, d|H|/dt = -2 K T / |H|, and
        # 2 T >= |H|^2 / J_max: |H| falls at least as fast as exp(-K t / J_max) (each answer
        # holds over the interval after its sample, which changes w by far less than the margin)
        tensor = state.simulation.body.tensor
        momentum = np.linalg.norm(first @ tensor.T, axis=1)
        t = (count - 1) / sim.publish_rate
        bound = np.exp(-gain * t / np.linalg.eigvalsh(tensor).max())
        assert momentum[-1] < momentum[0] * bound, (momentum[-1] / momentum[0], bound)
        with pytest.raises(ValueError, match='torque commands'):
            sim.truth(0.1)


# -- advance waits for the nodes added ------------------------------------------------------------
def test_advance_returns_only_after_a_slow_subscriber_processed_every_sample():
    with simulator(scene='estimator') as sim:
        node = sim.create_node('slow')
        seen, fixes = [], []
        # the subscriber's own work, slow: 5 periods of the 100 Hz samples, so that a kit that
        # did not wait would have let several more out meanwhile (not a wait of the test's)
        work = 0.05

        def slow(message):
            time.sleep(work)
            seen.append(stamp_ns(message.header.stamp))

        node.create_subscription(QuaternionStamped, 'attitude', slow, RELIABLE)
        node.create_subscription(
            Imu, 'star_tracker', lambda m: (time.sleep(work), fixes.append(m)), RELIABLE
        )
        samples = sim.advance(5)
        assert seen == [s.stamp_ns for s in samples]
        # the estimator scene's star tracker runs at 10 Hz: on samples 0 and `every` of 0..15
        every = round(sim.publish_rate / 10.0)
        samples += sim.advance(11)
        assert seen == [s.stamp_ns for s in samples]
        assert [sim.time_of(m.header.stamp) for m in fixes] == [0.0, every / sim.publish_rate]


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
        count = 4
        sim.advance(count)
        assert (
            len(with_info) == count
            and coroutine == [s.stamp_ns for s in sim.samples]
            and len(raw) == count
        )
        assert all(isinstance(message, bytes) for message in raw)


# -- namespaces -----------------------------------------------------------------------------------
def test_by_default_a_node_made_without_a_namespace_gets_the_samples():
    with simulator(scene='dzhanibekov') as sim:
        assert sim.namespace == '/'
        node = rclpy.create_node('plain', context=sim.context)  # the usual node: no namespace
        seen = []
        node.create_subscription(
            Vector3Stamped,
            'angular_velocity',
            lambda m: seen.append(stamp_ns(m.header.stamp)),
            RELIABLE,
        )
        sim.add_node(node)
        assert seen == [s.stamp_ns for s in sim.advance(3)]


def test_a_namespace_asked_for_holds_the_simulator_and_refuses_a_node_outside_it():
    with simulator(scene='dzhanibekov', namespace='left') as sim:
        assert sim.namespace == '/left'
        assert sim.node.resolve_topic_name('angular_velocity') == '/left/angular_velocity'
        seen = []
        inside = rclpy.create_node('inside', context=sim.context, namespace=sim.namespace)
        inside.create_subscription(
            Vector3Stamped,
            'angular_velocity',
            lambda m: seen.append(stamp_ns(m.header.stamp)),
            RELIABLE,
        )
        sim.add_node(inside)
        assert seen == [s.stamp_ns for s in sim.advance(2)]
        outside = rclpy.create_node('outside', context=sim.context)
        outside.create_subscription(Vector3Stamped, 'angular_velocity', lambda m: None, RELIABLE)
        with pytest.raises(
            ValueError,
            match='subscribes to /angular_velocity, the simulator publishes '
            '/left/angular_velocity: the subscription can never match; .*'
            r"namespace=sim.namespace \('/left'\)",
        ):
            sim.add_node(outside)
        outside.destroy_node()


def test_two_simulators_in_one_domain_keep_apart_in_namespaces_of_their_own():
    """
    Two simulators in one domain keep apart in namespaces of their own.

    A witness beside the left one takes the right one's samples, which shows that the two share the
    domain; the left one's own nodes get none of them.
    """
    from torquefree_ros.testing.domains import claim_domain

    claim = claim_domain()
    try:
        # their initial rates differ, so each one's samples are told apart
        with (
            simulator(
                scene='dzhanibekov',
                domain_id=claim.domain_id,
                namespace='left',
                angular_velocity=[0.0, 1.0, 0.0],
            ) as left,
            simulator(
                scene='dzhanibekov',
                domain_id=claim.domain_id,
                namespace='right',
                angular_velocity=[0.0, 2.0, 0.0],
            ) as right,
        ):
            users = [sim.create_node('user') for sim in (left, right)]
            for user in users:
                user.create_subscription(
                    Vector3Stamped, 'angular_velocity', lambda m: None, RELIABLE
                )
            left.advance(1)
            topic = right.node.resolve_topic_name('angular_velocity')
            witness, witnessed = rclpy.create_node('witness', context=left.context), []
            witness.create_subscription(Vector3Stamped, topic, witnessed.append, RELIABLE)
            left.add_node(witness)
            # the right one's publisher has matched every subscription to its topic in both
            # contexts, so none can miss a sample for want of discovery
            nodes = [left._kit, right._kit, witness, *users]
            subscriptions = sum(
                sub.topic_name == topic for node in nodes for sub in node.subscriptions
            )
            publisher = next(p for p in right.node.publishers if p.topic_name == topic)
            right.spin_until(
                lambda: publisher.get_subscription_count() >= subscriptions,
                GENEROUS,
                f'{topic} matched by its {subscriptions} subscriptions',
            )
            right.advance(3)
            left.spin_until(lambda: len(witnessed) >= 3, GENEROUS, "the right one's samples")
            for sim, count, spin in ((left, 1, 1.0), (right, 3, 2.0)):
                samples = sim.samples
                assert [s.index for s in samples] == list(range(count))
                assert np.array_equal(samples[0].angular_velocity, [0.0, spin, 0.0])
                truth = sim.truth([s.t for s in samples])
                rates = [s.angular_velocity for s in samples]
                assert np.array_equal(rates, truth.angular_velocity)
    finally:
        claim.release()


def test_a_node_in_another_namespace_is_refused_with_the_fix():
    with simulator(scene='dzhanibekov') as sim:
        node = rclpy.create_node('elsewhere', context=sim.context, namespace='robot')
        node.create_subscription(QuaternionStamped, 'attitude', lambda m: None, RELIABLE)
        with pytest.raises(
            ValueError,
            match='subscribes to /robot/attitude, the simulator publishes /attitude: '
            r"the subscription can never match; .*namespace=sim.namespace \('/'\)",
        ):
            sim.add_node(node)
        node.destroy_node()


def test_a_node_of_another_context_is_refused_with_the_fix():
    with simulator(scene='dzhanibekov', namespace='left') as sim:
        context = rclpy.Context()
        rclpy.init(context=context, domain_id=sim.domain_id)
        try:
            node = rclpy.create_node('stranger', context=context)
            with pytest.raises(
                ValueError,
                match='another context; create it with context=sim.context and '
                r"namespace=sim.namespace \('/left'\)",
            ):
                sim.add_node(node)
            node.destroy_node()
        finally:
            context.try_shutdown()


# -- clear timeouts -------------------------------------------------------------------------------
# A wait the test expects to time out gets a short timeout of its own; every other wait keeps the
# kit's default (DEFAULT_TIMEOUT, generous).
EXPECTED_TIMEOUT = 1.0


def test_a_subscriber_that_cannot_match_gets_a_timeout_naming_it_and_why():
    with simulator(scene='dzhanibekov') as sim:
        node = sim.create_node('deaf')
        qos = QoSProfile(
            depth=10,
            reliability=ReliabilityPolicy.RELIABLE,
            durability=DurabilityPolicy.TRANSIENT_LOCAL,
        )
        node.create_subscription(Vector3Stamped, 'angular_velocity', lambda m: None, qos)
        with pytest.raises(SimulatorTimeout) as error:
            sim.advance(1, timeout=EXPECTED_TIMEOUT)
        text = str(error.value)
        topic = sim.node.resolve_topic_name('angular_velocity')
        assert node.get_fully_qualified_name() in text and topic in text, text
        assert 'volatile publisher and transient local subscription' in text.lower(), text


def test_a_node_that_never_answers_gets_a_timeout_naming_the_topic():
    with simulator(scene='dzhanibekov') as sim:
        sim.create_node('mute')  # expected to publish an estimate, never does
        estimates = sim.tap('attitude_estimate', QuaternionStamped)
        sim.advance(3)
        with pytest.raises(
            SimulatorTimeout,
            match='/attitude_estimate .*0 of 1 messages.*publishers on the topic: none',
        ):
            estimates.wait(1, timeout=EXPECTED_TIMEOUT)


def test_a_controller_that_never_answers_in_lockstep_gets_a_timeout_naming_the_command_topic():
    # lockstep_timeout: the node's own wait for the answer, which the test expects to run out
    with simulator(scene='detumble', lockstep_timeout=0.3) as sim:
        sim.advance(1)  # sample 0 needs no answer
        with pytest.raises(
            SimulatorTimeout,
            match="without the controller's answer to sample 0.*"
            '/torque_command.*lockstep=False',
        ):
            sim.advance(1)


# -- teardown -------------------------------------------------------------------------------------
def _native_threads() -> set:
    """Return the process's native threads (DDS's included, not only Python's) by kernel id."""
    return {int(task) for task in os.listdir('/proc/self/task')}


def _thread_names(threads) -> list:
    names = []
    for task in sorted(threads):
        try:
            names.append(Path(f'/proc/self/task/{task}/comm').read_text().strip())
        except OSError:  # ended meanwhile
            pass
    return names


def _left_by_a_bare_context(domain_id: int) -> int:
    """
    Count the native threads that outlive a bare rclpy context: the runtime's own.

    One context with one node (one DDS participant, as the kit's), started and shut down beside
    the same contexts as the simulator will be; a thread born meanwhile that is still there after
    is the runtime's. (Seen with rmw_fastrtps on Jazzy: with no other context alive, the last one
    to shut down leaves a thread until the next one starts; beside a live one, none.)
    """
    before = _native_threads()
    context = rclpy.Context()
    rclpy.init(context=context, domain_id=domain_id)
    rclpy.create_node('bare', context=context).destroy_node()
    context.try_shutdown()
    return len(_native_threads() - before)


def _holds_lock(path: str) -> bool:
    """Whether this process holds a lock on the file ``path`` (``/proc/locks``)."""
    inode = os.stat(path).st_ino
    for line in Path('/proc/locks').read_text().splitlines():
        # '1: FLOCK  ADVISORY  WRITE PID MAJ:MIN:INODE 0 EOF' ('1: -> FLOCK ...' for a waiter)
        fields = line.split()
        if 'FLOCK' in fields:
            at = fields.index('FLOCK')
            pid, device_inode = fields[at + 3], fields[at + 4]
            if pid == str(os.getpid()) and device_inode.rsplit(':', 1)[-1] == str(inode):
                return True
    return False


def test_teardown_leaves_no_thread_context_node_participant_or_domain_claim_behind():
    """
    Teardown leaves no thread, context, node, participant or domain claim behind.

    Threads are judged by what the simulator started: those born while it ran that are still
    there after it closed. The runtime may keep a few past any context's shutdown, which a bare
    context shows (:func:`_left_by_a_bare_context`); the simulator may leave no more than that.
    Threads started by others, or after, do not count.
    """
    from torquefree_ros.testing.domains import claim_domain

    # DDS's process-wide threads start with the first participant; a simulator claims its domain
    with simulator(scene='dzhanibekov') as warm:
        warm.advance(1)
        lock = os.path.join(tempfile.gettempdir(), f'torquefree_ros_domain_{warm.domain_id}.lock')
        assert _holds_lock(lock)  # else the check below could not fail
    assert not _holds_lock(lock), 'the domain claim outlived the simulator'
    # a participant of our own watches the graph of a domain claimed for the simulator; made
    # first, its threads are not the simulator's
    claim, probe_context = claim_domain(), rclpy.Context()
    rclpy.init(context=probe_context, domain_id=claim.domain_id)
    probe = rclpy.create_node('probe', context=probe_context)
    try:
        runtime = _left_by_a_bare_context(claim.domain_id)
        python_before, native_before = set(threading.enumerate()), _native_threads()
        with simulator(scene='estimator', domain_id=claim.domain_id) as sim:
            user = sim.create_node('user')
            user.create_subscription(Imu, 'imu', lambda m: None, RELIABLE)
            sim.advance(3)
            nodes, context = [sim.node, user, sim._kit], sim.context
            names = {node.get_fully_qualified_name() for node in nodes}
            _spin_until(
                probe, probe_context, lambda: names <= _graph(probe), 'the probe never saw them'
            )
            python = set(threading.enumerate()) - python_before  # the sample loop's
            native = _native_threads() - native_before  # its participant's, the loop's, ...
            # else the checks below could not fail
            assert python and len(native) > runtime, (python, _thread_names(native), runtime)
        assert not context.ok()
        for node in nodes:
            with pytest.raises(InvalidHandle):
                with node.handle:
                    pass
        assert not python & set(threading.enumerate()), 'Python threads left behind'

        def ended() -> bool:
            return len(native & _native_threads()) <= runtime and not names & _graph(probe)

        _spin_until(
            probe,
            probe_context,
            ended,
            lambda: (
                f'left behind: native threads {_thread_names(native & _native_threads())} '
                f'(the runtime keeps {runtime}), nodes in the graph {names & _graph(probe)}'
            ),
        )
    finally:
        probe.destroy_node()
        probe_context.try_shutdown()
        claim.release()


def _graph(node) -> set:
    """Return the nodes in the graph ``node`` sees, by their full names."""
    graph = node.get_node_names_and_namespaces()
    return {f'{namespace.rstrip("/")}/{name}' for name, namespace in graph}


def _spin_until(node, context, condition, what) -> None:
    """
    Spin ``node`` until ``condition()`` holds: a wait that must succeed (GENEROUS s at most).

    The graph updates on DDS's threads; each spin waits for it a little.
    """
    from rclpy.executors import SingleThreadedExecutor

    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    try:
        deadline = time.monotonic() + GENEROUS
        while not condition():
            assert time.monotonic() < deadline, what() if callable(what) else what
            executor.spin_once(timeout_sec=0.1)
    finally:
        executor.remove_node(node)
        executor.shutdown()


# -- the fixture's parameters, resets -------------------------------------------------------------
@pytest.mark.torquefree_sim(scene='dzhanibekov', publish_rate=50.0)
def test_the_marker_sets_the_fixture_s_parameters(torquefree_sim):
    assert torquefree_sim.publish_rate == 50.0
    assert 'dzhanibekov' in torquefree_sim.node.stepping.state().request.configuration
    assert [s.t for s in torquefree_sim.advance(2)] == [0.0, 1 / 50.0]


@pytest.mark.parametrize(
    'torquefree_sim', ['explorer1', {'scene': 'dzhanibekov', 'publish_rate': 20.0}], indirect=True
)
def test_indirect_parametrization_sets_the_fixture_s_parameters(torquefree_sim):
    configuration = torquefree_sim.node.stepping.state().request.configuration
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
        assert 'angular_velocity [0, 1, 0]' in summary  # the summary names the value set
        after = sim.advance(2)
        assert [s.index for s in after] == [0, 1] and after[0].stamp_ns > before[-1].stamp_ns
        assert np.array_equal(after[0].angular_velocity, [0.0, 1.0, 0.0])
