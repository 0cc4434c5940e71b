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
A speed-mode wheel driven through ROS: set-points on wheel_command, in lock-step with the test kit.

A node answers every sample with a speed set-point (``velocity``) stamped like the sample; the
wheel follows the drive's first-order response, whose pole on a free body is ``speed_bandwidth
I_a / (I_a - Js)`` (actuators' docstring), and the body takes the momentum the wheel gives up.
"""

from __future__ import annotations

import math

from geometry_msgs.msg import Vector3Stamped
import numpy as np
from rclpy.node import Node
from sensor_msgs.msg import JointState
from torquefree_ros.testing import simulator

RATE = 20.0  # Hz
INERTIA = [4.0, 5.0, 6.0]  # the wheel on the major axis z: I_a = 6
JS, BANDWIDTH, SPEED0 = 0.2, 2.0, 10.0
# set-points: 30 rad/s from the start, -10 rad/s from 2 s
SWITCH, FIRST, SECOND = 2.0, 30.0, -10.0
SCENE = f"""
body: {{inertia: {INERTIA}}}
initial: {{angular_velocity: [0.0, 0.0, 0.0]}}
effects:
  - reaction_wheels:
      mode: speed
      speed_bandwidth: {BANDWIDTH}
      timeout: 1.0
      wheels:
        - {{name: z, axis: [0.0, 0.0, 1.0], spin_inertia: {JS}, max_torque: 100.0,
            max_speed: 1000.0, speed: {SPEED0}}}
  - wheel_states: {{}}
accuracy: 1.0e-12
"""


class SetPoints(Node):
    """Answer each sample with the wheel's set-point for the interval after it."""

    def __init__(self, context):
        super().__init__('set_points', context=context)
        self.commands = self.create_publisher(JointState, 'wheel_command', 10)
        self.create_subscription(Vector3Stamped, 'angular_velocity', self.answer, 10)

    def answer(self, sample: Vector3Stamped) -> None:
        stamp = sample.header.stamp
        t = stamp.sec + stamp.nanosec * 1e-9  # the kit's clock starts at 0
        command = JointState()
        command.header.stamp = stamp
        command.name = ['z']
        command.velocity = [FIRST if t < SWITCH - 1e-9 else SECOND]
        self.commands.publish(command)


def test_a_speed_set_point_through_wheel_command_settles_with_the_drives_first_order_pole(
    tmp_path,
):
    """
    ``Omega(t) = ref + (Omega(t_0) - ref) exp(-p (t - t_0))``, ``p = bandwidth I_a / (I_a - Js)``.

    Frictionless, so the proportional loop settles on the set-point itself; the answer to sample
    k holds on [t_k, t_k+1) (lock-step), so the first set-point acts from t = 0 and the second
    from 2 s. Compared at every sample's wheel_states velocity within 1e-8 rad/s (DOP853 at
    rtol 1e-12 on speeds of tens of rad/s, with room); the body's rate ``w_z = Js (Omega_0 -
    Omega) / I_a`` (the z momentum, constant, is Js Omega_0) within 1e-10 rad/s. Settled at the
    end, 4 s after the second set-point: the 39.7 rad/s step times exp(-4 p) = 2.5e-4 leaves
    0.01 rad/s (checked under 0.02).
    """
    path = tmp_path / 'speed_wheel.yaml'
    path.write_text(SCENE)
    I_a = INERTIA[2]
    pole = BANDWIDTH * I_a / (I_a - JS)
    with simulator(str(path), publish_rate=RATE) as sim:
        sim.add_node(SetPoints(sim.context))
        states = sim.tap('wheel_states', JointState)
        samples = sim.advance(int(6.0 * RATE) + 1)  # 0 .. 6 s
        assert sim.node.stepping.state().missed_steps == 0  # every sample answered in time
        states.wait(len(samples))
        t = np.array([s.t for s in samples])
        speeds = np.array([m.velocity[0] for m in states.messages[: len(samples)]])
        rates = np.array([s.angular_velocity[2] for s in samples])
    at_switch = FIRST + (SPEED0 - FIRST) * math.exp(-pole * SWITCH)
    expected = np.where(
        t <= SWITCH,
        FIRST + (SPEED0 - FIRST) * np.exp(-pole * t),
        SECOND + (at_switch - SECOND) * np.exp(-pole * np.maximum(t - SWITCH, 0.0)),
    )
    np.testing.assert_allclose(speeds, expected, rtol=0, atol=1e-8)
    np.testing.assert_allclose(rates, JS * (SPEED0 - speeds) / I_a, rtol=0, atol=1e-10)
    assert abs(speeds[-1] - SECOND) < 0.02
    # the response is the drive's pole, not the bandwidth alone (a 3 % slower loop): at 1 s
    locked = FIRST + (SPEED0 - FIRST) * math.exp(-BANDWIDTH * 1.0)
    assert abs(speeds[int(RATE)] - locked) > 0.01
