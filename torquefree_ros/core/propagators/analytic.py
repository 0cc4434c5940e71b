"""The exact torque-free propagator (see :mod:`torquefree_ros.core.polhode` for the equations).

The regime and every constant are chosen once in the constructor; evaluation is a pure, vectorised
function of time whose cost per sample does not depend on ``t``.
"""

from __future__ import annotations

import numpy as np

from .. import quaternion
from ..polhode import PolhodeAttitude, solve_polhode
from .base import Propagator, register


@register
class AnalyticPropagator(Propagator):
    name = "analytic"
    exact = True
    supports_effects = False

    def __init__(self, body, angular_velocity, orientation, effects=(), **options):
        super().__init__(body, angular_velocity, orientation, effects, **options)
        omega0_P = self.body.to_principal(self.omega0_B)
        self.polhode = solve_polhode(self.body.moments, omega0_P)
        if self.polhode is None:
            self._attitude = None
            return
        # body -> solver coordinates: omega_S = C omega_B
        self._attitude = PolhodeAttitude(self.polhode, self.q0_NB, self.polhode.to_solver @ self.body.principal_axes.T)

    def _evaluate(self, times):
        if self._attitude is None:  # stationary: constant rate, rotation about a fixed axis
            omega = np.broadcast_to(self.omega0_B, (times.size, 3)).copy()
            q = quaternion.multiply(self.q0_NB, quaternion.exp_rotation(times[:, None] * self.omega0_B))
            return omega, q, np.empty((times.size, 0))
        omega, q = self._attitude(times)
        return omega, q, np.empty((times.size, 0))
