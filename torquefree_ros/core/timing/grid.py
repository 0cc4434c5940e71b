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

"""The contract's sample times: sample ``k`` is the state at exactly ``t_k = k / rate``."""

from __future__ import annotations

import math

import numpy as np

# duration * rate is rounded (2.3 s * 100 Hz = 229.99999999999997): a product within this relative
# distance of an integer counts as that integer, so the sample at t = duration is not lost.
_COUNT_RTOL = 1e-12


def sample_count(duration: float, rate: float) -> int:
    """How many samples ``k = 0 ... floor(duration * rate)`` there are (both ends included)."""
    if not (math.isfinite(duration) and duration >= 0.0):
        raise ValueError(f'duration: must be a finite number >= 0, got {duration!r}')
    rate = check_rate(rate)
    return math.floor(duration * rate * (1.0 + _COUNT_RTOL)) + 1


def sample_times(duration: float, rate: float) -> np.ndarray:
    """``k / rate`` for ``k = 0 ... floor(duration * rate)``, both ends included."""
    return np.arange(sample_count(duration, rate)) / check_rate(rate)


# A sample period shorter than a microsecond is not a use case; it also keeps every stamp distinct.
MAX_RATE = 1e6
# Nor is one longer than 1000 s; below it, nanosecond stamp arithmetic (1e9 / rate) leaves int64.
MIN_RATE = 1e-3


def check_rate(rate, name: str = 'rate') -> float:
    """Check a sample rate in Hz (finite, in [MIN_RATE, MAX_RATE]); return it as a float."""
    if isinstance(rate, bool) or not isinstance(rate, (int, float, np.integer, np.floating)):
        raise ValueError(f'{name}: expected a number (Hz), got {rate!r}')
    rate = float(rate)
    if not (math.isfinite(rate) and MIN_RATE <= rate <= MAX_RATE):
        raise ValueError(
            f'{name}: must be a finite number in [{MIN_RATE:g}, {MAX_RATE:g}] Hz, got {rate!r}'
        )
    return rate


def first_sample_at_or_after(t: float, rate: float) -> int:
    """
    Return the first sample ``k >= 0`` whose time ``k / rate`` (float64, as sampled) is ``>= t``.

    The rule of every window on the grid (a fault's start and end): ``t`` finite.
    """
    k = max(0, math.ceil(t * rate))
    while k > 0 and (k - 1) / rate >= t:
        k -= 1
    while k / rate < t:
        k += 1
    return k


def sample_stamp_ns(k: int, rate: float, epoch_ns: int = 0) -> int:
    """
    Return the stamp of sample ``k`` of a run at ``rate`` Hz from ``epoch_ns``: the stamp rule.

    ``epoch + k / rate`` in integer nanoseconds, rounded to the nearest (half to even, as
    :func:`stamps_ns` rounds: the two agree on every sample).
    """
    return epoch_ns + round(k / rate * 1e9)


def stamps_ns(epoch_ns: int, times: np.ndarray) -> np.ndarray:
    """Stamps ``epoch + t`` in integer nanoseconds, ``t`` rounded to the nearest nanosecond."""
    return np.int64(epoch_ns) + np.rint(np.asarray(times) * 1e9).astype(np.int64)


def restart_epoch_ns(now_ns: int, last_stamp_ns: int | None, rate: float) -> int:
    """
    Return the epoch of a (re)start: now, unless that is too soon after the last stamp.

    The epoch is never before one period after the last published stamp, so stamps never go
    backwards and a clock of our own keeps its cadence across a reset.
    """
    if last_stamp_ns is None:
        return int(now_ns)
    return max(int(now_ns), int(last_stamp_ns) + max(1, round(1e9 / rate)))
