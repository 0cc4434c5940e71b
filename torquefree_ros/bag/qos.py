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
QoS profiles as rosbag2 (metadata version 9) writes them.

Policies are rmw's strings, durations ``{sec, nsec}`` with rmw's infinite
``{9223372036, 854775807}``. No rclpy import (see ``ros_qos``).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

INFINITE_NS = 2**63 - 1  # RMW_DURATION_INFINITE
_POLICIES = {
    'history': ('system_default', 'keep_last', 'keep_all', 'unknown'),
    'reliability': ('system_default', 'reliable', 'best_effort', 'unknown', 'best_available'),
    'durability': ('system_default', 'transient_local', 'volatile', 'unknown', 'best_available'),
    'liveliness': ('system_default', 'automatic', 'manual_by_topic', 'unknown', 'best_available'),
}
_DURATIONS = ('deadline', 'lifespan', 'liveliness_lease_duration')


@dataclass(frozen=True)
class BagQos:
    """One offered QoS profile; durations in nanoseconds (``INFINITE_NS`` = not limited)."""

    history: str = 'keep_last'
    depth: int = 10
    reliability: str = 'reliable'
    durability: str = 'volatile'
    deadline: int = INFINITE_NS
    lifespan: int = INFINITE_NS
    liveliness: str = 'automatic'
    liveliness_lease_duration: int = INFINITE_NS
    avoid_ros_namespace_conventions: bool = False

    def __post_init__(self):
        for policy, allowed in _POLICIES.items():
            if getattr(self, policy) not in allowed:
                raise ValueError(
                    f"qos.{policy}: '{getattr(self, policy)}' is not one of {', '.join(allowed)}"
                )
        for name in _DURATIONS:
            if not 0 <= getattr(self, name) <= INFINITE_NS:
                raise ValueError(
                    f'qos.{name}: must be in [0, 2^63 - 1] ns, got {getattr(self, name)}'
                )

    def to_yaml(self) -> dict:
        """Return the mapping rosbag2 writes (same keys, same order)."""
        data = asdict(self)
        for name in _DURATIONS:
            sec, nsec = divmod(data[name], 1_000_000_000)
            data[name] = {'sec': sec, 'nsec': nsec}
        return data

    @classmethod
    def from_yaml(cls, data: dict) -> 'BagQos':
        """Read version 9 (strings) and older integer policies, as rosbag2 does."""
        values = dict(data)
        for policy, allowed in _POLICIES.items():
            value = values.get(policy, 'unknown')
            if isinstance(value, int):
                value = allowed[value] if 0 <= value < len(allowed) else 'unknown'
            values[policy] = str(value).lower()
        for name in _DURATIONS:
            duration = values.get(name) or {'sec': 0, 'nsec': 0}
            values[name] = min(
                int(duration['sec']) * 1_000_000_000 + int(duration['nsec']), INFINITE_NS
            )
        values['depth'] = int(values.get('depth', 0))
        values['avoid_ros_namespace_conventions'] = bool(
            values.get('avoid_ros_namespace_conventions', False)
        )
        return cls(**{key: values[key] for key in cls.__dataclass_fields__ if key in values})
