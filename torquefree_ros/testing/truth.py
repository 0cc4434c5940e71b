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
Truth and reset: the node's run as the kit follows it.

Its samples as the kit's recorder received them (:attr:`Run.samples`), its exact truth from a fresh
propagator of the same values (:meth:`Run.truth`), the times of its stamps (:meth:`Run.time_of`),
and a reset under the node's own rules (:meth:`Run.reset`).
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from .samples import Sample, stamp_ns, State


class Run:
    """
    The run of ``node`` (a ``TorqueFreeSim``) the kit follows, from :meth:`follow` to the next.

    ``spin_until``: :meth:`~torquefree_ros.testing.Simulator.spin_until`.
    """

    def __init__(self, node, spin_until: Callable):
        self._node = node
        self._spin_until = spin_until
        self.simulation = None  # the node's simulation followed
        self.next = 0  # the index of the next sample advance lets out
        self.samples: list[Sample] = []
        self._halves: dict[int, dict] = {}  # stamp -> the sample's messages received so far
        self._values: dict = {}  # the parameter values the run was made from
        self._truth = None  # its fresh propagator, built when first asked for (truth)
        self._reset_client = None

    def follow(self, force: bool = False) -> bool:
        """
        Take up the node's running simulation, unless it is the one followed (and not ``force``).

        Then sample 0 (or the one after the last out) comes next, the samples start anew and the
        truth is built afresh. Returns whether it took it up.
        """
        from ..ros.parameters import check_value, SPECS

        state = self._node.stepping.state()
        if not force and state.simulation is self.simulation:
            return False
        self.simulation = state.simulation
        self.next = state.sent
        self.samples = []
        self._halves.clear()
        # the values the run was made from (they may change later, without a reset, through
        # the parameters)
        node = self._node
        self._values = {
            spec.name: check_value(spec.name, node.get_parameter(spec.name)) for spec in SPECS
        }
        self._truth = None
        return True

    # -- the samples, as received ----------------------------------------------------------------
    def record(self, kit_node) -> None:
        """Subscribe ``kit_node`` to the samples: each complete one joins :attr:`samples`."""
        from geometry_msgs.msg import QuaternionStamped, Vector3Stamped
        from rclpy.qos import QoSProfile, ReliabilityPolicy

        qos = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)
        kit_node.create_subscription(
            Vector3Stamped,
            'angular_velocity',
            lambda m: self._half(m.header.stamp, 'w', (m.vector.x, m.vector.y, m.vector.z)),
            qos,
        )
        kit_node.create_subscription(
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
            simulation = self.simulation
            k = round((ns - simulation.epoch_ns) * 1e-9 * simulation.rate)
            self.samples.append(Sample(k, k / simulation.rate, ns, parts['w'], parts['q']))

    # -- truth -----------------------------------------------------------------------------------
    def truth(self, t) -> State:
        """Return the exact state at ``t``: see :meth:`~torquefree_ros.testing.Simulator.truth`."""
        if self.simulation.command_holds:
            raise ValueError(
                'truth: the scene takes commands (torque commands, wheel commands); its motion '
                'depends on those the node received (compare with sim.samples)'
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
        """Return a stamp's time: see :meth:`~torquefree_ros.testing.Simulator.time_of`."""
        simulation = self.simulation
        ns = stamp if isinstance(stamp, (int, np.integer)) else stamp_ns(stamp)
        k = round((ns - simulation.epoch_ns) * 1e-9 * simulation.rate)
        if simulation.stamp_ns(k) == ns:
            return k / simulation.rate
        return (ns - simulation.epoch_ns) * 1e-9

    def _fresh_propagator(self):
        """
        Build the propagator the node's run has, anew from the same values.

        Never the running one: the sample loop's thread uses it, and an integrator keeps state.
        """
        from ..ros.parameters import run_request

        propagator = run_request(self._values).propagator
        running = self.simulation.propagator
        if not (
            np.array_equal(propagator.omega0_B, running.omega0_B)
            and np.array_equal(propagator.q0_NB, running.q0_NB)
        ):
            raise RuntimeError(
                "truth: the node's parameters changed between its last reset and the kit's first "
                'look at the run: reset it with sim.reset()'
            )
        return propagator

    # -- reset -----------------------------------------------------------------------------------
    def reset(self, kit_node, parameters: dict) -> str:
        """
        Set ``parameters`` atomically under the node's checks, then call its ``~/reset``.

        Returns the service's summary; a refusal raises ``ValueError`` with the node's reason.
        The caller then follows the new run (:meth:`follow`).
        """
        from rclpy.parameter import Parameter
        from std_srvs.srv import Trigger

        if parameters:
            values = [Parameter(name, value=value) for name, value in parameters.items()]
            try:
                result = self._node.set_parameters_atomically(values)
            # rclpy raises for read-only ones: the same refusal
            except Exception as error:  # noqa: BLE001 - a refusal either way
                raise ValueError(f'reset: parameters refused: {error}') from None
            if not result.successful:
                raise ValueError(f'reset: parameters refused: {result.reason}')
        if self._reset_client is None:
            self._reset_client = kit_node.create_client(
                Trigger, f'{self._node.get_fully_qualified_name()}/reset'
            )
        self._spin_until(
            self._reset_client.service_is_ready, None, lambda: "the simulator's ~/reset service"
        )
        future = self._reset_client.call_async(Trigger.Request())
        self._spin_until(future.done, None, lambda: 'the answer of ~/reset')
        response = future.result()
        if not response.success:
            raise ValueError(response.message)
        return response.message
