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
``torquefree_record``: records topics into a rosbag2 MCAP bag, like ``ros2 bag record``.

Topics are found by discovery (the ones named, or all that are not hidden); each gets a raw
(serialized) subscription, so messages are stored as they came off the wire. The bag keeps each
topic's publishers' QoS, and the subscription asks for reliable / transient-local delivery only if
every publisher offers it (rosbag2's rule). Log time = reception on the node's clock; publish time
= the publisher's source timestamp.
"""

from __future__ import annotations

import time

from rclpy.node import Node

from .qos import bag_qos, message_class, request_for_offers
from ..bag import BagError, BagWriter

DISCOVERY_PERIOD = 0.2  # s
FLUSH_PERIOD = 0.25  # s; a chunk open longer than the writer's chunk_seconds is written out


def _hidden(topic: str) -> bool:
    return any(part.startswith('_') for part in topic.split('/'))


class TopicRecorder(Node):
    def __init__(
        self,
        writer: BagWriter,
        topics: list[str] | None = None,
        include_hidden: bool = False,
        **node_options,
    ):
        super().__init__('torquefree_record', **node_options)
        self.writer = writer
        # names resolve as ROS resolves them: relative to the node's namespace, remappings applied
        self._wanted = (
            None if topics is None else {self.resolve_topic_name(topic) for topic in topics}
        )
        self._include_hidden = include_hidden
        self._recording: dict[str, object] = {}
        self._skipped: set[str] = set()
        self.failure = ''
        # time.monotonic() of the first message written
        self.first_message_time: float | None = None
        self.create_timer(DISCOVERY_PERIOD, self.discover)
        self.create_timer(FLUSH_PERIOD, self._flush_if_due)
        self.discover()

    @property
    def recorded_topics(self) -> list[str]:
        return sorted(self._recording)

    def discover(self) -> None:
        for topic, types in self.get_topic_names_and_types():
            if topic in self._recording or topic in self._skipped:
                continue
            if self._wanted is not None and topic not in self._wanted:
                continue
            if self._wanted is None and _hidden(topic) and not self._include_hidden:
                continue
            publishers = self.get_publishers_info_by_topic(topic)
            if not publishers:
                continue
            self._subscribe(topic, types, publishers)

    def _subscribe(self, topic: str, types: list[str], publishers) -> None:
        if len(types) != 1:
            self._skip(topic, f'more than one type ({", ".join(types)})')
            return
        try:
            cls = message_class(types[0])
            offers = [bag_qos(info.qos_profile) for info in publishers]
            channel = self.writer.add_topic(topic, types[0], offers)
        except (ValueError, BagError) as error:
            self._skip(topic, str(error))
            return

        def on_message(data: bytes, info, channel=channel) -> None:
            self._write(channel, data, info)

        self._recording[topic] = self.create_subscription(
            cls, topic, on_message, request_for_offers(offers), raw=True
        )
        self.get_logger().info(f'recording {topic} ({types[0]})')

    def _skip(self, topic: str, reason: str) -> None:
        self._skipped.add(topic)
        self.get_logger().warning(f'not recording {topic}: {reason}')

    def _write(self, channel: int, data: bytes, info) -> None:
        if self.failure:
            return
        if self.first_message_time is None:
            self.first_message_time = time.monotonic()
        try:
            self.writer.write(
                channel, self.get_clock().now().nanoseconds, data, info['source_timestamp']
            )
        except BagError as error:
            self.failure = str(error)
            self.get_logger().error(f'recording stopped: {error}')

    def _flush_if_due(self) -> None:
        if not self.failure:
            try:
                self.writer.flush_if_due()
            except BagError as error:
                self.failure = str(error)
                self.get_logger().error(f'recording stopped: {error}')
