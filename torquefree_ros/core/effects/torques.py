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
External torques: a commanded torque and the gravity-gradient torque of a circular orbit.

The commanded torque is constant or piecewise constant, in the body or the inertial frame.
"""

from __future__ import annotations

import bisect
import copy
import math

import numpy as np

from .base import MotionEffect, register
from ..checks.schema import child, choice, FieldError, listing, mapping, number, Param, vector
from ..compiled import motion_kernels
from ..frames import quaternion

EARTH_MU = 3.986004418e14  # m^3/s^2 (WGS 84 / IERS)

_SEGMENT = mapping(
    {
        'start': Param(number(minimum=0.0, unit='s'), description='time the segment starts, s'),
        'torque': Param(vector(3, unit='N m'), description='torque [x, y, z], N m'),
    }
)


@register
class ExternalTorque(MotionEffect):
    """
    A constant or piecewise-constant torque, in the ``body`` or the ``inertial`` frame.

    ``torque`` held constant, or a ``schedule`` of segments ``{start, torque}`` each held until the
    next starts (zero before the first); in the ``body`` or the ``inertial`` frame.
    """

    name = 'external_torque'
    summary = 'a constant or piecewise-constant torque, fixed in the body or in the inertial frame'
    parameters = {
        'torque': Param(vector(3, unit='N m'), None),
        'schedule': Param(listing(_SEGMENT, min_length=1), None),
        'frame': Param(choice('body', 'inertial'), 'body'),
    }

    @classmethod
    def from_parameters(cls, values, path):
        torque, schedule = values['torque'], values['schedule']
        if (torque is None) == (schedule is None):
            raise FieldError(
                path,
                "give either 'torque' (constant) or 'schedule' (piecewise constant), not "
                + ('both' if torque is not None else 'neither'),
            )
        if schedule is not None:
            starts = [segment['start'] for segment in schedule]
            for index in range(1, len(starts)):
                if starts[index] <= starts[index - 1]:
                    raise FieldError(
                        child(child(child(path, 'schedule'), index), 'start'),
                        f'segments must start in increasing order, got {starts[index]:g} '
                        f'after {starts[index - 1]:g}',
                    )
        return cls(**values)

    def __init__(self, torque=None, schedule=None, frame='body'):
        super().__init__(torque=torque, schedule=schedule, frame=frame)
        if schedule is None:
            self._starts, self._torques = [0.0], [np.asarray(torque, float)]
        else:
            self._starts = [0.0] + [s['start'] for s in schedule if s['start'] > 0.0]
            self._torques = ([np.zeros(3)] if schedule[0]['start'] > 0.0 else []) + [
                np.asarray(s['torque'], float) for s in schedule
            ]
        self.inertial = frame == 'inertial'
        self.uses_attitude = self.inertial

    def torque_at(self, t: float) -> np.ndarray:
        """
        Return the commanded torque at ``t``, in its own frame.

        A segment holds from its start on.
        """
        return self._torques[bisect.bisect_right(self._starts, t) - 1]

    def held_torque(self, segment_start):
        return self.torque_at(segment_start), self.inertial

    def torque_B(self, t, omega_B, q_NB, state, segment_start):
        torque, inertial = self.held_torque(segment_start)
        return quaternion.rotate_inverse(q_NB, torque) if inertial else torque

    def breakpoints(self):
        return tuple(self._starts[1:])


@register
class GravityGradient(MotionEffect):
    """
    The gravity-gradient torque of a circular orbit in the inertial x-y plane.

    The orbit is prograde about +z, the body at argument of latitude ``u = u0 + n t`` from +x:
    ``r_N = r (cos u, sin u, 0)``. Torque ``3 mu / r^5  r_B x (I r_B) = 3 n^2  e_B x (I e_B)`` with
    ``e_B = R(q)^T r_N / r``.
    """

    name = 'gravity_gradient'
    summary = 'gravity-gradient torque of a circular orbit (radius and mu, or mean motion)'
    uses_attitude = True
    kernel_code = motion_kernels.GRAVITY_GRADIENT
    parameters = {
        'radius': Param(number(positive=True, unit='m'), None),
        'gravitational_parameter': Param(number(positive=True, unit='m^3/s^2'), None),
        'mean_motion': Param(number(positive=True, unit='rad/s'), None),
        'argument_of_latitude': Param(number(unit='rad'), 0.0),
    }

    @classmethod
    def from_parameters(cls, values, path):
        n, radius, mu = values['mean_motion'], values['radius'], values['gravitational_parameter']
        if n is not None and (radius is not None or mu is not None):
            raise FieldError(
                path,
                "give either 'mean_motion' or 'radius' (with 'gravitational_parameter', "
                "default Earth's), not both",
            )
        if n is None:
            if radius is None:
                raise FieldError(child(path, 'radius'), "missing (or give 'mean_motion')")
            values = {**values, 'gravitational_parameter': EARTH_MU if mu is None else mu}
        return cls(**values)

    def __init__(
        self,
        radius=None,
        gravitational_parameter=EARTH_MU,
        mean_motion=None,
        argument_of_latitude=0.0,
    ):
        super().__init__(
            radius=radius,
            gravitational_parameter=gravitational_parameter if mean_motion is None else None,
            mean_motion=mean_motion,
            argument_of_latitude=argument_of_latitude,
        )
        self.mean_motion = (
            mean_motion
            if mean_motion is not None
            else float(np.sqrt(gravitational_parameter / radius**3))
        )
        self.u0 = argument_of_latitude
        self._tensor: np.ndarray | None = None

    def bound(self, tensor):
        bound = copy.copy(self)
        bound._tensor = tensor
        return bound

    def kernel_parameters(self):
        return (self.mean_motion, self.u0, *self._tensor.ravel().tolist())

    def radial_N(self, t: float) -> np.ndarray:
        u = self.u0 + self.mean_motion * t
        return np.array([math.cos(u), math.sin(u), 0.0])

    def torque_B(self, t, omega_B, q_NB, state, segment_start):
        e_B = quaternion.rotate_inverse(q_NB, self.radial_N(t))
        return 3.0 * self.mean_motion**2 * quaternion.cross(e_B, self._tensor @ e_B)
