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

"""The dynamics core: numpy and scipy only, no ROS (a test enforces it)."""

from .body.rigid_body import MotionRegime, RigidBody
from .propagators import make_propagator, Propagator, PROPAGATORS
from .propagators.batch import propagate_batch


def propagate(inertia, angular_velocity, orientation, times, propagator='auto', **options):
    """
    Return the torque-free ``(omega_B, q_NB)`` at the sorted ``times`` (s).

    The shapes are ``(N, 3)`` and ``(N, 4)``. ``inertia``: principal moments ``[I1, I2, I3]``, a
    tensor ``[Ixx, Iyy, Izz, Ixy, Ixz, Iyz]`` or a 3x3 matrix (kg m^2); ``angular_velocity``:
    body-frame rate (rad/s); ``orientation``: ``q_NB`` as ``(x, y, z, w)``; ``propagator``:
    ``auto`` or a name in :data:`PROPAGATORS`; ``options``: the propagator's settings (``step`` for
    fixed-step methods, ``rtol``/``atol`` for adaptive ones).
    """
    return make_propagator(inertia, angular_velocity, orientation, propagator, **options)(times)


__all__ = [
    'PROPAGATORS',
    'MotionRegime',
    'Propagator',
    'RigidBody',
    'make_propagator',
    'propagate',
    'propagate_batch',
]
