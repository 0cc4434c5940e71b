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
The exact torque-free propagator (see :mod:`torquefree_ros.core.exact.polhode` for the equations).

The regime and every constant are chosen once in the constructor; evaluation is a pure, vectorised
function of time whose cost per sample does not depend on ``t``.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from .base import Propagator, register
from ..exact.polhode import body_polhode, exact_attitude, Polhode
from ..frames import quaternion


@register
class AnalyticPropagator(Propagator):
    name = 'analytic'
    exact = True
    supports_effects = False

    def __init__(self, body, angular_velocity, orientation, effects=(), **options):
        super().__init__(body, angular_velocity, orientation, effects, **options)
        self._attitude = exact_attitude(self.body, self.omega0_B, self.q0_NB)

    @functools.cached_property
    def polhode(self) -> Polhode | None:
        """
        Return the motion's regime parameters and Jacobi functions.

        ``None`` for a stationary motion.
        """
        return body_polhode(self.body, self.omega0_B)

    def _evaluate(self, times):
        if self._attitude is None:  # stationary: constant rate, rotation about a fixed axis
            omega = np.empty((times.size, 3))
            omega[:] = self.omega0_B
            q = spin_attitude(self.omega0_B, self.q0_NB, times)
            return omega, q, np.empty((times.size, 0))
        omega, q = self._attitude(times)
        return omega, q, np.empty((times.size, 0))


def spin_attitude(omega0_B: np.ndarray, q0_NB: np.ndarray, times) -> np.ndarray:
    """
    Return ``q0 ⊗ exp(t w / 2)`` at ``times`` for the constant rate ``w``.

    ``q0 ⊗ exp(t w / 2) = cos(|w| t / 2) q0 + sin(|w| t / 2) q0 ⊗ (w / |w|, 0)``
    (``quaternion.exp_rotation`` would find the same axis and norm again at every sample).
    """
    speed = math.hypot(*omega0_B.tolist())
    if speed == 0.0:
        q = np.empty((times.size, 4))
        q[:] = q0_NB
        return q
    axis = [v / speed for v in omega0_B.tolist()]
    turned = np.array(quaternion.multiply_values(q0_NB.tolist(), (*axis, 0.0)))
    half = (0.5 * speed) * times
    return np.cos(half)[:, None] * q0_NB + np.sin(half)[:, None] * turned
