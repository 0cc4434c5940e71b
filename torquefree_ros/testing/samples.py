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

"""What the kit hands out: :class:`Sample` (as received), :class:`State` (the truth), stamps."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np


@dataclass(frozen=True)
class Sample:
    """One sample the simulator published, as the kit's subscriber received it."""

    index: int  # k, since the run's (re)start
    t: float  # k / publish_rate, s since the run's (re)start
    stamp_ns: int  # header.stamp: the run's epoch + t
    angular_velocity: np.ndarray  # (3,) rad/s, body frame
    attitude: np.ndarray  # (4,) q_NB (x, y, z, w)


@dataclass(frozen=True)
class State:
    """
    The exact state at ``t`` (s since the run's start).

    Arrays of states when ``t`` is an array.
    """

    t: Any
    angular_velocity: np.ndarray  # (3,) or (N, 3)
    attitude: np.ndarray  # (4,) or (N, 4)


def stamp_ns(stamp) -> int:
    """Return a ``builtin_interfaces/Time`` in integer nanoseconds."""
    return stamp.sec * 1_000_000_000 + stamp.nanosec


def message_stamp_ns(message) -> int | None:
    """
    Return the stamp a message of the simulator's carries (ns), or None when it has none.

    Its header's, ``/clock``'s time, the first transform's or marker's.
    """
    header = getattr(message, 'header', None)
    if header is not None:
        return stamp_ns(header.stamp)
    clock = getattr(message, 'clock', None)
    if clock is not None:
        return stamp_ns(clock)
    for field in ('transforms', 'markers'):
        items = getattr(message, field, None)
        if items:
            return stamp_ns(items[0].header.stamp)
    return None
