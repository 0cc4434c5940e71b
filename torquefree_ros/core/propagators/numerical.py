"""Numerical propagators: cross-checks for the exact solution and, later, the integrators for scenes
with torques. They integrate Euler's equations ``I w' + w x I w = tau`` and
``q' = 1/2 q ⊗ (w, 0)`` in the user's body frame with the full inertia tensor, independently of the
principal-axis machinery the exact solver uses.

Fixed-step methods advance on the grid ``t = j * step`` whatever times are asked for, and reach an
output time with one partial step from the grid point below it, so a sample does not depend on which
other samples were requested (the node asks in blocks; offline tools ask all at once).
"""

from __future__ import annotations

import abc
import math

import numpy as np
from scipy.integrate import DOP853

from .. import quaternion
from .base import Propagator, register


class _Dynamics:
    """Torque-free right-hand side in the body frame."""

    def __init__(self, tensor: np.ndarray):
        self.tensor = tensor
        self.inverse = np.linalg.inv(tensor)

    def omega_dot(self, omega: np.ndarray) -> np.ndarray:
        return self.inverse @ np.cross(self.tensor @ omega, omega)

    @staticmethod
    def q_dot(q: np.ndarray, omega: np.ndarray) -> np.ndarray:
        return 0.5 * quaternion.multiply(q, np.append(omega, 0.0))


def _positive_option(settings: dict, key: str) -> float:
    value = settings[key]
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
        raise ValueError(f"{key}: must be a positive finite number, got {value!r}")
    return float(value)


class FixedStepPropagator(Propagator):
    """A one-step method on a fixed grid; subclasses implement :meth:`advance`."""

    options = {"step": 1e-3}
    #: True when the method keeps |q| = 1 by construction (no output normalisation)
    geometric = False

    def __init__(self, body, angular_velocity, orientation, **options):
        super().__init__(body, angular_velocity, orientation, **options)
        self.step = _positive_option(self.settings, "step")
        self.dynamics = _Dynamics(self.body.tensor)
        self._restart()

    def _restart(self):
        self._grid_index = 0
        self._state = (self.omega0_B.copy(), self.q0_NB.copy())

    @abc.abstractmethod
    def advance(self, omega: np.ndarray, q: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray]: ...

    def _grid_index_below(self, t: float) -> int:
        j = math.floor(t / self.step)
        if (j + 1) * self.step <= t:
            j += 1
        elif j * self.step > t:
            j -= 1
        return j

    def _evaluate(self, times):
        omegas = np.empty((times.size, 3))
        qs = np.empty((times.size, 4))
        for i, t in enumerate(times):
            j = self._grid_index_below(float(t))
            if j < self._grid_index:
                self._restart()
            while self._grid_index < j:
                self._state = self.advance(*self._state, self.step)
                self._grid_index += 1
            partial = float(t) - j * self.step
            omega, q = self.advance(*self._state, partial) if partial > 0.0 else self._state
            omegas[i] = omega
            qs[i] = q if self.geometric else q / np.linalg.norm(q)
        return omegas, qs


@register
class RK4Propagator(FixedStepPropagator):
    """Classical fourth-order Runge-Kutta on ``(w, q)``; ``q`` is normalised only on output."""

    name = "rk4"

    def advance(self, omega, q, h):
        f = self.dynamics
        k1w, k1q = f.omega_dot(omega), f.q_dot(q, omega)
        w2, q2 = omega + 0.5 * h * k1w, q + 0.5 * h * k1q
        k2w, k2q = f.omega_dot(w2), f.q_dot(q2, w2)
        w3, q3 = omega + 0.5 * h * k2w, q + 0.5 * h * k2q
        k3w, k3q = f.omega_dot(w3), f.q_dot(q3, w3)
        w4, q4 = omega + h * k3w, q + h * k3q
        k4w, k4q = f.omega_dot(w4), f.q_dot(q4, w4)
        return (
            omega + h / 6.0 * (k1w + 2.0 * k2w + 2.0 * k3w + k4w),
            q + h / 6.0 * (k1q + 2.0 * k2q + 2.0 * k3q + k4q),
        )


@register
class LieRK4Propagator(FixedStepPropagator):
    """Commutator-free Lie-group Runge-Kutta of order 4 (Celledoni, Marthinsen & Owren, FGCS 19,
    2003) for ``q' = q ⊗ (w/2)`` acting from the right, classical RK4 on ``w``. The attitude only
    ever moves by products of unit quaternions, so ``|q| = 1`` by construction; the renormalisation
    per step only removes the rounding random walk."""

    name = "lie_rk4"
    geometric = True

    def advance(self, omega, q, h):
        f = self.dynamics
        exp = quaternion.exp_rotation
        mul = quaternion.multiply
        k1 = f.omega_dot(omega)
        w2 = omega + 0.5 * h * k1
        k2 = f.omega_dot(w2)
        w3 = omega + 0.5 * h * k2
        k3 = f.omega_dot(w3)
        w4 = omega + h * k3
        k4 = f.omega_dot(w4)
        # Stage attitudes are not needed for torque-free motion (w' does not depend on q); the
        # frozen rates of the four stages are the stage rates w1..w4.
        w1 = omega
        first = exp(h / 12.0 * (3.0 * w1 + 2.0 * w2 + 2.0 * w3 - w4))
        second = exp(h / 12.0 * (-w1 + 2.0 * w2 + 2.0 * w3 + 3.0 * w4))
        q_new = mul(mul(q, first), second)
        return omega + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4), q_new / np.linalg.norm(q_new)


@register
class DOP853Propagator(Propagator):
    """Adaptive explicit Runge-Kutta 8(5,3) of Dormand & Prince with its 7th-order dense output,
    scipy's implementation stepping freely (``t_bound = inf``) so that outputs never shape the steps.
    ``q`` is normalised only on output."""

    name = "dop853"
    options = {"rtol": 1e-10, "atol": 1e-12}

    def __init__(self, body, angular_velocity, orientation, **options):
        super().__init__(body, angular_velocity, orientation, **options)
        self.rtol = _positive_option(self.settings, "rtol")
        self.atol = _positive_option(self.settings, "atol")
        self.dynamics = _Dynamics(self.body.tensor)
        self._restart()

    def _rhs(self, t, y):
        omega, q = y[:3], y[3:]
        return np.concatenate([self.dynamics.omega_dot(omega), self.dynamics.q_dot(q, omega)])

    def _restart(self):
        y0 = np.concatenate([self.omega0_B, self.q0_NB])
        self._solver = DOP853(self._rhs, 0.0, y0, t_bound=np.inf, rtol=self.rtol, atol=self.atol)
        self._step_start = 0.0
        self._dense = None

    def _evaluate(self, times):
        out = np.empty((times.size, 7))
        for i, t in enumerate(times):
            if t < self._step_start:
                self._restart()
            while self._solver.t < t:
                self._step_start = self._solver.t
                with np.errstate(under="ignore"):  # scipy's min-step guard: nextafter(0) - 0
                    message = self._solver.step()
                if self._solver.status == "failed":
                    raise RuntimeError(f"dop853 failed at t = {self._solver.t}: {message}")
                self._dense = None
            if t == self._solver.t:
                out[i] = self._solver.y
            else:
                if self._dense is None:  # built only for steps that hold an output time
                    self._dense = self._solver.dense_output()
                out[i] = self._dense(t)
        q = out[:, 3:]
        return out[:, :3], q / np.linalg.norm(q, axis=1, keepdims=True)
