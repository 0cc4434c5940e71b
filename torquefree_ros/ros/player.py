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
``torquefree_play``: replays a bag onto its topics with the recorded timing.

It works like ``ros2 bag play``.

Each topic gets a publisher with the QoS its publishers offered when it was recorded (rosbag2's
rule, ``ros_qos.offer_for_recorded``); messages go out as the recorded bytes, message ``i`` at
``start + (t_i - t_0) / rate`` on the wall clock. ``--clock HZ`` publishes the bag's time on
``/clock``; ``--loop`` starts over at the end.
"""

from __future__ import annotations

import math
import threading
import time

import rclpy.duration
from rclpy.node import Node
from rclpy.qos import QoSProfile
from rosgraph_msgs.msg import Clock

from .qos import message_class, offer_for_recorded
from ..bag import BagReader
from ..bag.cdr import encode_times

ACK_TIMEOUT = 10.0  # s; reliable subscribers get everything before the player exits


class BagPlayer(Node):
    def __init__(
        self,
        bag: BagReader,
        rate: float = 1.0,
        clock_rate: float = 0.0,
        loop: bool = False,
        topics: list[str] | None = None,
        **node_options,
    ):
        super().__init__('torquefree_play', **node_options)
        self.bag, self.rate, self.loop = bag, rate, loop
        self.topics = [t for t in bag.topics if topics is None or t.name in topics]
        self.publishers_by_topic = {}
        for topic in self.topics:
            try:
                cls = message_class(topic.type_name)
            except ValueError as error:
                self.get_logger().warning(f'not playing {topic.name}: {error}')
                continue
            self.publishers_by_topic[topic.name] = self.create_publisher(
                cls, topic.name, offer_for_recorded(topic.offered_qos_profiles)
            )
        self._clock = (
            self.create_publisher(Clock, '/clock', QoSProfile(depth=10))
            if clock_rate > 0
            else None
        )
        self._clock_period = 1.0 / clock_rate if clock_rate > 0 else math.inf
        self.played = 0
        self._stop = threading.Event()

    def wait_for_subscribers(self, timeout: float) -> bool:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline and not self._stop.is_set():
            if all(p.get_subscription_count() > 0 for p in self.publishers_by_topic.values()):
                return True
            time.sleep(0.05)
        return False

    def play(self) -> None:
        """Blocks until the bag has been played (once, or until stopped with ``--loop``)."""
        names = set(self.publishers_by_topic)
        while not self._stop.is_set() and self.context.ok():
            self._play_once(names)
            if not self.loop:
                break
        for publisher in self.publishers_by_topic.values():
            if not self.context.ok():
                return
            publisher.wait_for_all_acked(rclpy.duration.Duration(seconds=ACK_TIMEOUT))

    def stop(self) -> None:
        self._stop.set()

    def _play_once(self, names: set[str]) -> None:
        start = time.monotonic()
        first = None
        next_clock = start
        for message in self.bag.messages(names):
            if first is None:
                first = message.log_time_ns
            due = start + (message.log_time_ns - first) / 1e9 / self.rate
            while True:
                now = time.monotonic()
                if self._clock is not None and now >= next_clock:
                    bag_time = first + int((now - start) * self.rate * 1e9)
                    self._clock.publish(encode_times([min(bag_time, message.log_time_ns)])[0])
                    next_clock += self._clock_period
                wait = min(due, next_clock) - now
                if wait <= 0 and now >= due:
                    break
                if self._stop.wait(min(max(wait, 0.0), 0.1)) or not self.context.ok():
                    return
            self.publishers_by_topic[message.topic].publish(message.data)
            self.played += 1
