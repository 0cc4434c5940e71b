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
QoS: rclpy's profiles and the bag's, rosbag2's rules, the node's own profiles and warnings.

Between rclpy's QoS profiles and the bag's (rosbag2 v9) ones, and rosbag2's rules for choosing
the QoS a recorder requests and a player offers; the node's own profiles and its warnings when a
peer's QoS cannot match them.
"""

from __future__ import annotations

import importlib

from rclpy.duration import Duration
from rclpy.event_handler import PublisherEventCallbacks, SubscriptionEventCallbacks
from rclpy.qos import (
    DurabilityPolicy,
    HistoryPolicy,
    LivelinessPolicy,
    QoSPolicyKind,
    QoSProfile,
    ReliabilityPolicy,
)

from ..bag.qos import BagQos, INFINITE_NS

# A player keeps at least this many messages per topic for reliable delivery at high rates.
PLAYER_DEPTH = 1000
RECORDER_DEPTH = 1000


def _duration_ns(duration: Duration) -> int:
    ns = duration.nanoseconds
    return INFINITE_NS if ns <= 0 or ns >= INFINITE_NS else ns  # 0 = rmw default = not limited


def bag_qos(profile: QoSProfile) -> BagQos:
    return BagQos(
        history=profile.history.name.lower(),
        depth=int(profile.depth),
        reliability=profile.reliability.name.lower(),
        durability=profile.durability.name.lower(),
        deadline=_duration_ns(profile.deadline),
        lifespan=_duration_ns(profile.lifespan),
        liveliness=profile.liveliness.name.lower(),
        liveliness_lease_duration=_duration_ns(profile.liveliness_lease_duration),
        avoid_ros_namespace_conventions=bool(profile.avoid_ros_namespace_conventions),
    )


def _duration(ns: int) -> Duration:
    return Duration(nanoseconds=0 if ns >= INFINITE_NS else ns)


def request_for_offers(offers: list[BagQos]) -> QoSProfile:
    """
    Return the QoS rosbag2's recorder requests for topics with these ``offers``.

    What rosbag2's recorder requests: reliable / transient local only if every publisher offers
    it.
    """
    reliable = bool(offers) and all(q.reliability == 'reliable' for q in offers)
    transient = bool(offers) and all(q.durability == 'transient_local' for q in offers)
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST,
        depth=RECORDER_DEPTH,
        reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT,
        durability=DurabilityPolicy.TRANSIENT_LOCAL if transient else DurabilityPolicy.VOLATILE,
    )


def offer_for_recorded(profiles: tuple[BagQos, ...]) -> QoSProfile:
    """
    Return the QoS rosbag2's player offers for a topic recorded with ``profiles``.

    The recorded profile when all publishers agreed on the policies that decide compatibility
    (keep-last history of its own), else rmw's defaults (reliable, volatile).
    """
    same = profiles and all(
        (q.reliability, q.durability, q.deadline, q.liveliness, q.liveliness_lease_duration)
        == (
            profiles[0].reliability,
            profiles[0].durability,
            profiles[0].deadline,
            profiles[0].liveliness,
            profiles[0].liveliness_lease_duration,
        )
        for q in profiles
    )
    if not same:
        return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=PLAYER_DEPTH)
    p = profiles[0]

    def policy(enum, name):
        return enum[name.upper()] if name.upper() in enum.__members__ else enum.SYSTEM_DEFAULT

    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST,
        depth=max(p.depth, PLAYER_DEPTH),
        reliability=policy(ReliabilityPolicy, p.reliability),
        durability=policy(DurabilityPolicy, p.durability),
        deadline=_duration(p.deadline),
        lifespan=_duration(p.lifespan),
        liveliness=policy(LivelinessPolicy, p.liveliness),
        liveliness_lease_duration=_duration(p.liveliness_lease_duration),
        avoid_ros_namespace_conventions=p.avoid_ros_namespace_conventions,
    )


def message_class(type_name: str):
    """Return the Python class of ``pkg/msg/Type``; ``ValueError`` names it when not installed."""
    try:
        package, namespace, name = type_name.split('/')
        return getattr(importlib.import_module(f'{package}.{namespace}'), name)
    except (ValueError, ImportError, AttributeError):
        raise ValueError(f"message type '{type_name}': not installed for Python") from None


# -- the node's profiles -------------------------------------------------------------------------
TF_MESSAGE = 'tf2_msgs/msg/TFMessage'
#: tf2_ros's TransformBroadcaster publishes /tf keep-last 100 (DynamicBroadcasterQoS): a listener
#: joining a busy /tf with its usual depth-100 subscription then matches what it expects
TF_DEPTH = 100


def sample_profile(depth: int, message_type: str = '') -> QoSProfile:
    """
    Return what the node's publishers offer: reliable, volatile, keep-last ``depth``.

    On /tf the depth is at least TF_DEPTH.
    """
    if message_type == TF_MESSAGE:
        depth = max(depth, TF_DEPTH)
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST, depth=depth, reliability=ReliabilityPolicy.RELIABLE
    )


def command_profile(depth: int) -> QoSProfile:
    """
    Return what a command subscription requests: best effort.

    Best effort, because it matches reliable and best-effort publishers alike whenever they
    appear. Not BEST_AVAILABLE: rmw resolves it once, when the subscription is created; with no
    publisher yet (the node starts before its controller) it becomes reliable and never matches a
    best-effort publisher that comes later (seen with rmw_fastrtps_cpp, Jazzy). The cost: a
    reliable publisher's commands arrive best effort, without resending; a lost one is a missed
    step in lock-step (counted in /diagnostics), not a wrong sample.
    """
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST, depth=depth, reliability=ReliabilityPolicy.BEST_EFFORT
    )


def describe_profile(profile: QoSProfile) -> str:
    """``reliable, volatile, keep-last 10``: the policies that decide whether peers match."""
    history = (
        f'keep-last {profile.depth}'
        if profile.history == HistoryPolicy.KEEP_LAST
        else profile.history.name.lower().replace('_', '-')
    )
    return ', '.join(
        [
            profile.reliability.name.lower().replace('_', ' '),
            profile.durability.name.lower().replace('_', ' '),
            history,
        ]
    )


def _policy(event) -> str:
    try:
        return QoSPolicyKind(event.last_policy_kind).name.lower()
    except ValueError:
        return f'policy {event.last_policy_kind}'


def publisher_warnings(logger, topic: str, offered: QoSProfile) -> PublisherEventCallbacks:
    """
    Build callbacks that warn when a subscription asks ``topic`` for more than it offers.

    The warnings go to ``logger`` (rclpy's own line does not say what is offered nor that the peer
    gets nothing).
    """

    def incompatible(event) -> None:
        logger.warning(
            f'{topic}: a subscription requests QoS this node does not offer '
            f'(last policy in conflict: {_policy(event)}; '
            f'offered: {describe_profile(offered)}), so it receives no message '
            f'from this node (incompatible subscriptions so far: {event.total_count})'
        )

    return PublisherEventCallbacks(incompatible_qos=incompatible)


def subscription_warnings(logger, topic: str, requested: QoSProfile) -> SubscriptionEventCallbacks:
    """
    Build callbacks that warn when a publisher on ``topic`` offers less than is requested.

    The warnings go to ``logger``.
    """

    def incompatible(event) -> None:
        logger.warning(
            f'{topic}: a publisher offers QoS this node does not accept '
            f'(last policy in conflict: {_policy(event)}; '
            f'requested: {describe_profile(requested)}), so none of its messages '
            f'arrive (incompatible publishers so far: {event.total_count})'
        )

    return SubscriptionEventCallbacks(incompatible_qos=incompatible)
