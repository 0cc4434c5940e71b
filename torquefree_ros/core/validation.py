"""Input checks shared by the core: every error names the argument and says what is wrong."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

# |q| may differ from 1 by this much before it is called "not a unit quaternion" rather than
# silently renormalised: measured attitudes in YAML files carry about 6 to 9 digits.
UNIT_QUATERNION_RTOL = 1e-6


def finite_vector(value, name: str, lengths: Sequence[int] = (3,)) -> np.ndarray:
    """``value`` as a float vector whose length is one of ``lengths``, every entry finite."""
    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as error:
        raise ValueError(f"{name}: expected a list of numbers, got {value!r} ({error})") from None
    if array.ndim != 1 or array.shape[0] not in lengths:
        wanted = " or ".join(str(n) for n in lengths)
        raise ValueError(f"{name}: expected {wanted} numbers, got shape {array.shape}")
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{name}: every entry must be finite, got {array.tolist()}")
    return array


def unit_quaternion(value, name: str = "orientation") -> np.ndarray:
    """An ``(x, y, z, w)`` quaternion, normalised; zero or far-from-unit norms are refused."""
    q = finite_vector(value, name, (4,))
    norm = float(np.linalg.norm(q))
    if norm == 0.0:
        raise ValueError(f"{name}: the zero quaternion is not a rotation")
    if abs(norm - 1.0) > UNIT_QUATERNION_RTOL:
        raise ValueError(
            f"{name}: expected a unit quaternion (x, y, z, w), got norm {norm:.9g} "
            f"(allowed |norm - 1| <= {UNIT_QUATERNION_RTOL:g})"
        )
    return q / norm


def sample_times(value, name: str = "times") -> np.ndarray:
    """A 1-D array of finite, non-negative, non-decreasing times in seconds."""
    try:
        times = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as error:
        raise ValueError(f"{name}: expected an array of numbers ({error})") from None
    if times.ndim == 0:
        times = times.reshape(1)
    if times.ndim != 1:
        raise ValueError(f"{name}: expected a 1-D array, got shape {times.shape}")
    if not np.all(np.isfinite(times)):
        raise ValueError(f"{name}: every time must be finite")
    if times.size and times[0] < 0.0:
        raise ValueError(f"{name}: times are seconds since the initial state and must be >= 0")
    if np.any(np.diff(times) < 0.0):
        first = int(np.argmax(np.diff(times) < 0.0))
        raise ValueError(
            f"{name}: must be sorted, but times[{first + 1}] = {float(times[first + 1])!r} "
            f"< times[{first}] = {float(times[first])!r}"
        )
    return times
