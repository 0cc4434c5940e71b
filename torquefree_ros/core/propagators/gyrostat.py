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

A body whose only motion effects are ``rotor``s (constant relative momentum) and coasting
``reaction_wheels`` (scheduled, every motor torque zero, no friction: each wheel's absolute axial
momentum ``h_i`` is then constant) is the free gyrostat ``I_s w' + w x (I_s w + h) = 0`` with
``I_s = I - sum Js g g^T`` (``I`` for rotors alone) and ``h = sum h_rotor + sum h_i g_i``; this
propagator solves it exactly when ``h`` lies along a principal axis of ``I_s``. The regime and
every constant are chosen once in the constructor; evaluation is a pure, vectorised function of
time. ``h = 0`` with rotors alone is the free body, evaluated by the ``analytic`` propagator
itself.

A coasting wheel's state is ``h_i`` (constant) and its angle relative to the body,
``theta_i = (h_i / Js_i) t - g_i . ∫_0^t w dt``: the rates' integral comes from
:class:`~torquefree_ros.core.exact.gyrostat.RateIntegrals` (their Chebyshev series, at the
float64 floor), in closed form for a uniform precession and a relative equilibrium.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from .analytic import AnalyticPropagator, spin_attitude
from .base import Propagator, register
from ..body.rigid_body import RigidBody
from ..effects import remaining_inertia_problem
from ..effects.actuators import ReactionWheels
from ..effects.internal import Rotor
from ..exact.gyrostat import (
    GyrostatAttitude,
    RateIntegrals,
    solve_gyrostat,
    solver_frame,
    UniformPrecession,
)

#: ``h`` counts as along a principal axis when its part across that axis is at most this fraction
#: of ``|h|``: the rounding of the axis itself (a few units of float64's; ``I_s``'s eigenvectors
#: carry that much when the wheels make it a full tensor), so the part left out moves the motion
#: no more than the inputs' own rounding does
ROTOR_AXIS_TOLERANCE = 4.0 * float(np.finfo(float).eps)


class FreeGyrostat(NamedTuple):
    """A scene's free gyrostat: its inertia, the principal axis ``h`` lies along, and ``h``."""

    inertia: RigidBody  # I_s: the scene's inertia less the wheels' spin
    axis: int  # the principal axis of ``inertia`` (its column) that h lies along
    momentum: float  # h along that axis, N m s, signed


def free_gyrostat(body, effects, omega0_B) -> FreeGyrostat | str:
    """
    Return the scene's free gyrostat, or why the exact gyrostat does not apply.

    Every effect must be a ``rotor`` or coasting ``reaction_wheels``
    (:meth:`ReactionWheels.coasting_problem`);
    ``h`` (rotors' ``h_B`` plus the wheels' ``h_i g_i``, ``h_i`` at ``omega0_B``) must lie along a
    principal axis of ``I_s`` within :data:`ROTOR_AXIS_TOLERANCE`. No effect: the free body,
    ``h = 0``. Wheels whose momenta sum to zero are refused: the free body's path gives no
    integral of the rates, which their angles need.
    """
    body = RigidBody.from_inertia(body)
    omega0_B = np.asarray(omega0_B, dtype=float)
    h_B, spin, wheels = np.zeros(3), np.zeros((3, 3)), False
    for effect in effects:
        if isinstance(effect, Rotor):
            h_B = h_B + effect.h_B
            continue
        if not isinstance(effect, ReactionWheels):
            return f"effects other than 'rotor' and coasting 'reaction_wheels' ({effect.name})"
        problem = effect.coasting_problem()
        if problem is not None:
            return problem
        momenta = effect.momenta(effect.initial_state(omega0_B))
        h_B = h_B + momenta @ effect.axes
        spin = spin + effect.spin_inertia_B()
        wheels = True
    inertia = body
    if wheels:
        problem = remaining_inertia_problem(body.tensor, spin)
        if problem is not None:
            return problem
        inertia = spin_less_inertia(body.tensor - spin)
    h_P = h_B @ inertia.principal_axes
    axis = int(np.argmax(np.abs(h_P)))
    size = float(np.linalg.norm(h_P))
    across = math.hypot(*(float(h_P[k]) for k in range(3) if k != axis))
    if across > ROTOR_AXIS_TOLERANCE * size:
        return (
            f'a rotor momentum {h_B.tolist()} off every principal axis '
            f'(the general oblique gyrostat is not solved in closed form here)'
        )
    if wheels and size == 0.0:
        return 'coasting wheels whose momenta sum to zero (their angles need the rates integrated)'
    return FreeGyrostat(inertia, axis, float(h_P[axis]))


def spin_less_inertia(tensor: np.ndarray) -> RigidBody:
    """
    Return ``I_s`` with its principal moments and axes, as :meth:`RigidBody.from_inertia` does.

    Without its triangle inequality: ``I_s`` (the numerical path's ``Dynamics.tensor``, the same
    subtraction) is the body less its wheels' spin, positive definite but often no rigid body's
    inertia (``I = diag(1, 2, 3)`` less ``Js = 0.4`` about axis 2), and the gyrostat's equations
    need no more.
    """
    if not np.any(tensor - np.diag(np.diag(tensor))):
        return RigidBody(tensor, np.diag(tensor).copy(), np.eye(3))
    moments, axes = np.linalg.eigh(tensor)
    if np.linalg.det(axes) < 0.0:
        axes[:, 2] = -axes[:, 2]  # a proper rotation
    return RigidBody(tensor, moments, axes)


@register
class GyrostatPropagator(Propagator):
    """
    The exact solution of ``I_s w' + w x (I_s w + h) = 0`` for ``h`` along a principal axis.

    Rotors and coasting reaction wheels (:func:`free_gyrostat`).
    """

    name = 'gyrostat'
    exact = True

    def __init__(self, body, angular_velocity, orientation, effects=(), **options):
        super().__init__(body, angular_velocity, orientation, effects, **options)
        found = free_gyrostat(self.body, self.effects, self.omega0_B)
        if isinstance(found, str):
            raise ValueError(
                f"propagator: '{self.name}' is the exact gyrostat with rotors or coasting wheels "
                f'along a principal axis; the scene has {found}: use a numerical propagator '
                "('auto' picks one)"
            )
        h = found.momentum
        #: the principal axis (of the inertia less the wheels' spin) the momentum lies along,
        #: and that momentum (N m s, signed)
        self.rotor_axis, self.rotor_momentum = found.axis, h
        #: the regime and constants (:class:`.exact.gyrostat.GyrostatMotion`); None for the free
        #: body, a uniform precession or a relative equilibrium
        self.motion = None
        self._free = self._attitude = self._integrals = None
        self._stationary = False
        self._wheels = self._wheel_parts()
        if h == 0.0:  # rotors alone: the free body, through its own path (bit for bit)
            self._free = AnalyticPropagator(self.body, self.omega0_B, self.q0_NB)
            return
        inertia = found.inertia
        frame = solver_frame(inertia.moments, inertia.principal_axes, found.axis, h)
        J1, J2, J3 = frame.moments
        omega_S = [sum(r * w for r, w in zip(row, self.omega0_B.tolist())) for row in frame.rows]
        if J1 == J2:  # a rotor on the symmetry axis: a uniform precession
            self._attitude = UniformPrecession(
                J1, J3, h, inertia.principal_axes[:, found.axis], self.omega0_B, self.q0_NB
            )
            return
        self.motion = solve_gyrostat(frame.moments, omega_S, h)
        if self.motion is None:  # a relative equilibrium: a constant rate
            self._stationary = True
            return
        self._attitude = GyrostatAttitude(self.motion, frame, self.q0_NB)
        if self._wheels:
            self._integrals = RateIntegrals(self._attitude.rates)
            self._solver_rows = np.array(frame.rows)  # v_S = C v_B

    def _wheel_parts(self) -> tuple:
        """Return ``(slice of the states, axes (n, 3), h_i / Js_i)`` per reaction wheels effect."""
        dynamics = self.dynamics
        parts = []
        for effect, part in zip(dynamics.effects, dynamics.slices):
            if isinstance(effect, ReactionWheels):
                momenta = effect.momenta(self.x0[part])
                parts.append((part, effect.axes, momenta / effect.spin_inertias))
        return tuple(parts)

    def _evaluate(self, times):
        if self._free is not None:
            return self._free._evaluate(times)
        if self._stationary:
            omega = np.empty((times.size, 3))
            omega[:] = self.omega0_B
            q = spin_attitude(self.omega0_B, self.q0_NB, times)
        else:
            omega, q = self._attitude(times)
        x = np.empty((times.size, self.dynamics.state_size))
        for part, axes, spins in self._wheels:
            x[:, part.start: part.stop: 2] = self.x0[part][0::2]  # h_i, constant
            x[:, part.start + 1: part.stop: 2] = self._wheel_angles(times, axes, spins)
        return omega, q, x

    def _wheel_angles(self, times, axes, spins):
        """Return each wheel's ``theta_i = (h_i / Js_i) t - g_i . ∫_0^t w dt``, ``(N, n)``."""
        if self._integrals is not None:
            return self._integrals.wheel_angles(times, axes @ self._solver_rows.T, spins)
        if self._stationary:  # w constant
            return np.outer(times, spins - axes @ self.omega0_B)
        mean, rest = self._attitude.rate_integral(times)  # a uniform precession
        return np.outer(times, spins - axes @ mean) - rest @ axes.T
