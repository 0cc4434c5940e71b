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
In-process harness for the simulator node.

A client node beside the node under test that subscribes, sets parameters and calls ``~/reset``
like any other participant, on the public test kit (``torquefree_ros.testing.Simulator``, which
owns the private context, the namespace, the executor and the teardown). The node paces itself here
(``stepped=False``): these tests are about its pacing, resets and pauses as the world sees them.
Everything is driven by spinning the kit's executor until a condition holds (no sleeps).
"""

from __future__ import annotations

import contextlib
import os
import re
import tempfile

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import QuaternionStamped, Vector3Stamped
import numpy as np
from rclpy.parameter import Parameter, parameter_value_to_python
from rclpy.parameter_client import AsyncParameterClient
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from rosgraph_msgs.msg import Clock
from std_srvs.srv import Trigger
from torquefree_ros.testing import Simulator, stamp_ns  # stamp_ns: the tests import it from here

SPIN_TIMEOUT = 20.0  # s; generous for a loaded 2-core CI machine


def reset_epoch_ns(response) -> int:
    """Return the stamp of sample 0 of the run a reset started, as its summary states it."""
    match = re.search(r'first stamp (\d+)\.(\d{9}) s', response.message)
    assert match, response.message
    return int(match[1]) * 1_000_000_000 + int(match[2])


@contextlib.contextmanager
def connected_harness(**parameters):
    """Yield a started, connected harness, closed on exit (the body of the tests' fixtures)."""
    harness = SimHarness(**parameters)
    try:
        harness.wait_connected()
        yield harness
    finally:
        harness.close()


class SimHarness:
    """
    A client of the simulator node under test, in a namespace of its own.

    So harnesses alive at the same time (a module-scoped one beside a test's own) never receive
    each other's samples.
    """

    _count = 0

    def __init__(self, args=None, namespace=None, **parameters):
        SimHarness._count += 1
        self.namespace = f'harness{SimHarness._count}' if namespace is None else namespace
        # the tests write scene files under the temporary directory: let the node read them
        if args is None:  # (a parameter file given in args sets its own)
            parameters.setdefault('scene_directories', [tempfile.gettempdir()])
        # the session's domain (conftest.py): some tests talk to nodes they start as processes
        domain = os.environ.get('ROS_DOMAIN_ID')
        self.sim = Simulator(
            stepped=False,
            namespace=self.namespace,
            args=args,
            timeout=SPIN_TIMEOUT,
            domain_id=int(domain) if domain else None,
            **parameters,
        )
        self.context, self.executor, self.node = self.sim.context, self.sim.executor, self.sim.node
        try:
            self.client = self.sim.create_node('test_client')
        except BaseException:
            self.sim.close()
            raise
        self.omega: dict[int, np.ndarray] = {}
        self.q: dict[int, np.ndarray] = {}
        self.arrivals: list[int] = []  # angular_velocity stamps in order of arrival
        self.complete: list[int] = []  # stamps received on both topics, in order of completion
        self.frames: set[tuple[str, str]] = set()
        self.clock: list[int] = []
        self.diagnostics: list[DiagnosticArray] = []
        qos = QoSProfile(
            history=HistoryPolicy.KEEP_LAST, depth=10000, reliability=ReliabilityPolicy.RELIABLE
        )
        self.client.create_subscription(Vector3Stamped, 'angular_velocity', self._on_omega, qos)
        self.client.create_subscription(QuaternionStamped, 'attitude', self._on_q, qos)
        self.client.create_subscription(
            Clock, '/clock', lambda m: self.clock.append(stamp_ns(m.clock)), qos
        )
        self.client.create_subscription(
            DiagnosticArray, '/diagnostics', self.diagnostics.append, 10
        )
        node_name = self.node.get_fully_qualified_name()
        self.parameters = AsyncParameterClient(self.client, node_name)
        self.reset_client = self.client.create_client(Trigger, f'{node_name}/reset')

    def _on_omega(self, message: Vector3Stamped) -> None:
        v = message.vector
        stamp = stamp_ns(message.header.stamp)
        self.omega[stamp] = np.array([v.x, v.y, v.z])
        self.arrivals.append(stamp)
        if stamp in self.q:
            self.complete.append(stamp)
        self.frames.add(('angular_velocity', message.header.frame_id))

    def _on_q(self, message: QuaternionStamped) -> None:
        q = message.quaternion
        stamp = stamp_ns(message.header.stamp)
        self.q[stamp] = np.array([q.x, q.y, q.z, q.w])
        if stamp in self.omega:
            self.complete.append(stamp)
        self.frames.add(('attitude', message.header.frame_id))

    # -- driving ----------------------------------------------------------------------------------
    def spin_until(self, condition, timeout: float = SPIN_TIMEOUT, what: str = 'condition'):
        self.sim.spin_until(condition, timeout, f'waiting for {what}')

    def wait_future(self, future, what: str):
        self.spin_until(future.done, what=what)
        return future.result()

    def pairs(self) -> list[tuple[int, np.ndarray, np.ndarray]]:
        """``(stamp_ns, w, q)`` for every stamp received on both topics, in stamp order."""
        return [(s, self.omega[s], self.q[s]) for s in sorted(self.omega.keys() & self.q.keys())]

    def wait_samples(self, count: int, after: int | None = None):
        """Wait for ``count`` complete samples with stamps after ``after``; return them."""
        counted, found = 0, 0

        def enough() -> bool:
            # only the samples completed since the last check: the check runs after every
            # callback, and a paced node sends thousands a second
            nonlocal counted, found
            new = self.complete[counted:]
            counted += len(new)
            found += sum(1 for stamp in new if after is None or stamp > after)
            return found >= count

        self.spin_until(enough, what=f'{count} samples')
        return [p for p in self.pairs() if after is None or p[0] > after]

    def wait_connected(self):
        """Until the node's publishers see the test subscriptions (samples from then on arrive)."""
        outputs = self.node._outputs
        self.spin_until(
            lambda: (
                outputs.angular_velocity.get_subscription_count() > 0
                and outputs.attitude.get_subscription_count() > 0
            ),
            what='discovery',
        )
        self.spin_until(self.reset_client.service_is_ready, what='the reset service')
        self.spin_until(
            lambda: self.parameters.services_are_ready(), what='the parameter services'
        )

    def set_parameters(self, **values):
        params = [Parameter(name, value=value) for name, value in values.items()]
        return self.wait_future(self.parameters.set_parameters(params), 'set_parameters').results

    def set_parameters_atomically(self, **values):
        params = [Parameter(name, value=value) for name, value in values.items()]
        return self.wait_future(
            self.parameters.set_parameters_atomically(params), 'atomic set'
        ).result

    def get_parameter(self, name: str):
        values = self.wait_future(self.parameters.get_parameters([name]), 'get_parameters').values
        return parameter_value_to_python(values[0])

    def reset(self):
        return self.wait_future(self.reset_client.call_async(Trigger.Request()), '~/reset')

    def close(self):
        self.sim.close()  # the client too
