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
The exact free gyrostat propagator (:mod:`torquefree_ros.core.exact.gyrostat` has the equations).

A body with rotors of constant relative momentum (``rotor`` effects) whose total ``h`` lies along a
principal axis. The regime and every constant are chosen once in the constructor; evaluation is a
pure, vectorised function of time. ``h = 0`` (or no rotor) is the free body, evaluated by the
``analytic`` propagator itself.
"""

from __future__ import annotations

import math

import numpy as np

from .analytic import AnalyticPropagator, spin_attitude
from .base import Propagator, register
from ..effects.internal import Rotor
from ..exact.gyrostat import (
    GyrostatAttitude,
    solve_gyrostat,
    solver_frame,
    UniformPrecession,
)

#: ``h`` counts as along a principal axis when its part across that axis is at most this fraction
#: of ``|h|``: the rounding of the axis itself (a few units of float64's), so the part left out
#: moves the motion no more than the inputs' own rounding does
ROTOR_AXIS_TOLERANCE = 4.0 * float(np.finfo(float).eps)


def principal_rotor(body, effects) -> tuple[int, float] | str:
    """
    Return ``(principal axis, h)`` of the scene's rotors, or why the exact gyrostat does not apply.

    Every effect must be a ``rotor``; their momenta add up to ``h`` (body frame), which must lie
    along a principal axis within :data:`ROTOR_AXIS_TOLERANCE`. No rotor: ``(0, 0.0)``.
    """
    others = [effect.name for effect in effects if not isinstance(effect, Rotor)]
    if others:
        return f"effects other than 'rotor' ({', '.join(others)})"
    h_B = np.zeros(3)
    for effect in effects:
        h_B = h_B + effect.h_B
    h_P = h_B @ body.principal_axes
    axis = int(np.argmax(np.abs(h_P)))
    size = float(np.linalg.norm(h_P))
    across = math.hypot(*(float(h_P[k]) for k in range(3) if k != axis))
    if across > ROTOR_AXIS_TOLERANCE * size:
        return (
            f'a rotor momentum {h_B.tolist()} off every principal axis '
            f'(the general oblique gyrostat is not solved in closed form here)'
        )
    return axis, float(h_P[axis])


@register
class GyrostatPropagator(Propagator):
    """The exact solution of ``I w' + w x (I w + h) = 0`` for ``h`` along a principal axis."""

    name = 'gyrostat'
    exact = True

    def __init__(self, body, angular_velocity, orientation, effects=(), **options):
        super().__init__(body, angular_velocity, orientation, effects, **options)
        rotor = principal_rotor(self.body, self.effects)
        if isinstance(rotor, str):
            raise ValueError(
                f"propagator: '{self.name}' is the exact gyrostat with rotors along a principal "
                f"axis; the scene has {rotor}: use a numerical propagator ('auto' picks one)"
            )
        axis, h = rotor
        #: the principal axis the rotors' momentum lies along, and that momentum (N m s, signed)
        self.rotor_axis, self.rotor_momentum = axis, h
        #: the regime and constants (:class:`.exact.gyrostat.GyrostatMotion`); None for the free
        #: body, a uniform precession or a relative equilibrium
        self.motion = None
        self._free = self._attitude = None
        self._stationary = False
        if h == 0.0:  # the free body, through its own path (bit for bit)
            self._free = AnalyticPropagator(self.body, self.omega0_B, self.q0_NB)
            return
        frame = solver_frame(self.body.moments, self.body.principal_axes, axis, h)
        J1, J2, J3 = frame.moments
        omega_S = [sum(r * w for r, w in zip(row, self.omega0_B.tolist())) for row in frame.rows]
        if J1 == J2:  # a rotor on the symmetry axis: a uniform precession
            self._attitude = UniformPrecession(
                J1, J3, h, self.body.principal_axes[:, axis], self.omega0_B, self.q0_NB
            )
            return
        self.motion = solve_gyrostat(frame.moments, omega_S, h)
        if self.motion is None:  # a relative equilibrium: a constant rate
            self._stationary = True
            return
        self._attitude = GyrostatAttitude(self.motion, frame, self.q0_NB)

    def _evaluate(self, times):
        if self._free is not None:
            return self._free._evaluate(times)
        if self._stationary:
            omega = np.empty((times.size, 3))
            omega[:] = self.omega0_B
            return omega, spin_attitude(self.omega0_B, self.q0_NB, times), _no_state(times)
        omega, q = self._attitude(times)
        return omega, q, _no_state(times)


def _no_state(times) -> np.ndarray:
    return np.empty((times.size, 0))
