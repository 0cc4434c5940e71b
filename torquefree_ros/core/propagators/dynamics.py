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
The equations of motion a numerical propagator integrates.

Euler's equations with the torques of a scene's motion effects, the attitude kinematics, and the
effects' own states.

    I' w' = I' w x w + sum(torque_B),   q' = 1/2 q ⊗ (w, 0),   x_e' = effect_e.state_rate

in the user's body frame, on one flat state ``y = (w, q, x)``. ``I'`` is the full inertia tensor
``I`` less the inertia the effects carry in their own states (``spin_inertia_B``: reaction
wheels' ``sum Js g g^T``, whose momentum ``Js (Omega + g . w)`` each wheel's state holds; Schaub &
Junkins, *Analytical Mechanics of Space Systems*, ch. 4): ``I' = I`` for every other scene, bit for
bit. The invariants count the whole system: ``H_B = I' w + sum(momentum_B(x_e))`` and
``T = w . I' w / 2 + sum(energy(x_e))``. Without effects this is the torque-free right-hand side
alone (no loop over effects). Effects on an orbit read the environment held per window
(``environment.place``): the window ends are breakpoints.
"""

from __future__ import annotations

import bisect
import math

import numpy as np

from ..body.rigid_body import RigidBody
from ..effects import ENERGY, invariants_conserved, MOMENTUM, remaining_inertia_problem
from ..environment.place import next_window_end


class Dynamics:

    def __init__(self, body: RigidBody, effects=()):
        self.body = body
        self.effects = tuple(effects)
        spin = np.zeros((3, 3))
        for effect in self.effects:
            spin = spin + effect.spin_inertia_B()
        #: the inertia the effects carry in their own states (wheels' spin), body frame
        self.spin_inertia_B = spin
        self._spin = bool(spin.any())
        if self._spin:
            problem = remaining_inertia_problem(body.tensor, spin)
            if problem is not None:  # (each effect alone passed this when bound to the body)
                raise ValueError(f'effects: {problem}')
        #: the inertia Euler's equations are integrated with: the body's less ``spin_inertia_B``
        self.tensor = body.tensor - spin if self._spin else body.tensor
        self._tensor_rows = tuple(map(tuple, self.tensor.tolist()))
        self._inverse_rows = tuple(map(tuple, np.linalg.inv(self.tensor).tolist()))
        self.uses_attitude = any(effect.uses_attitude for effect in self.effects)
        self.slices = []
        offset = 0
        for effect in self.effects:
            self.slices.append(slice(offset, offset + effect.state_size))
            offset += effect.state_size
        self.state_size = offset
        self.breakpoints = tuple(
            sorted({t for effect in self.effects for t in effect.breakpoints()})
        )
        self.conserved = invariants_conserved(self.effects)
        #: an effect whose torque changes only at sample times (a controller's command) makes every
        #: sample time ``k / sample_rate`` a breakpoint; the simulation sets the rate
        self.holds_per_sample = any(effect.holds_per_sample for effect in self.effects)
        self.sample_rate: float | None = None
        places = {effect.place for effect in self.effects if effect.place is not None}
        if len(places) > 1:
            raise ValueError('effects: placed on different orbits (a scene has one)')
        #: the scene's place when an effect reads the environment (``environment.place.Place``):
        #: every environment window's end is then a breakpoint, so that a piece holds one window
        self.place = places.pop() if places else None

    def next_breakpoint(self, t: float) -> float:
        """Return the first breakpoint after ``t`` (``inf`` when none)."""
        index = bisect.bisect_right(self.breakpoints, t)
        following = self.breakpoints[index] if index < len(self.breakpoints) else math.inf
        rate = self.sample_rate
        if rate is not None:
            # the sample time k / rate just after t, as samples compute it
            k = math.floor(t * rate) + 1
            while k > 1 and (k - 1) / rate > t:
                k -= 1
            while k / rate <= t:
                k += 1
            following = min(following, k / rate)
        if self.place is not None:
            following = min(following, next_window_end(t))
        return following

    @property
    def torque_free(self) -> bool:
        return not self.effects

    def initial_state(self, omega0_B: np.ndarray) -> np.ndarray:
        parts = [effect.initial_state(omega0_B) for effect in self.effects]
        return np.concatenate(parts) if parts else np.empty(0)

    def derivative(self, t: float, y: np.ndarray, segment_start: float) -> np.ndarray:
        """
        Return ``y'`` of the flat state ``y = (w, q, x)``.

        On the smooth piece that starts at ``segment_start`` (see :meth:`MotionEffect.torque_B`).
        The rigid body's part is plain float arithmetic: it is evaluated once per stage, and
        numpy's per-call cost would dominate.
        """
        w1, w2, w3, qx, qy, qz, qw = y[:7].tolist()
        (a11, a12, a13), (a21, a22, a23), (a31, a32, a33) = self._tensor_rows  # I'
        h1, h2, h3 = (
            a11 * w1 + a12 * w2 + a13 * w3,
            a21 * w1 + a22 * w2 + a23 * w3,
            a31 * w1 + a32 * w2 + a33 * w3,
        )
        m1, m2, m3 = h2 * w3 - h3 * w2, h3 * w1 - h1 * w3, h1 * w2 - h2 * w1  # (I' w) x w
        if self.effects:
            torque, x_dot = self._effect_terms(t, y, segment_start)
            e1, e2, e3 = torque.tolist()
            m1, m2, m3 = m1 + e1, m2 + e2, m3 + e3
        (b11, b12, b13), (b21, b22, b23), (b31, b32, b33) = self._inverse_rows
        rates = np.array(
            [
                b11 * m1 + b12 * m2 + b13 * m3,
                b21 * m1 + b22 * m2 + b23 * m3,
                b31 * m1 + b32 * m2 + b33 * m3,
                # q' = 1/2 q ⊗ (w, 0)
                0.5 * (qw * w1 + qy * w3 - qz * w2),
                0.5 * (qw * w2 - qx * w3 + qz * w1),
                0.5 * (qw * w3 + qx * w2 - qy * w1),
                -0.5 * (qx * w1 + qy * w2 + qz * w3),
            ]
        )
        return np.concatenate([rates, x_dot]) if self.effects else rates

    def _effect_terms(self, t, y, segment_start):
        omega, q, x = y[:3], y[3:7], y[7:]
        torque = np.zeros(3)
        x_dot = np.empty(self.state_size)
        for effect, part in zip(self.effects, self.slices):
            state = x[part]
            torque = torque + effect.torque_B(t, omega, q, state, segment_start)
            if effect.state_size:
                x_dot[part] = effect.state_rate(t, omega, q, state, segment_start)
        return torque, x_dot

    def overflowing_effect(
        self, omega_B: np.ndarray, q_NB: np.ndarray, x: np.ndarray
    ) -> int | None:
        """
        Find the first effect whose torque or state rate is not finite at this state.

        Return its index, or None; such an effect has a parameter like a mean motion of 1e308.
        """
        with np.errstate(all='ignore'):
            for index, (effect, part) in enumerate(zip(self.effects, self.slices)):
                state = x[part]
                try:
                    terms = [effect.torque_B(0.0, omega_B, q_NB, state, 0.0)]
                    if effect.state_size:
                        terms.append(effect.state_rate(0.0, omega_B, q_NB, state, 0.0))
                    terms.append(np.linalg.solve(self.tensor, terms[0]))
                except OverflowError:  # Python floats raise where numpy gives inf
                    return index
                if not all(np.all(np.isfinite(term)) for term in terms):
                    return index
        return None

    # -- invariants of the whole system (body + effects' own momentum and energy) -----------------
    def momentum_B(self, omega_B: np.ndarray, x: np.ndarray) -> np.ndarray:
        total = self.body.angular_momentum(omega_B)
        if self._spin:  # that momentum is in the effects' states
            total = total - np.einsum('ij,...j->...i', self.spin_inertia_B, omega_B)
        for effect, part in zip(self.effects, self.slices):
            total = total + effect.momentum_B(x[..., part])
        return total

    def energy(self, omega_B: np.ndarray, x: np.ndarray) -> np.ndarray:
        total = self.body.kinetic_energy(omega_B)
        if self._spin:
            spin_w = np.einsum('ij,...j->...i', self.spin_inertia_B, omega_B)
            total = total - 0.5 * np.einsum('...i,...i->...', omega_B, spin_w)
        for effect, part in zip(self.effects, self.slices):
            total = total + effect.energy(x[..., part])
        return total


__all__ = ['Dynamics', 'ENERGY', 'MOMENTUM']
