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
A slew controller on reaction wheels: quaternion feedback, the wheels' torques on wheel_command.

The control law is the quaternion feedback regulator of Wie, Weiss & Arapostathis ("Quaternion
feedback regulator for spacecraft eigenaxis rotations", J. Guidance, Control, and Dynamics 12(3),
375-380, 1989; also Schaub & Junkins, *Analytical Mechanics of Space Systems*, ch. 8): with the
error quaternion ``q_e = q_target^* ⊗ q_NB`` (taken the short way round, ``q_e4 >= 0``), the body
torque asked is::

    tau = -k J q_e(1:3) - c J w + w x H_B

``J`` the body's inertia (wheels locked), ``H_B = J w + sum Js_i Omega_i g_i`` the whole momentum
(the last term cancels the gyroscopic torque), gains ``k = 2 omega_n^2``, ``c = 2 zeta omega_n``:
near the target (``q_e(1:3) ~ theta / 2``) each axis is a second-order loop of natural frequency
``omega_n`` and damping ``zeta``, and with ``K = k J``, ``C = c J`` the rotation stays about the
eigenaxis (their theorem). The wheels make it: the body feels ``-sum u_i g_i``, so the motor
torques are the least-norm ``u = -G (G^T G)^{-1} tau`` (``G`` the axes, a row each), scaled down
as a whole when one would pass its wheel's ``max_torque`` (the direction of ``tau``, hence the
eigenaxis, is kept).

It answers each sample (``angular_velocity``, ``attitude``, ``wheel_states`` of one stamp) with a
``sensor_msgs/JointState`` on ``wheel_command`` stamped like the sample, naming every wheel, in
``effort``. The body and wheels are read from the scene (``scene`` parameter, default the library's
``wheel_slew``); the target attitude is the ``target`` parameter (x, y, z, w; default the inertial
frame). Its test, ``test_wheel_slew_controller.py``, runs it in lock-step with the test kit.

    ros2 run torquefree_ros torquefree_sim --ros-args -p scene:=wheel_slew -p lockstep:=true
    python3 examples/wheel_slew_controller.py   # beside it
"""

from __future__ import annotations

from geometry_msgs.msg import QuaternionStamped, Vector3Stamped
import numpy as np
import rclpy
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
from torquefree_ros import load_scene

NATURAL_FREQUENCY = 0.2  # rad/s: omega_n
DAMPING = 1.0  # zeta: critically damped near the target


def conjugate_times(a, b):
    """Return ``a^* ⊗ b`` (quaternions x, y, z, w; Hamilton product)."""
    ax, ay, az, aw = -a[0], -a[1], -a[2], a[3]
    bx, by, bz, bw = b
    return np.array(
        [
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz,
        ]
    )


class SlewLaw:
    """
    The control law of the module's docstring for one scene's body and wheels, without ROS.

    ``torques(q_NB, w, speeds)`` returns the motor torques to hold (N m, one per wheel).
    """

    def __init__(
        self,
        scene='wheel_slew',
        target=(0.0, 0.0, 0.0, 1.0),
        natural_frequency=NATURAL_FREQUENCY,
        damping=DAMPING,
    ):
        scene = load_scene(scene) if isinstance(scene, str) else scene
        (wheels,) = [e for e in scene.effects if e.name == 'reaction_wheels']
        self.names = list(wheels.names)
        self.axes = wheels.axes  # (n, 3), unit
        self.spin_inertias = wheels.spin_inertias
        self.max_torques = np.array([row[4] for row in wheels.rows])
        i = scene.inertia
        self.inertia = (
            np.diag(i) if len(i) == 3
            else np.array([[i[0], i[3], i[4]], [i[3], i[1], i[5]], [i[4], i[5], i[2]]])
        )
        self.target = np.asarray(target, dtype=float) / np.linalg.norm(target)
        self.k = 2.0 * natural_frequency**2
        self.c = 2.0 * damping * natural_frequency
        self.allocation = -self.axes @ np.linalg.inv(self.axes.T @ self.axes)

    def error(self, q_NB) -> np.ndarray:
        """Return the error quaternion ``q_target^* ⊗ q_NB``, the short way round (w >= 0)."""
        error = conjugate_times(self.target, np.asarray(q_NB, dtype=float))
        return error if error[3] >= 0.0 else -error

    def torques(self, q_NB, w, speeds) -> np.ndarray:
        w = np.asarray(w, dtype=float)
        momentum = self.inertia @ w + (self.spin_inertias * np.asarray(speeds)) @ self.axes
        tau = (
            -self.k * (self.inertia @ self.error(q_NB)[:3])
            - self.c * (self.inertia @ w)
            + np.cross(w, momentum)
        )
        u = self.allocation @ tau
        worst = float(np.max(np.abs(u) / self.max_torques))
        return u / worst if worst > 1.0 else u


def stamp_ns(stamp) -> int:
    return stamp.sec * 1_000_000_000 + stamp.nanosec


class WheelSlewController(Node):
    """The law as a node: answers each sample on ``wheel_command`` (the module's docstring)."""

    def __init__(self, **node_options):
        super().__init__('wheel_slew_controller', **node_options)
        scene = self.declare_parameter('scene', 'wheel_slew').value
        target = self.declare_parameter('target', [0.0, 0.0, 0.0, 1.0]).value
        self.law = SlewLaw(scene, target)
        qos = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
        self.publisher = self.create_publisher(JointState, 'wheel_command', qos)
        self._parts: dict[int, dict] = {}  # stamp -> what came of that sample
        self.create_subscription(
            Vector3Stamped, 'angular_velocity', lambda m: self._take(m, 'w', m.vector), qos
        )
        self.create_subscription(
            QuaternionStamped, 'attitude', lambda m: self._take(m, 'q', m.quaternion), qos
        )
        self.create_subscription(
            JointState, 'wheel_states', lambda m: self._take(m, 'speeds', m), qos
        )

    def _take(self, message, part: str, value) -> None:
        stamp = stamp_ns(message.header.stamp)
        parts = self._parts.setdefault(stamp, {})
        if part == 'speeds':
            by_name = dict(zip(value.name, value.velocity))
            parts[part] = [by_name[name] for name in self.law.names]
        else:
            xyz = [value.x, value.y, value.z] + ([value.w] if part == 'q' else [])
            parts[part] = xyz
        if len(parts) == 3:  # the whole sample: answer it, forget it and any older
            self._answer(message.header.stamp, parts)
            for old in [s for s in self._parts if s <= stamp]:
                del self._parts[old]

    def _answer(self, stamp, parts: dict) -> None:
        command = JointState()
        command.header.stamp = stamp
        command.name = self.law.names
        command.effort = self.law.torques(parts['q'], parts['w'], parts['speeds']).tolist()
        self.publisher.publish(command)


def main():
    rclpy.init()
    node = WheelSlewController()
    try:
        rclpy.spin(node)
    except KeyboardInterrupt:
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == '__main__':
    main()
