"""How far a trajectory is from a reference: the measures the tests and benchmarks report."""

from __future__ import annotations

import numpy as np

from .quaternion import angle_between


def trajectory_errors(omega, q, omega_ref, q_ref):
    """Per sample: relative rate error ``|w - w_ref| / |w_ref|`` (absolute where ``w_ref = 0``) and
    attitude error, the rotation angle (rad) between ``q`` and ``q_ref`` (sign-independent)."""
    omega, omega_ref = np.asarray(omega, float), np.asarray(omega_ref, float)
    speed = np.linalg.norm(omega_ref, axis=-1)
    rate = np.linalg.norm(omega - omega_ref, axis=-1) / np.where(speed > 0, speed, 1.0)
    return rate, angle_between(q, q_ref)
