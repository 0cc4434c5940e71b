"""Output effects: topics derived from the samples, never changing the motion.

``imu`` is a gyro on the body: ``w_meas = w + b + n`` with white noise ``n`` of density ``N``
(rad/s/sqrt(Hz): per-sample standard deviation ``N sqrt(rate)``) and a bias random walk
``b_k = b_(k-1) + K sqrt(1/rate) m_k`` (``K`` in rad/s/sqrt(s)). Its Allan deviation is
``N / sqrt(tau)`` at short ``tau`` and ``K sqrt(tau / 3)`` at long ``tau`` (IEEE Std 952). The
draws come from a seeded PCG64 stream consumed in sample order, so sample ``k`` is the same however
the samples are cut into blocks, live or offline.

``euler_angles`` are the 3-2-1 angles of seed 000 (yaw psi about z, then pitch theta about the new
y, then roll phi about the new x) of ``[BN] = R(q_NB)^T``, published as Vector3Stamped
``(x, y, z) = (roll, pitch, yaw)`` in rad.
"""

from __future__ import annotations

import numpy as np

from .. import quaternion
from ..schema import Param, integer, number, topic_name, vector
from .base import OutputEffect, OutputStream, register

# sensor_msgs/Imu after its header: orientation [0:4], its covariance [4:13], angular_velocity
# [13:16], its covariance [16:25], linear_acceleration [25:28], its covariance [28:37]
IMU_ROW = 37
NOT_PROVIDED = -1.0  # REP 145: element 0 of a covariance is -1 when the quantity is not provided


@register
class Imu(OutputEffect):
    name = "imu"
    summary = "sensor_msgs/Imu gyro on the body: white noise and bias random walk, seeded (REP 145 covariances)"
    message_type = "sensor_msgs/msg/Imu"
    frame = "body"
    parameters = {
        "gyro_noise_density": Param(number(minimum=0.0, unit="rad/s/sqrt(Hz)"), 0.0),
        "gyro_bias_random_walk": Param(number(minimum=0.0, unit="rad/s/sqrt(s)"), 0.0),
        "initial_bias": Param(vector(3, unit="rad/s"), np.zeros(3)),
        "seed": Param(integer(0, 2**63 - 1), 0),
        "topic": Param(topic_name, "imu"),
    }

    def stream(self, rate):
        return _ImuStream(self, rate)


class _ImuStream(OutputStream):
    def __init__(self, imu: Imu, rate: float):
        values = imu.values
        self.seed = values["seed"]
        self.white_sigma = values["gyro_noise_density"] * np.sqrt(rate)
        self.walk_sigma = values["gyro_bias_random_walk"] / np.sqrt(rate)
        self.initial_bias = np.asarray(values["initial_bias"], float)
        self.template = np.zeros(IMU_ROW)
        self.template[4] = NOT_PROVIDED  # orientation not provided
        self.template[16:25] = np.diag(np.full(3, self.white_sigma ** 2)).ravel()
        self.template[28] = NOT_PROVIDED  # linear acceleration not provided
        self._restart()

    def _restart(self):
        self.rng = np.random.Generator(np.random.PCG64(self.seed))
        self.next_index = 0
        self.bias = self.initial_bias.copy()  # b_(k-1) of the next sample

    def _draw(self, count: int):
        """White noise and bias of the next ``count`` samples; sample 0 carries the initial bias."""
        normals = self.rng.standard_normal((count, 6))
        steps = self.walk_sigma * normals[:, 3:]
        if self.next_index == 0:
            steps[0] = 0.0
        # accumulate is sequential: ((b + s1) + s2) + ..., the same floats however blocks are cut
        bias = np.cumsum(np.vstack([self.bias, steps]), axis=0)[1:]
        self.bias = bias[-1].copy()
        self.next_index += count
        return self.white_sigma * normals[:, :3], bias

    def rows(self, first, times, omega_B, q_NB):
        count = times.shape[0]
        if first < self.next_index:
            self._restart()
        if first > self.next_index:
            self._draw(first - self.next_index)  # skipped samples still consume their draws
        if count == 0:
            return np.empty((0, IMU_ROW))
        white, bias = self._draw(count)
        rows = np.tile(self.template, (count, 1))
        rows[:, 13:16] = omega_B + bias + white
        return rows


@register
class EulerAngles(OutputEffect):
    name = "euler_angles"
    summary = "3-2-1 (yaw, pitch, roll) Euler angles of the attitude, as Vector3Stamped (roll, pitch, yaw)"
    message_type = "geometry_msgs/msg/Vector3Stamped"
    frame = "inertial"
    parameters = {"topic": Param(topic_name, "euler_angles")}

    def stream(self, rate):
        return _EulerStream()


class _EulerStream(OutputStream):
    def rows(self, first, times, omega_B, q_NB):
        return roll_pitch_yaw(q_NB)


def roll_pitch_yaw(q_NB) -> np.ndarray:
    """``(phi, theta, psi)`` per row: ``[BN] = R1(phi) R2(theta) R3(psi)``, ``theta`` in
    ``[-pi/2, pi/2]``, the others in ``(-pi, pi]``."""
    R = quaternion.to_matrix(q_NB)  # [NB]; [BN] is its transpose
    yaw = np.arctan2(R[..., 1, 0], R[..., 0, 0])
    pitch = -np.arcsin(np.clip(R[..., 2, 0], -1.0, 1.0))
    roll = np.arctan2(R[..., 2, 1], R[..., 2, 2])
    return np.stack([roll, pitch, yaw], axis=-1)
