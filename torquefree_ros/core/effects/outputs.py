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
Output effects: topics derived from the samples, never changing the motion.

The sensors, ``imu`` (a gyro with its datasheet errors) and ``star_tracker``, are in
:mod:`.sensors`.

``tf`` is the attitude as ``tf2_msgs/TFMessage`` on ``/tf``: one transform per sample, parent the
inertial frame, child the body frame, rotation ``q_NB``, zero translation (REP 105). On a scene
with an ``orbit:`` each message also carries the Earth-fixed and the orbit (LVLH) frames
(:class:`Tf`).

``pose`` is the attitude as ``geometry_msgs/PoseStamped`` (inertial frame, zero position,
``q_NB``), what the 3-D panels of RViz and Foxglove draw.

``odometry`` is the whole ground truth in the message estimators and ``robot_localization`` take,
``nav_msgs/Odometry``: ``header.frame_id`` the inertial frame, ``child_frame_id`` the body frame,
zero position, orientation ``q_NB``, ``twist.angular`` the body rates ``w`` in the child (body)
frame as REP 105 wants, zero linear velocity: bit for bit the numbers ``attitude`` and
``angular_velocity`` carry. Both covariances are zero: the values are exact, not estimates (zero,
not REP 145's ``-1``, which would say "not provided").

``markers`` draws the motion for RViz/Foxglove as ``visualization_msgs/MarkerArray`` in the
inertial frame (no ``/tf`` needed): the uniform box with the body's principal moments (sides
``d_i ~ sqrt(J_j + J_k - J_i)``, the longest ``size`` m), oriented by its principal axes, and
arrows from its centre along ``w`` and ``H``, each labelled past its tip. Every message carries all
five markers, even when
``H`` is constant: a viewer shows the latest MarkerArray, so one that joins late or seeks in a bag
shows the whole picture at every sample (``momentum_interval``, which would thin the ``H`` arrow
out, is refused).

``orbit`` is the scene's orbit as ``nav_msgs/Odometry`` (:class:`Orbit`): position and velocity
with the attitude and rates.

``euler_angles`` are the 3-2-1 angles of seed 000 (yaw psi about z, then pitch theta about the new
y, then roll phi about the new x) of ``[BN] = R(q_NB)^T``, published as Vector3Stamped
``(x, y, z) = (roll, pitch, yaw)`` in rad.
"""

from __future__ import annotations

import copy
import re

import numpy as np

from .actuators import ReactionWheels
from .base import OutputEffect, OutputStream, register
from .sensors import ARCSEC, IMU_ROW, NOT_PROVIDED  # noqa: F401  (their old home: kept importable)
from .sensors import body_frame
from ..checks.schema import FieldError, number, Param, retired, shown, topic_name
from ..frames import quaternion
from ..numerics.ops import COLUMNS


@register
class EulerAngles(OutputEffect):
    name = 'euler_angles'
    summary = (
        '3-2-1 (yaw, pitch, roll) Euler angles of the attitude, '
        'as Vector3Stamped (roll, pitch, yaw)'
    )
    message_type = 'geometry_msgs/msg/Vector3Stamped'
    frame = 'inertial'
    parameters = {'topic': Param(topic_name, 'euler_angles'), 'rate': OutputEffect.RATE}

    def stream(self, rate, propagator):
        return _EulerStream()


class _EulerStream(OutputStream):

    def rows(self, first, times, omega_B, q_NB, internal):
        return roll_pitch_yaw(q_NB)


def roll_pitch_yaw(q_NB) -> np.ndarray:
    """
    Return ``(phi, theta, psi)`` per row, with ``[BN] = R1(phi) R2(theta) R3(psi)``.

    ``theta`` in ``[-pi/2, pi/2]``, the others in ``(-pi, pi]``.
    """
    R = quaternion.to_matrix(q_NB)  # [NB]; [BN] is its transpose
    yaw = np.arctan2(R[..., 1, 0], R[..., 0, 0])
    pitch = -np.arcsin(np.clip(R[..., 2, 0], -1.0, 1.0))
    roll = np.arctan2(R[..., 2, 1], R[..., 2, 2])
    return np.stack([roll, pitch, yaw], axis=-1)


#: a frame's own name (tf2, REP 105): letters, digits, '_', '-', '.'; the body frame's namespace
#: goes before it
_FRAME_NAME = re.compile(r'[A-Za-z0-9_.\-]{1,128}')


def _frame_name(value, path):
    if not isinstance(value, str) or not _FRAME_NAME.fullmatch(value):
        raise FieldError(
            path,
            "expected a frame name of 1 to 128 letters, digits, '_', '-' or '.' (no '/': the "
            f"body frame's namespace goes before it), got {shown(value)}",
        )
    return value


@register
class Tf(OutputEffect):
    """
    The attitude on ``/tf``; on an orbit, the Earth-fixed and orbit frames beside it.

    Without an ``orbit:`` a message holds one transform: the inertial frame -> the body frame,
    rotation ``q_NB``, zero translation (the node's ``position`` places the body). With one, three
    transforms, each from the inertial frame, whose origin stays at the body's centre so that the
    views keep opening on the body: the body frame as without an orbit; the Earth-fixed frame
    (``earth_frame``, ``environment.earth``'s PEF), rotation ``q_NE`` with ``R(q_NE) = W^T``
    (``r_EF = W r_N``, :func:`~..environment.earth.earth_fixed_matrix` at the sample's UTC
    instant), translation ``-r_N``: the Earth's centre seen from the body; the orbit frame
    (``lvlh_frame``, local vertical local horizontal: ``z = -r/|r|`` to nadir, ``y = -h/|h|``
    with ``h = r x v`` the orbit normal, ``x = y x z``, along the velocity on a circular orbit;
    Markley & Crassidis, *Fundamentals of Spacecraft Attitude Determination and Control*, 2014,
    sec. 2.6.4), rotation ``q_NL`` whose matrix has these axes as columns, zero translation: it
    sits at the body's centre. The two frames are named in the body frame's namespace (its part up
    to its last '/': ``sat1/earth_fixed``, ``sat1/lvlh``), as each body sees its own Earth.
    """

    name = 'tf'
    summary = (
        'tf2_msgs/TFMessage on /tf: inertial frame -> body frame, rotation q_NB, zero '
        'translation; on an orbit also inertial -> Earth-fixed frame (at -r) and -> LVLH frame'
    )
    message_type = 'tf2_msgs/msg/TFMessage'
    frame = 'inertial'  # the parent; the child is the body frame
    layout = 'transform'
    parameters = {
        'topic': Param(topic_name, '/tf'),
        'rate': OutputEffect.RATE,
        'earth_frame': Param(
            _frame_name, 'earth_fixed', 'the Earth-fixed frame (PEF), on a scene with an orbit'
        ),
        'lvlh_frame': Param(
            _frame_name, 'lvlh', 'the orbit frame (LVLH), on a scene with an orbit'
        ),
    }

    def placed(self, place, path: str) -> 'Tf':
        """Return the transforms of the scene's ``place``: with an orbit, the frames it gives."""
        if place is None:
            for key in ('earth_frame', 'lvlh_frame'):
                if self.values[key] != self.parameters[key].default:
                    raise FieldError(
                        f'{path}.{key}',
                        "names a frame of the orbit: add an 'orbit:' section or remove this key",
                    )
            return self
        placed = copy.copy(self)
        placed.place = place
        placed.layout = 'orbit_transforms'
        return placed

    @property
    def layout_options(self) -> dict:
        if self.place is None:
            return {}
        return {'earth_frame': self.values['earth_frame'], 'lvlh_frame': self.values['lvlh_frame']}

    def stream(self, rate, propagator):
        if self.place is None:
            return _PoseStream()  # the same row: translation (zero), rotation q_NB
        return _OrbitFramesStream(self.place)


# an orbit's tf row: the body [0:7], the Earth-fixed frame [7:14], the LVLH frame [14:21], each a
# translation (x, y, z) then a rotation (x, y, z, w), relative to the inertial frame
ORBIT_TF_ROW = 21


class _OrbitFramesStream(OutputStream):

    def __init__(self, place):
        self.place = place

    def rows(self, first, times, omega_B, q_NB, internal):
        rows = np.zeros((times.shape[0], ORBIT_TF_ROW))
        if times.shape[0]:
            position, velocity = self.place.state(times)
            rows[:, 3:7] = q_NB
            rows[:, 7:10] = -position
            W = self.place.earth_fixed(times)
            rows[:, 10:14] = _quaternions(np.swapaxes(W, -1, -2))
            rows[:, 17:21] = _quaternions(lvlh_axes(position, velocity))
        return rows


def lvlh_axes(position_N, velocity_N) -> np.ndarray:
    """Return the LVLH axes as the columns of ``[N L]`` (``v_N = [N L] v_L``), one per row."""
    z = -position_N / np.linalg.norm(position_N, axis=-1, keepdims=True)
    normal = np.cross(position_N, velocity_N)
    y = -normal / np.linalg.norm(normal, axis=-1, keepdims=True)
    return np.stack([np.cross(y, z), y, z], axis=-1)


def _quaternions(matrices) -> np.ndarray:
    """Return the unit quaternions (x, y, z, w; ``w >= 0``) of rotation matrices ``(n, 3, 3)``."""
    if matrices.shape[0] == 1:  # a closed loop's one sample: floats, the same operations
        return np.array([quaternion.matrix_quaternion(matrices[0].tolist())])
    rows = [[matrices[:, i, j] for j in range(3)] for i in range(3)]
    return np.stack(quaternion.matrix_quaternion(rows, COLUMNS), axis=-1)


@register
class Pose(OutputEffect):
    name = 'pose'
    summary = (
        'geometry_msgs/PoseStamped of the attitude (inertial frame, zero position), for 3-D panels'
    )
    message_type = 'geometry_msgs/msg/PoseStamped'
    frame = 'inertial'
    layout = 'pose'  # stamped doubles (position, orientation), placed at the body's position
    parameters = {'topic': Param(topic_name, 'pose'), 'rate': OutputEffect.RATE}

    def stream(self, rate, propagator):
        return _PoseStream()


class _PoseStream(OutputStream):

    def rows(self, first, times, omega_B, q_NB, internal):
        rows = np.zeros((times.shape[0], 7))  # position (x, y, z), orientation (x, y, z, w)
        rows[:, 3:] = q_NB
        return rows


@register
class Odometry(OutputEffect):
    name = 'odometry'
    summary = (
        'nav_msgs/Odometry ground truth: inertial frame -> body frame, zero position, q_NB, '
        'body rates in the body frame (REP 105), zero linear velocity; '
        'covariances zero (exact values)'
    )
    message_type = 'nav_msgs/msg/Odometry'
    frame = 'inertial'  # header.frame_id; child_frame_id is the body frame
    layout = 'odometry'
    parameters = {'topic': Param(topic_name, 'odometry'), 'rate': OutputEffect.RATE}

    def stream(self, rate, propagator):
        return _OdometryStream()


# an odometry row: position (x, y, z) [0:3], orientation (x, y, z, w) [3:7], linear velocity
# [7:10], angular velocity (body frame) [10:13]; the covariances are not in the row (zero: exact
# values)
ODOMETRY_ROW = 13


class _OdometryStream(OutputStream):

    def rows(self, first, times, omega_B, q_NB, internal):
        rows = np.zeros((times.shape[0], ODOMETRY_ROW))
        rows[:, 3:7] = q_NB  # copies: the very floats of attitude and angular_velocity
        rows[:, 10:13] = omega_B
        return rows


@register
class Orbit(OutputEffect):
    """
    The orbit's truth as ``nav_msgs/Odometry``: where the body is and how it moves and turns.

    ``header.frame_id`` the inertial frame (EME2000, ``environment.earth``), ``child_frame_id`` the
    body frame; ``pose.position`` the orbit's position ``r_N`` (m) at the sample's instant, exactly
    (Kepler's equation or SGP4, ``environment.place``); ``pose.orientation`` ``q_NB``; the twist in
    the child (body) frame, as nav_msgs/Odometry defines it: ``twist.linear = R(q_NB)^T v_N``, the
    orbit's velocity (m/s) in body axes (``v_N = R(q_NB) twist.linear``), ``twist.angular`` the
    body rates ``w``, the very floats of ``angular_velocity``. Covariances zero: exact values.
    """

    name = 'orbit'
    summary = (
        "nav_msgs/Odometry of the scene's orbit: position in the inertial frame (m), q_NB, the "
        'velocity (m/s) and body rates in the body frame; covariances zero (exact values)'
    )
    message_type = 'nav_msgs/msg/Odometry'
    frame = 'inertial'  # header.frame_id; child_frame_id is the body frame
    layout = 'odometry'
    needs_orbit = True
    parameters = {'topic': Param(topic_name, 'orbit'), 'rate': OutputEffect.RATE}

    def stream(self, rate, propagator):
        return _OrbitStream(self.place)


class _OrbitStream(OutputStream):

    def __init__(self, place):
        self.place = place

    def rows(self, first, times, omega_B, q_NB, internal):
        rows = np.zeros((times.shape[0], ODOMETRY_ROW))
        if times.shape[0]:
            position, velocity = self.place.state(times)
            rows[:, 0:3] = position
            rows[:, 3:7] = q_NB
            rows[:, 7:10] = body_frame(q_NB, velocity)
            rows[:, 10:13] = omega_B
        return rows


@register
class Markers(OutputEffect):
    name = 'markers'
    summary = (
        "visualization_msgs/MarkerArray in the inertial frame: the body's inertia box "
        'on its principal axes, arrows along w and H with their labels, all in every message, '
        'and an arrow per reaction wheel along its axis, as long as the momentum it stores'
    )
    message_type = 'visualization_msgs/msg/MarkerArray'
    frame = 'inertial'
    layout = 'markers'
    parameters = {
        'size': Param(number(positive=True, unit='m'), 1.0, "the box's longest side"),
        'angular_velocity_scale': Param(
            number(positive=True, unit='m/(rad/s)'),
            None,
            'arrow length per rad/s; default: the initial w is size long',
        ),
        'momentum_scale': Param(
            number(positive=True, unit='m/(kg m^2/s)'),
            None,
            'arrow length per kg m^2/s; default: the initial H is 1.25 size long',
        ),
        # refused rather than ignored: a key that silently does nothing misleads whoever set it
        'momentum_interval': Param(
            retired(
                'every MarkerArray now carries the H arrow, so that a viewer that '
                'seeks or joins late shows it; remove this key'
            ),
            None,
        ),
        'topic': Param(topic_name, 'markers'),
        'rate': OutputEffect.RATE,
    }

    def box_sides(self, body) -> np.ndarray:
        """
        Return the sides of the uniform box with the body's principal moments.

        Along ``body.principal_axes``: ``d_i^2 = 6 (J_j + J_k - J_i) / m``, scaled so the longest
        is ``size``; a side of a rod or a plate (zero by the triangle inequality's edge) is drawn
        ``size / 100`` thick.
        """
        J = body.moments
        squared = np.maximum(J.sum() - 2.0 * J, 0.0)
        sides = np.sqrt(squared / squared.max())
        return self.values['size'] * np.maximum(sides, MIN_SIDE)

    #: the reaction wheels drawn, by name, once bound to a run (:meth:`for_run`)
    wheel_names: tuple = ()

    def for_run(self, propagator):
        """
        Return the markers of a run: with reaction wheels, an arrow per wheel after the five.

        The layout is then ``wheel_markers`` (``bag.wheel_markers``), which takes the wheels'
        names: each wheel's arrow is in its namespace ``wheel_NAME``.
        """
        names = tuple(name for effect, _ in _wheels_of(propagator) for name in effect.names)
        if not names:
            return self
        bound = copy.copy(self)
        bound.wheel_names = names
        bound.layout = 'wheel_markers'
        return bound

    @property
    def layout_options(self) -> dict:
        return {'names': self.wheel_names} if self.wheel_names else {}

    def stream(self, rate, propagator):
        return _MarkerStream(self, rate, propagator)


def _wheels_of(propagator) -> list:
    """Return the propagator's ``reaction_wheels`` effects with their parts of the states."""
    dynamics = propagator.dynamics
    return [
        (effect, part)
        for effect, part in zip(dynamics.effects, dynamics.slices)
        if isinstance(effect, ReactionWheels)
    ]


MIN_SIDE = 0.01  # of the longest side: what a rod's or a plate's thin sides are drawn as
# a markers row: box orientation (x, y, z, w) [0:4] and sides [4:7], the tips of the w [7:10] and H
# [10:13] arrows (inertial frame, from the box's centre); with reaction wheels, then each wheel
# arrow's tip (3 a wheel, in the scene's order)
MARKER_ROW = 13


class _MarkerStream(OutputStream):

    def __init__(self, markers: Markers, rate: float, propagator):
        values, body = markers.values, propagator.body
        size = values['size']
        self.q_BP_values = tuple(quaternion.from_matrix(body.principal_axes).tolist())
        self.sides = markers.box_sides(body)
        omega0, x0 = propagator.omega0_B, propagator.x0
        self.momentum_B = propagator.momentum_B
        w0 = float(np.linalg.norm(omega0))
        h0 = float(np.linalg.norm(propagator.momentum_B(omega0, x0)))
        self.omega_scale = values['angular_velocity_scale'] or (size / w0 if w0 > 0.0 else size)
        self.momentum_scale = values['momentum_scale'] or (1.25 * size / h0 if h0 > 0.0 else size)
        self.wheels = _wheels_of(propagator)

    def rows(self, first, times, omega_B, q_NB, internal):
        count = times.shape[0]
        if count == 0:
            return np.empty((0, MARKER_ROW))
        momentum_B = self.momentum_B(omega_B, internal)
        # a closed loop's one sample at a time: floats are ~20x faster than 1-row arrays
        if count == 1:
            q_values = q_NB[0].tolist()
            row = self._row(q_values, omega_B[0].tolist(), momentum_B[0].tolist())
            if self.wheels:
                row = (*row, *self._wheel_tips(omega_B, q_values, internal, single=True))
            return np.array([row])
        columns = self._row(q_NB.T, omega_B.T, momentum_B.T)
        if self.wheels:
            columns = (*columns, *self._wheel_tips(omega_B, q_NB.T, internal, single=False))
        return np.column_stack(columns)

    def _wheel_tips(self, omega_B, q_values, internal, single: bool) -> list:
        """
        Return each wheel arrow's tip ``momentum_scale Js Omega R(q_NB) g``, by components.

        The wheel's momentum relative to the body along its axis, in the inertial frame, at the H
        arrow's scale: floats for one sample (``q_values`` a list), else arrays (``q_values`` the
        quaternions' columns); element by element, the same operations, so a row does not depend
        on how blocks are cut.
        """
        tips = []
        for effect, part in self.wheels:
            relative = effect.spin_inertias * effect.wheel_speeds(omega_B, internal[:, part])
            lengths = self.momentum_scale * relative
            for index, axis in enumerate(effect.axes.tolist()):
                rotated = quaternion.rotate_values(q_values, axis)
                length = float(lengths[0, index]) if single else lengths[:, index]
                tips += [length * component for component in rotated]
        return tips

    def _row(self, q_NB, omega_B, momentum_B) -> tuple:
        """
        Build a markers row from values: floats (one sample) or arrays (a block).

        By the same operations in the same order, so a sample's row does not depend on how the
        blocks are cut.
        """
        x, y, z, w = q_NB
        # R(q_NB), as quaternion.to_matrix writes it
        r = (
            (1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)),
            (2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)),
            (2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)),
        )
        w_tip = tuple(
            self.omega_scale * (a * omega_B[0] + b * omega_B[1] + c * omega_B[2]) for a, b, c in r
        )
        h_tip = tuple(
            self.momentum_scale * (a * momentum_B[0] + b * momentum_B[1] + c * momentum_B[2])
            for a, b, c in r
        )
        sides = (
            tuple(self.sides.tolist())
            if np.ndim(x) == 0
            else tuple(np.full_like(x, s) for s in self.sides)
        )
        return quaternion.multiply_values(q_NB, self.q_BP_values) + sides + w_tip + h_tip
