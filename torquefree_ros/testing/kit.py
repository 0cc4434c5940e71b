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
The simulator node in process, stepped by the test: :func:`simulator` and :class:`Simulator`.

One simulator is one private rclpy context (in a ROS domain of its own, :mod:`.domains`), one
``SingleThreadedExecutor`` spun only in the caller's thread, the ``torquefree_sim`` node in a
namespace of its own, and a small node of the kit's (``torquefree_test_kit``) that records what the
simulator publishes (:attr:`Simulator.samples`) and holds the taps. Nothing waits on the wall
clock: every wait spins the executor until a condition holds, with a timeout that names what did
not happen.
"""

from __future__ import annotations

import contextlib
from dataclasses import dataclass
import inspect
import itertools
import os
import time
from typing import Any, Callable, Iterator

import numpy as np

#: seconds a single wait may take before it fails (generous: CI machines are shared and noisy)
DEFAULT_TIMEOUT = 20.0
_NAMESPACES = itertools.count(1)
KIT_NODE = 'torquefree_test_kit'


class SimulatorTimeout(TimeoutError):
    """
    A wait of the kit's did not end within its timeout.

    The message names what did not arrive.
    """


@dataclass(frozen=True)
class Sample:
    """One sample the simulator published, as the kit's subscriber received it."""

    index: int  # k, since the run's (re)start
    t: float  # k / publish_rate, s since the run's (re)start
    stamp_ns: int  # header.stamp: the run's epoch + t
    angular_velocity: np.ndarray  # (3,) rad/s, body frame
    attitude: np.ndarray  # (4,) q_NB (x, y, z, w)


@dataclass(frozen=True)
class State:
    """
    The exact state at ``t`` (s since the run's start).

    Arrays of states when ``t`` is an array.
    """

    t: Any
    angular_velocity: np.ndarray  # (3,) or (N, 3)
    attitude: np.ndarray  # (4,) or (N, 4)


def stamp_ns(stamp) -> int:
    """Return a ``builtin_interfaces/Time`` in integer nanoseconds."""
    return stamp.sec * 1_000_000_000 + stamp.nanosec


def message_stamp_ns(message) -> int | None:
    """
    Return the stamp a message of the simulator's carries (ns), or None when it has none.

    Its header's, ``/clock``'s time, the first transform's or marker's.
    """
    header = getattr(message, 'header', None)
    if header is not None:
        return stamp_ns(header.stamp)
    clock = getattr(message, 'clock', None)
    if clock is not None:
        return stamp_ns(clock)
    for field in ('transforms', 'markers'):
        items = getattr(message, field, None)
        if items:
            return stamp_ns(items[0].header.stamp)
    return None


class Tap:
    """
    What is published on one topic, in order of arrival (:attr:`messages`).

    :meth:`wait` for more.
    """

    def __init__(self, simulator: 'Simulator', topic: str, message_type, qos):
        self._simulator = simulator
        self.message_type = message_type
        self.messages: list = []
        self.subscription = simulator._kit.create_subscription(
            message_type, topic, self.messages.append, qos
        )
        self.topic = self.subscription.topic_name

    def wait(self, count: int, timeout: float | None = None) -> list:
        """
        Spin until ``count`` messages in all have arrived; return them all.

        On timeout the error names the topic, how many came and who publishes it (none: the node
        never answered).
        """

        def missing() -> str:
            publishers = self._simulator._kit.get_publishers_info_by_topic(self.topic)
            who = (
                ', '.join(
                    sorted({f'{p.node_namespace.rstrip("/")}/{p.node_name}' for p in publishers})
                )
                or 'none'
            )
            return (
                f'tap on {self.topic} ({_type_name(self.message_type)}): '
                f'{len(self.messages)} of {count} messages arrived; publishers on the topic: {who}'
            )

        self._simulator.spin_until(lambda: len(self.messages) >= count, timeout, missing)
        return self.messages


class _Watch:
    """
    What a watched subscription's callbacks have processed.

    They returned for ``count`` messages, the last of them stamped ``latest`` (ns).
    """

    def __init__(self):
        self.count = 0
        self.latest: int | None = None

    def note(self, message, raw_type) -> None:
        if raw_type is not None:  # a raw subscription gets bytes
            from rclpy.serialization import deserialize_message

            message = deserialize_message(message, raw_type)
        stamp = message_stamp_ns(message)
        self.count += 1
        if stamp is not None and (self.latest is None or stamp > self.latest):
            self.latest = stamp


class Simulator:
    """
    ``torquefree_sim`` in a private context, stepped by the caller. Use :func:`simulator`.

    ``scene`` and ``parameters`` are the node's parameters (``scene``, ``publish_rate``,
    ``angular_velocity``, ...). Stepped (the default), the node runs on its own clock from 0
    (``real_time_factor`` 0) and in lock-step (a scene with ``torque_command`` waits for the
    controller's answer to each sample), unless ``parameters`` say otherwise, and a sample goes out
    only when :meth:`advance` lets it. ``stepped=False``: the node paces itself as it would
    anywhere (no :meth:`advance`, no :attr:`samples`; the project's own tests of pacing use it).

    ``namespace``: default ``torquefree_test_<n>`` (with the pytest-xdist worker's name);
    ``domain_id``: default a free one claimed for this simulator alone (:mod:`.domains`);
    ``timeout``: seconds any single wait may take (:data:`DEFAULT_TIMEOUT`); ``args``: ROS
    command-line arguments for the context (``["--ros-args", "--params-file", FILE]``). Raises
    ``torquefree_ros.ros.parameters.ConfigurationError`` for unusable start-up parameters, leaving
    nothing behind.
    """

    def __init__(
        self,
        scene: str | None = None,
        *,
        namespace: str | None = None,
        domain_id: int | None = None,
        stepped: bool = True,
        timeout: float = DEFAULT_TIMEOUT,
        args: list[str] | None = None,
        node_name: str = 'torquefree',
        **parameters,
    ):
        import rclpy
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.parameter import Parameter

        from .domains import claim_domain, keep_discovery_local
        from ..ros.node import TorqueFreeSim

        if scene is not None:
            parameters['scene'] = scene
        if stepped:
            parameters.setdefault('real_time_factor', 0.0)
            parameters.setdefault('lockstep', True)
        if namespace is None:
            worker = os.environ.get('PYTEST_XDIST_WORKER', '')
            namespace = f'torquefree_test_{worker + "_" if worker else ""}{next(_NAMESPACES)}'
        self.namespace = namespace
        self.stepped = stepped
        self.timeout = float(timeout)
        self._claim = claim_domain() if domain_id is None else None
        self.domain_id = self._claim.domain_id if domain_id is None else int(domain_id)
        self._closed = False
        self._added: list = []  # the caller's nodes, in order added
        self._watches: dict[int, tuple] = {}  # id(subscription) -> (node, subscription, _Watch)
        self._matched: set[int] = set()  # ids of watched subscriptions the publisher has matched
        self._taps: list[Tap] = []
        self.samples: list[Sample] = []
        self._simulation = None  # the node's run the kit follows (_sync)
        self._truth = None  # its fresh propagator, built when first asked for (truth)
        self._halves: dict[int, dict] = {}  # stamp -> the sample's messages received so far
        self._reset_client = None
        keep_discovery_local()
        self.context = rclpy.Context()
        try:
            rclpy.init(args=args, context=self.context, domain_id=self.domain_id)
            self.executor = SingleThreadedExecutor(context=self.context)
            overrides = [Parameter(name, value=value) for name, value in parameters.items()]
            self.node = TorqueFreeSim(
                node_name,
                context=self.context,
                namespace=namespace,
                parameter_overrides=overrides,
                stepped=stepped,
            )
        except BaseException:
            self.context.try_shutdown()
            self._release_domain()
            raise
        self.executor.add_node(self.node)
        # the kit's own node, made when first needed (stepped: at once, to record)
        self._kit_node = None
        try:
            if stepped:
                self._record()
            self._sync(force=True)
        except BaseException:
            self.close()
            raise

    @property
    def _kit(self):
        if self._kit_node is None:
            import rclpy

            self._kit_node = rclpy.create_node(
                KIT_NODE, context=self.context, namespace=self.namespace
            )
            self.executor.add_node(self._kit_node)
        return self._kit_node

    # -- the caller's nodes ----------------------------------------------------------------------
    def add_node(self, node) -> None:
        """
        Spin ``node`` with the simulator (same context, same executor, the caller's thread).

        From now on :meth:`advance` waits for its subscriptions to the simulator's topics. The
        simulator destroys it on exit.
        """
        if node.context is not self.context:
            raise ValueError(
                f"add_node: node '{node.get_name()}' belongs to another context; create it with "
                'context=sim.context (and namespace=sim.namespace, to subscribe with relative '
                'names)'
            )
        self._check_names(node)
        self._added.append(node)
        self.executor.add_node(node)

    def create_node(self, name: str, **options):
        """
        Create a node (``rclpy.create_node``) in the simulator's context and namespace.

        The node is added (:meth:`add_node`).
        """
        import rclpy

        options.setdefault('namespace', self.namespace)
        node = rclpy.create_node(name, context=self.context, **options)
        self.add_node(node)
        return node

    def tap(self, topic: str, message_type, qos=None) -> Tap:
        """
        Collect what is published on ``topic``.

        Relative names resolve in the simulator's namespace; the subscription is reliable
        keep-last 1000 unless ``qos`` is given.
        """
        from rclpy.qos import QoSProfile, ReliabilityPolicy

        tap = Tap(
            self,
            topic,
            message_type,
            qos or QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE),
        )
        self._taps.append(tap)
        return tap

    # -- stepping --------------------------------------------------------------------------------
    @property
    def k(self) -> int:
        """Return the index of the next sample :meth:`advance` lets out."""
        return self._next

    @property
    def t(self) -> float:
        """Return the time (s since the run's start) of the last sample out, or 0 before any."""
        return max(self._next - 1, 0) / self._simulation.rate

    @property
    def publish_rate(self) -> float:
        return self._simulation.rate

    def advance(self, n: int = 1, timeout: float | None = None) -> list[Sample]:
        """
        Publish the next ``n`` samples, one at a time, and return them.

        They are returned as :attr:`samples` has them.

        A sample counts as processed, and the next goes out, once every subscription of every node
        added (and of the kit's recorder) to a topic the sample went out on has had its callback
        return for that sample's message or a later one (delivery is reliable and in order, so
        every earlier message of the topic has been taken too, unless the subscription's own
        keep-last depth dropped it). The executor is spun in this thread meanwhile, so the
        callbacks and whatever else is ready (timers, services, the simulator's command input) run
        here too. A slow callback therefore only makes ``advance`` slower. Each sample may take
        ``timeout`` s (default: the simulator's): then
        :class:`SimulatorTimeout` names each subscription that has not processed it and why it may
        not have (an incompatible QoS, no match), or why the simulator did not publish it.
        """
        if not self.stepped:
            raise RuntimeError('advance: this simulator paces itself (stepped=False)')
        if n < 0:
            raise ValueError(f'advance: n must be >= 0, got {n}')
        out = []
        for _ in range(n):
            out.append(self._advance_one(self.timeout if timeout is None else timeout))
        return out

    def _advance_one(self, timeout: float) -> Sample:
        self._sync()
        loop, k = self.node.sample_loop, self._next
        stamp = self._simulation.stamp_ns(k)
        expected = self._topics_of(k)
        watched = self._watched(expected)
        self._wait_matched(watched, timeout)
        missed = loop.missed_steps
        loop.step(1)
        try:
            self.spin_until(
                lambda: self._processed(watched, expected, stamp),
                timeout,
                lambda: self._not_processed(k, stamp, watched, expected),
                check=self._check_loop,
            )
        except BaseException:
            loop.step(-1)  # if it did not go out, it must not later, unasked
            last = loop.last
            if last is not None and last.simulation is self._simulation and last.index >= k:
                self._next = last.index + 1  # it went out (a subscriber did not process it)
            raise
        if loop.missed_steps != missed:
            raise SimulatorTimeout(
                f"advance: sample {k} went out without the controller's answer to sample {k - 1}: "
                f'{self._lockstep_wait(k)}'
            )
        self._next = k + 1
        sample = self.samples[-1]
        if sample.index != k:  # the recorder is watched: its sample k is complete by now
            raise AssertionError(f'advance: the kit recorded sample {sample.index}, expected {k}')
        return sample

    def _watched(self, expected: dict) -> list:
        """
        Return (node, subscription, watch) for every subscription to a topic in ``expected``.

        The callbacks of subscriptions not seen before are wrapped.
        """
        out = []
        for node in [node for node in (self._kit_node, *self._added) if node is not None]:
            for subscription in list(node.subscriptions):
                if subscription.topic_name not in expected:
                    continue
                entry = self._watches.get(id(subscription))
                if entry is None or entry[1] is not subscription:
                    entry = (node, subscription, self._wrap(subscription))
                    self._watches[id(subscription)] = entry
                out.append(entry)
        return out

    @staticmethod
    def _wrap(subscription) -> _Watch:
        """Note each message after the subscription's callback returned for it."""
        watch, original = _Watch(), subscription.callback
        raw_type = subscription.msg_type if subscription.raw else None
        # the same kind and arity as the original: rclpy awaits a coroutine function, and passes
        # the MessageInfo to a callback that takes two arguments
        if inspect.iscoroutinefunction(original):
            if _takes_two(original):

                async def callback(message, info):
                    await original(message, info)
                    watch.note(message, raw_type)
            else:

                async def callback(message):
                    await original(message)
                    watch.note(message, raw_type)
        elif _takes_two(original):

            def callback(message, info):
                original(message, info)
                watch.note(message, raw_type)
        else:

            def callback(message):
                original(message)
                watch.note(message, raw_type)

        subscription.callback = callback
        return watch

    def _wait_matched(self, watched: list, timeout: float) -> None:
        """
        Spin until the simulator's publishers have matched the watched subscriptions.

        The publisher on each watched topic, that is: a volatile sample published before then
        would be lost to them.
        """
        fresh = [entry for entry in watched if id(entry[1]) not in self._matched]
        if not fresh:
            return
        wanted: dict[str, int] = {}
        for _, subscription, _ in watched:
            wanted[subscription.topic_name] = wanted.get(subscription.topic_name, 0) + 1

        def matched() -> bool:
            return all(
                self._publisher(topic).get_subscription_count() >= count
                for topic, count in wanted.items()
            ) and all(subscription.get_publisher_count() > 0 for _, subscription, _ in fresh)

        def unmatched() -> str:
            lines = [
                f'node {_node_name(node)}, its subscription to {subscription.topic_name}'
                f'{self._qos_problem(subscription)}'
                for node, subscription, _ in fresh
                if subscription.get_publisher_count() == 0
            ]
            return (
                "discovery: the simulator's publishers have not matched every subscription to "
                'them: '
                + ('; '.join(lines) or 'each has a publisher, but a publisher lacks a subscriber')
            )

        self.spin_until(matched, timeout, unmatched)
        self._matched.update(id(entry[1]) for entry in fresh)

    @staticmethod
    def _processed(watched: list, expected: dict, stamp: int) -> bool:
        return all(
            watch.latest is not None and watch.latest >= stamp
            for _, subscription, watch in watched
            if expected[subscription.topic_name]
        )

    def _not_processed(self, k: int, stamp: int, watched: list, expected: dict) -> str:
        loop = self.node.sample_loop
        head = (
            f'advance: sample {k} (t = {k / self._simulation.rate:g} s, stamp {_seconds(stamp)}) '
            f'of {self._simulation_name()}'
        )
        last = loop.last
        if last is None or last.simulation is not self._simulation or last.index < k:
            why = (
                f'{self._lockstep_wait(k)}'
                if loop.request.lockstep and self._simulation.command_holds and k > 0
                else 'the simulator did not publish it'
            )
            return f'{head} did not go out: {why}'
        lines = []
        for node, subscription, watch in watched:
            if not expected[subscription.topic_name] or (
                watch.latest is not None and watch.latest >= stamp
            ):
                continue
            seen = (
                f'its callback returned for {watch.count} message(s), '
                f'the last stamped {_seconds(watch.latest)}'
                if watch.count
                else 'its callback has not run for any message'
            )
            lines.append(
                f'{_node_name(node)}, subscription to {subscription.topic_name} '
                f'({_type_name(subscription.msg_type)}): {seen}{self._qos_problem(subscription)}'
            )
        return f'{head} was published but not processed: ' + '; '.join(lines)

    def _lockstep_wait(self, k: int) -> str:
        topics = ', '.join(
            self.node.resolve_topic_name(effect.topic)
            for effect, _ in self._simulation.command_holds
        )
        answer = _seconds(self._simulation.stamp_ns(k - 1))
        timeout = self.node.sample_loop.request.lockstep_timeout
        return (
            f'in lock-step it waits for a command stamped {answer} or later on {topics} '
            f'(the answer to sample {k - 1}) and none came within lockstep_timeout '
            f'({timeout:g} s); for an open loop pass lockstep=False'
        )

    def _qos_problem(self, subscription) -> str:
        from rclpy.qos import qos_check_compatible, QoSCompatibility

        try:
            publisher = self._publisher(subscription.topic_name)
        except KeyError:
            return ''
        compatibility, reason = qos_check_compatible(
            publisher.qos_profile, subscription.qos_profile
        )
        if compatibility == QoSCompatibility.ERROR:
            reason = reason.strip().removeprefix('ERROR:').strip().rstrip(';')
            return f" (its QoS cannot match the simulator's publisher: {reason})"
        return ''

    def _check_loop(self) -> None:
        """Fail at once, not at the timeout, when the simulator cannot publish at all."""
        loop = self.node.sample_loop
        if loop.failure:
            raise RuntimeError(f'the simulation stopped: {loop.failure}')
        if loop.paused:
            raise RuntimeError(
                f'the simulator is paused (at {loop.paused_at}): ~/pause false resumes it'
            )
        if loop.simulation is not self._simulation:
            raise RuntimeError(
                "the simulator was reset behind the kit's back (its ~/reset service): "
                'use sim.reset()'
            )

    # -- truth, samples, reset -------------------------------------------------------------------
    def truth(self, t) -> State:
        """
        Return the exact state at ``t`` (s since the run's start; a number or a sorted array).

        It comes from a fresh propagator of the same scene and parameters: the exact solution, or
        the scene's propagator at its accuracy when an effect changes the motion (the node's
        samples are its values at ``k / rate``, bit for bit). A scene that takes torque commands
        has no truth without them: compare with :attr:`samples` instead.
        """
        self._sync()
        if self._simulation.command_holds:
            raise ValueError(
                'truth: the scene takes torque commands; its motion depends on those the node '
                'received (compare with sim.samples)'
            )
        scalar = np.ndim(t) == 0
        times = np.atleast_1d(np.asarray(t, dtype=float))
        if self._truth is None:
            self._truth = self._fresh_propagator()
        omega, q, _ = self._truth.states(times)
        if scalar:
            return State(float(times[0]), omega[0], q[0])
        return State(times, omega, q)

    def time_of(self, stamp) -> float:
        """
        Return the time (s since the run's start) of a stamp.

        The stamp is a ``builtin_interfaces/Time`` or integer ns; for a sample's stamp the time is
        exactly its ``k / publish_rate``, the time :meth:`truth` wants.
        """
        self._sync()
        ns = stamp if isinstance(stamp, (int, np.integer)) else stamp_ns(stamp)
        k = round((ns - self._simulation.epoch_ns) * 1e-9 * self._simulation.rate)
        if self._simulation.stamp_ns(k) == ns:
            return k / self._simulation.rate
        return (ns - self._simulation.epoch_ns) * 1e-9

    def reset(self, **parameters) -> str:
        """
        Set ``parameters`` (atomically, with the node's checks) and call ``~/reset``.

        The run restarts at ``t = 0`` and :attr:`samples` start over. Returns the service's
        summary; raises ``ValueError`` with the reason when a value or the reset is refused (the
        running simulation then goes on unchanged; values accepted stay set, as through the
        parameter service).
        """
        from rclpy.parameter import Parameter
        from std_srvs.srv import Trigger

        if parameters:
            values = [Parameter(name, value=value) for name, value in parameters.items()]
            try:
                result = self.node.set_parameters_atomically(values)
            # rclpy raises for read-only ones: the same refusal
            except Exception as error:  # noqa: BLE001 - a refusal either way
                raise ValueError(f'reset: parameters refused: {error}') from None
            if not result.successful:
                raise ValueError(f'reset: parameters refused: {result.reason}')
        if self._reset_client is None:
            self._reset_client = self._kit.create_client(
                Trigger, f'{self.node.get_fully_qualified_name()}/reset'
            )
        self.spin_until(
            self._reset_client.service_is_ready, None, lambda: "the simulator's ~/reset service"
        )
        future = self._reset_client.call_async(Trigger.Request())
        self.spin_until(future.done, None, lambda: 'the answer of ~/reset')
        response = future.result()
        if not response.success:
            raise ValueError(response.message)
        self._sync(force=True)
        return response.message

    def _sync(self, force: bool = False) -> None:
        """Take up the node's running simulation: sample 0 next, samples anew, a fresh truth."""
        from ..ros.parameters import check_value, SPECS

        loop = self.node.sample_loop
        if not force and loop.simulation is self._simulation:
            return
        self._simulation = loop.simulation
        self._next = (
            loop.last.index + 1
            if (loop.last is not None and loop.last.simulation is self._simulation)
            else 0
        )
        self.samples = []
        self._halves.clear()
        self._matched.clear()  # a reset may have made new output publishers
        # the values the run was made from (they may change later, without a reset, through
        # the parameters)
        self._values = {
            spec.name: check_value(spec.name, self.node.get_parameter(spec.name)) for spec in SPECS
        }
        self._truth = None

    def _fresh_propagator(self):
        """
        Build the propagator the node's run has, anew from the same values.

        Never the running one: the sample loop's thread uses it, and an integrator keeps state.
        """
        from ..ros.parameters import run_request

        propagator = run_request(self._values).propagator
        running = self._simulation.propagator
        if not (
            np.array_equal(propagator.omega0_B, running.omega0_B)
            and np.array_equal(propagator.q0_NB, running.q0_NB)
        ):
            raise RuntimeError(
                "truth: the node's parameters changed between its last reset and the kit's first "
                'look at the run: reset it with sim.reset()'
            )
        return propagator

    def _topics_of(self, k: int) -> dict:
        """
        Map resolved topic -> whether sample ``k`` goes out on it.

        For every topic the run publishes.
        """
        from ..bag.samples import ANGULAR_VELOCITY, ATTITUDE, CLOCK

        request, resolve = self.node.sample_loop.request, self.node.resolve_topic_name
        topics = {resolve(ANGULAR_VELOCITY[0]): True, resolve(ATTITUDE[0]): True}
        if request.clock:
            topics[resolve(CLOCK[0])] = True
        for output in request.outputs:
            topics[resolve(output.topic)] = (
                k % output.every(request.publish_rate, 'publish_rate') == 0
            )
        return topics

    def _publisher(self, topic: str):
        """Return the node's publisher of a resolved topic (KeyError when it has none)."""
        for publisher in self.node.publishers:
            if publisher.topic_name == topic:
                return publisher
        raise KeyError(topic)

    def _record(self) -> None:
        from geometry_msgs.msg import QuaternionStamped, Vector3Stamped
        from rclpy.qos import QoSProfile, ReliabilityPolicy

        qos = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)
        self._kit.create_subscription(
            Vector3Stamped,
            'angular_velocity',
            lambda m: self._half(m.header.stamp, 'w', (m.vector.x, m.vector.y, m.vector.z)),
            qos,
        )
        self._kit.create_subscription(
            QuaternionStamped,
            'attitude',
            lambda m: self._half(
                m.header.stamp,
                'q',
                (m.quaternion.x, m.quaternion.y, m.quaternion.z, m.quaternion.w),
            ),
            qos,
        )

    def _half(self, stamp, key: str, values) -> None:
        ns = stamp_ns(stamp)
        parts = self._halves.setdefault(ns, {})
        parts[key] = np.array(values)
        if len(parts) == 2:
            del self._halves[ns]
            simulation = self._simulation
            k = round((ns - simulation.epoch_ns) * 1e-9 * simulation.rate)
            self.samples.append(Sample(k, k / simulation.rate, ns, parts['w'], parts['q']))

    # -- spinning --------------------------------------------------------------------------------
    def spin_until(
        self,
        condition: Callable[[], bool],
        timeout: float | None = None,
        what: str | Callable[[], str] = 'condition',
        check: Callable[[], None] | None = None,
    ) -> None:
        """
        Spin the executor in this thread until ``condition()`` holds.

        :class:`SimulatorTimeout` after ``timeout`` s (default: the simulator's), naming ``what``
        (a text, or a function giving one then). ``check()`` runs between spins and may raise to
        stop at once.
        """
        timeout = self.timeout if timeout is None else timeout
        deadline = time.monotonic() + timeout
        while not condition():
            if check is not None:
                check()
            remaining = deadline - time.monotonic()
            if remaining <= 0.0:
                text = what() if callable(what) else what
                raise SimulatorTimeout(f'timed out after {timeout:g} s: {text}')
            self.executor.spin_once(timeout_sec=min(remaining, 0.1))

    # -- teardown --------------------------------------------------------------------------------
    def close(self) -> None:
        """
        Stop the simulator and destroy every node of its context, the caller's included.

        Leaves no thread, context, participant or domain claim behind.
        """
        from rclpy.exceptions import InvalidHandle

        if self._closed:
            return
        self._closed = True
        loop = self.node.sample_loop if getattr(self, 'node', None) is not None else None
        try:
            self.executor.shutdown()
            self.node.destroy_node()  # stops and joins the sample loop's thread
            for node in (*reversed(self._added), self._kit_node):
                if node is not None:
                    # the caller may have destroyed it already
                    with contextlib.suppress(InvalidHandle):
                        node.destroy_node()
        finally:
            self.context.try_shutdown()
            self._release_domain()
        if loop is not None and loop.running:
            raise RuntimeError("the simulator's sample loop did not stop within 5 s")

    def _release_domain(self) -> None:
        if self._claim is not None:
            self._claim.release()
            self._claim = None

    def __enter__(self) -> 'Simulator':
        return self

    def __exit__(self, *exc_info) -> None:
        self.close()

    # -- helpers ---------------------------------------------------------------------------------
    def _simulation_name(self) -> str:
        return self.node.sample_loop.request.configuration

    def _check_names(self, node) -> None:
        """
        Refuse a node whose subscription to a simulator's topic resolves elsewhere.

        A subscription to a topic named like the simulator's but resolved elsewhere is a
        namespace mistake: say so now rather than at the first timeout.
        """
        ours = {name.rsplit('/', 1)[-1]: name for name in self._topics_of(0)}
        own = node.get_namespace().rstrip('/')
        for subscription in node.subscriptions:
            name = subscription.topic_name
            base = name.rsplit('/', 1)[-1]
            # a relative name, elsewhere
            if base in ours and name != ours[base] and name == f'{own}/{base}':
                raise ValueError(
                    f"add_node: node '{node.get_name()}' subscribes to {name}, "
                    f'the simulator publishes {ours[base]}: '
                    'create the node with namespace=sim.namespace '
                    f"('{self.namespace}') or subscribe to the full name"
                )


@contextlib.contextmanager
def simulator(scene: str | None = None, **options) -> Iterator[Simulator]:
    """
    Start a :class:`Simulator`, closed on exit (every node in it destroyed).

    ``with simulator(scene="dzhanibekov", publish_rate=50.0) as sim:``
    """
    sim = Simulator(scene, **options)
    try:
        yield sim
    finally:
        sim.close()


def _takes_two(function) -> bool:
    try:
        inspect.signature(function).bind(object(), object())
    except TypeError:
        return False
    try:
        inspect.signature(function).bind(object())
    except TypeError:
        return True
    return False  # both bind (a default or *args): rclpy passes the message only


def _node_name(node) -> str:
    return node.get_fully_qualified_name()


def _type_name(message_type) -> str:
    module = message_type.__module__.split('.')
    return (
        f'{module[0]}/{module[1]}/{message_type.__name__}'
        if len(module) >= 2
        else message_type.__name__
    )


def _seconds(ns: int | None) -> str:
    if ns is None:
        return '-'
    return f'{ns // 1_000_000_000}.{ns % 1_000_000_000:09d} s'
