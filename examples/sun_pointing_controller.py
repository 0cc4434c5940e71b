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
A sun-pointing controller on reaction wheels: the sun sensor and the rates in, wheel torques out.

The law turns the panel normal ``n`` (body frame) to the Sun's unit vector ``s`` the sun sensor
reads (body frame), the vector-alignment form of the quaternion feedback regulator (Wie, *Space
Vehicle Dynamics and Control*, 2nd ed., 2008, 7.3; Sidi, *Spacecraft Dynamics and Control*, 1997,
7.4)::

    tau = k J (n x s) - c J w + w x H_B

``J`` the body's inertia (wheels locked), ``w`` the body rate, ``H_B = J w + sum Js_i Omega_i
g_i`` the whole momentum (the last term cancels the gyroscopic torque), ``k = omega_n^2``, ``c = 2
zeta omega_n``: ``|n x s| = sin theta`` for the angle ``theta`` between them, so near the Sun each
axis across it is a second-order loop of natural frequency ``omega_n`` and damping ``zeta``; the
rate about the Sun line is only damped (pointing one axis leaves that angle free). In eclipse the
sensor reads the zero vector (no Sun): the law then holds the attitude still, ``tau = -c J w + w
x H_B``, until the Sun comes back. The wheels make the torque: the body feels ``-sum u_i g_i``, so
the motor torques are the least-norm ``u = -G (G^T G)^{-1} tau`` (``G`` the axes, a row each),
scaled down as a whole when one would pass its wheel's ``max_torque``, plus each wheel's dry
friction, ``coulomb_i sign(Omega_i)`` (friction compensation, as a wheel drive's speed loop does:
the motor cancels the friction, whose reaction on the body it also cancels, so the wheels keep
their bias and the body gets ``tau``; the scene's small wheels would lose their bias in minutes
without it, then stick at zero speed and hold the body off the Sun).

It answers each sample (``sun_sensor``, ``angular_velocity``, ``wheel_states`` of one stamp) with
a ``sensor_msgs/JointState`` on ``wheel_command`` stamped like the sample, naming every wheel, in
``effort``. The body, the wheels and the panel normal (the sun sensor's boresight) are read from
the scene (``scene`` parameter, default the library's ``sun_pointing``). Its test,
``test_sun_pointing_controller.py``, runs it in lock-step with the test kit.

    ros2 run torquefree_ros torquefree_sim --ros-args -p scene:=sun_pointing -p lockstep:=true
    python3 examples/sun_pointing_controller.py   # beside it
"""

from __future__ import annotations

from geometry_msgs.msg import Vector3Stamped
import numpy as np
import rclpy
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
from torquefree_ros import load_scene

NATURAL_FREQUENCY = 0.05  # rad/s: omega_n (the wheels' 0.015 N m s holds the slew's momentum)
DAMPING = 1.0  # zeta: critically damped near the Sun
NO_SUN = 0.5  # a reading shorter than this is the sensor's "no Sun" (the zero vector)


class SunPointingLaw:
    """
    The control law of the module's docstring for one scene's body and wheels, without ROS.

    ``torques(s, w, speeds)`` returns the motor torques to hold (N m, one per wheel).
    """

    def __init__(
        self, scene='sun_pointing', natural_frequency=NATURAL_FREQUENCY, damping=DAMPING
    ):
        scene = load_scene(scene) if isinstance(scene, str) else scene
        (wheels,) = [e for e in scene.effects if e.name == 'reaction_wheels']
        (sensor,) = [o for o in scene.outputs if o.name == 'sun_sensor']
        self.names = list(wheels.names)
        self.axes = wheels.axes  # (n, 3), unit
        self.spin_inertias = wheels.spin_inertias
        self.max_torques = np.array([wheel['max_torque'] for wheel in wheels.values['wheels']])
        self.coulombs = np.array([wheel['coulomb'] for wheel in wheels.values['wheels']])
        boresight = np.asarray(sensor.values['boresight'], dtype=float)
        self.normal = boresight / np.linalg.norm(boresight)
        i = scene.inertia
        self.inertia = (
            np.diag(i) if len(i) == 3
            else np.array([[i[0], i[3], i[4]], [i[3], i[1], i[5]], [i[4], i[5], i[2]]])
        )
        self.k = natural_frequency**2
        self.c = 2.0 * damping * natural_frequency
        self.allocation = -self.axes @ np.linalg.inv(self.axes.T @ self.axes)

    def torques(self, sun, w, speeds) -> np.ndarray:
        sun, w, speeds = (np.asarray(x, dtype=float) for x in (sun, w, speeds))
        momentum = self.inertia @ w + (self.spin_inertias * speeds) @ self.axes
        tau = -self.c * (self.inertia @ w) + np.cross(w, momentum)
        if np.linalg.norm(sun) > NO_SUN:
            tau += self.k * (self.inertia @ np.cross(self.normal, sun))
        u = self.allocation @ tau
        worst = float(np.max(np.abs(u) / self.max_torques))
        u = u / worst if worst > 1.0 else u
        return u + self.coulombs * np.sign(speeds)


def stamp_ns(stamp) -> int:
    return stamp.sec * 1_000_000_000 + stamp.nanosec


class SunPointingController(Node):
    """The law as a node: answers each sample on ``wheel_command`` (the module's docstring)."""

    def __init__(self, **node_options):
        super().__init__('sun_pointing_controller', **node_options)
        scene = self.declare_parameter('scene', 'sun_pointing').value
        self.law = SunPointingLaw(scene)
        qos = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
        self.publisher = self.create_publisher(JointState, 'wheel_command', qos)
        self._parts: dict[int, dict] = {}  # stamp -> what came of that sample
        self.create_subscription(
            Vector3Stamped, 'sun_sensor', lambda m: self._take(m, 's', m.vector), qos
        )
        self.create_subscription(
            Vector3Stamped, 'angular_velocity', lambda m: self._take(m, 'w', m.vector), qos
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
            parts[part] = [value.x, value.y, value.z]
        if len(parts) == 3:  # the whole sample: answer it, forget it and any older
            self._answer(message.header.stamp, parts)
            for old in [s for s in self._parts if s <= stamp]:
                del self._parts[old]

    def _answer(self, stamp, parts: dict) -> None:
        command = JointState()
        command.header.stamp = stamp
        command.name = self.law.names
        command.effort = self.law.torques(parts['s'], parts['w'], parts['speeds']).tolist()
        self.publisher.publish(command)


def main():
    rclpy.init()
    node = SunPointingController()
    try:
        rclpy.spin(node)
    except KeyboardInterrupt:
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == '__main__':
    main()
