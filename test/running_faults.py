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
A command fault set on a running node through ``set_parameters``, and its two references.

The node damps a body in lock-step (:class:`Damping`, ``tau = -K w``); the fault, set between
samples ``first - 1`` and ``first``, acts from interval ``first``. References: the core's own run
(``Simulation`` with the same commands, the fault put in force at ``first`` by ``retune``), and
``torquefree_bag --commands``' replay of the recording (``write_scene_bag``).
"""

from __future__ import annotations

import json
from typing import NamedTuple

from geometry_msgs.msg import Vector3Stamped, WrenchStamped
import numpy as np
from rclpy.node import Node
from rclpy.parameter import Parameter
from torquefree_ros.bag import BagReader
from torquefree_ros.bag.offline import write_scene_bag
from torquefree_ros.core.run.simulation import Simulation
from torquefree_ros.core.scene.loader import faults_from_text, scene_from_mapping
from torquefree_ros.testing import simulator

RATE = 10.0
NODE_SCENE = {
    'body': {'inertia': [4.0, 5.0, 6.0]},
    'initial': {'angular_velocity': [0.3, -0.2, 0.25]},
    'effects': [{'torque_command': {'max_torque': 0.1}}],
    'accuracy': 1e-12,
}
GAIN = 0.05  # N m s: K w, under max_torque


class Damping(Node):
    """Answer each sample with the torque ``-K w`` for the interval after it."""

    def __init__(self, context):
        super().__init__('damping', context=context)
        self.commands = self.create_publisher(WrenchStamped, 'torque_command', 10)
        self.create_subscription(Vector3Stamped, 'angular_velocity', self.answer, 10)

    def answer(self, sample: Vector3Stamped) -> None:
        command = WrenchStamped()
        command.header.stamp, command.header.frame_id = sample.header.stamp, 'body'
        torque = command.wrench.torque
        torque.x, torque.y, torque.z = (-GAIN * sample.vector.x, -GAIN * sample.vector.y,
                                        -GAIN * sample.vector.z)
        self.commands.publish(command)


class RunningFault(NamedTuple):
    live: np.ndarray  # the node's rates, samples 0 .. first + more - 1
    offline: np.ndarray  # the core's, the same samples
    diagnostics: dict  # the node's fault diagnostics at sample first
    recorded: object  # the node's bag
    epoch: int  # the first sample's stamp, ns


def set_while_running(tmp_path, text: str, first: int, more: int) -> RunningFault:
    """Run the node ``first`` samples, set ``faults`` to ``text``, run ``more``; and the core."""
    path = tmp_path / 'damping.yaml'
    path.write_text(json.dumps(NODE_SCENE))
    recorded = tmp_path / 'live'
    with simulator(str(path), publish_rate=RATE, record_bag=str(recorded)) as sim:
        sim.add_node(Damping(sim.context))
        rates = sim.tap('angular_velocity', Vector3Stamped)
        sim.advance(first)
        result = sim.node.set_parameters_atomically([Parameter('faults', value=text)])
        assert result.successful, result.reason
        sim.advance(more)
        rates.wait(first + more)
        diagnostics = sim.node.sample_loop.simulation.fault_diagnostics(first)
        received = rates.messages[: first + more]
        epoch = sim.samples[0].stamp_ns
    live = np.array([[m.vector.x, m.vector.y, m.vector.z] for m in received])
    simulation = Simulation(scene_from_mapping(NODE_SCENE).propagator(), RATE)
    ((_, hold),) = simulation.command_holds
    offline = [simulation.samples(0, 1).omega_B[0]]
    for k in range(first + more - 1):
        if k == first:
            simulation.retune(k, faults_from_text(text, ()))
        assert hold.receive(hold.stamp_ns(k), -GAIN * offline[-1], frame_id='')[0]
        hold.seal(k)
        offline.append(simulation.samples(k + 1, 1).omega_B[0])
    return RunningFault(live, np.array(offline), diagnostics, recorded, epoch)


def assert_the_replay_is_the_recording(tmp_path, run: RunningFault) -> None:
    """``torquefree_bag --commands``' replay gives the recording's rates and changes, bytes."""
    count = len(run.live)
    replay = tmp_path / 'replay'
    write_scene_bag(scene_from_mapping(NODE_SCENE), replay, (count - 1) / RATE, RATE,
                    epoch_ns=run.epoch, commands_bag=run.recorded)
    window = (run.epoch, run.epoch + (count - 1) * round(1e9 / RATE))

    def messages(bag, topic):
        return [m.data for m in BagReader(bag).messages([topic])
                if window[0] <= m.log_time_ns <= window[1]]

    for topic in ('/angular_velocity', '/sensor_changes'):
        recorded_messages = messages(run.recorded, topic)
        assert recorded_messages and recorded_messages == messages(replay, topic), topic
