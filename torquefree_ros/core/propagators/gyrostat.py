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
propagator solves it exactly for any ``h``: along a principal axis of ``I_s`` by
:mod:`torquefree_ros.core.exact.gyrostat` (Jacobi functions in the solver frame), oblique to them
by :mod:`torquefree_ros.core.exact.gyrostat_oblique` (Weierstrass's solution on the momentum
sphere, Basak 2009), in the principal frame of ``I_s``. The regime and every constant are chosen
once in the constructor; evaluation is a pure, vectorised function of time.

An oblique ``h`` the closed form refuses (a motion whose curve is a circle: a uniform
precession, or a momentum beyond
:data:`OBLIQUE_MOMENTUM_RATIO` times the body's own) is no ``FreeGyrostat``:
:func:`free_gyrostat` says why, and ``auto`` integrates it. An oblique relative equilibrium
(``m x w = 0``) spins at its constant rate, as on a principal axis.

``h = 0`` is the free body ``I_s w' + w x I_s w = 0``, its rates and attitude evaluated by the
``analytic`` propagator itself (with ``I_s``): rotors whose momenta cancel, or coasting wheels
whose *absolute* momenta cancel, ``sum h_i g_i = 0`` (a null-motion distribution of a pyramid,
or two wheels on opposite axes with equal ``h_i``). Their relative momenta then cancel the
wheels' share of the body's rotation, ``sum Js_i Omega_i g_i = -sum Js_i g_i (g_i . w)``, which
the motion changes: cancelling *relative* momenta, ``sum Js_i Omega_i g_i = 0``, are not a free
body (``sum h_i g_i = sum Js_i g_i (g_i . w0)``, a gyrostat like any other).

A coasting wheel's state is ``h_i`` (constant: ``h_i' = u_i - f_i = 0``) and its angle relative
to the body, ``theta_i' = Omega_i = h_i / Js_i - g_i . w``, so
``theta_i = (h_i / Js_i) t - g_i . ∫_0^t w dt``: the relative speed is not constant (the body's
rate along ``g_i`` moves it), ``h = 0`` or not. The rates' integral comes from
:class:`~torquefree_ros.core.exact.gyrostat.RateIntegrals` (their Chebyshev series, at the
float64 floor), or for an oblique ``h`` from
:class:`~torquefree_ros.core.exact.gyrostat_oblique.ObliqueRateIntegrals` (the same, on panels
of the period), in closed form for a uniform precession and a relative equilibrium; for
``h = 0`` from the gyrostat's closed form of the same rates at ``h = 0`` (with ``I_s``'s
largest or distinct moment as the solver's axis 3).

Wheels *held* at constant relative speeds ``Omega_i`` (``reaction_wheels`` in mode ``hold``: an
ideal drive whose torque is ``u_i = Js_i g_i . w'``) are a rotor: ``I w' + w x (I w + h) = 0``
with the locked inertia ``I`` and ``h = sum Js_i Omega_i g_i``; they have no state, and each
wheel's angle is ``Omega_i t`` (the effect's own).
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
    GyrostatRates,
    RateIntegrals,
    solve_gyrostat,
    solver_frame,
    UniformPrecession,
)
from ..exact.gyrostat_oblique import (
    ObliqueAttitude,
    ObliqueMotion,
    ObliqueRateIntegrals,
    solve_oblique,
)

#: ``h`` counts as along a principal axis when its part across that axis is at most this fraction
#: of ``|h|``: the rounding of the axis itself (a few units of float64's; ``I_s``'s eigenvectors
#: carry that much when the wheels make it a full tensor), so the part left out moves the motion
#: no more than the inputs' own rounding does
ROTOR_AXIS_TOLERANCE = 4.0 * float(np.finfo(float).eps)


class FreeGyrostat(NamedTuple):
    """
    A scene's free gyrostat: its inertia, the principal axis ``h`` lies along, and ``h``.

    An oblique ``h`` (off every principal axis) has ``axis`` :data:`OBLIQUE`, ``momentum`` its
    size ``|h|``, ``momentum_P`` the vector in the principal frame of ``inertia`` and ``motion``
    its constants (:func:`.exact.gyrostat_oblique.solve_oblique`; None for a relative
    equilibrium); ``h`` along an axis or zero leaves both None.
    """

    inertia: RigidBody  # I_s: the scene's inertia less the wheels' spin
    axis: int  # the principal axis of ``inertia`` (its column) h lies along (h = 0: the solver's)
    momentum: float  # h along that axis, N m s, signed (oblique: |h|)
    momentum_P: tuple | None = None  # oblique: h in the principal frame of ``inertia``, N m s
    motion: ObliqueMotion | None = None  # oblique: the motion's constants (None: stationary)

    @property
    def oblique(self) -> bool:
        """Whether ``h`` lies off every principal axis (the general closed form solves it)."""
        return self.momentum_P is not None


#: :attr:`FreeGyrostat.axis` of an oblique ``h``: along no principal axis
OBLIQUE = -1
#: the oblique closed form forms the rates from the total momentum, ``w = I^-1 (m - h)``, so they
#: carry ``m``'s rounding: about ``eps |m| / |I w|`` relative (measured against DOP853 at rtol
#: 1e-13 on one body: 1.3e-12 at a ratio of 1.5e4, 2e-10 at 1.5e6). Beyond this ratio (with
#: ``|I w| >= sqrt(I_min 2T)``, its least value along the motion) that is over ~2e-10, the order
#: of ``auto``'s integrator tolerance, and ``auto`` integrates the scene instead
OBLIQUE_MOMENTUM_RATIO = 1e6


def free_gyrostat(body, effects, omega0_B) -> FreeGyrostat | str:
    """
    Return the scene's free gyrostat, or why the exact gyrostat does not apply.

    Every effect must be a ``rotor`` or coasting ``reaction_wheels``
    (:meth:`ReactionWheels.coasting_problem`);
    ``h`` (rotors' ``h_B`` plus the wheels' ``h_i g_i``, ``h_i`` at ``omega0_B``) along a
    principal axis of ``I_s`` within :data:`ROTOR_AXIS_TOLERANCE` is the principal-axis gyrostat;
    off every one, the oblique gyrostat (:func:`oblique_gyrostat`), unless its closed form refuses
    the state. No effect: the free body, ``h = 0``; so are momenta whose sum is within
    :data:`ROTOR_AXIS_TOLERANCE` of the sum of their sizes (its own rounding: a pyramid's
    null-motion momenta add to a few rounding units, in no particular direction), which the
    gyrostat takes as ``h = 0``: the free body with ``I_s``.
    """
    parts = gyrostat_parts(body, effects, omega0_B)
    if isinstance(parts, str):
        return parts
    inertia, h_B, total = parts
    h_P = h_B @ inertia.principal_axes
    axis = int(np.argmax(np.abs(h_P)))
    size = float(np.linalg.norm(h_P))
    if size <= ROTOR_AXIS_TOLERANCE * total:  # (0 <= 0 too: no momentum at all)
        return FreeGyrostat(inertia, free_body_axis(inertia.moments), 0.0)
    across = math.hypot(*(float(h_P[k]) for k in range(3) if k != axis))
    if across > ROTOR_AXIS_TOLERANCE * size:
        return oblique_gyrostat(inertia, h_P, omega0_B)
    return FreeGyrostat(inertia, axis, float(h_P[axis]))


def gyrostat_parts(body, effects, omega0_B) -> tuple[RigidBody, np.ndarray, float] | str:
    """
    Return ``(I_s, h_B, the momenta's summed sizes)`` of a free gyrostat's scene, or why not.

    Every effect must be a ``rotor``, ``reaction_wheels`` held at constant speeds (a rotor of
    ``sum Js_i Omega_i g_i`` with the locked inertia: :meth:`ReactionWheels.holds_speeds`) or
    coasting ones (:meth:`ReactionWheels.coasting_problem`), and ``I_s`` positive definite.
    """
    body = RigidBody.from_inertia(body)
    omega0_B = np.asarray(omega0_B, dtype=float)
    h_B, spin, wheels = np.zeros(3), np.zeros((3, 3)), False
    total = 0.0  # the sum of the momenta's sizes, N m s
    for effect in effects:
        if isinstance(effect, Rotor):
            h_B = h_B + effect.h_B
            total += float(np.linalg.norm(effect.h_B))
            continue
        if not isinstance(effect, ReactionWheels):
            return (
                "effects other than 'rotor' and held or coasting 'reaction_wheels' "
                f'({effect.name})'
            )
        if effect.holds_speeds():  # a rotor: the locked inertia, h constant
            h_B = h_B + effect.held_momentum_B()
            total += float(np.abs(effect.spin_inertias * effect.speeds).sum())
            continue
        problem = effect.coasting_problem()
        if problem is not None:
            return problem
        momenta = effect.momenta(effect.initial_state(omega0_B))
        h_B = h_B + momenta @ effect.axes
        total += float(np.abs(momenta).sum())
        spin = spin + effect.spin_inertia_B()
        wheels = True
    inertia = body
    if wheels:
        problem = remaining_inertia_problem(body.tensor, spin)
        if problem is not None:
            return problem
        inertia = spin_less_inertia(body.tensor - spin)
    return inertia, h_B, total


def oblique_gyrostat(inertia: RigidBody, h_P, omega0_B) -> FreeGyrostat | str:
    """
    Return the gyrostat with ``h_P`` off every principal axis of ``inertia``, or why not.

    Its constants are solved here, once (:func:`.exact.gyrostat_oblique.solve_oblique`, about a
    millisecond of decimal arithmetic), so that a state the closed form refuses (a circle: a
    uniform precession), whose constants overflow float64, or whose
    momentum dwarfs the body's own beyond :data:`OBLIQUE_MOMENTUM_RATIO` is said before any
    propagator is built, and ``auto`` integrates it.
    """
    h = tuple(float(v) for v in h_P)
    omega_P = inertia.to_principal(omega0_B)
    size = math.hypot(*h)
    where = f'a momentum {list(h)} N m s off every principal axis'
    try:
        motion = solve_oblique(inertia.moments, omega_P, h)
    except (ValueError, ArithmeticError, np.linalg.LinAlgError) as refusal:
        return f'{where}, which the oblique closed form refuses: {refusal}'
    if motion is not None:
        # on a separatrix (mc = 0) the period is inf: the motion tends to a saddle
        if not _finite(motion._replace(period=0.0) if motion.mc == 0.0 else motion):
            return f'{where}, whose closed form overflows float64'
        least = math.sqrt(float(inertia.moments.min()) * motion.energy)  # of |I w| on the motion
        if not motion.momentum <= OBLIQUE_MOMENTUM_RATIO * least:
            return (
                f'{where}, |I w + h| {motion.momentum:.6g} more than {OBLIQUE_MOMENTUM_RATIO:g} '
                f"times the body's own momentum (at least {least:.6g}): the oblique closed form "
                'would carry its rounding into the rates'
            )
    return FreeGyrostat(inertia, OBLIQUE, size, h, motion)


def _finite(values) -> bool:
    """Return whether every number in a nest of tuples is finite."""
    if isinstance(values, tuple):
        return all(_finite(value) for value in values)
    return not isinstance(values, float) or math.isfinite(values)


def free_body_axis(moments) -> int:
    """
    Return the principal axis the gyrostat's solver takes as its axis 3 when ``h = 0``.

    The moment the other two share, if two are equal (the solver's ``J1 = J2``: a uniform
    precession), else the largest.
    """
    a, b, c = (float(m) for m in moments)
    if a == b:
        return 2
    if a == c:
        return 1
    if b == c:
        return 0
    return int(np.argmax(moments))


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
    The exact solution of ``I_s w' + w x (I_s w + h) = 0``, ``h`` along a principal axis or not.

    Rotors and coasting reaction wheels (:func:`free_gyrostat`).
    """

    name = 'gyrostat'
    exact = True

    def __init__(self, body, angular_velocity, orientation, effects=(), **options):
        super().__init__(body, angular_velocity, orientation, effects, **options)
        found = free_gyrostat(self.body, self.effects, self.omega0_B)
        if isinstance(found, str):
            raise ValueError(
                f"propagator: '{self.name}' is the exact gyrostat with rotors or coasting wheels; "
                f"the scene has {found}: use a numerical propagator ('auto' picks one)"
            )
        h = found.momentum
        #: the principal axis (of the inertia less the wheels' spin) the momentum lies along,
        #: and that momentum (N m s, signed); an oblique momentum: :data:`OBLIQUE` and ``|h|``
        self.rotor_axis, self.rotor_momentum = found.axis, h
        #: an oblique momentum in the principal frame of that inertia (N m s); None on an axis
        self.momentum_P = found.momentum_P
        #: the regime and constants (:class:`.exact.gyrostat.GyrostatMotion`, or
        #: :class:`.exact.gyrostat_oblique.ObliqueMotion` for an oblique momentum); None for the
        #: free body, a uniform precession or a relative equilibrium
        self.motion = None
        self._free = self._attitude = self._integrals = None
        self._stationary = False
        self._wheels = self._wheel_parts()
        inertia = found.inertia
        if found.oblique:
            self._oblique(inertia, found)
            return
        if h == 0.0:
            # the free body with I_s (the body's inertia for rotors alone), through its own path
            # (bit for bit); the wheels' angles from the gyrostat's rates at h = 0
            self._free = AnalyticPropagator(inertia, self.omega0_B, self.q0_NB)
            if self._wheels:
                self._rate_integrals(inertia, found.axis, 0.0, attitude=False)
            return
        self._rate_integrals(inertia, found.axis, h, attitude=True)

    def _rate_integrals(self, inertia: RigidBody, axis: int, h: float, attitude: bool) -> None:
        """
        Choose the closed form of the motion, and of the rates' integral when wheels need it.

        ``attitude``: the rates and attitude come from it too (else from the free body's path).
        """
        frame = solver_frame(inertia.moments, inertia.principal_axes, axis, h)
        J1, J2, J3 = frame.moments
        omega_S = [sum(r * w for r, w in zip(row, self.omega0_B.tolist())) for row in frame.rows]
        free_stationary = not attitude and self._free._attitude is None
        if J1 == J2 and not free_stationary:  # a rotor on the symmetry axis: a uniform precession
            # (at h = 0 only its rates' integral is read: the free body's path gives the rest)
            self._attitude = UniformPrecession(
                J1, J3, h, inertia.principal_axes[:, axis], self.omega0_B, self.q0_NB
            )
            return
        motion = None if free_stationary else solve_gyrostat(frame.moments, omega_S, h)
        if motion is None:  # a relative equilibrium (a steady spin at h = 0): a constant rate
            self._stationary = True
            return
        if attitude:
            self.motion = motion
            self._attitude = GyrostatAttitude(motion, frame, self.q0_NB)
            rates = self._attitude.rates
        else:
            rates = GyrostatRates(motion)
        if self._wheels:
            self._integrals = RateIntegrals(rates)
            self._solver_rows = np.array(frame.rows)  # v_S = C v_B

    def _oblique(self, inertia: RigidBody, found: FreeGyrostat) -> None:
        """
        Take the oblique closed form :func:`oblique_gyrostat` solved, in ``inertia``'s frame.

        The rates and attitude by :class:`.exact.gyrostat_oblique.ObliqueAttitude` (body frame
        out), the wheels' angles by the rates' periodic integrals; a relative equilibrium spins at
        its constant rate.
        """
        if found.motion is None:
            self._stationary = True
            return
        self.motion = found.motion
        axes = inertia.principal_axes
        self._attitude = ObliqueAttitude(found.motion, found.momentum_P, axes, self.q0_NB)
        if self._wheels:
            self._integrals = ObliqueRateIntegrals(self._attitude.rates)
            self._solver_rows = axes.T  # v_P = axes^T v_B

    def _wheel_parts(self) -> tuple:
        """Return ``(slice of the states, axes (n, 3), h_i / Js_i)`` per reaction wheels effect."""
        dynamics = self.dynamics
        parts = []
        for effect, part in zip(dynamics.effects, dynamics.slices):
            if isinstance(effect, ReactionWheels) and not effect.holds_speeds():  # (held: none)
                momenta = effect.momenta(self.x0[part])
                parts.append((part, effect.axes, momenta / effect.spin_inertias))
        return tuple(parts)

    def _evaluate(self, times):
        if self._free is not None:
            omega, q, x = self._free._evaluate(times)
            if not self._wheels:
                return omega, q, x
        elif self._stationary:
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
