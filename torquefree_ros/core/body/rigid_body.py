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
Rigid body: inertia, validation, invariants, the Duffing analog and the motion's classification.

The inertia is principal moments or a full tensor; the Duffing analog is that of seed 000 (Junkins,
Jacobson & Blanton 1973); the classification is of the torque-free motion.

Frames in names: ``omega_B`` is the body-frame rate in the user's body frame B; ``_P`` marks the
principal frame P. ``principal_axes`` has the principal axes as columns in B coordinates, is a
proper rotation, and ``tensor = principal_axes @ diag(moments) @ principal_axes.T``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..checks.validation import finite_vector
from ..exact.regime import classify_motion, MotionRegime
from ..frames import quaternion

# A body's largest moment may exceed the sum of the other two by this relative amount before it is
# refused as unphysical (a flat plate sits exactly on the bound; rounding of a diagonalised tensor
# is ~1e-16, moments typed with 9+ significant digits pass).
TRIANGLE_RTOL = 1e-9
# Off-diagonal asymmetry of a 3x3 tensor tolerated (relative to its largest entry) as rounding.
SYMMETRY_RTOL = 1e-12


@dataclass(frozen=True)
class RigidBody:
    """A validated inertia. Build it with :meth:`from_inertia`."""

    tensor: np.ndarray  # 3x3, body frame B
    moments: np.ndarray  # principal moments, in the order of the columns of principal_axes
    principal_axes: np.ndarray  # 3x3 proper rotation, columns = principal axes in B

    @classmethod
    def from_inertia(cls, inertia, name: str = 'inertia') -> 'RigidBody':
        """
        Build a body from principal moments, tensor elements or a 3x3 matrix.

        ``[I1, I2, I3]`` (principal; B is then the principal frame, any order),
        ``[Ixx, Iyy, Izz, Ixy, Ixz, Iyz]`` (tensor elements, as in URDF) or a 3x3 matrix.
        """
        if isinstance(inertia, RigidBody):
            return inertia
        array = _float_array(inertia)
        if array is not None and array.shape == (3, 3):
            tensor = _symmetric_tensor(array, name)
        else:
            values = finite_vector(array if array is not None else inertia, name, (3, 6))
            _check_magnitude(values, name)
            if values.shape[0] == 3:
                _check_moments(values, name)
                return cls(values[:, None] * _IDENTITY, values.copy(), _IDENTITY)
            xx, yy, zz, xy, xz, yz = values
            tensor = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
        if not np.all(np.isfinite(tensor)):
            raise ValueError(f'{name}: every entry must be finite')
        _check_magnitude(tensor, name)
        if not np.any(tensor - np.diag(np.diag(tensor))):
            # Already principal: keep B as the principal frame exactly (no eigen-solver rounding).
            moments = np.diag(tensor).copy()
            _check_moments(moments, name)
            return cls(tensor, moments, _IDENTITY)
        moments, axes = np.linalg.eigh(tensor)
        if np.linalg.det(axes) < 0.0:
            axes[:, 2] = -axes[:, 2]  # a proper rotation, not a reflection
        _check_moments(moments, name)
        return cls(tensor, moments, axes)

    # -- invariants (broadcast over leading axes of omega_B) -----------------------------------
    def angular_momentum(self, omega_B) -> np.ndarray:
        """``H_B = I omega_B`` in the body frame."""
        return np.einsum('ij,...j->...i', self.tensor, np.asarray(omega_B, dtype=float))

    def angular_momentum_inertial(self, omega_B, q_NB) -> np.ndarray:
        """``H_N = R(q_NB) I omega_B``: constant in a torque-free motion."""
        return quaternion.rotate(q_NB, self.angular_momentum(omega_B))

    def kinetic_energy(self, omega_B) -> np.ndarray:
        """``T = omega · I omega / 2``."""
        omega_B = np.asarray(omega_B, dtype=float)
        return 0.5 * np.einsum('...i,...i->...', omega_B, self.angular_momentum(omega_B))

    def momentum_magnitude(self, omega_B) -> np.ndarray:
        """``|H|``."""
        return np.linalg.norm(self.angular_momentum(omega_B), axis=-1)

    def to_principal(self, omega_B) -> np.ndarray:
        return np.asarray(omega_B, dtype=float) @ self.principal_axes

    def momentum_energy_gaps(self, omega_B) -> np.ndarray:
        """
        ``H^2 - 2 T I_j`` for each principal moment ``I_j``, as ``sum_i I_i (I_i - I_j) w_i^2``.

        The direct difference of ``H^2`` and ``2 T I_j`` cancels catastrophically next to the
        separatrix (``H^2 = 2 T I_mid``); this form only subtracts moments.
        """
        w2 = self.to_principal(omega_B) ** 2
        moments = self.moments
        return np.einsum('i,ij,...i->...j', moments, moments[:, None] - moments[None, :], w2)

    def duffing_constants(self, omega_B):
        """
        Return ``(A, B, K)`` of each principal rate's Duffing equation (seed 000).

        The equation is ``w_i'' + A_i w_i + B_i w_i^3 = 0``, its integral
        ``w_i'^2 + A_i w_i^2 + B_i/2 w_i^4 = K_i``; principal axis order.
        """
        moments = self.moments  # I_1, I_2, I_3
        g = self.momentum_energy_gaps(omega_B)  # g_j = H^2 - 2 T I_j
        product = moments[0] * moments[1] * moments[2]
        A, B, K = np.empty(3), np.empty(3), np.empty(3)
        for i, j, k in ((0, 1, 2), (1, 2, 0), (2, 0, 1)):
            I_i, I_j, I_k = moments[i], moments[j], moments[k]
            A[i] = -((I_i - I_j) * g[k] + (I_i - I_k) * g[j]) / product
            B[i] = 2.0 * (I_i - I_j) * (I_i - I_k) / (I_j * I_k)
            K[i] = -g[j] * g[k] / (I_i**2 * I_j * I_k)
        return A, B, K

    def classify(self, omega_B) -> MotionRegime:
        """Classify the torque-free motion this body starts at ``omega_B`` (body frame)."""
        return classify_motion(self, omega_B)


def _float_array(value) -> np.ndarray | None:
    """
    Return ``value`` as a float array, or ``None`` if it is not numbers.

    ``None``: the value is then checked for the message.
    """
    try:
        return np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        return None


def _symmetric_tensor(matrix: np.ndarray, name: str) -> np.ndarray:
    if not np.all(np.isfinite(matrix)):
        raise ValueError(f'{name}: every entry must be finite')
    scale = float(np.max(np.abs(matrix)))
    if np.max(np.abs(matrix - matrix.T)) > SYMMETRY_RTOL * scale:
        raise ValueError(f'{name}: an inertia tensor must be symmetric, got {matrix.tolist()}')
    return 0.5 * (matrix + matrix.T)


# the principal axes of a body given in its principal frame (shared: read-only)
_IDENTITY = np.eye(3)
_IDENTITY.flags.writeable = False

# Sums and products of moments (eigen-solver, triangle check, I_max |H|^2) must stay finite in
# float64.
MAX_INERTIA = 1e100  # kg m^2


def _check_magnitude(values: np.ndarray, name: str) -> None:
    if max(map(abs, values.ravel().tolist())) > MAX_INERTIA:
        raise ValueError(
            f'{name}: entries must lie within ±{MAX_INERTIA:g} kg m^2 '
            'so that float64 sums and products '
            f'of them stay finite; this one overflows (largest {np.max(np.abs(values)):g})'
        )


def _check_moments(moments: np.ndarray, name: str) -> None:
    values = moments.tolist()  # plain floats: three numbers, checked on every propagator built
    if min(values) <= 0.0:
        raise ValueError(
            f'{name}: principal moments must be positive (positive-definite tensor), got {values}'
        )
    largest = max(values)
    others = values[0] + values[1] + values[2] - largest
    if largest > others * (1.0 + TRIANGLE_RTOL):
        raise ValueError(
            f'{name}: principal moments {moments.tolist()} violate the triangle inequality '
            f'(the largest, {largest:g}, exceeds the sum of the other two, {others:g}): '
            'no rigid body has this inertia'
        )
