"""Numerical propagators: cross-checks for the exact solution and the integrators for scenes with
effects. They integrate :class:`~.dynamics.Dynamics` (Euler's equations with the effects' torques,
``q' = 1/2 q ⊗ (w, 0)``, the effects' own states) in the user's body frame with the full inertia
tensor, independently of the principal-axis machinery the exact solver uses.

Fixed-step methods advance on the grid ``t = j * step`` whatever times are asked for, and reach an
output time with one partial step from the grid point below it, so a sample does not depend on which
other samples were requested (the node asks in blocks; offline tools ask all at once). Every method
stops at the effects' breakpoints (a torque schedule's switching times), so a jump in the torque
never falls inside a step.
"""

from __future__ import annotations

import abc
import bisect
import math

import numpy as np
from scipy.integrate import DOP853

from .. import quaternion
from .base import Propagator, register


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

    def __init__(self, body, angular_velocity, orientation, effects=(), **options):
        super().__init__(body, angular_velocity, orientation, effects, **options)
        self.step = _positive_option(self.settings, "step")
        self._restart()

    def _restart(self):
        self._grid_index = 0
        self._state = (self.omega0_B.copy(), self.q0_NB.copy(), self.x0.copy())

    @abc.abstractmethod
    def advance(self, t: float, omega: np.ndarray, q: np.ndarray, x: np.ndarray, h: float) -> tuple: ...

    def _advance(self, t: float, state: tuple, h: float) -> tuple:
        """``advance`` over ``[t, t + h]``, split at the breakpoints inside it."""
        breakpoints = self.dynamics.breakpoints
        end = t + h
        index = bisect.bisect_right(breakpoints, t)
        while index < len(breakpoints) and breakpoints[index] < end:
            state = self.advance(t, *state, breakpoints[index] - t)
            t = breakpoints[index]
            index += 1
        return self.advance(t, *state, end - t)

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
        xs = np.empty((times.size, self.dynamics.state_size))
        for i, t in enumerate(times):
            j = self._grid_index_below(float(t))
            if j < self._grid_index:
                self._restart()
            while self._grid_index < j:
                self._state = self._advance(self._grid_index * self.step, self._state, self.step)
                self._grid_index += 1
            partial = float(t) - j * self.step
            omega, q, x = self._advance(j * self.step, self._state, partial) if partial > 0.0 else self._state
            omegas[i] = omega
            qs[i] = q if self.geometric else q / np.linalg.norm(q)
            xs[i] = x
        return omegas, qs, xs


@register
class RK4Propagator(FixedStepPropagator):
    """Classical fourth-order Runge-Kutta on ``(w, q, x)``; ``q`` is normalised only on output."""

    name = "rk4"

    def advance(self, t, omega, q, x, h):
        f = self.dynamics
        half = t + 0.5 * h
        k1w, k1x = f.rates(t, omega, q, x, t)
        k1q = f.q_dot(q, omega)
        w2, q2, x2 = omega + 0.5 * h * k1w, q + 0.5 * h * k1q, x + 0.5 * h * k1x
        k2w, k2x = f.rates(half, w2, q2, x2, t)
        k2q = f.q_dot(q2, w2)
        w3, q3, x3 = omega + 0.5 * h * k2w, q + 0.5 * h * k2q, x + 0.5 * h * k2x
        k3w, k3x = f.rates(half, w3, q3, x3, t)
        k3q = f.q_dot(q3, w3)
        w4, q4, x4 = omega + h * k3w, q + h * k3q, x + h * k3x
        k4w, k4x = f.rates(t + h, w4, q4, x4, t)
        k4q = f.q_dot(q4, w4)
        return (
            omega + h / 6.0 * (k1w + 2.0 * k2w + 2.0 * k3w + k4w),
            q + h / 6.0 * (k1q + 2.0 * k2q + 2.0 * k3q + k4q),
            x + h / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x),
        )


@register
class LieRK4Propagator(FixedStepPropagator):
    """Commutator-free Lie-group Runge-Kutta of order 4 (Celledoni, Marthinsen & Owren, FGCS 19,
    2003) for ``q' = q ⊗ (w/2)`` acting from the right, classical RK4 on ``w`` and ``x``. The
    attitude only ever moves by products of unit quaternions, so ``|q| = 1`` by construction; the
    renormalisation per step only removes the rounding random walk."""

    name = "lie_rk4"
    geometric = True

    def advance(self, t, omega, q, x, h):
        f = self.dynamics
        exp = quaternion.exp_rotation
        mul = quaternion.multiply
        half = t + 0.5 * h
        # Stage attitudes (Y2 = exp(h/2 F1) Y1, Y3 = exp(h/2 F2) Y1, Y4 = exp(h F3 - h/2 F1) Y2,
        # written for the right action) matter only to torques that depend on q.
        attitude = f.uses_attitude
        w1 = omega
        k1, k1x = f.rates(t, w1, q, x, t)
        w2, x2 = omega + 0.5 * h * k1, x + 0.5 * h * k1x
        q2 = mul(q, exp(0.5 * h * w1)) if attitude else q
        k2, k2x = f.rates(half, w2, q2, x2, t)
        w3, x3 = omega + 0.5 * h * k2, x + 0.5 * h * k2x
        q3 = mul(q, exp(0.5 * h * w2)) if attitude else q
        k3, k3x = f.rates(half, w3, q3, x3, t)
        w4, x4 = omega + h * k3, x + h * k3x
        q4 = mul(q2, exp(h * (w3 - 0.5 * w1))) if attitude else q
        k4, k4x = f.rates(t + h, w4, q4, x4, t)
        first = exp(h / 12.0 * (3.0 * w1 + 2.0 * w2 + 2.0 * w3 - w4))
        second = exp(h / 12.0 * (-w1 + 2.0 * w2 + 2.0 * w3 + 3.0 * w4))
        q_new = mul(mul(q, first), second)
        return (omega + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4), q_new / np.linalg.norm(q_new),
                x + h / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x))


@register
class DOP853Propagator(Propagator):
    """Adaptive explicit Runge-Kutta 8(5,3) of Dormand & Prince with its 7th-order dense output,
    scipy's implementation stepping freely (``t_bound = inf``) so that outputs never shape the steps.
    ``q`` is normalised only on output."""

    name = "dop853"
    options = {"rtol": 1e-10, "atol": 1e-12}

    def __init__(self, body, angular_velocity, orientation, effects=(), **options):
        super().__init__(body, angular_velocity, orientation, effects, **options)
        self.rtol = _positive_option(self.settings, "rtol")
        self.atol = _positive_option(self.settings, "atol")
        self._restart()

    def _rhs(self, t, y):
        omega, q, x = y[:3], y[3:7], y[7:]
        f = self.dynamics
        omega_dot, x_dot = f.rates(t, omega, q, x, self._segment_start)
        return np.concatenate([omega_dot, f.q_dot(q, omega), x_dot])

    def _restart(self):
        self._begin_segment(0.0, np.concatenate([self.omega0_B, self.q0_NB, self.x0]))

    def _begin_segment(self, t0: float, y0: np.ndarray):
        """A solver that ends at the next breakpoint (none: it steps freely)."""
        breakpoints = self.dynamics.breakpoints
        index = bisect.bisect_right(breakpoints, t0)
        bound = breakpoints[index] if index < len(breakpoints) else np.inf
        self._segment_start = t0
        self._solver = DOP853(self._rhs, t0, y0, t_bound=bound, rtol=self.rtol, atol=self.atol)
        self._step_start = t0
        self._dense = None

    def _evaluate(self, times):
        out = np.empty((times.size, 7 + self.dynamics.state_size))
        for i, t in enumerate(times):
            if t < self._step_start:
                self._restart()
            while self._solver.t < t:
                if self._solver.status == "finished":  # at a breakpoint: a new segment from here
                    self._begin_segment(self._solver.t, self._solver.y)
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
        q = out[:, 3:7]
        return out[:, :3], q / np.linalg.norm(q, axis=1, keepdims=True), out[:, 7:]
