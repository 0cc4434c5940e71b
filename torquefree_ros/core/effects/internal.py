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
Internal momentum: a viscous nutation damper and a constant-momentum rotor (a gyrostat).

Both exchange momentum with the body only, so the total angular momentum
``R(q) (I w + h_internal)`` is constant in the inertial frame.
"""

from __future__ import annotations

import numpy as np

from .base import ENERGY, MOMENTUM, MotionEffect, register
from ..checks.schema import FieldError, number, Param, vector
from ..compiled import motion_kernels
from ..frames import quaternion


@register
class Damper(MotionEffect):
    """
    A spherical viscous damper: a rotor of scalar inertia ``J`` in a cavity filled with fluid.

    The fluid's damping coefficient is ``c`` (Hughes, *Spacecraft Attitude Dynamics*, ch. 7). Its
    state is its absolute rate ``nu`` in body components:

        I w'  + w x I w  =  c (nu - w)          (body, inertia without the damper's rotor)
        J (nu' + w x nu) = -c (nu - w)          (rotor)

    The sum conserves ``H_N``; the kinetic energy falls at ``dT/dt = -c |nu - w|^2``, so the body
    ends in a pure spin about its major axis (seed 002's major axis rule).
    """

    name = 'damper'
    summary = (
        'viscous nutation damper with its own rate: energy falls, |H| stays, '
        'the spin goes to the major axis'
    )
    state_size = 3
    conserves = frozenset({MOMENTUM})
    kernel_code = motion_kernels.DAMPER
    parameters = {
        'inertia': Param(
            number(positive=True, unit='kg m^2'),
            description="the damper rotor's inertia J, kg m^2",
        ),
        'damping': Param(
            number(positive=True, unit='N m s'), description='viscous coefficient c, N m s'
        ),
        'initial_rate': Param(vector(3, unit='rad/s'), None),
    }

    def __init__(self, inertia, damping, initial_rate=None):
        super().__init__(inertia=inertia, damping=damping, initial_rate=initial_rate)
        self.J, self.c = inertia, damping

    def initial_state(self, omega0_B):
        """Return the rotor's initial rate: the body's, unless ``initial_rate`` says otherwise."""
        rate = self.values['initial_rate']
        return np.array(omega0_B if rate is None else rate, dtype=float)

    def kernel_parameters(self):
        return (self.J, self.c)

    def torque_B(self, t, omega_B, q_NB, state, segment_start):
        return self.c * (state - omega_B)

    def state_rate(self, t, omega_B, q_NB, state, segment_start):
        return -self.c / self.J * (state - omega_B) - quaternion.cross(omega_B, state)

    def momentum_B(self, state):
        return self.J * state

    def energy(self, state):
        return 0.5 * self.J * np.einsum('...i,...i->...', state, state)


@register
class Rotor(MotionEffect):
    """
    A wheel spinning at constant relative momentum ``h`` along a body-fixed ``axis`` (a gyrostat).

    ``I w' + w x (I w + h) = 0``, ``I`` the whole body's inertia with the wheel included. Both
    ``|H|`` of body + wheel and ``w . I w / 2`` are constant.
    """

    name = 'rotor'
    summary = 'a wheel of constant relative momentum (gyrostat): total angular momentum conserved'
    conserves = frozenset({ENERGY, MOMENTUM})
    kernel_code = motion_kernels.ROTOR
    parameters = {
        'momentum': Param(
            number(unit='N m s'), description="the wheel's momentum relative to the body, N m s"
        ),
        'axis': Param(vector(3), description="the wheel's spin axis, body frame (normalised)"),
    }

    @classmethod
    def from_parameters(cls, values, path):
        if not np.linalg.norm(values['axis']) > 0.0:
            raise FieldError(f'{path}.axis', 'must not be the zero vector')
        return cls(**values)

    def __init__(self, momentum, axis):
        super().__init__(momentum=momentum, axis=axis)
        self.h_B = momentum * np.asarray(axis, float) / np.linalg.norm(axis)

    def kernel_parameters(self):
        return tuple(self.h_B.tolist())

    def torque_B(self, t, omega_B, q_NB, state, segment_start):
        return quaternion.cross(self.h_B, omega_B)

    def momentum_B(self, state):
        return np.broadcast_to(self.h_B, state.shape[:-1] + (3,))
