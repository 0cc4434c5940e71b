"""How far a trajectory is from a reference: the measures the tests and benchmarks report."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .quaternion import angle_between


def trajectory_errors(omega, q, omega_ref, q_ref):
    """Per sample: relative rate error ``|w - w_ref| / |w_ref|`` (absolute where ``w_ref = 0``) and
    attitude error, the rotation angle (rad) between ``q`` and ``q_ref`` (sign-independent)."""
    omega, omega_ref = np.asarray(omega, float), np.asarray(omega_ref, float)
    speed = np.linalg.norm(omega_ref, axis=-1)
    rate = np.linalg.norm(omega - omega_ref, axis=-1) / np.where(speed > 0, speed, 1.0)
    return rate, angle_between(q, q_ref)


#: the estimate looks this far ahead (s), and a fixed-step method at most this many steps
ESTIMATE_HORIZON = 10.0
ESTIMATE_MAX_STEPS = 2000
_ESTIMATE_SAMPLES = 21


@dataclass(frozen=True)
class AccuracyEstimate:
    """What a propagator's settings deliver for one initial state: the largest attitude error (rad)
    and relative rate error over ``horizon_s``, measured against ``reference``."""

    attitude_rad: float
    rate_rel: float
    horizon_s: float
    reference: str

    def describe(self) -> str:
        if self.reference == EXACT:
            return "exact (closed form: float64 rounding of the inputs)"
        return (f"attitude error ~{self.attitude_rad:.1e} rad, rate error ~{self.rate_rel:.1e} (relative) "
                f"over the first {self.horizon_s:g} s, against {self.reference}")


EXACT = "the closed form"


def estimate_accuracy(propagator) -> AccuracyEstimate:
    """Measure what ``propagator``'s method and settings deliver from its initial state, on fresh
    instances (the given one is not advanced): against the exact solution when no effect changes the
    motion, else against the same method refined (half the step, with Richardson's factor for its
    order; or tolerances / 100)."""
    from .propagators import propagator_class

    cls = type(propagator)
    if cls.exact:
        return AccuracyEstimate(0.0, 0.0, 0.0, EXACT)
    settings = dict(propagator.settings)
    horizon = ESTIMATE_HORIZON
    if "step" in settings:
        horizon = min(horizon, ESTIMATE_MAX_STEPS * settings["step"])
    times = np.linspace(0.0, horizon, _ESTIMATE_SAMPLES)
    start = (propagator.body, propagator.omega0_B, propagator.q0_NB)
    omega, q = cls(*start, propagator.effects, **settings)(times)
    factor = 1.0
    if propagator.dynamics.torque_free:
        omega_ref, q_ref = propagator_class("analytic")(*start)(times)
        reference = "the exact solution"
    elif "step" in settings:
        omega_ref, q_ref = cls(*start, propagator.effects, **{**settings, "step": settings["step"] / 2})(times)
        factor = 2.0**cls.order / (2.0**cls.order - 1.0)
        reference = "the same method at half the step (Richardson)"
    else:
        refined = {key: value / 100.0 for key, value in settings.items() if key in ("rtol", "atol")}
        omega_ref, q_ref = cls(*start, propagator.effects, **{**settings, **refined})(times)
        reference = "the same method at tolerances / 100"
    rate, attitude = trajectory_errors(omega, q, omega_ref, q_ref)
    return AccuracyEstimate(factor * float(attitude.max()), factor * float(rate.max()), horizon, reference)
