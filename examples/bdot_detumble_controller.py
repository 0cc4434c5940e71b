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
A B-dot detumble controller: the magnetometer in, a body dipole on magnetorquer_command out.

The law is Stickler & Alfriend's B-dot ("Elementary magnetic attitude control system", J.
Spacecraft and Rockets 13(5), 282-287, 1976; also Avanzini & Giulietti, "Magnetic detumbling of a
rigid spacecraft", J. Guidance, Control, and Dynamics 35(4), 1326-1334, 2012)::

    m = -k dB_B/dt,   dB_B/dt ~ (B_k - B_(k-1)) / (t_k - t_(k-1))

from two successive magnetometer samples (body frame). While the body turns much faster than the
field along the orbit, ``dB_B/dt ~ -w x B_B`` and the torque ``m x B = -k |B|^2 (w - (w.b) b)``
(``b = B / |B|``) takes out the rate across the field, whose direction changes along the orbit:
the rate falls until the body turns with the field, about twice the orbital rate. The dipole is
scaled down as a whole when a component would pass ``max_dipole`` (its direction kept, so the
rods, one per body axis, never saturate).

It answers each ``magnetometer`` sample with a ``geometry_msgs/Vector3Stamped`` on
``magnetorquer_command`` stamped like the sample, in the sample's frame (the body frame): the first
sample (no difference yet) with a zero dipole. Parameters: ``gain`` (k, A m^2 s/T) and
``max_dipole`` (A m^2; default the smallest rod's of the ``scene`` parameter's magnetorquers, the
library's ``bdot_detumble``). Its test, ``test_bdot_detumble_controller.py``, runs it in lock-step
with the test kit.

    ros2 run torquefree_ros torquefree_sim --ros-args -p scene:=bdot_detumble -p lockstep:=true
    python3 examples/bdot_detumble_controller.py   # beside it
"""

from __future__ import annotations

from geometry_msgs.msg import Vector3Stamped
import numpy as np
import rclpy
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import MagneticField
from torquefree_ros import load_scene

GAIN = 1.0e5  # A m^2 s/T: k


class BdotLaw:
    """
    The law of the module's docstring, without ROS: ``dipole(t, B)`` for each sample in turn.

    ``t`` in s, ``B`` the body-frame field in T; returns the dipole to hold (A m^2).
    """

    def __init__(self, gain: float = GAIN, max_dipole: float = 0.2):
        self.gain = float(gain)
        self.max_dipole = float(max_dipole)
        self._last: tuple[float, np.ndarray] | None = None

    @classmethod
    def for_scene(cls, scene='bdot_detumble', gain: float = GAIN) -> 'BdotLaw':
        """Return the law saturating at the smallest rod's ``max_dipole`` of ``scene``."""
        scene = load_scene(scene) if isinstance(scene, str) else scene
        (rods,) = [e for e in scene.effects if e.name == 'magnetorquers']
        return cls(gain, float(rods.max_dipoles.min()))

    def dipole(self, t: float, field_B) -> np.ndarray:
        field_B = np.asarray(field_B, dtype=float)
        last, self._last = self._last, (t, field_B)
        if last is None or t <= last[0]:
            return np.zeros(3)
        m = -self.gain * (field_B - last[1]) / (t - last[0])
        largest = float(np.max(np.abs(m)))
        return m * (self.max_dipole / largest) if largest > self.max_dipole else m


def stamp_ns(stamp) -> int:
    return stamp.sec * 1_000_000_000 + stamp.nanosec


class BdotController(Node):
    """The law as a node: answers each magnetometer sample (the module's docstring)."""

    def __init__(self, **node_options):
        super().__init__('bdot_detumble_controller', **node_options)
        scene = self.declare_parameter('scene', 'bdot_detumble').value
        gain = self.declare_parameter('gain', GAIN).value
        self.law = BdotLaw.for_scene(scene, gain)
        max_dipole = self.declare_parameter('max_dipole', self.law.max_dipole).value
        self.law.max_dipole = float(max_dipole)
        qos = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
        self.publisher = self.create_publisher(Vector3Stamped, 'magnetorquer_command', qos)
        self.create_subscription(MagneticField, 'magnetometer', self._answer, qos)

    def _answer(self, message: MagneticField) -> None:
        field = message.magnetic_field
        t = stamp_ns(message.header.stamp) * 1e-9
        x, y, z = self.law.dipole(t, [field.x, field.y, field.z]).tolist()
        command = Vector3Stamped()
        command.header = message.header  # the sample's stamp and frame (the body frame)
        command.vector.x, command.vector.y, command.vector.z = x, y, z
        self.publisher.publish(command)


def main():
    rclpy.init()
    node = BdotController()
    try:
        rclpy.spin(node)
    except KeyboardInterrupt:
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == '__main__':
    main()
