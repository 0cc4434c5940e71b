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
Numerical propagators: cross-checks for the exact solution and integrators for scenes with effects.

They integrate :class:`~.dynamics.Dynamics` (Euler's equations with the effects' torques,
``q' = 1/2 q ⊗ (w, 0)``, the effects' own states) in the user's body frame with the full inertia
tensor, independently of the principal-axis machinery the exact solver uses.

With numba present (and ``TORQUEFREE_ROS_KERNELS`` not ``numpy``), a propagator hands its
evaluation to the compiled kernels (``core/integrators``): the same method, stops and restarts, per
step without Python; the code here stays the reference they are tested against.

Fixed-step methods advance on the grid ``t = j * step`` whatever times are asked for, and reach an
output time with one partial step from the grid point below it, so a sample does not depend on
which other samples were requested (the node asks in blocks; offline tools ask all at once). Every
method stops at the effects' breakpoints (a torque schedule's switching times), so a jump in the
torque never falls inside a step.
"""

from __future__ import annotations

import abc
import math

import numpy as np
from scipy.integrate import DOP853

from .base import Propagator, register
from ..compiled import drivers
from ..frames import quaternion
from ..numerics import kernels
from ..numerics.steps import StepBudgetExceeded, StepTooSmall


def _positive_option(settings: dict, key: str) -> float:
    value = settings[key]
    if (
        isinstance(value, bool)
        or not isinstance(value, (int, float))
        or not math.isfinite(value)
        or value <= 0
    ):
        raise ValueError(f'{key}: must be a positive finite number, got {value!r}')
    return float(value)


#: how close (in rounding units of t) an output time must be to a grid point to be on it
_GRID_SNAP_ULPS = 4


class FixedStepPropagator(Propagator):
    """
    A one-step method on a fixed grid.

    Subclasses implement :meth:`advance` on the flat state ``y = (w, q, x)``.
    """

    options = {'step': 1e-3}
    #: the order of the global error (for the step-halving error estimate)
    order = 4
    #: True when the method keeps |q| = 1 by construction (no output normalisation)
    geometric = False

    #: the method's code in the compiled kernels
    kernel_method: int

    def __init__(self, body, angular_velocity, orientation, effects=(), **options):
        super().__init__(body, angular_velocity, orientation, effects, **options)
        self.step = _positive_option(self.settings, 'step')
        self._kernel = (
            drivers.FixedStepKernel(self, self.kernel_method) if kernels.ENABLED else None
        )
        self._restart()

    @property
    def compiled(self) -> bool:
        return self._kernel is not None

    def _restart(self):
        self._grid_index = 0
        self._y = np.concatenate([self.omega0_B, self.q0_NB, self.x0])
        if self._kernel is not None:
            self._kernel.restart()

    @abc.abstractmethod
    def advance(self, t: float, y: np.ndarray, h: float) -> np.ndarray: ...

    def _advance(self, t: float, y: np.ndarray, h: float) -> np.ndarray:
        """``advance`` over ``[t, t + h]``, split at the breakpoints inside it."""
        end = t + h
        stop = self.dynamics.next_breakpoint(t)
        while stop < end:
            y = self.advance(t, y, stop - t)
            t, stop = stop, self.dynamics.next_breakpoint(stop)
        return self.advance(t, y, end - t)

    def _grid_point(self, t: float) -> tuple[int, float]:
        """
        Return the grid point ``j`` at or below ``t`` and the partial step from it.

        A time within rounding of a grid point is on it, so a 100 Hz output on a 1 ms grid takes no
        extra partial step.
        """
        j = round(t / self.step)
        if abs(t - j * self.step) <= _GRID_SNAP_ULPS * math.ulp(t):
            return j, 0.0
        j = math.floor(t / self.step)
        if (j + 1) * self.step <= t:
            j += 1
        elif j * self.step > t:
            j -= 1
        return j, t - j * self.step

    def _evaluate(self, times):
        if self._kernel is not None and self._kernel.whole_loop:
            out = self._kernel.evaluate(times)
            q = out[:, 3:7]
            if not self.geometric:
                q = q / np.linalg.norm(q, axis=1, keepdims=True)
            return out[:, :3], q, out[:, 7:]
        out = np.empty((times.size, 7 + self.dynamics.state_size))
        for i, t in enumerate(times.tolist()):
            j, partial = self._grid_point(t)
            if j < self._grid_index:
                self._restart()
            budget = self.max_steps_per_sample
            if budget is not None and j - self._grid_index > budget:
                raise StepBudgetExceeded(self, t, self.step)
            if self._kernel is not None:
                self._kernel.advance_grid(self._grid_index, j, self.step)
                self._grid_index = j
                out[i] = (
                    self._kernel.partial_step(j * self.step, partial)
                    if partial > 0.0
                    else self._kernel.y
                )
                continue
            while self._grid_index < j:
                self._y = self._advance(self._grid_index * self.step, self._y, self.step)
                self._grid_index += 1
            out[i] = self._advance(j * self.step, self._y, partial) if partial > 0.0 else self._y
        q = out[:, 3:7]
        if not self.geometric:
            q = q / np.linalg.norm(q, axis=1, keepdims=True)
        return out[:, :3], q, out[:, 7:]


@register
class RK4Propagator(FixedStepPropagator):
    """Classical fourth-order Runge-Kutta on ``(w, q, x)``; ``q`` is normalised only on output."""

    name = 'rk4'
    kernel_method = drivers.kernels.RK4

    def advance(self, t, y, h):
        f = self.dynamics.derivative
        half = t + 0.5 * h
        k1 = f(t, y, t)
        k2 = f(half, y + (0.5 * h) * k1, t)
        k3 = f(half, y + (0.5 * h) * k2, t)
        k4 = f(t + h, y + h * k3, t)
        return y + (h / 6.0) * (k1 + 2.0 * (k2 + k3) + k4)


@register
class LieRK4Propagator(FixedStepPropagator):
    """
    Commutator-free Lie-group Runge-Kutta of order 4 for the attitude.

    After Celledoni, Marthinsen & Owren (FGCS 19, 2003), for ``q' = q ⊗ (w/2)`` acting from the
    right; classical RK4 on ``w`` and ``x``. The attitude only ever moves by products of unit
    quaternions, so ``|q| = 1`` by construction; the renormalisation per step only removes the
    rounding random walk.
    """

    name = 'lie_rk4'
    kernel_method = drivers.kernels.LIE_RK4
    geometric = True

    def advance(self, t, y, h):
        f = self.dynamics.derivative
        exp = quaternion.exp_rotation
        mul = quaternion.multiply
        half = t + 0.5 * h
        # Stage attitudes (Y2 = exp(h/2 F1) Y1, Y3 = exp(h/2 F2) Y1, Y4 = exp(h F3 - h/2 F1) Y2,
        # written for the right action) matter only to torques that depend on q; otherwise the
        # stages' q slots are never read.
        attitude = self.dynamics.uses_attitude
        q, w1 = y[3:7], y[:3]
        k1 = f(t, y, t)
        y2 = y + (0.5 * h) * k1
        if attitude:
            y2[3:7] = mul(q, exp((0.5 * h) * w1))
        k2 = f(half, y2, t)
        y3 = y + (0.5 * h) * k2
        if attitude:
            y3[3:7] = mul(q, exp((0.5 * h) * y2[:3]))
        k3 = f(half, y3, t)
        y4 = y + h * k3
        if attitude:
            y4[3:7] = mul(y2[3:7], exp(h * (y3[:3] - 0.5 * w1)))
        k4 = f(t + h, y4, t)
        y_new = y + (h / 6.0) * (k1 + 2.0 * (k2 + k3) + k4)
        w2, w3, w4 = y2[:3], y3[:3], y4[:3]
        middle = 2.0 * (w2 + w3)
        q_new = mul(
            mul(q, exp((h / 12.0) * (3.0 * w1 + middle - w4))),
            exp((h / 12.0) * (middle - w1 + 3.0 * w4)),
        )
        y_new[3:7] = q_new / math.sqrt(q_new @ q_new)
        return y_new


@register
class DOP853Propagator(Propagator):
    """
    Adaptive explicit Runge-Kutta 8(5,3) of Dormand & Prince with its 7th-order dense output.

    scipy's implementation, stepping freely (``t_bound = inf``) so that outputs never shape the
    steps. ``q`` is normalised only on output.
    """

    name = 'dop853'
    options = {'rtol': 1e-10, 'atol': 1e-12}
    # An explicit method whose step collapses far below the motion's own time scale is stability-
    # limited by stiff effects (a damper with damping 1e9): it would take ~forever, so it stops.
    MIN_STEP_PER_TURN = 1e-7

    def __init__(self, body, angular_velocity, orientation, effects=(), **options):
        super().__init__(body, angular_velocity, orientation, effects, **options)
        self.rtol = _positive_option(self.settings, 'rtol')
        self.atol = _positive_option(self.settings, 'atol')
        speed = float(np.linalg.norm(self.omega0_B))
        self.min_step = self.MIN_STEP_PER_TURN * min(
            1.0, 2.0 * math.pi / speed if speed > 0 else 1.0
        )
        self._kernel = drivers.DOP853Kernel(self) if kernels.ENABLED else None
        self._restart()

    @property
    def compiled(self) -> bool:
        return self._kernel is not None

    def _rhs(self, t, y):
        return self.dynamics.derivative(t, y, self._segment_start)

    def _restart(self):
        # the first segment's solver is made when the first step is due, not now: scipy evaluates
        # the right-hand side as it is made, and a commanded torque may only be known by then
        self._solver = _SegmentStart(0.0, np.concatenate([self.omega0_B, self.q0_NB, self.x0]))
        self._segment_start = self._step_start = 0.0
        if self._kernel is not None:
            self._kernel.restart()

    def _advance_past(self, t: float):
        """Step until the solver's last step reaches ``t``; returns the solver."""
        solver = self._solver
        budget = self.max_steps_per_sample
        steps = 0
        while solver.t < t:
            steps += 1
            if budget is not None and steps > budget:
                raise StepBudgetExceeded(self, t, solver.step_size)
            if solver.status == 'finished':  # at a breakpoint: a new segment from here
                self._begin_segment(solver.t, solver.y)
                solver = self._solver
            self._step_start = solver.t
            solver.step()
            # scipy's "Required step size is less than spacing between numbers"
            if solver.status == 'failed':
                raise StepTooSmall(self, solver.t)
            if solver.step_size < self.min_step and solver.status != 'finished':
                raise RuntimeError(
                    f'dop853: the step fell to {solver.step_size:.2g} s at t = {solver.t:.6g} s, '
                    f'under {self.min_step:.2g} s (1e-7 of a turn): '
                    "the scene's effects are too stiff for an explicit integrator"
                )
        return solver

    def _begin_segment(self, t0: float, y0: np.ndarray):
        """
        Make a solver that ends at the next breakpoint (none: it steps freely).

        Made when its first step is due (scipy evaluates the right-hand side at ``t0`` as it is
        made).
        """
        bound = self.dynamics.next_breakpoint(t0)
        self._segment_start = t0
        self._solver = DOP853(self._rhs, t0, y0, t_bound=bound, rtol=self.rtol, atol=self.atol)
        self._step_start = t0

    def _evaluate(self, times):
        if self._kernel is not None:  # (q normalised by the kernel)
            out = self._kernel.evaluate(times)
            return out[:, :3], out[:, 3:7], out[:, 7:]
        out = np.empty((times.size, 7 + self.dynamics.state_size))
        i = 0
        # scipy's min-step guard underflows (nextafter(0) - 0); a scene that overflows its stages
        # ends in StepTooSmall, our message, without numpy's warnings about the steps on the way
        with np.errstate(all='ignore'):
            while i < times.size:
                if times[i] < self._step_start:
                    self._restart()
                solver = self._advance_past(float(times[i]))
                # every output time up to the step's end: its state, or one dense output for the
                # rest
                end = int(np.searchsorted(times, solver.t, side='right'))
                dense_end = end
                if times[end - 1] == solver.t:
                    out[end - 1] = solver.y
                    dense_end -= 1
                if dense_end > i:
                    out[i:dense_end] = solver.dense_output()(times[i:dense_end]).T
                i = end
        q = out[:, 3:7]
        return out[:, :3], q / np.linalg.norm(q, axis=1, keepdims=True), out[:, 7:]


class _SegmentStart:
    """
    Where the next segment starts, before its solver exists.

    A finished solver's ``t`` and ``y``.
    """

    status = 'finished'

    def __init__(self, t: float, y: np.ndarray):
        self.t, self.y = t, y
