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
External torques: a commanded torque, the gravity-gradient torque and a residual magnetic dipole.

The commanded torque is constant or piecewise constant, in the body or the inertial frame. The
gravity gradient follows the scene's orbit (or a circular orbit of its own); the residual dipole
reads the Earth's field on the scene's orbit.
"""

from __future__ import annotations

import bisect
import copy
import math

import numpy as np

from .base import MotionEffect, register
from ..checks.schema import child, choice, FieldError, listing, mapping, number, Param, vector
from ..compiled import motion_kernels
from ..environment.place import FIELD_MODELS, QUANTITIES
from ..frames import quaternion

POSITION = QUANTITIES.index('position')

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
    The gravity-gradient torque ``3 mu / r^5  r_B x (I r_B)``, on the scene's orbit or a circle.

    ``r_B = R(q)^T r_N`` is the body's position from the Earth's centre (Hughes, *Spacecraft
    Attitude Dynamics*, 1986, ch. 8). On the scene's orbit (an ``orbit:`` section, and no
    parameters here): ``r_N`` is the orbit's true position, held per environment window
    (:mod:`..environment.place`), ``mu`` the orbit's GM. Without an orbit, the special case it
    always was: a circular orbit in the inertial x-y plane, prograde about +z, the body at
    argument of latitude ``u = u0 + n t`` from +x, ``r_N = r (cos u, sin u, 0)``, and the torque
    ``3 n^2 e_B x (I e_B)`` with ``e_B = r_B / r``.
    """

    name = 'gravity_gradient'
    summary = (
        "gravity-gradient torque on the scene's orbit, or on a circular orbit of its own (radius "
        'and mu, or mean motion)'
    )
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
        if radius is not None:
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
        #: the circular orbit's mean motion, rad/s (None: the effect follows the scene's orbit)
        self.mean_motion = (
            mean_motion
            if mean_motion is not None
            else None if radius is None else float(np.sqrt(gravitational_parameter / radius**3))
        )
        self.u0 = argument_of_latitude
        self._tensor: np.ndarray | None = None

    def placed(self, place, path):
        """
        Follow the scene's orbit, or keep the circular orbit of its own parameters.

        Both, or neither, is refused with the field path.
        """
        if place is None:
            if self.mean_motion is None:
                raise FieldError(
                    child(path, 'radius'),
                    "missing (or give 'mean_motion', or the scene an 'orbit:' section, whose "
                    'orbit it then follows)',
                )
            return self
        for key in ('radius', 'mean_motion', 'gravitational_parameter', 'argument_of_latitude'):
            value = self.values[key]
            if value is not None and (key != 'argument_of_latitude' or value != 0.0):
                raise FieldError(
                    child(path, key),
                    "the scene's orbit gives the radius, the nadir and GM: remove it (a circular "
                    'orbit of its own is for scenes without an orbit)',
                )
        placed = copy.copy(self)
        placed.place = place
        placed.kernel_code = motion_kernels.ORBIT_GRAVITY_GRADIENT
        placed.environment_quantities = (POSITION,)
        return placed

    def bound(self, tensor):
        if self.mean_motion is None and self.place is None:  # (a scene places it when it loads)
            raise ValueError(
                "gravity_gradient: no orbit: give 'radius' or 'mean_motion', or place it on the "
                "scene's orbit"
            )
        bound = copy.copy(self)
        bound._tensor = tensor
        return bound

    def kernel_parameters(self):
        if self.place is not None:
            return (self.place.gm, *self._tensor.ravel().tolist())
        return (self.mean_motion, self.u0, *self._tensor.ravel().tolist())

    def radial_N(self, t: float) -> np.ndarray:
        """Return the circular orbit's radial unit vector at ``t`` (inertial frame)."""
        u = self.u0 + self.mean_motion * t
        return np.array([math.cos(u), math.sin(u), 0.0])

    def torque_B(self, t, omega_B, q_NB, state, segment_start):
        if self.place is None:
            e_B = quaternion.rotate_inverse(q_NB, self.radial_N(t))
            return 3.0 * self.mean_motion**2 * quaternion.cross(e_B, self._tensor @ e_B)
        # the kernel's operations (motion_kernels._orbit_gravity_gradient), in its order
        x, y, z = self.place.evaluate(POSITION, segment_start, t)
        r_B = quaternion.rotate_values(quaternion.conjugate_values(q_NB.tolist()), (x, y, z))
        r2 = x * x + y * y + z * z
        k = 3.0 * self.place.gm / (r2 * r2 * math.sqrt(r2))
        return k * quaternion.cross(np.array(r_B), self._tensor @ np.array(r_B))


class FieldDipole(MotionEffect):
    """
    A magnetic dipole in the Earth's field on the scene's orbit: the torque ``m x B_B``.

    ``B_B = R(q)^T B_N``, ``B_N`` the field model named by the ``field`` parameter (IGRF-14 or the
    tilted dipole), held per environment window (:mod:`..environment.place`). The one source of
    the field's slot and of the torque for every effect whose dipole sits in the field.
    """

    uses_attitude = True
    needs_orbit = True

    def placed(self, place, path):
        placed = super().placed(place, path)
        place.check_field()
        return placed

    @property
    def quantity(self) -> int:
        """Return the field's slot among the held quantities (``place.QUANTITIES``)."""
        return QUANTITIES.index(self.values['field'])

    @property
    def environment_quantities(self) -> tuple:
        return (self.quantity,)

    def dipole_torque_B(self, dipole, t, q_NB, segment_start) -> np.ndarray:
        """Return ``m x B_B`` for the body-frame ``dipole`` (A m^2): the kernels' operations."""
        m1, m2, m3 = dipole
        b_N = self.place.evaluate(self.quantity, segment_start, t)
        b1, b2, b3 = quaternion.rotate_values(quaternion.conjugate_values(q_NB.tolist()), b_N)
        return np.array([m2 * b3 - m3 * b2, m3 * b1 - m1 * b3, m1 * b2 - m2 * b1])


@register
class ResidualDipole(FieldDipole):
    """
    A magnetic dipole fixed in the body: the torque ``m x B_B``, ``B_B = R(q)^T B_N``.

    ``dipole``: ``m`` in the body frame, A m^2 (a spacecraft's residual dipole: its currents and
    magnetised parts; Wertz, *Spacecraft Attitude Determination and Control*, 1978, 17.3); ``B_N``
    the Earth's field on the scene's orbit, IGRF-14 (``field: igrf``) or the tilted dipole
    (``field: dipole``), held per environment window (:mod:`..environment.place`).
    """

    name = 'residual_dipole'
    summary = (
        "the torque m x B of a magnetic dipole fixed in the body (A m^2), B on the scene's orbit "
        '(IGRF-14 or the tilted dipole)'
    )
    kernel_code = motion_kernels.RESIDUAL_DIPOLE
    parameters = {
        'dipole': Param(
            vector(3, unit='A m^2'), description='the dipole [mx, my, mz] in the body frame, A m^2'
        ),
        'field': Param(choice(*FIELD_MODELS), 'igrf'),
    }

    def bound(self, tensor):
        if self.place is None:  # (a scene places it when it loads)
            raise ValueError("residual_dipole: needs the scene's orbit (place it there first)")
        return self

    def kernel_parameters(self):
        return (*self.values['dipole'].tolist(), float(self.quantity))

    def torque_B(self, t, omega_B, q_NB, state, segment_start):
        # the kernel's operations (motion_kernels._residual_dipole), in its order
        return self.dipole_torque_B(self.values['dipole'].tolist(), t, q_NB, segment_start)
