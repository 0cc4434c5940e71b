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

"""Input checks shared by the core: every error names the argument and says what is wrong."""

from __future__ import annotations

from collections.abc import Sequence
import math

import numpy as np

# Hand-typed quaternions: tf2 accepts |q|^2 within 0.01 of 1 and normalises (its
# QUATERNION_NORMALIZATION_TOLERANCE); the same rule here, so 3-4 typed digits are enough.
UNIT_QUATERNION_TOLERANCE = 0.01
# A norm within this many rounding units of 1 is unit to float64 precision (sin/cos, a normalised
# quaternion printed with repr): such an input is used bit for bit, not divided by 1 +- ulps.
UNIT_QUATERNION_ROUNDING = 4 * np.finfo(float).eps


def finite_vector(value, name: str, lengths: Sequence[int] = (3,)) -> np.ndarray:
    """``value`` as a float vector whose length is one of ``lengths``, every entry finite."""
    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as error:
        raise ValueError(f'{name}: expected a list of numbers, got {value!r} ({error})') from None
    if array.ndim != 1 or array.shape[0] not in lengths:
        wanted = ' or '.join(str(n) for n in lengths)
        raise ValueError(f'{name}: expected {wanted} numbers, got shape {array.shape}')
    # a few numbers: plain floats beat numpy's reductions
    if not all(map(math.isfinite, array.tolist())):
        raise ValueError(f'{name}: every entry must be finite, got {array.tolist()}')
    return array


def unit_quaternion(value, name: str = 'orientation') -> np.ndarray:
    """
    Return the ``(x, y, z, w)`` quaternion ``value`` as the rotation it is meant to be.

    The initial state is exactly the input when ``|q|`` is 1 to float64 rounding
    (``| |q| - 1 | <= 4 eps``): no bit changes. Otherwise ``q / |q|`` when
    ``| |q|^2 - 1 | <= 0.01`` (tf2's rule: hand-typed values such as ``[0.2, 0.1, -0.3, 0.927]``);
    beyond that the input is refused, with the normalised value in the message. ``|q|`` is
    ``math.hypot`` (correctly rounded up to one ulp, the same on every machine and numpy version).
    """
    q = finite_vector(value, name, (4,))
    norm = math.hypot(*q.tolist())
    if norm == 0.0:
        raise ValueError(f'{name}: the zero quaternion is not a rotation')
    if abs(norm - 1.0) <= UNIT_QUATERNION_ROUNDING:
        return q
    if abs(norm * norm - 1.0) > UNIT_QUATERNION_TOLERANCE:
        normalised = ', '.join(f'{x:.6g}' for x in q / norm)
        raise ValueError(
            f'{name}: expected a unit quaternion (x, y, z, w), got norm {norm:.6g} '
            f'(allowed: |norm^2 - 1| <= {UNIT_QUATERNION_TOLERANCE:g}, as tf2); '
            f'if [{normalised}] is the rotation you mean, give that'
        )
    return q / norm


def sample_times(value, name: str = 'times') -> np.ndarray:
    """Return ``value`` as a 1-D array of finite, non-negative, non-decreasing times in seconds."""
    try:
        times = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as error:
        raise ValueError(f'{name}: expected an array of numbers ({error})') from None
    if times.ndim == 0:
        times = times.reshape(1)
    if times.ndim != 1:
        raise ValueError(f'{name}: expected a 1-D array, got shape {times.shape}')
    # one comparison finds both faults in the common case: it is false at a decrease and next to a
    # NaN, and a sorted array holds an infinity only at an end
    in_order = times[1:] >= times[:-1]
    if times.size and not (
        in_order.all() and math.isfinite(times[0]) and math.isfinite(times[-1])
    ):
        if not np.isfinite(times).all():
            raise ValueError(f'{name}: every time must be finite')
        first = int(np.argmin(in_order))
        raise ValueError(
            f'{name}: must be sorted, but times[{first + 1}] = {float(times[first + 1])!r} '
            f'< times[{first}] = {float(times[first])!r}'
        )
    if times.size and times[0] < 0.0:
        raise ValueError(f'{name}: times are seconds since the initial state and must be >= 0')
    return times


def initial_samples(times: np.ndarray) -> int:
    """
    Count the checked ``times`` (:func:`sample_times`) that are ``t = 0``.

    They lead, and are the initial state itself, not its reconstruction through a solution.
    """
    return int(np.searchsorted(times, 0.0, side='right')) if times.size and times[0] == 0.0 else 0
