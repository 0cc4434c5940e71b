#!/usr/bin/env python3
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
A small attitude estimator node: a complementary filter over a gyro and a star tracker.

It integrates the gyro (``imu``, sensor_msgs/Imu ``angular_velocity``, body frame) minus its bias
estimate, and pulls the attitude a fraction ``gain`` of the way towards each star-tracker fix
(``star_tracker``, sensor_msgs/Imu ``orientation``, q_NB), while the bias estimate follows the part
of the error that keeps coming back (``bias_gain``). Each estimate goes out on
``attitude_estimate`` (geometry_msgs/QuaternionStamped, q_NB) with the gyro sample's stamp.

A fix is applied when the next gyro reading arrives, before that reading is integrated: the
estimate is then at the fix's stamp, and the result does not depend on the order in which the
callbacks of one sample run. The first estimate goes out with the second gyro reading after the
first fix. Its test, ``test_attitude_estimator.py``, runs it against the simulator's ``estimator``
scene with the test kit (torquefree_ros.testing).

    ros2 run torquefree_ros torquefree_sim --ros-args -p scene:=estimator   # and, beside it:
    python3 examples/attitude_estimator.py
"""

from __future__ import annotations

from geometry_msgs.msg import QuaternionStamped
import numpy as np
import rclpy
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import Imu


def multiply(a, b):
    """Hamilton product of quaternions (x, y, z, w)."""
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return np.array(
        [
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz,
        ]
    )


def rotation(vector):
    """Return the unit quaternion of the rotation vector ``vector`` (rad)."""
    angle = float(np.linalg.norm(vector))
    if angle < 1e-12:
        return np.array([0.5 * vector[0], 0.5 * vector[1], 0.5 * vector[2], 1.0])
    axis = np.asarray(vector) / angle
    return np.append(axis * np.sin(0.5 * angle), np.cos(0.5 * angle))


def rotation_vector(q):
    """Return the rotation vector (rad) of the unit quaternion ``q``, the short way round."""
    q = q if q[3] >= 0.0 else -q
    s = float(np.linalg.norm(q[:3]))
    if s < 1e-12:
        return 2.0 * q[:3]
    return q[:3] / s * 2.0 * np.arctan2(s, q[3])


def nanoseconds(stamp) -> int:
    return stamp.sec * 1_000_000_000 + stamp.nanosec


class AttitudeEstimator(Node):
    """
    The complementary filter as a node (see the module's docstring).

    ``gain``: the share of a fix's error taken at once (0..1); ``bias_gain``: the share of the
    error rate taken into the bias estimate at each fix.
    """

    def __init__(self, gain: float = 0.2, bias_gain: float = 0.05, **node_options):
        super().__init__('attitude_estimator', **node_options)
        self.gain, self.bias_gain = gain, bias_gain
        self.q: np.ndarray | None = None  # q_NB, from the first fix on
        self.bias = np.zeros(3)  # rad/s
        self.stamp: int | None = None  # ns: the time self.q is at
        self.rate: np.ndarray | None = None  # the last gyro reading, bias removed
        self.fixes: list[tuple[int, np.ndarray]] = []  # (stamp, q_NB) not applied yet
        self.last_fix: int | None = None
        qos = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)
        self.create_subscription(Imu, 'imu', self.on_gyro, qos)
        self.create_subscription(Imu, 'star_tracker', self.on_fix, qos)
        self.publisher = self.create_publisher(QuaternionStamped, 'attitude_estimate', qos)

    def on_gyro(self, message: Imu) -> None:
        self.apply_fixes()  # those up to the estimate's time, before it moves on
        v = message.angular_velocity
        stamp, rate = nanoseconds(message.header.stamp), np.array([v.x, v.y, v.z]) - self.bias
        if self.q is not None and self.stamp is not None and stamp > self.stamp:
            # the mean of the readings at both ends of the interval: second order in the step
            step = 0.5 * (self.rate + rate) * (stamp - self.stamp) * 1e-9
            self.q = multiply(self.q, rotation(step))
            self.q /= np.linalg.norm(self.q)
        self.stamp, self.rate = stamp, rate
        if self.q is not None:
            estimate = QuaternionStamped()
            estimate.header.stamp = message.header.stamp
            estimate.header.frame_id = 'world'
            (
                estimate.quaternion.x,
                estimate.quaternion.y,
                estimate.quaternion.z,
                estimate.quaternion.w,
            ) = self.q
            self.publisher.publish(estimate)

    def on_fix(self, message: Imu) -> None:
        o = message.orientation
        self.fixes.append((nanoseconds(message.header.stamp), np.array([o.x, o.y, o.z, o.w])))

    def apply_fixes(self) -> None:
        """
        Apply the fixes stamped at or before the gyro's last reading, in stamp order.

        One that came late, stamped before it, is taken as if it were stamped then.
        """
        self.fixes.sort(key=lambda fix: fix[0])
        while self.fixes and self.stamp is not None and self.fixes[0][0] <= self.stamp:
            stamp, measured = self.fixes.pop(0)
            if self.q is None:
                self.q = measured / np.linalg.norm(measured)
            else:
                error = rotation_vector(
                    multiply(np.array([-self.q[0], -self.q[1], -self.q[2], self.q[3]]), measured)
                )
                self.q = multiply(self.q, rotation(self.gain * error))
                self.q /= np.linalg.norm(self.q)
                if self.last_fix is not None and stamp > self.last_fix:
                    # the estimate drifted by about -(bias error) * dt since the last fix
                    self.bias -= self.bias_gain * error / ((stamp - self.last_fix) * 1e-9)
            self.last_fix = stamp


def main() -> None:
    rclpy.init()
    node = AttitudeEstimator()
    try:
        rclpy.spin(node)
    except KeyboardInterrupt:
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == '__main__':
    main()
