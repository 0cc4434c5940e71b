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
Delivery tracking: which subscriptions of the watched nodes have processed which sample.

``advance``'s rule: sample ``k`` counts as processed once every subscription of every node added
(and of the kit's recorder) to a topic ``k`` went out on has had its callback return for that
sample's message or a later one. The kit learns it by wrapping each such subscription's callback
(:class:`Watch`). Before a subscription is first waited for, the simulator's publishers must have
matched it: a volatile sample published before then would be lost to it.
"""

from __future__ import annotations

import inspect
from typing import Callable, NamedTuple

from .failures import qos_problem, unmatched
from .samples import message_stamp_ns


class Watch:
    """
    What a watched subscription's callbacks have processed.

    They returned for ``count`` messages, the last of them stamped ``latest`` (ns).
    """

    def __init__(self):
        self.count = 0
        self.latest: int | None = None

    def note(self, message, raw_type) -> None:
        if raw_type is not None:  # a raw subscription gets bytes
            from rclpy.serialization import deserialize_message

            message = deserialize_message(message, raw_type)
        stamp = message_stamp_ns(message)
        self.count += 1
        if stamp is not None and (self.latest is None or stamp > self.latest):
            self.latest = stamp


class Watched(NamedTuple):
    node: object
    subscription: object
    watch: Watch


class Delivery:
    """
    The watched subscriptions, and which of them the simulator's publishers have matched.

    ``publisher_of(topic)``: the simulator's publisher of a resolved topic, or None;
    ``spin_until``: :meth:`~torquefree_ros.testing.Simulator.spin_until`.
    """

    def __init__(self, publisher_of: Callable, spin_until: Callable):
        self._publisher_of = publisher_of
        self._spin_until = spin_until
        self._watches: dict[int, Watched] = {}  # id(subscription) -> its entry
        self._matched: set[int] = set()  # ids of watched subscriptions the publisher has matched

    def forget_matches(self) -> None:
        """Match every subscription again before its next wait: a reset may make new publishers."""
        self._matched.clear()

    def watched(self, nodes, expected: dict) -> list[Watched]:
        """
        Return every subscription of ``nodes`` to a topic in ``expected``.

        The callbacks of subscriptions not seen before are wrapped.
        """
        out = []
        for node in nodes:
            for subscription in list(node.subscriptions):
                if subscription.topic_name not in expected:
                    continue
                entry = self._watches.get(id(subscription))
                if entry is None or entry.subscription is not subscription:
                    entry = Watched(node, subscription, _wrap(subscription))
                    self._watches[id(subscription)] = entry
                out.append(entry)
        return out

    def wait_matched(self, watched: list[Watched], timeout: float) -> None:
        """
        Spin until the simulator's publishers have matched the watched subscriptions.

        The publisher on each watched topic counts as many subscriptions as are watched on it,
        and each subscription not matched before sees a publisher.
        """
        fresh = [entry for entry in watched if id(entry.subscription) not in self._matched]
        if not fresh:
            return
        wanted: dict[str, int] = {}
        for entry in watched:
            topic = entry.subscription.topic_name
            wanted[topic] = wanted.get(topic, 0) + 1

        def matched() -> bool:
            publishers = {topic: self._publisher_of(topic) for topic in wanted}
            return all(
                publishers[topic] is not None
                and publishers[topic].get_subscription_count() >= count
                for topic, count in wanted.items()
            ) and all(entry.subscription.get_publisher_count() > 0 for entry in fresh)

        self._spin_until(matched, timeout, lambda: unmatched(fresh, self.qos_problem))
        self._matched.update(id(entry.subscription) for entry in fresh)

    def qos_problem(self, subscription) -> str:
        """Say why ``subscription``'s QoS cannot match the simulator's publisher (or ``''``)."""
        return qos_problem(self._publisher_of(subscription.topic_name), subscription)

    @staticmethod
    def pending(watched: list[Watched], expected: dict, stamp: int) -> list[Watched]:
        """Return those watched on a topic the sample went out on that have not processed it."""
        return [
            entry
            for entry in watched
            if expected[entry.subscription.topic_name]
            and (entry.watch.latest is None or entry.watch.latest < stamp)
        ]


def _wrap(subscription) -> Watch:
    """Note each message after the subscription's callback returned for it."""
    watch, original = Watch(), subscription.callback
    raw_type = subscription.msg_type if subscription.raw else None
    # the same kind and arity as the original: rclpy awaits a coroutine function, and passes
    # the MessageInfo to a callback that takes two arguments
    if inspect.iscoroutinefunction(original):
        if _takes_two(original):

            async def callback(message, info):
                await original(message, info)
                watch.note(message, raw_type)
        else:

            async def callback(message):
                await original(message)
                watch.note(message, raw_type)
    elif _takes_two(original):

        def callback(message, info):
            original(message, info)
            watch.note(message, raw_type)
    else:

        def callback(message):
            original(message)
            watch.note(message, raw_type)

    subscription.callback = callback
    return watch


def _takes_two(function) -> bool:
    try:
        inspect.signature(function).bind(object(), object())
    except TypeError:
        return False
    try:
        inspect.signature(function).bind(object())
    except TypeError:
        return True
    return False  # both bind (a default or *args): rclpy passes the message only
