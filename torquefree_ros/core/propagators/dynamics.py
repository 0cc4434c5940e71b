"""The equations of motion a numerical propagator integrates: Euler's equations with the torques
of a scene's motion effects, the attitude kinematics, and the effects' own states.

    I w' = I w x w + sum(torque_B),   q' = 1/2 q ⊗ (w, 0),   x_e' = effect_e.state_rate

in the user's body frame with the full inertia tensor. Without effects this is the torque-free
right-hand side alone (no loop, no allocation beyond the cross product).
"""

from __future__ import annotations

import numpy as np

from .. import quaternion
from ..effects import ENERGY, MOMENTUM, invariants_conserved
from ..rigid_body import RigidBody


class Dynamics:
    def __init__(self, body: RigidBody, effects=()):
        self.body = body
        self.tensor = body.tensor
        self.inverse = np.linalg.inv(body.tensor)
        self.effects = tuple(effects)
        self.uses_attitude = any(effect.uses_attitude for effect in self.effects)
        self.slices = []
        offset = 0
        for effect in self.effects:
            self.slices.append(slice(offset, offset + effect.state_size))
            offset += effect.state_size
        self.state_size = offset
        self.breakpoints = tuple(sorted({t for effect in self.effects for t in effect.breakpoints()}))
        self.conserved = invariants_conserved(self.effects)

    @property
    def torque_free(self) -> bool:
        return not self.effects

    def initial_state(self, omega0_B: np.ndarray) -> np.ndarray:
        parts = [effect.initial_state(omega0_B) for effect in self.effects]
        return np.concatenate(parts) if parts else np.empty(0)

    def rates(self, t: float, omega: np.ndarray, q: np.ndarray, x: np.ndarray, segment_start: float):
        """``(w', x')`` at a state, on the smooth piece that starts at ``segment_start`` (see
        :meth:`MotionEffect.torque_B`)."""
        torque = np.cross(self.tensor @ omega, omega)
        if not self.effects:
            return self.inverse @ torque, x
        x_dot = np.empty(self.state_size)
        for effect, part in zip(self.effects, self.slices):
            state = x[part]
            torque = torque + effect.torque_B(t, omega, q, state, segment_start)
            if effect.state_size:
                x_dot[part] = effect.state_rate(t, omega, q, state)
        return self.inverse @ torque, x_dot

    @staticmethod
    def q_dot(q: np.ndarray, omega: np.ndarray) -> np.ndarray:
        return 0.5 * quaternion.multiply(q, np.append(omega, 0.0))

    # -- invariants of the whole system (body + effects' own momentum and energy) ------------------
    def momentum_B(self, omega_B: np.ndarray, x: np.ndarray) -> np.ndarray:
        total = self.body.angular_momentum(omega_B)
        for effect, part in zip(self.effects, self.slices):
            total = total + effect.momentum_B(x[..., part])
        return total

    def energy(self, omega_B: np.ndarray, x: np.ndarray) -> np.ndarray:
        total = self.body.kinetic_energy(omega_B)
        for effect, part in zip(self.effects, self.slices):
            total = total + effect.energy(x[..., part])
        return total


__all__ = ["Dynamics", "ENERGY", "MOMENTUM"]
