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
``SingleThreadedExecutor`` spun only in the caller's thread, the ``torquefree_sim`` node (in the
root namespace unless the test names one) and a small node of the kit's (``torquefree_test_kit``)
that records what the simulator publishes (:attr:`Simulator.samples`) and holds the taps. Nothing
waits on the wall clock: every wait spins the executor until a condition holds, with a timeout that
names what did not happen.

This module is the simulator's life (start, nodes, stepping, spinning, teardown); the rest of the
kit: :mod:`.delivery` (what the watched subscriptions processed), :mod:`.failures` (what a failure
says), :mod:`.truth` (the run followed: samples, truth, reset) and :mod:`.samples` (the values
handed out). The node is stepped and followed through its one interface for it,
``TorqueFreeSim.stepping`` (:class:`torquefree_ros.ros.sample_loop.Stepping`).
"""

from __future__ import annotations

import contextlib
import time
from typing import Callable, Iterator

from . import failures
from .delivery import Delivery
from .failures import SimulatorTimeout
from .samples import Sample, State
from .truth import Run

__all__ = ['DEFAULT_TIMEOUT', 'Simulator', 'Tap', 'simulator']

#: seconds a single wait may take before it fails (generous: CI machines are shared and noisy)
DEFAULT_TIMEOUT = 20.0
KIT_NODE = 'torquefree_test_kit'


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
        kit = self._simulator._kit
        self._simulator.spin_until(
            lambda: len(self.messages) >= count,
            timeout,
            lambda: failures.tap_short(self, count, kit.get_publishers_info_by_topic(self.topic)),
        )
        return self.messages


class Simulator:
    """
    ``torquefree_sim`` in a private context, stepped by the caller. Use :func:`simulator`.

    ``scene`` and ``parameters`` are the node's parameters (``scene``, ``publish_rate``,
    ``angular_velocity``, ...). Stepped (the default), the node runs on its own clock from 0
    (``real_time_factor`` 0) and in lock-step (a scene taking commands, ``torque_command`` or
    commanded ``reaction_wheels``, waits for the controller's answer to each sample), unless
    ``parameters`` say otherwise, and a sample goes out only when :meth:`advance` lets it.
    ``stepped=False``: the node paces itself as it would anywhere (no :meth:`advance`, no
    :attr:`samples`; the project's own tests of pacing use it).

    ``namespace``: default none (the root): the simulator's domain is its own, so its topics are
    ``/angular_velocity``, ``/attitude``, ... and a node made without a namespace finds them; name
    one to run several simulators in one domain. :attr:`namespace` is the node's, absolute (``/``
    by default). ``domain_id``: default a free one claimed for this simulator alone
    (:mod:`.domains`); ``timeout``: seconds any single wait may take (:data:`DEFAULT_TIMEOUT`);
    ``args``: ROS command-line arguments for the context (``["--ros-args", "--params-file",
    FILE]``). Raises ``torquefree_ros.ros.parameters.ConfigurationError`` for unusable start-up
    parameters, leaving nothing behind.
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
        self.stepped = stepped
        self.timeout = float(timeout)
        self._claim = claim_domain() if domain_id is None else None
        self.domain_id = self._claim.domain_id if domain_id is None else int(domain_id)
        self._closed = False
        self._added: list = []  # the caller's nodes, in order added
        self._taps: list[Tap] = []
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
        #: the simulator node's namespace, absolute: ``/`` unless ``namespace`` named one
        self.namespace = self.node.get_namespace()
        self._stepping = self.node.stepping
        self.executor.add_node(self.node)
        self._run = Run(self.node, self.spin_until)
        self._delivery = Delivery(self._publisher, self.spin_until)
        # the kit's own node, made when first needed (stepped: at once, to record)
        self._kit_node = None
        try:
            if stepped:
                self._run.record(self._kit)
            self._follow(force=True)
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
        simulator destroys it on exit. A node from another context, or one with a subscription
        named like a simulator's topic that resolves elsewhere (a relative name in another
        namespace: it can never match), is refused with ``ValueError`` naming the fix.
        """
        if node.context is not self.context:
            raise ValueError(failures.other_context(node, self.namespace))
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
        return self._run.next

    @property
    def t(self) -> float:
        """Return the time (s since the run's start) of the last sample out, or 0 before any."""
        return max(self._run.next - 1, 0) / self._run.simulation.rate

    @property
    def publish_rate(self) -> float:
        return self._run.simulation.rate

    @property
    def samples(self) -> list[Sample]:
        """Return the current run's samples, as the kit's recorder received them."""
        return self._run.samples

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
        self._follow()
        run, k = self._run, self._run.next
        simulation = run.simulation
        stamp = simulation.stamp_ns(k)
        expected = self._stepping.topics(k)
        nodes = [node for node in (self._kit_node, *self._added) if node is not None]
        watched = self._delivery.watched(nodes, expected)
        self._delivery.wait_matched(watched, timeout)
        missed = self._stepping.state().missed_steps
        self._stepping.let_out(1)
        try:
            self.spin_until(
                lambda: not self._delivery.pending(watched, expected, stamp),
                timeout,
                lambda: failures.not_processed(
                    k,
                    stamp,
                    simulation,
                    self._stepping.state(),
                    self._delivery.pending(watched, expected, stamp),
                    self.node.resolve_topic_name,
                    self._delivery.qos_problem,
                ),
                check=self._check_loop,
            )
        except BaseException:
            self._stepping.hold()  # if it did not go out, it must not later, unasked
            state = self._stepping.state()
            if state.simulation is simulation and state.sent > k:
                run.next = state.sent  # it went out (a subscriber did not process it)
            raise
        state = self._stepping.state()
        if state.missed_steps != missed:
            raise SimulatorTimeout(
                failures.missed_answer(k, simulation, state, self.node.resolve_topic_name)
            )
        run.next = k + 1
        sample = run.samples[-1]
        if sample.index != k:  # the recorder is watched: its sample k is complete by now
            raise AssertionError(f'advance: the kit recorded sample {sample.index}, expected {k}')
        return sample

    def _check_loop(self) -> None:
        """Fail at once, not at the timeout, when the simulator cannot publish at all."""
        problem = failures.loop_problem(self._stepping.state(), self._run.simulation)
        if problem:
            raise RuntimeError(problem)

    def _publisher(self, topic: str):
        """Return the node's publisher of a resolved topic, or None when it has none."""
        for publisher in self.node.publishers:
            if publisher.topic_name == topic:
                return publisher
        return None

    # -- truth, samples, reset -------------------------------------------------------------------
    def truth(self, t) -> State:
        """
        Return the exact state at ``t`` (s since the run's start; a number or a sorted array).

        It comes from a fresh propagator of the same scene and parameters: the exact solution, or
        the scene's propagator at its accuracy when an effect changes the motion (the node's
        samples are its values at ``k / rate``, bit for bit). A scene that takes commands (torque
        or wheel commands) has no truth without them: compare with :attr:`samples` instead.
        """
        self._follow()
        return self._run.truth(t)

    def time_of(self, stamp) -> float:
        """
        Return the time (s since the run's start) of a stamp.

        The stamp is a ``builtin_interfaces/Time`` or integer ns; for a sample's stamp the time is
        exactly its ``k / publish_rate``, the time :meth:`truth` wants.
        """
        self._follow()
        return self._run.time_of(stamp)

    def reset(self, **parameters) -> str:
        """
        Set ``parameters`` (atomically, with the node's checks) and call ``~/reset``.

        The run restarts at ``t = 0`` and :attr:`samples` start over. Returns the service's
        summary; raises ``ValueError`` with the reason when a value or the reset is refused (the
        running simulation then goes on unchanged; values accepted stay set, as through the
        parameter service).
        """
        summary = self._run.reset(self._kit, parameters)
        self._follow(force=True)
        return summary

    def _follow(self, force: bool = False) -> None:
        """Take up the node's running simulation when it is new (or ``force``)."""
        if self._run.follow(force):
            self._delivery.forget_matches()  # a reset may have made new output publishers

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
        stepping = getattr(self, '_stepping', None)
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
        if stepping is not None and stepping.state().running:
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
    def _check_names(self, node) -> None:
        """
        Refuse a node whose subscription to a simulator's topic resolves elsewhere.

        A relative name, resolved in the node's own namespace, that is named like the simulator's
        topic but is not it can never match: say so now rather than at the first timeout.
        """
        ours = {name.rsplit('/', 1)[-1]: name for name in self._stepping.topics(0)}
        own = node.get_namespace().rstrip('/')
        for subscription in node.subscriptions:
            name = subscription.topic_name
            base = name.rsplit('/', 1)[-1]
            # a relative name, elsewhere
            if base in ours and name != ours[base] and name == f'{own}/{base}':
                raise ValueError(failures.elsewhere(node, name, ours[base], self.namespace))


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
