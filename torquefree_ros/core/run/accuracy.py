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

"""How far a trajectory is from a reference: the measures the tests and benchmarks report."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..frames.quaternion import angle_between

RTOL_FLOOR = 100 * float(np.finfo(float).eps)  # the smallest rtol scipy's Runge-Kutta solvers take


def trajectory_errors(omega, q, omega_ref, q_ref):
    """
    Return the per-sample rate error and attitude error of a trajectory against a reference.

    The rate error is relative, ``|w - w_ref| / |w_ref|`` (absolute where ``w_ref = 0``); the
    attitude error is the rotation angle (rad) between ``q`` and ``q_ref`` (sign-independent).
    """
    omega, omega_ref = np.asarray(omega, float), np.asarray(omega_ref, float)
    speed = np.linalg.norm(omega_ref, axis=-1)
    rate = np.linalg.norm(omega - omega_ref, axis=-1) / np.where(speed > 0, speed, 1.0)
    return rate, angle_between(q, q_ref)


#: the estimate follows the motion for this many turns (2 pi / |w0| each): a method's error grows
#: with the angle turned, not the time (10 s for a body starting at rest); a fixed-step method at
#: most ESTIMATE_MAX_STEPS steps
ESTIMATE_TURNS = 2.0
ESTIMATE_HORIZON_AT_REST = 10.0
ESTIMATE_MAX_STEPS = 2000
_ESTIMATE_SAMPLES = 101
#: an adaptive method's steps between two of the estimate's samples (scenes in the library take
#: 1-2): the estimate is bounded work wherever it runs (the node computes it during a reset)
ESTIMATE_STEPS_PER_SAMPLE = 50


@dataclass(frozen=True)
class AccuracyEstimate:
    """
    What a propagator's settings deliver for one initial state.

    The largest attitude error (rad) and relative rate error over ``horizon_s``, measured against
    ``reference``.
    """

    attitude_rad: float
    rate_rel: float
    horizon_s: float
    reference: str
    turns: float = 0.0  # of the initial rate over the horizon

    def describe(self) -> str:
        if self.reference == EXACT:
            return 'exact (closed form: float64 rounding of the inputs)'
        seconds = f'{self.horizon_s:.3g}' if self.horizon_s < 1000.0 else f'{self.horizon_s:.0f}'
        turns = f' ({self.turns:.2g} turns)' if self.turns else ''
        return (
            f'attitude error ~{self.attitude_rad:.1e} rad, '
            f'rate error ~{self.rate_rel:.1e} (relative) '
            f'over the first {seconds} s{turns}, against {self.reference}'
        )


EXACT = 'the closed form'


def estimate_accuracy(propagator) -> AccuracyEstimate:
    """
    Measure what ``propagator``'s method and settings deliver from its initial state.

    The measure runs on fresh instances (the given one is not advanced): against the exact solution
    when no effect changes the motion, else against the same method refined (half the step, with
    Richardson's factor for its order; or tolerances / 100).
    """
    from ..propagators import propagator_class, StepBudgetExceeded

    cls = type(propagator)
    if cls.exact:
        return AccuracyEstimate(0.0, 0.0, 0.0, EXACT)
    settings = dict(propagator.settings)
    horizon = estimate_horizon(propagator.omega0_B)
    if 'step' in settings:
        horizon = min(horizon, ESTIMATE_MAX_STEPS * settings['step'])
    times = np.linspace(0.0, horizon, _ESTIMATE_SAMPLES)
    start = (propagator.body, propagator.omega0_B, propagator.q0_NB)

    def run(cls, effects=(), **options):
        fresh = cls(*start, effects, **options)
        if 'step' not in settings:  # a fixed step's work is bounded by the horizon's cap
            fresh.max_steps_per_sample = ESTIMATE_STEPS_PER_SAMPLE
        try:
            return fresh(times)
        except StepBudgetExceeded:
            raise RuntimeError(
                f'{cls.name} needs more than {ESTIMATE_STEPS_PER_SAMPLE * (times.size - 1):,} '
                f'steps over the first {horizon:.3g} s'
            ) from None

    omega, q = run(cls, propagator.effects, **settings)
    factor = 1.0
    if propagator.dynamics.torque_free:
        omega_ref, q_ref = run(propagator_class('analytic'))
        reference = 'the exact solution'
    elif 'step' in settings:
        omega_ref, q_ref = run(
            cls, propagator.effects, **{**settings, 'step': settings['step'] / 2}
        )
        factor = 2.0**cls.order / (2.0**cls.order - 1.0)
        reference = 'the same method at half the step (Richardson)'
    else:
        refined = {
            key: value / 100.0 for key, value in settings.items() if key in ('rtol', 'atol')
        }
        reference = 'the same method at tolerances / 100'
        if refined.get('rtol', RTOL_FLOOR) < RTOL_FLOOR:  # scipy would raise it (with a warning)
            refined['rtol'] = RTOL_FLOOR
            reference += f" (rtol at scipy's floor {RTOL_FLOOR:.2g})"
        omega_ref, q_ref = run(cls, propagator.effects, **{**settings, **refined})
    rate, attitude = trajectory_errors(omega, q, omega_ref, q_ref)
    turns = horizon * float(np.linalg.norm(propagator.omega0_B)) / (2.0 * np.pi)
    return AccuracyEstimate(
        factor * float(attitude.max()), factor * float(rate.max()), horizon, reference, turns
    )


def estimate_horizon(omega0_B) -> float:
    """Seconds the estimate looks ahead from this initial rate (before the fixed-step cap)."""
    speed = float(np.linalg.norm(omega0_B))
    return ESTIMATE_TURNS * 2.0 * np.pi / speed if speed > 0.0 else ESTIMATE_HORIZON_AT_REST
